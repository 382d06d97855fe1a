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

No smoothing (issue 12): the paper assumes unknown transitions and predicts every mode with
probability ``1/n_q`` (eq. (20)).  Under that uniform chain Kim's backward factor
``Σ_j Π_ij μ^s_j(k+1)/c̄_j(k+1)`` is the same for every mode, so the smoothed mode
probabilities equal the filtered ones, and the Viterbi path is the per-sample argmax of the
likelihoods of eq. (34): neither would add anything the filter does not show.  A smoother
that weighs the smoothed state (expectation correction) would, but its RTS steps need each
mode's covariance as a posterior, and eq. (24) inflates them on purpose (the fading factors
of eqs. (28)-(30)).  The
registry entry therefore says ``supports_smoothing=False`` and ``--smooth`` is refused with
one line; a model with a Markov matrix can be smoothed with ``imm``.

References
----------
Wang W., Peng Z., Zhou D. State estimation of a class of hybrid systems in the presence of
unknown mode transitions. ``papers/000_e6c6af29d4167a70.txt``.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace
from functools import partial
from typing import NamedTuple

import numpy as np

from hybridlog.estimators.common import (
    Accelerator,
    Chunk,
    FilterBuffers,
    FilterCode,
    FilterRun,
    Fn,
    run_filter_chunks,
)
from hybridlog.estimators.filter_options import HstfOptions
from hybridlog.estimators.kernels import (
    Workspace,
    argmax,
    cholesky,
    congruence,
    dimensions,
    kalman_update,
    leave_out_unmeasured,
    left_out,
    measured_log_density,
    mixture_moments,
    normalize_log,
    record,
    weighed,
    workspace,
)
from hybridlog.estimators.options import options_dict
from hybridlog.estimators.result import EstimationResult
from hybridlog.estimators.unrolled import (
    Entry,
    Matrix,
    Program,
    Vector,
    matrix_names,
    noise_matrices,
    product,
    reshape,
    state_slots,
    term,
    upper,
    vector_names,
)
from hybridlog.jit import jitable_kernel
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.signals import AlignedSignals, FloatArray, IntArray

NAME = "hstf"

FADED_LIKELIHOOD_NOTE = (
    "likelihood=faded is the paper's eq. (35), whose fading factor also inflates the "
    "likelihood covariance S_i, which keeps the mode posterior flat so that the θ-rule of "
    "eq. (40) seldom lets the estimate leave its initial mode: on the paper's own three-tank "
    "example this gives 45 % mode accuracy over 30 seeds against 95 % with --set "
    "likelihood=unfaded (docs/three_tank.md in hybridlog's repository)"
)
"""Why the paper-faithful HSTF underperforms, shown in every report of it (one sentence)."""

UNIFORM_PREDICTION_NOTE = (
    "ŷ(k), of which MSE, VAF and fit are computed, is the paper's one-step prediction under "
    "the uniform mode prediction Pr(q(k) = i | Y^(k-1)) = 1/n_q (eqs. (20)-(21)): the mean of "
    "every mode's predicted output, not the estimated mode's, so where the modes' output "
    "equations differ these metrics score that mean, low even where the modes are right"
)
"""Why the HSTF's output fit is low on a model whose ``h`` differs by mode (one sentence)."""


class HstfSettings(NamedTuple):
    """The HSTF's own settings as its loops take them (from :class:`HstfOptions`)."""

    rho: float
    beta: float
    theta: float
    fading: bool
    unfaded_likelihood: bool


