r"""Expectation correction (Barber 2006) against Kim's mode recursion, on the study's logs.

Run from the repository root::

    .venv/bin/python docs/studies/smoothing_ec.py        # ~4 min: 120 three-tank logs

A plain-Python prototype (numpy, one log at a time; not hybridlog's compiled smoother) of the
backward pass of D. Barber, "Expectation Correction for Smoothed Inference in Switching
Linear Dynamical Systems", *JMLR* 7 (2006) 2515-2540, with one Gaussian per mode and the
"mean" approximation of its expectation (the paper's equation numbers were not checked
here).  Kim's recursion takes ``Pr(q(k)=i | q(k+1)=j, Y^N) ≈ Pr(q(k)=i | q(k+1)=j, Y^k)``;
expectation correction conditions on the smoothed state of ``k+1`` as well, which in a
switching model makes the future independent of ``q(k)``:

.. math::

    \Pr(q(k)=i \mid q(k+1)=j, Y^N) \propto \mu_i(k)\,\Pi_{ij}\,
        N\bigl(\hat x^s_j(k+1);\ f_j(\hat x_i(k|k)),\ F P_i(k|k) F^T + Q_j\bigr)

(the density at the mean of ``p(x(k+1) | q(k+1)=j, Y^N)``).  The states: Kim's own pairwise
extended RTS step from ``x̂_i(k|k)`` for every pair ``(i, j)``, mixed with these weights
(``n_q²`` RTS steps a sample; hybridlog's smoother takes ``n_q``, from the mixed prior).
The forward pass is an IMM written out here; its filtered modes and Kim's smoothed ones are
checked to be hybridlog's own (``imm``, ``smooth = true``) on every log, so the comparison is
of the backward recursions alone.

Three-tank scenarios of ``docs/studies/smoothing.py``: seeds 0..29 and 100..139 (its
schedule), 200..229 (random schedules), 501..520 (80-step segments).  The double cart is not
run: its plant has no process noise, and there the density above is nearly singular
(``P_ij = F P_i Fᵀ``) and decides by rounding (first runs put 52-83 % of case 1's samples
in the wrong mode where the filter had 5 %, docs/smoothing.md); as the
"evidence" variant of ``smoothing_modes.py`` it would have to fall back to Kim's weights for
a next mode without positive definite process noise.
"""

from __future__ import annotations

import statistics
import sys
from pathlib import Path

import numpy as np

if __package__ in (None, ""):  # run as a file: make the repository root and the study importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
    sys.path.insert(0, str(Path(__file__).resolve().parent))

import smoothing as study  # docs/studies/smoothing.py

from hybridlog.estimators.filter_options import ImmOptions
from hybridlog.estimators.imm import transition_matrix
from hybridlog.estimators.registry import ESTIMATORS, Prepared
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


def smoothed_modes(
    model: HybridModel,
    signals: AlignedSignals,
    T: np.ndarray,
    forward: tuple[np.ndarray, np.ndarray, np.ndarray],
    corrected: bool,
) -> np.ndarray:
    """Smoothed mode probabilities: Kim's recursion, or with the correction (``corrected``)."""
    c = compile_model(model)
    X, P, MU = forward
    N, nq, n = X.shape
    xs, Ps, mus = X[-1].copy(), P[-1].copy(), MU[-1].copy()
    out = np.zeros((N, nq))
    out[-1] = mus
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
        out[k] = mus
    return out


def schedule(seed: int) -> str:
    """The schedule of a seed's scenario in docs/studies/smoothing.py."""
    if 200 <= seed < 300:
        return study.random_schedule(seed)
    return study.SHORT_SCHEDULE if seed > 500 else study.THREE_TANK_SCHEDULE


def main() -> None:
    """Print, per scenario, how each backward recursion's mode error compares with the filter's."""
    tank = study.three_tank()
    T = transition_matrix(tank, ImmOptions())
    scenarios = {
        "seeds 0..29": range(30),
        "seeds 100..139": range(100, 140),
        "random schedules, seeds 200..229": range(200, 230),
        "80-step segments, seeds 501..520": range(501, 521),
    }
    for title, seeds in scenarios.items():
        errors: dict[str, list[float]] = {"filter": [], "kim": [], "ec": []}
        for seed in seeds:
            signals = study.simulate(tank, schedule=schedule(seed), seed=seed).signals(tank)
            truth = signals.truth_modes
            assert truth is not None
            forward = imm_forward(tank, signals, T)
            kim = smoothed_modes(tank, signals, T, forward, corrected=False).argmax(1)
            own = Prepared(ESTIMATORS["imm"], ImmOptions(smooth=True)).run(tank, signals)
            assert own.post_processing is not None
            assert np.array_equal(own.post_processing.filtered.modes, forward[2].argmax(1))
            assert np.array_equal(own.modes, kim)  # the same forward pass and Kim's recursion
            ec = smoothed_modes(tank, signals, T, forward, corrected=True).argmax(1)
            for name, modes in (("filter", forward[2].argmax(1)), ("kim", kim), ("ec", ec)):
                errors[name].append(100.0 * float(np.mean(modes[1:] != truth[1:])))
        print(f"- {title}:", end="")
        for name in ("kim", "ec"):
            pairs = list(zip(errors[name], errors["filter"], strict=True))
            print(
                f" {name} median {statistics.median(errors[name]):.2f} % (filter "
                f"{statistics.median(errors['filter']):.2f} %), below the filter on "
                f"{sum(a < b for a, b in pairs)}/{len(pairs)}, above on "
                f"{sum(a > b for a, b in pairs)}, at most half of it on "
                f"{sum(a <= 0.5 * b for a, b in pairs)};",
                end="",
            )
        print(flush=True)


if __name__ == "__main__":
    main()
