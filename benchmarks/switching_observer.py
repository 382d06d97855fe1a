"""Speed and accuracy of paper 004's ``switching-observer`` on the engine with clutch.

    .venv/bin/python -m benchmarks.switching_observer      # ~1 minute, prints a Markdown table
    .venv/bin/python -m benchmarks.run --only switching_observer

Log: the built-in ``ice_clutch`` (dt = 10 ms, RK4 at 1 ms: 10 integration steps a sample),
the plant integrated by SciPy (``tests/support/clutch.py``'s equations, DOP853, rtol 1e-10)
with the clutch switching every 2 s and the jump maps (45)-(46), throttle
``0.4 + 0.1 sin(2t)``.

Rows:

* ``compiled`` -- ``run_switching_observer`` over 600 s (60,000 samples, 600,000 RK4 steps of
  observer (20), each four evaluations of ``dx``, ``h``, ``Q`` and a 3x3 solve); the time is
  ``EstimationResult.runtime_s`` after a warm-up run (no compilation), best of ``repeat``.
* ``solve_ivp`` -- SciPy's ``solve_ivp`` (RK45, rtol 1e-10, atol 1e-12 x scale) on the same
  right-hand side (the generated module's ``dx``, ``h``, ``Q`` called from Python, the same
  hold of ``y`` and ``u``, the same jumps) over the first 10 s; its time per sample and the
  largest difference of the two estimates, per state, relative to the state's range.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Sequence

import numpy as np
from scipy.integrate import solve_ivp

from hybridlog.estimators.hybrid_observer import observer_module, run_switching_observer
from hybridlog.estimators.hybrid_observer_options import SwitchingObserverOptions
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.model.loader import load_model
from hybridlog.signals import AlignedSignals
from tests.support import clutch

FULL_SECONDS = 600.0
QUICK_SECONDS = 60.0
REFERENCE_SECONDS = 10.0
DWELL_S = 2.0
AGREEMENT_TARGET = 1e-6
"""Largest allowed |x̂_hybridlog − x̂_solve_ivp| / range of the state."""


def clutch_log(model: HybridModel, seconds: float) -> AlignedSignals:
    """The plant over ``seconds``: one ``solve_ivp`` call per dwell, jumps between them.

    As ``hybridlog simulate`` writes a log: the mode of row ``k + 1`` governs the interval
    into it, so a dwell's jump is applied just after its first row's predecessor.
    """
    values = {k: float(v) for k, v in model.parameters.items()}
    dt = model.dt
    count = round(seconds / dt)
    per = round(DWELL_S / dt)
    times = np.arange(count) * dt
    modes = (np.arange(count) // per % 2).astype(np.int64)
    alpha = 0.4 + 0.1 * np.sin(2 * times)
    states = np.empty((count, 3))
    x = np.array([0.08, 140.0, 15.0])
    states[0] = x
    for start in range(0, count, per):
        stop = min(start + per, count)
        mode = int(modes[start])
        first = max(start, 1)  # row 0 is the initial state
        if start:
            x = clutch.jump(int(modes[start - 1]), mode, x, values)
        sol = solve_ivp(
            lambda t, s, q=mode: clutch.plant(q, s, 0.4 + 0.1 * np.sin(2 * t), values),
            (times[first - 1], times[stop - 1]),
            x,
            method="DOP853",
            rtol=1e-10,
            atol=1e-12,
            t_eval=times[first - 1 : stop],
        )
        states[first:stop] = sol.y[:, 1:].T
        x = sol.y[:, -1]
    return clutch.signals(times, alpha, states, modes)


def reference(model: HybridModel, signals: AlignedSignals, count: int) -> np.ndarray:
    """Observer (20) over the first ``count`` samples integrated by ``solve_ivp``.

    As the compiled observer reads sigma: the mode of row ``k + 1`` governs ``(t_k,
    t_{k+1}]``, a switch applies ``R`` at ``t_k^+`` and runs that interval without output
    injection.
    """
    module = observer_module(model)
    from hybridlog.estimators.hybrid_observer import brunovsky_gain

    table = model.estimator_options.get("switching-observer", {})
    eigenvalues = SwitchingObserverOptions(eigenvalues=str(table.get("eigenvalues", "-5")))
    gain = brunovsky_gain(eigenvalues.eigenvalue_list(3))
    t, u, y, modes = signals.time, signals.inputs, signals.outputs[:, 0], signals.truth_modes
    assert modes is not None
    out = np.empty(3)
    hv = np.empty(1)
    q_matrix = np.empty((3, 3))

    def rhs(s: float, x: np.ndarray, k: int, slope: float, inject: bool) -> np.ndarray:
        q, uk = int(modes[k + 1]), u[k]
        xc = np.ascontiguousarray(x)
        module.dx(q, xc, uk, out)
        if not inject:
            return np.asarray(out.copy())
        module.h(q, xc, uk, hv)
        module.Q(q, xc, uk, q_matrix)
        innovation = y[k] + slope * (s - t[k]) - hv[0]
        return np.asarray(out + np.linalg.solve(q_matrix, gain * innovation))

    x = np.asarray(model.initial_state, dtype=float).copy()
    estimates = np.empty((count, 3))
    estimates[0] = x
    scale = np.array([0.1, 100.0, 10.0])
    for k in range(count - 1):
        q = int(modes[k + 1])
        inject = q == int(modes[k])
        if not inject:  # the switch at t_k^+
            jumped = np.empty(3)
            module.reset(int(modes[k]), q, x, jumped)
            x = jumped
        slope = 0.0
        if inject and k > 0 and modes[k - 1] == q:
            slope = (y[k] - y[k - 1]) / (t[k] - t[k - 1])
        elif inject:
            module.dx(q, x, u[k], out)
            module.Q(q, x, u[k], q_matrix)
            slope = float(q_matrix[0] @ out)
        sol = solve_ivp(
            rhs, (t[k], t[k + 1]), x, args=(k, slope, inject), rtol=1e-10, atol=1e-12 * scale
        )
        x = np.ascontiguousarray(sol.y[:, -1])
        estimates[k + 1] = x
    return estimates


def bench_switching_observer(
    quick: bool = False, repeat: int = 3
) -> list[tuple[str, int, float | None, str, bool | None, str]]:
    """Rows ``(benchmark, integration steps, time, target, met, notes)``."""
    model = load_model("ice_clutch")
    options_table = model.estimator_options.get("switching-observer", {})
    options = SwitchingObserverOptions(eigenvalues=str(options_table.get("eigenvalues", "-5")))
    seconds = QUICK_SECONDS if quick else FULL_SECONDS
    signals = clutch_log(model, seconds)
    substeps = model.timebase.substeps
    run_switching_observer(model, signals, options)  # compile or load from the cache
    best = min(
        run_switching_observer(model, signals, options).runtime_s for _ in range(max(1, repeat))
    )
    result = run_switching_observer(model, signals, options)
    steps = (signals.n_samples - 1) * substeps
    rows: list[tuple[str, int, float | None, str, bool | None, str]] = [
        (
            "ice_clutch · switching-observer (compiled)",
            steps,
            best,
            "",
            None,
            f"{signals.n_samples:,} samples x {substeps} RK4 steps; "
            f"{steps / best:,.0f} steps/s; {result.notes[1]}",
        )
    ]
    count = round(REFERENCE_SECONDS / model.dt)
    start = time.perf_counter()
    estimates = reference(model, signals, count)
    elapsed = time.perf_counter() - start
    span = np.ptp(signals.truth_states[:count], axis=0)  # type: ignore[index]
    difference = np.abs(result.state_means[:count] - estimates).max(axis=0) / span
    worst = float(difference.max())
    per_step = best / steps
    rows.append(
        (
            "ice_clutch · observer (20) by solve_ivp (rtol 1e-10)",
            (count - 1) * substeps,
            elapsed,
            f"agreement ≤ {AGREEMENT_TARGET:g} of range",
            worst <= AGREEMENT_TARGET,
            f"first {REFERENCE_SECONDS:g} s; max abs(x̂ − x̂_solve_ivp) / range per state "
            + ", ".join(f"{name} {d:.1e}" for name, d in zip(model.states, difference, strict=True))
            + f"; {elapsed / ((count - 1) * substeps) / per_step:,.0f}x the compiled time per step",
        )
    )
    return rows


def main(argv: Sequence[str] | None = None) -> int:
    quick = "--quick" in (sys.argv[1:] if argv is None else argv)
    print("| Benchmark | Steps | Time (s) | Target | Met | Notes |")
    print("| --- | ---: | ---: | --- | :-: | --- |")
    for label, n, seconds, target, met, notes in bench_switching_observer(quick):
        shown = "–" if seconds is None else f"{seconds:.3f}"
        flag = "" if met is None else ("yes" if met else "**NO**")
        print(f"| {label} | {n:,} | {shown} | {target} | {flag} | {notes} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