class HstfState(NamedTuple):
    """What the HSTF carries from one step to the next (a :class:`~.common.Chunk`'s state).

    ``x̂(k|k)``, ``P(k|k)``, the output residual covariance ``S(k)`` of eq. (38) that eq. (30)
    reads at the next step, the mode probabilities and the decided mode ``q̂(k)`` of eq. (40)
    (one entry).  ``L`` is the generic loop's Cholesky factor: a factorisation that fails
    (an innovation covariance not positive definite) leaves part of the one before in it,
    which the EKF update then reads; the straight-line code's failed factor is NaN instead,
    and it leaves ``L`` alone.
    """

    x: FloatArray
    P: FloatArray
    S: FloatArray
    mu: FloatArray
    q_hat: IntArray
    L: FloatArray

    @classmethod
    def prior(cls, run: FilterRun) -> HstfState:
        """The state before the first step: the model's prior, ``S = 0``, ``q̂`` its likeliest mode.

        Eq. (40) needs ``q̂(k)``: it starts from the most probable mode.
        """
        m = run.outputs.shape[1]
        return cls(
            run.x0.copy(),
            run.P0.copy(),
            np.zeros((m, m)),
            run.mu0.copy(),
            np.array([argmax(run.mu0)], dtype=np.int64),
            np.zeros((m, m)),
        )


class HstfScratch(NamedTuple):
    """The arrays the HSTF's time loop works in (:func:`_hstf_steps` allocates them)."""

    x_i_pred: FloatArray
    F_i: FloatArray
    H_i: FloatArray
    y_i: FloatArray
    gamma_i: FloatArray
    P_i_pred: FloatArray
    FPF: FloatArray
    x_i_post: FloatArray
    P_i_post: FloatArray
    S_i: FloatArray
    log_likelihood: FloatArray
    uniform: FloatArray
    x_pred: FloatArray
    P_pred: FloatArray
    y_mix: FloatArray
    HQH: FloatArray
    M: FloatArray
    H_left: FloatArray
    gamma_left: FloatArray
    R_left: FloatArray
    S_left: FloatArray
    work: Workspace


def _hstf_steps(
    f: Fn,
    F: Fn,
    h: Fn,
    H: Fn,
    run: FilterRun,
    settings: HstfSettings,
    chunk: Chunk[HstfState],
    out: FilterBuffers,
) -> None:
    """The generic HSTF time loop (compiled on first use; the docstring of the module).

    Computes the rows of ``chunk`` from its :class:`HstfState`, worked on in place: allocates
    the loop's :class:`HstfScratch`, then runs :func:`_hstf_rows`, which allocates nothing.
    """
    _, n, m, n_q = dimensions(run)
    scratch = HstfScratch(
        np.empty((n_q, n)),
        np.empty((n_q, n, n)),
        np.empty((n_q, m, n)),
        np.empty((n_q, m)),
        np.empty((n_q, m)),
        np.empty((n_q, n, n)),
        np.empty((n_q, n, n)),
        np.empty((n_q, n)),
        np.empty((n_q, n, n)),
        np.empty((n_q, m, m)),
        np.empty(n_q),
        np.full(n_q, 1.0 / n_q),
        np.empty(n),
        np.empty((n, n)),
        np.empty(m),
        np.empty((m, m)),
        np.empty((m, m)),
        np.empty((m, n)),
        np.empty(m),
        np.empty((m, m)),
        np.empty((m, m)),
        workspace(n, m),
    )
    _hstf_rows(f, F, h, H, run, settings, chunk, out, scratch)


