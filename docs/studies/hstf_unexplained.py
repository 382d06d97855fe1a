"""Whether a refusal could tell a log the HSTF never explains from one it recovers from.

Run from the repository root::

    .venv/bin/python docs/studies/hstf_unexplained.py      # ~10 s

The HSTF's refusal (:func:`hybridlog.estimators.vouch.check_surprise`) reads the smallest
``γᵀ S_i⁻¹ γ`` over the modes with the paper's faded ``S_i`` (eq. (35)), whose fading factor
grows with the innovations: a log whose outputs are all ``1e6`` (the levels are ~20 cm) passed
at exit 0 where ``imm`` refuses it at sample 1.  This study measures, per sample, the unfaded
distance the IMM would read, ``γ_iᵀ S_i⁻¹ γ_i`` with ``S_i = H_i (F_i P Fᵢᵀ + Q_i) H_iᵀ + R_i``
from the HSTF's own ``x̂(k|k)`` and ``P(k|k)`` (eqs. (10), (12), (31): exactly what
``likelihood = unfaded`` computes from them), on logs of the paper's three-tank scenario
(seeds 2024, 1, 2) with abrupt changes the model does not describe and on logs no plant of
the model wrote, and prints for each: the largest distance, how many samples pass
:func:`~hybridlog.estimators.vouch.surprise_limit` (1650 for three outputs), the longest run
of consecutive ones, the last sample's distance, the largest ``|x̂|``, and how far the final
estimate is from what the model reaches from its prior (:func:`reach_at_end`).  Then the same for
the measurement-variance-60 scenario of ``docs/smoothing.md`` (schedule
``1:100,3:90,2:110,1:70,2:90,3:80,1:60``, seeds 0..29), summarised.

Nothing of the filter is changed: the distances are recomputed after the run from its
stored covariances (``store_covariances=True``).
"""

from __future__ import annotations

import dataclasses
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import numpy.typing as npt

if __package__ in (None, ""):  # run as a file: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from hybridlog.errors import HybridlogError
from hybridlog.estimators.filter_options import HstfOptions
from hybridlog.estimators.hstf import run_hstf
from hybridlog.estimators.result import EstimationResult
from hybridlog.estimators.vouch import surprise_limit
from hybridlog.model.builtins import builtin_text
from hybridlog.model.compiled import compile_model
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.model.loader import parse_model
from hybridlog.signals import AlignedSignals, FloatArray
from hybridlog.simulate import simulate

TEXT = builtin_text("three_tank_hstf")
SEEDS = (2024, 1, 2)
AT = 150  # mid-log, in true mode 2
VARIANCE_60_SCHEDULE = "1:100,3:90,2:110,1:70,2:90,3:80,1:60"


def unfaded_distances(
    model: HybridModel, signals: AlignedSignals, result: EstimationResult
) -> FloatArray:
    """Per row, the smallest unfaded ``γ_iᵀ S_i⁻¹ γ_i`` over the modes (row 0: NaN)."""
    assert result.covariances is not None
    compiled = compile_model(model)
    n, m, n_q = model.n_states, model.n_outputs, model.n_modes
    out = np.full(signals.n_samples, np.nan)
    for k in range(signals.n_samples - 1):
        x = np.ascontiguousarray(result.state_means[k])
        u = np.ascontiguousarray(signals.inputs[k])
        v = np.ascontiguousarray(signals.inputs[k + 1])
        x_i, F_i = np.zeros((n_q, n)), np.zeros((n_q, n, n))
        for i in range(n_q):
            compiled.f(i, x, u, x_i[i])
            compiled.F(i, x, u, F_i[i])
        x_pred = np.ascontiguousarray(x_i.mean(axis=0))  # (21), where eq. (12) takes H
        nearest = np.inf
        for i, mode in enumerate(model.modes):
            H, y_i = np.zeros((m, n)), np.zeros(m)
            compiled.H(i, x_pred, v, H)
            compiled.h(i, np.ascontiguousarray(x_i[i]), v, y_i)
            gamma = signals.outputs[k + 1] - y_i  # (31)
            P_pred = F_i[i] @ result.covariances[k] @ F_i[i].T + mode.process_noise
            S = H @ P_pred @ H.T + mode.measurement_noise
            nearest = min(nearest, float(gamma @ np.linalg.solve(S, gamma)))
        out[k + 1] = nearest
    return out


def reach_at_end(model: HybridModel, signals: AlignedSignals, result: EstimationResult) -> float:
    """``eᵀ (C + P(N|N))⁻¹ e``, ``e`` the final ``x̂`` less the open-loop prediction from the prior.

    The prediction and its covariance ``C`` are the HSTF's without updates (eqs. (21)-(22):
    every mode's step from the mean, mixed with weights ``1/n_q``).
    """
    assert result.covariances is not None
    compiled = compile_model(model)
    n, n_q = model.n_states, model.n_modes
    mean, C = model.initial_state.astype(float), model.initial_covariance.astype(float)
    for k in range(signals.n_samples - 1):
        u = np.ascontiguousarray(signals.inputs[k])
        x_i, C_i = np.zeros((n_q, n)), np.zeros((n_q, n, n))
        for i, mode in enumerate(model.modes):
            F = np.zeros((n, n))
            compiled.f(i, np.ascontiguousarray(mean), u, x_i[i])
            compiled.F(i, np.ascontiguousarray(mean), u, F)
            C_i[i] = F @ C @ F.T + mode.process_noise
        mean = x_i.mean(axis=0)
        spread = x_i - mean
        C = (C_i + spread[:, :, None] * spread[:, None, :]).mean(axis=0)
    e = result.state_means[-1] - mean
    return float(e @ np.linalg.solve(C + result.covariances[-1], e))


