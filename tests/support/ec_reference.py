r"""Expectation correction (Barber 2006) in plain NumPy: the reference of ``smoother = "ec"``.

Moved here from the prototype of ``docs/studies/smoothing_ec.py`` (which imports it): one log
at a time, a NumPy call per matrix step, nothing of hybridlog's compiled passes but the
model's mode functions (:func:`hybridlog.model.compiled.compile_model`).  D. Barber,
"Expectation Correction for Smoothed Inference in Switching Linear Dynamical Systems",
*JMLR* 7 (2006) 2515-2540, with one Gaussian per mode and the "mean" approximation:

.. math::

    \Pr(q(k)=i \mid q(k+1)=j, Y^N) \propto \mu_i(k)\,\Pi_{ij}\,
        N\bigl(\hat x^s_j(k+1);\ f_j(\hat x_i(k|k)),\ F P_i(k|k) F^T + Q_j\bigr)

and per pair ``(i, j)`` an extended RTS step from ``x̂_i(k|k), P_i(k|k)`` to
``x̂^s_j(k+1), P^s_j(k+1)``, mixed with the joint weights.  Without ``corrected`` the weights
are Kim's (``Pr(q(k)=i | q(k+1)=j, Y^k)``).  No guard, rounding probe or skip of negligible
modes: compare it with hybridlog's only where those do not act.
"""

import numpy as np

from hybridlog.model.compiled import compile_model
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.signals import AlignedSignals


def log_density(gamma: np.ndarray, S: np.ndarray) -> float:
    """``log N(gamma; 0, S)``."""
    L = np.linalg.cholesky(S)
    z = np.linalg.solve(L, gamma)
    return float(-0.5 * z @ z - np.log(np.diag(L)).sum() - 0.5 * len(gamma) * np.log(2 * np.pi))


def imm_forward(
    model: HybridModel, signals: AlignedSignals, T: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The IMM's filtered ``x̂_i(k|k)``, ``P_i(k|k)`` and ``μ(k)`` of every sample."""
    c = compile_model(model)
    n, m, nq, N = model.n_states, model.n_outputs, model.n_modes, signals.n_samples
    Q = [mode.process_noise for mode in model.modes]
    R = [mode.measurement_noise for mode in model.modes]
    xi = np.repeat(model.initial_state[None], nq, 0).astype(float)
    Pi = np.repeat(model.initial_covariance[None], nq, 0).astype(float)
    mu = np.asarray(model.initial_mode_probabilities, dtype=float)
    X, P, MU = np.zeros((N, nq, n)), np.zeros((N, nq, n, n)), np.zeros((N, nq))
    X[0], P[0], MU[0] = xi, Pi, mu
    xp, Fj, yh, Hj = np.empty(n), np.empty((n, n)), np.empty(m), np.empty((m, n))
    for k in range(N - 1):
        u, u_next, y = signals.inputs[k], signals.inputs[k + 1], signals.outputs[k + 1]
        c_bar = T.T @ mu
        new_x, new_P, ll = np.zeros((nq, n)), np.zeros((nq, n, n)), np.full(nq, -np.inf)
        for j in range(nq):
            w = T[:, j] * mu / c_bar[j]
            x0 = w @ xi
            P0 = sum(w[i] * (Pi[i] + np.outer(xi[i] - x0, xi[i] - x0)) for i in range(nq))
            c.f(j, x0, u, xp)
            c.F(j, x0, u, Fj)
            P_pred = Fj @ P0 @ Fj.T + Q[j]
            c.h(j, xp, u_next, yh)
            c.H(j, xp, u_next, Hj)
            S = Hj @ P_pred @ Hj.T + R[j]
            gamma = y - yh
            K = np.linalg.solve(S, Hj @ P_pred).T
            new_x[j] = xp + K @ gamma
            IKH = np.eye(n) - K @ Hj
            new_P[j] = IKH @ P_pred @ IKH.T + K @ R[j] @ K.T
            ll[j] = log_density(gamma, S)
        log_post = np.log(np.maximum(c_bar, 1e-300)) + ll
        mu = np.exp(log_post - log_post.max())
        mu /= mu.sum()
        xi, Pi = new_x, new_P
        X[k + 1], P[k + 1], MU[k + 1] = xi, Pi, mu
    return X, P, MU


def smoothed(
    model: HybridModel,
    signals: AlignedSignals,
    T: np.ndarray,
    forward: tuple[np.ndarray, np.ndarray, np.ndarray],
    corrected: bool = True,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Smoothed mode probabilities, state means and covariances (the mixtures over the modes).

    Expectation correction's weights (``corrected``), or Kim's; the pairwise RTS steps either
    way.  ``forward`` is :func:`imm_forward`'s.
    """
    c = compile_model(model)
    X, P, MU = forward
    N, nq, n = X.shape
    xs, Ps, mus = X[-1].copy(), P[-1].copy(), MU[-1].copy()
    out_mu = np.zeros((N, nq))
    out_x = np.zeros((N, n))
    out_P = np.zeros((N, n, n))

    def combined(k: int) -> None:
        out_mu[k] = mus
        out_x[k] = mus @ xs
        spread = xs - out_x[k]
        out_P[k] = np.einsum("i,iab->ab", mus, Ps + spread[:, :, None] * spread[:, None, :])

    combined(N - 1)
    xp, Fj = np.empty(n), np.empty((n, n))
    for k in range(N - 2, -1, -1):
        u = signals.inputs[k]
        log_w = np.zeros((nq, nq))
        x_ij, P_ij = np.zeros((nq, nq, n)), np.zeros((nq, nq, n, n))
        for i in range(nq):
            for j in range(nq):
                c.f(j, X[k, i], u, xp)
                c.F(j, X[k, i], u, Fj)
                P_pred = Fj @ P[k, i] @ Fj.T + model.modes[j].process_noise
                J = P[k, i] @ Fj.T @ np.linalg.inv(P_pred)
                x_ij[i, j] = X[k, i] + J @ (xs[j] - xp)
                P_ij[i, j] = P[k, i] + J @ (Ps[j] - P_pred) @ J.T
                log_w[i, j] = np.log(max(MU[k, i], 1e-300)) + np.log(max(T[i, j], 1e-300))
                if corrected:
                    log_w[i, j] += log_density(xs[j] - xp, P_pred)
        w = np.exp(log_w - log_w.max(0))
        w /= w.sum(0)  # Pr(q(k)=i | q(k+1)=j, ...), normalised over i
        joint = w * mus[None, :]
        mus_k = joint.sum(1)
        new_x, new_P = np.zeros((nq, n)), np.zeros((nq, n, n))
        for i in range(nq):
            weights = joint[i] / mus_k[i] if mus_k[i] > 0 else np.eye(nq)[i]
            new_x[i] = weights @ x_ij[i]
            new_P[i] = sum(
                weights[j] * (P_ij[i, j] + np.outer(x_ij[i, j] - new_x[i], x_ij[i, j] - new_x[i]))
                for j in range(nq)
            )
        xs, Ps, mus = new_x, new_P, mus_k / mus_k.sum()
        combined(k)
    return out_mu, out_x, out_P