@jitable_kernel
def _hstf_rows(
    f: Fn,
    F: Fn,
    h: Fn,
    H: Fn,
    run: FilterRun,
    settings: HstfSettings,
    chunk: Chunk[HstfState],
    out: FilterBuffers,
    scratch: HstfScratch,
) -> None:
    """The time loop of :func:`_hstf_steps`, in its ``scratch``.

    Compiled without reference counts (:data:`~hybridlog.jit.WITHOUT_REFCOUNTS`): it slices
    views freely, and every array copy is a loop.
    """
    inputs, outputs, Q, R = run.inputs, run.outputs, run.Q, run.R
    rho, beta, theta, fading, unfaded_likelihood = settings
    first, stop, state = chunk
    _, n, m, n_q = dimensions(run)

    x, P, S, mu = state.x, state.P, state.S, state.mu
    q_hat = state.q_hat[0]

    x_i_pred, F_i, H_i, y_i, gamma_i, P_i_pred, FPF, x_i_post, P_i_post = scratch[:9]
    S_i, log_likelihood, uniform, x_pred, P_pred, y_mix, HQH, M = scratch[9:17]
    H_left, gamma_left, R_left, S_left, work = scratch[17:]
    work_nn, work_mn, L, vec_m = work.nn, work.mn, work.L, work.m
    for b in range(m):
        for c in range(m):
            L[b, c] = state.L[b, c]
    predictions_out = out.output_predictions

    if first == 0 and stop > 0:
        record(out, 0, q_hat, mu, x, P)

    for k in range(max(first, 1) - 1, stop - 1):
        row = k + 1 - first
        u = inputs[k]
        u_next = inputs[k + 1]
        y = outputs[k + 1]
        left = left_out(y)  # outputs not measured at k+1: the update is the others'
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
            predictions_out[row, b] = acc / n_q
        for i in range(n_q):
            congruence(F_i[i], P, work_nn, FPF[i])  # F̄_i P(k|k) F̄_iᵀ
            lam = 1.0
            if fading:
                congruence(H_i[i], FPF[i], work_mn, M)  # (28)
                congruence(H_i[i], Q[i], work_mn, HQH)
                trace_n = 0.0
                trace_m = 0.0
                for b in range(m):  # the traces over the measured outputs
                    if y[b] == y[b]:
                        outer = gamma_i[i, b] * gamma_i[i, b]
                        V = outer if k == 0 else (rho * S[b, b] + outer) / (1.0 + rho)  # (30)
                        trace_n += V - HQH[b, b] - beta * R[i, b, b]  # (29)
                        trace_m += M[b, b]
                if trace_m > 0.0 and trace_n / trace_m > 1.0:  # (26), (27)
                    lam = trace_n / trace_m
            for a in range(n):
                for c in range(n):
                    P_i_pred[i, a, c] = lam * FPF[i, a, c] + Q[i, a, c]  # (24)
        mixture_moments(uniform, x_i_pred, P_i_pred, x_pred, P_pred)  # (22)
        nearest = np.nan  # the smallest γᵀ S⁻¹ γ over the modes (FilterBuffers.surprise)
        for i in range(n_q):
            # (9), (11), (32): the gain from the combined P(k+1|k), of the measured outputs.
            H_u, R_u, gamma_u = H_i[i], R[i], gamma_i[i]
            if left:
                for b in range(m):
                    gamma_left[b] = gamma_u[b]
                    for a in range(n):
                        H_left[b, a] = H_u[b, a]
                leave_out_unmeasured(y, H_left, gamma_left, R_u, R_left)
                H_u, R_u, gamma_u = H_left, R_left, gamma_left
            kalman_update(x_i_pred[i], P_pred, H_u, R_u, gamma_u, work, x_i_post[i], P_i_post[i])
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
            S_u = S_i[i]  # (38)-(39) mix the whole S_i; (34) weighs the measured outputs'
            if left:
                leave_out_unmeasured(y, H_left, gamma_left, S_u, S_left)
                S_u = S_left
            if cholesky(S_u, L):
                log_likelihood[i] = measured_log_density(gamma_u, L, vec_m, left)  # (34)
                distance = 0.0  # vec_m holds L⁻¹ γ
                for b in range(m):
                    distance += vec_m[b] * vec_m[b]
                if weighed(distance, log_likelihood[i]) and not nearest <= distance:
                    nearest = distance
            else:
                log_likelihood[i] = -np.inf
        out.surprise[row] = nearest if left < m else np.nan
        # (33) with the uniform prior of (20), normalised in log space.
        normalize_log(log_likelihood, mu)
        mixture_moments(mu, x_i_post, P_i_post, x, P)  # (36), (37)
        mixture_moments(mu, y_i, S_i, y_mix, S)  # (38), (39)
        best = argmax(mu)  # (40)
        if mu[best] >= theta:
            q_hat = best
        record(out, row, q_hat, mu, x, P)
    state.q_hat[0] = q_hat
    for b in range(m):
        for c in range(m):
            state.L[b, c] = L[b, c]


def _settings(options: HstfOptions) -> HstfSettings:
    return HstfSettings(
        options.rho,
        options.beta,
        options.theta,
        options.fading,
        options.likelihood == "unfaded",
    )


