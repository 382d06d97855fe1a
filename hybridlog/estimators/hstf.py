r"""Hybrid strong tracking filter (HSTF), paper 000 (Wang, Peng, Zhou), eqs. (5)-(40).

.. math::

    \hat x(k+1|k) = \tfrac{1}{n_q}\sum_i f_i(\hat x(k|k), u(k))                     \quad (21)

    P_i(k+1|k) = \lambda_i \bar f_i P(k|k) \bar f_i^T + Q_i                         \quad (24)

    \hat x_i(k+1|k+1) = \hat x_i(k+1|k) + K_i \gamma_i,\;
    K_i = P(k+1|k) \bar h_i^T (\bar h_i P(k+1|k) \bar h_i^T + R)^{-1}                  \quad (9, 11)

    \Pr(q(k+1)=i|Y^{k+1}) \propto N(\gamma_i; 0, S_i),\;
    S_i = \bar h_i P_i(k+1|k) \bar h_i^T + R                                          \quad (33-35)

The mode transition is unknown, so the predicted mode probability is ``1/n_q`` (eqs. (19),
(20)).  Readings of the garbled text (papers/NOTES.md): the residual of eq. (31) is
``γ_i = y(k+1) − h_i(x̂_i(k+1|k))`` with ``x̂_i(k+1|k) = f_i(x̂(k|k), u(k))`` (eq. (10)); the
Jacobian ``h̄_i`` of eq. (12) is taken at the combined prediction ``x̂(k+1|k)`` as written.
``P_i(k+1|k+1)`` of eq. (32) is computed in the equivalent Joseph form so it stays symmetric
positive semi-definite; mode probabilities are normalised in log space.

Options: ``rho`` (forgetting factor ρ of eq. (30)), ``beta`` (softening factor β of eq. (29)),
``theta`` (mode threshold θ of eq. (40)), ``fading`` (false forces λ_i = 1: with one mode the
filter is then the plain EKF) and ``likelihood`` (``faded``: S_i from the faded P_i(k+1|k) as
in eq. (35), the paper's choice; ``unfaded``: S_i from λ_i = 1, a named variant).

References
----------
Wang W., Peng Z., Zhou D. State estimation of a class of hybrid systems in the presence of
unknown mode transitions. ``papers/000_e6c6af29d4167a70.txt``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from numba import types

from hybridlog.estimators.common import FilterBuffers, contiguous, noise_stacks
from hybridlog.estimators.kernels import (
    cholesky,
    congruence,
    gain,
    gaussian_log_density,
    joseph_update,
    mixture_moments,
    normalize_log,
)
from hybridlog.estimators.options import options_dict, parse_options
from hybridlog.estimators.result import EstimationResult
from hybridlog.jit import jit_signature
from hybridlog.model.compiled import (
    MATRIX_FUNCTION,
    VECTOR_FUNCTION,
    ModelFunction,
    compile_model,
)
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.signals import AlignedSignals, FloatArray, IntArray

NAME = "hstf"


@dataclass(frozen=True)
class HstfOptions:
    """Options of the HSTF (paper 000): ρ, β, θ and the two switches documented above."""

    rho: float = field(default=0.95, metadata={"range": (1e-12, 1.0)})
    beta: float = field(default=1.0, metadata={"range": (1.0, 1e12)})
    theta: float = field(default=0.95, metadata={"range": (0.5, 1.0)})
    fading: bool = True
    likelihood: str = field(default="faded", metadata={"choices": ("faded", "unfaded")})


_F8_1 = types.float64[::1]
_F8_2 = types.float64[:, ::1]
_F8_3 = types.float64[:, :, ::1]
_SIGNATURE = types.void(
    VECTOR_FUNCTION,
    MATRIX_FUNCTION,
    VECTOR_FUNCTION,
    MATRIX_FUNCTION,
    _F8_2,
    _F8_2,
    _F8_3,
    _F8_3,
    _F8_1,
    _F8_2,
    _F8_1,
    types.float64,
    types.float64,
    types.float64,
    types.boolean,
    types.boolean,
    types.int64[::1],
    _F8_2,
    _F8_2,
    _F8_2,
    _F8_2,
    _F8_3,
)


def _hstf_steps(
    f: ModelFunction,
    F: ModelFunction,
    h: ModelFunction,
    H: ModelFunction,
    inputs: FloatArray,
    outputs: FloatArray,
    Q: FloatArray,
    R: FloatArray,
    x0: FloatArray,
    P0: FloatArray,
    mu0: FloatArray,
    rho: float,
    beta: float,
    theta: float,
    fading: bool,
    unfaded_likelihood: bool,
    modes_out: IntArray,
    probabilities_out: FloatArray,
    means_out: FloatArray,
    variances_out: FloatArray,
    predictions_out: FloatArray,
    covariances_out: FloatArray,
) -> None:  # compiled as run_hstf
    n_samples = outputs.shape[0]
    n = x0.shape[0]
    m = outputs.shape[1]
    n_q = mu0.shape[0]
    store_covariances = covariances_out.shape[0] == n_samples

    x = x0.copy()
    P = P0.copy()
    S = np.zeros((m, m))  # output residual covariance of eq. (38), previous step
    mu = mu0.copy()
    q_hat = 0  # eq. (40) needs q̂(k): start from the most probable mode
    for i in range(n_q):
        if mu[i] > mu[q_hat]:
            q_hat = i

    x_i_pred = np.empty((n_q, n))
    F_i = np.empty((n_q, n, n))
    H_i = np.empty((n_q, m, n))
    y_i = np.empty((n_q, m))
    gamma_i = np.empty((n_q, m))
    P_i_pred = np.empty((n_q, n, n))
    FPF = np.empty((n_q, n, n))
    x_i_post = np.empty((n_q, n))
    P_i_post = np.empty((n_q, n, n))
    S_i = np.empty((n_q, m, m))
    log_likelihood = np.empty(n_q)
    uniform = np.full(n_q, 1.0 / n_q)
    x_pred = np.empty(n)
    P_pred = np.empty((n, n))
    y_mix = np.empty(m)
    work_nn = np.empty((n, n))
    work_mn = np.empty((m, n))
    work_nm = np.empty((n, m))
    IKH = np.empty((n, n))
    K = np.empty((n, m))
    L = np.zeros((m, m))
    HQH = np.empty((m, m))
    M = np.empty((m, m))
    Si_gain = np.empty((m, m))
    vec_m = np.empty(m)
    vec_m2 = np.empty(m)

    modes_out[0] = q_hat
    probabilities_out[0, :] = mu
    means_out[0, :] = x
    for a in range(n):
        variances_out[0, a] = P[a, a]
    if store_covariances:
        covariances_out[0] = P

    for k in range(n_samples - 1):
        u = inputs[k]
        u_next = inputs[k + 1]
        y = outputs[k + 1]
        # (10), (25): mode-conditional predictions and state Jacobians at x̂(k|k).
        for i in range(n_q):
            f(i, x, u, x_i_pred[i])
            F(i, x, u, F_i[i])
        # (21): combined prediction with Pr(q(k+1)=i|Y^k) = 1/n_q (eq. (20)).
        for a in range(n):
            acc = 0.0
            for i in range(n_q):
                acc += x_i_pred[i, a]
            x_pred[a] = acc / n_q
        for i in range(n_q):
            H(i, x_pred, u_next, H_i[i])  # (12)
            h(i, x_i_pred[i], u_next, y_i[i])  # ŷ_i(k+1)
            for b in range(m):
                gamma_i[i, b] = y[b] - y_i[i, b]  # (31)
        # One-step-ahead output prediction before y(k+1) is used: the same 1/n_q weights.
        for b in range(m):
            acc = 0.0
            for i in range(n_q):
                acc += y_i[i, b]
            predictions_out[k + 1, b] = acc / n_q
        for i in range(n_q):
            congruence(F_i[i], P, work_nn, FPF[i])  # F̄_i P(k|k) F̄_iᵀ
            lam = 1.0
            if fading:
                congruence(H_i[i], FPF[i], work_mn, M)  # (28)
                congruence(H_i[i], Q[i], work_mn, HQH)
                trace_n = 0.0
                trace_m = 0.0
                for b in range(m):
                    for c in range(m):
                        outer = gamma_i[i, b] * gamma_i[i, c]
                        V = outer if k == 0 else (rho * S[b, c] + outer) / (1.0 + rho)  # (30)
                        if b == c:
                            trace_n += V - HQH[b, b] - beta * R[i, b, b]  # (29)
                    trace_m += M[b, b]
                if trace_m > 0.0 and trace_n / trace_m > 1.0:  # (26), (27)
                    lam = trace_n / trace_m
            for a in range(n):
                for c in range(n):
                    P_i_pred[i, a, c] = lam * FPF[i, a, c] + Q[i, a, c]  # (24)
        mixture_moments(uniform, x_i_pred, P_i_pred, x_pred, P_pred)  # (22)
        for i in range(n_q):
            # (11): gain from the combined P(k+1|k).
            congruence(H_i[i], P_pred, work_mn, Si_gain)
            for b in range(m):
                for c in range(m):
                    Si_gain[b, c] += R[i, b, c]
            cholesky(Si_gain, L)
            gain(P_pred, H_i[i], L, work_nm, vec_m, vec_m2, K)
            for a in range(n):  # (9)
                acc = x_i_pred[i, a]
                for b in range(m):
                    acc += K[a, b] * gamma_i[i, b]
                x_i_post[i, a] = acc
            joseph_update(P_pred, K, H_i[i], R[i], IKH, work_nn, work_nm, P_i_post[i])  # (32)
            # (35): likelihood covariance from the mode-conditional P_i(k+1|k) (Remark 1).
            if unfaded_likelihood:
                for a in range(n):
                    for c in range(n):
                        work_nn[a, c] = FPF[i, a, c] + Q[i, a, c]
                congruence(H_i[i], work_nn, work_mn, S_i[i])
            else:
                congruence(H_i[i], P_i_pred[i], work_mn, S_i[i])
            for b in range(m):
                for c in range(m):
                    S_i[i, b, c] += R[i, b, c]
            if cholesky(S_i[i], L):
                log_likelihood[i] = gaussian_log_density(gamma_i[i], L, vec_m)  # (34)
            else:
                log_likelihood[i] = -np.inf
        # (33) with the uniform prior of (20), normalised in log space.
        normalize_log(log_likelihood, mu)
        mixture_moments(mu, x_i_post, P_i_post, x, P)  # (36), (37)
        mixture_moments(mu, y_i, S_i, y_mix, S)  # (38), (39)
        best = 0  # (40)
        for i in range(n_q):
            if mu[i] > mu[best]:
                best = i
        if mu[best] >= theta:
            q_hat = best
        modes_out[k + 1] = q_hat
        probabilities_out[k + 1, :] = mu
        means_out[k + 1, :] = x
        for a in range(n):
            variances_out[k + 1, a] = P[a, a]
        if store_covariances:
            covariances_out[k + 1] = P


_hstf_loop = jit_signature(_SIGNATURE)(_hstf_steps)


def run_hstf(
    model: HybridModel,
    signals: AlignedSignals,
    options: HstfOptions,
    *,
    jit: bool = True,
    store_covariances: bool = False,
) -> EstimationResult:
    """Run the HSTF over the aligned signals.

    ``jit=False`` runs the same loop as plain Python on plain-Python mode functions (slow;
    the reference the compiled path is tested against).
    """
    compiled = compile_model(model, jit=jit)
    Q, R = noise_stacks(model)
    buffers = FilterBuffers.allocate(model, signals.n_samples, store_covariances=store_covariances)
    loop = _hstf_loop if jit else _hstf_steps
    start = time.perf_counter()
    loop(
        compiled.f,
        compiled.F,
        compiled.h,
        compiled.H,
        contiguous(signals.inputs),
        contiguous(signals.outputs),
        Q,
        R,
        contiguous(model.initial_state),
        contiguous(model.initial_covariance),
        contiguous(model.initial_mode_probabilities),
        options.rho,
        options.beta,
        options.theta,
        options.fading,
        options.likelihood == "unfaded",
        buffers.modes,
        buffers.mode_probabilities,
        buffers.state_means,
        buffers.state_variances,
        buffers.output_predictions,
        buffers.covariances,
    )
    runtime = time.perf_counter() - start
    return buffers.result(
        NAME,
        options_dict(options),
        model,
        signals,
        runtime_s=runtime,
        compile_s=compiled.compile_s,
    )


def hstf_options(values: dict[str, object]) -> HstfOptions:
    """Validated HSTF options from a name → value mapping."""
    return parse_options(HstfOptions, values, estimator=NAME)