def longest_run(flags: npt.NDArray[np.bool_]) -> int:
    """The most consecutive true entries."""
    best = run = 0
    for flag in flags.tolist():
        run = run + 1 if flag else 0
        best = max(best, run)
    return best


def row(name: str, model: HybridModel, signals: AlignedSignals) -> str:
    """One log's line: what the HSTF did, and its unfaded distances."""
    try:
        result = run_hstf(model, signals, HstfOptions(), store_covariances=True)
    except HybridlogError as err:
        return f"{name:32s} refused: {str(err)[:100]}"
    d = unfaded_distances(model, signals, result)
    beyond = d > surprise_limit(model.n_outputs)
    return (
        f"{name:32s} max {np.nanmax(d):9.3g}  past limit {int(beyond.sum()):3d}  "
        f"longest {longest_run(beyond):3d}  last {d[-1]:9.3g}  median {np.nanmedian(d):7.3g}  "
        f"max|x̂| {np.abs(result.state_means).max():8.3g}  "
        f"reach {reach_at_end(model, signals, result):8.3g}"
    )


def stepped(model: HybridModel, seed: int, state: int, delta: float) -> AlignedSignals:
    """The paper's log with ``delta`` cm added to one true level at sample :data:`AT` (a fill).

    The plant is simulated from that sample on again from the stepped level (modes 2, 3).
    """
    first = simulate(model, seed=seed).signals(model)
    assert first.truth_states is not None
    x = first.truth_states[AT].copy()
    x[state] += delta
    start = ", ".join(repr(float(value)) for value in x)
    text = TEXT.replace("state = [15.0, 10.0, 10.0]", f"state = [{start}]").replace(
        'schedule = "1:100,2:100,3:100"', 'schedule = "2:50,3:100"'
    )
    second = simulate(parse_model(text), seed=seed + 1).signals(model)
    assert second.truth_states is not None

    def joined(a: FloatArray, b: FloatArray) -> FloatArray:
        return np.concatenate([a[:AT], b])

    return dataclasses.replace(
        first,
        inputs=joined(first.inputs, second.inputs),
        outputs=joined(first.outputs, second.outputs),
        truth_states=joined(first.truth_states, second.truth_states),
    )


def edited(
    model: HybridModel, seed: int, edit: Callable[[FloatArray], FloatArray]
) -> AlignedSignals:
    """The paper's log with its outputs edited."""
    signals = simulate(model, seed=seed).signals(model)
    return dataclasses.replace(signals, outputs=edit(signals.outputs.copy()))


def added(rows: slice | int, value: float) -> Callable[[FloatArray], FloatArray]:
    """``y1`` plus ``value`` on ``rows``."""

    def edit(y: FloatArray) -> FloatArray:
        y[rows, 0] += value
        return y

    return edit


def main() -> None:
    """Print the table for each seed, then the variance-60 summary."""
    model = parse_model(TEXT)
    logs: dict[str, Callable[[int], AlignedSignals]] = {
        "clean": lambda s: edited(model, s, lambda y: y),
        "step x1 +30 cm @150": lambda s: stepped(model, s, 0, 30.0),
        "step x3 +30 cm @150": lambda s: stepped(model, s, 2, 30.0),
        "offset y1 +10 @150..169": lambda s: edited(model, s, added(slice(AT, AT + 20), 10.0)),
        "offset y1 +30 @150..169": lambda s: edited(model, s, added(slice(AT, AT + 20), 30.0)),
        "outlier y1 +50 @150": lambda s: edited(model, s, added(AT, 50.0)),
        "outlier y1 +1e3 @150": lambda s: edited(model, s, added(AT, 1e3)),
        "outlier y1 +1e6 @150": lambda s: edited(model, s, added(AT, 1e6)),
        "outlier y1 +1e6 @1": lambda s: edited(model, s, added(1, 1e6)),
        "outlier y1 +1e6 @300 (last)": lambda s: edited(model, s, added(300, 1e6)),
        "outputs all 1e6": lambda s: edited(model, s, lambda y: np.full_like(y, 1e6)),
        "outputs 10x": lambda s: edited(model, s, lambda y: 10.0 * y),
    }
    for seed in SEEDS:
        print(f"seed {seed}")
        for name, make in logs.items():
            print("  " + row(name, model, make(seed)))
    noisy = parse_model(TEXT.replace("measurement = 0.5 ", "measurement = 60.0"))
    largest, past = 0.0, 0
    for seed in range(30):
        signals = simulate(noisy, schedule=VARIANCE_60_SCHEDULE, seed=seed).signals(noisy)
        result = run_hstf(noisy, signals, HstfOptions(), store_covariances=True)
        d = unfaded_distances(noisy, signals, result)
        largest = max(largest, float(np.nanmax(d)))
        past += int((d > surprise_limit(noisy.n_outputs)).sum())
    print(f"measurement variance 60, seeds 0..29: max {largest:.3g}, samples past limit {past}")


if __name__ == "__main__":
    main()