def tied_prior_note(model: HybridModel, options: HstfOptions) -> str | None:
    """A ``WARNING`` where the prior's largest mode probability is shared, else None.

    Eq. (40) starts from q̂(0), the prior's most probable mode, and changes it only where a
    posterior reaches θ, which the faded likelihood seldom lets happen: a tie picked the
    first mode of the file, and the mode accuracy followed the modes' order without a word
    (``three_tank_hstf`` with a prior of 0.5, 0.5, 0 held mode 1: 87.0 % on a 1:150,3:150
    log of seed 1002, against 36.9 % with its prior on mode 2).
    """
    mu0 = model.initial_mode_probabilities
    if mu0.size < 2:
        return None
    tied = np.flatnonzero(mu0 == mu0.max())
    if tied.size < 2:
        return None
    ids = ", ".join(f"'{model.mode_ids[j]}'" for j in tied)
    return (
        f"WARNING: the prior ([initial]) gives modes {ids} the same largest probability "
        f"({mu0.max():g}), so q̂(0) is '{model.mode_ids[tied[0]]}', the first of them in the "
        f"model's order, and eq. (40) keeps it until a mode's posterior reaches θ = "
        f"{options.theta:g}: the mode estimate depends on that order; give [initial] a mode"
    )


def _noted(result: EstimationResult, options: HstfOptions, model: HybridModel) -> EstimationResult:
    """``result`` with the notes that explain its numbers.

    :data:`FADED_LIKELIHOOD_NOTE` where the likelihood is the faded one (not with ``fading =
    false``: λ_i = 1 fades nothing, and the note's 45 % is not this run's; nor on a one-mode
    model, whose posterior is 1 whatever S_i: there is no mode for θ to hold or miss), and
    :data:`UNIFORM_PREDICTION_NOTE` where the modes' output equations differ.
    """
    faded = options.fading and options.likelihood == "faded" and model.n_modes > 1
    tied = tied_prior_note(model, options)
    notes = (
        *((tied,) if tied is not None else ()),
        *((FADED_LIKELIHOOD_NOTE,) if faded else ()),
        *((UNIFORM_PREDICTION_NOTE,) if model.outputs_differ_by_mode else ()),
    )
    return replace(result, notes=(*result.notes, *notes)) if notes else result


def run_hstf(
    model: HybridModel,
    signals: AlignedSignals,
    options: HstfOptions,
    *,
    jit: bool = True,
    kernel: str = "auto",
    store_covariances: bool = False,
) -> EstimationResult:
    """Run the HSTF over the aligned signals: :func:`stream_hstf` in one chunk.

    The mode of sample k is the one under which ``x(k)`` came from ``x(k-1)``; for a
    state-driven model, whose mode of sample k governs the step from ``x(k)``, the registry's
    run (``prepare(model, ...).run``, what the commands use) moves the modes one sample
    earlier (:meth:`~hybridlog.estimators.result.EstimationResult.with_modes_of_the_step_from`).

    ``kernel`` and ``jit`` choose the code path (:func:`~hybridlog.estimators.common.run_filter`):
    :func:`generate_hstf_source` for small models, else the generic :func:`_hstf_steps`.
    """
    (result,) = stream_hstf(
        model,
        signals,
        options,
        rows=max(signals.n_samples, 1),
        jit=jit,
        kernel=kernel,
        store_covariances=store_covariances,
    )
    return result


def stream_hstf(
    model: HybridModel,
    signals: AlignedSignals,
    options: HstfOptions,
    *,
    rows: int,
    jit: bool = True,
    kernel: str = "auto",
    store_covariances: bool = False,
) -> Iterator[EstimationResult]:
    """:func:`run_hstf`'s result in consecutive chunks of at most ``rows`` rows.

    The chunks of :func:`~hybridlog.estimators.common.run_filter_chunks` (views of buffers
    the next chunk overwrites), each with :func:`run_hstf`'s notes.
    """
    chunks = run_filter_chunks(
        CODE,
        model,
        signals,
        _settings(options),
        options_dict(options),
        jit=jit,
        kernel=kernel,
        store_covariances=store_covariances,
        rows=rows,
    )
    return (_noted(chunk, options, model) for chunk in chunks)


def generate_hstf_source(model: HybridModel, *, masked: bool = False) -> str:
    """Straight-line source of the whole HSTF time loop for ``model`` (see ``unrolled.py``).

    Defines ``hstf_run(run, settings, chunk, out)``, the frame of :func:`_hstf_steps`
    without the model functions, computing exactly what :func:`_hstf_steps` does, with the
    mode functions, noise covariances and small matrix products written out.  The carried
    variables are loaded from the chunk's :class:`HstfState` before the time loop and
    stored back after it (``L`` is the generic loop's only).  ``masked``: the code for a log
    with outputs not measured at some rows, as :func:`_hstf_steps` runs it (the traces of
    (26)-(30) over the measured outputs, the update and (34) on them alone, (38)-(39) of
    the whole ``S_i``).
    """
    n, m, n_u, n_q = model.n_states, model.n_outputs, model.n_inputs, model.n_modes
    p = Program(indent="    ")
    x = vector_names("x", n)
    P = matrix_names("P", n, n, symmetric=True)
    S = matrix_names("S", m, m, symmetric=True)
    mu = vector_names("mu", n_q)
    Q, R = noise_matrices(model)
    uniform = 1.0 / n_q

    carried = [
        *state_slots("x", x),
        *state_slots("P", P),
        *state_slots("S", S),
        *state_slots("mu", mu),
        *state_slots("q_hat", ["q_hat"]),
    ]

    p.prologue(HstfSettings._fields)
    p.resume(carried)
    with p.block("if first == 0 and stop > 0:"):  # row 0: the prior
        p.record("0", "q_hat", mu, x, P)
    u, v, y = p.open_time_loop(n_u, m, chunk=True)
    measured = p.measured_flags(y) if masked else None
    x_names = list(x)
    x_i = [p.mode_values(model, i, "f", x_names, u) for i in range(n_q)]  # (10)
    F_i = [reshape(p.mode_values(model, i, "F", x_names, u), n, n) for i in range(n_q)]  # (25)
    x_pred = [
        p.let("xp", [product(uniform, x_i[i][a]) for i in range(n_q)]) for a in range(n)
    ]  # (21)
    x_pred_names = p.named("xpn", x_pred)
    H_i = [reshape(p.mode_values(model, i, "H", x_pred_names, v), m, n) for i in range(n_q)]  # (12)
    y_i = [p.mode_values(model, i, "h", p.named("xin", x_i[i]), v) for i in range(n_q)]
    gamma = [[p.difference("g", y[b], y_i[i][b]) for b in range(m)] for i in range(n_q)]  # (31)
    for b in range(m):
        prediction = p.let("yp", [product(uniform, y_i[i][b]) for i in range(n_q)])
        p.emit(f"predictions_out[row, {b}] = {term(prediction)}")
    H_u, R_u, gamma_u = H_i, R, gamma  # of the update and (34): the measured outputs'
    if measured is not None:
        lefts = [p.left_out(measured, H_i[i], R[i], gamma[i]) for i in range(n_q)]
        H_u, R_u, gamma_u = (
            [left[0] for left in lefts],
            [left[1] for left in lefts],
            [left[2] for left in lefts],
        )
    FPF = [p.congruence(f"fpf{i}_", F_i[i], P) for i in range(n_q)]
    lam: list[str] = []
    for i in range(n_q):
        # (26)-(30): only the traces of M_i and N_i are needed, over the measured outputs.
        HFPF = p.matmul(f"hf{i}_", H_u[i], FPF[i])
        HQ = p.matmul(f"hq{i}_", H_u[i], Q[i])
        trace_m = p.let(
            "trm", [product(HFPF[b][c], H_u[i][b][c]) for b in range(m) for c in range(n)]
        )
        hqh = p.let("hqh", [product(HQ[b][c], H_u[i][b][c]) for b in range(m) for c in range(n)])
        outer = p.let("gg", [product(gamma_u[i][b], gamma_u[i][b]) for b in range(m)])
        R_diagonal = [float(r) for r in np.diag(model.modes[i].measurement_noise)]
        if measured is None:
            trace_s = p.let("trs", [S[b][b] for b in range(m)])
            trace_r: Entry = float(sum(R_diagonal))
        else:
            trace_s = p.let("trs", [p.select(S[b][b], measured[b], 0.0) for b in range(m)])
            trace_r = p.let("trr", [p.select(R_diagonal[b], measured[b], 0.0) for b in range(m)])
        trace_n = p.assign(
            "trn",
            f"({term(outer)} if k == 0 else (rho*{term(trace_s)} + {term(outer)})/(1.0 + rho))"
            f" - {term(hqh)} - beta*{term(trace_r)}",
        )
        factor = p.fresh("lam")
        p.emit(f"{factor} = 1.0")
        p.emit(f"if fading and {term(trace_m)} > 0.0 and {trace_n} / {term(trace_m)} > 1.0:")
        p.emit(f"    {factor} = {trace_n} / {term(trace_m)}")
        lam.append(factor)
    P_i_pred = [
        p.symmetric_sum(f"pip{i}_", [p.scaled("sc", lam[i], FPF[i]), Q[i]]) for i in range(n_q)
    ]  # (24)
    _, P_pred = p.mixture("pm", [uniform] * n_q, x_i, P_i_pred)  # (22)
    x_post: list[Vector] = []
    P_post: list[Matrix] = []
    S_i: list[Matrix] = []
    log_likelihood: Vector = []
    distances: list[str] = []
    for i in range(n_q):
        # (9), (11), (32): the gain from the combined P(k+1|k).
        x_update, P_update, _ = p.kalman_update(
            f"u{i}_", x_i[i], P_pred, H_u[i], R_u[i], gamma_u[i]
        )
        x_post.append(x_update)
        P_post.append(P_update)
        scale = p.assign("ls", f"1.0 if unfaded_likelihood else {lam[i]}")
        base = p.symmetric_sum(f"b{i}_", [p.scaled("sc", scale, FPF[i]), Q[i]])
        S_i.append(p.congruence(f"si{i}_", H_i[i], base, add=R[i]))  # (35)
        S_u = S_i[i] if measured is None else p.left_out_matrix(measured, S_i[i])
        Ls = p.cholesky(f"ls{i}_", S_u)
        ll, distance = p.gaussian_log_density_and_distance(f"ll{i}_", gamma_u[i], Ls)  # (34)
        if measured is not None:  # the measured sub-vector's density (kernels.measured_log_density)
            p.emit(f"{ll} = {ll} + 0.5 * left * LOG_2PI")
        p.weighed_distance(distance, ll)  # NaN: no distance (S = ∞), as the loop
        distances.append(distance)
        p.minus_inf_if_nan(ll)
        log_likelihood.append(ll)
    nearest = p.nearest(distances)
    anything = f" if left < {m} else math.nan" if measured is not None else ""  # nothing: none
    p.emit(f"surprise_out[row] = {nearest}{anything}")
    mu_new = p.normalized_weights(log_likelihood, mu)  # (33)
    x_new, P_new = p.mixture("cm", mu_new, x_post, P_post)  # (36), (37)
    _, S_new = p.mixture("sm", mu_new, y_i, S_i)  # (38), (39)
    best = p.argmax(mu_new)  # (40)
    top_mu = p.assign("topmu", f"max({', '.join(term(w) for w in mu_new)})")
    p.emit(f"if {top_mu} >= theta:")
    p.emit(f"    q_hat = {best}")
    p.carry(x, x_new)
    p.carry(upper(P), upper(P_new))
    p.carry(upper(S), upper(S_new))
    p.carry(mu, mu_new)
    p.record("row", "q_hat", mu, x, P)
    p.close_time_loop()
    p.suspend(carried)
    return p.function("hstf_run")


CODE = FilterCode(
    NAME,
    _hstf_steps,
    HstfState.prior,
    Accelerator(
        generate_hstf_source, "hstf_run", masked=partial(generate_hstf_source, masked=True)
    ),
)
"""The generic loop and its accelerator, run by :func:`~hybridlog.estimators.common.run_filter`."""
