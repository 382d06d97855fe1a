"""Speed and accuracy of the ``sliding-mode`` observer (paper 003) on the valve three-tank.

    .venv/bin/python -m benchmarks.sliding_mode
    .venv/bin/python -m benchmarks.run --only sliding_mode

Rows: the compiled observer over a 60 s log at 1 ms (60,000 integration steps, the model's
Euler step; target ≥ 10^6 steps/s, i.e. < 0.1 s, ``EstimationResult.runtime_s`` after a warm
run, no compilation), and the same observer right-hand side integrated by
``scipy.integrate.solve_ivp`` over the first 2 s: ż = G(x(t), u(t)) + w(t) with the measured
state and input held over each sample (as the observer holds them) and w(t) the observer's
own input, piecewise linear (ẇ = ±α V_M over each step) and recovered from the result as
w = D δ̃ (eq. (30) with a square, invertible D).  The difference of the two z is the
error of the observer's Euler step on its right-hand side; solve_ivp's time shows the cost of
the general integrator on the same right-hand side.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Sequence

import numpy as np

STEPS = 60_000
TARGET_STEPS_PER_S = 1e6
REFERENCE_STEPS = 2_000

Result = tuple[str, int, float, str, bool | None, str]


def bench_sliding_mode(quick: bool, repeat: int) -> list[Result]:
    """The rows (label, integration steps, seconds, target, met, notes)."""
    from scipy.integrate import solve_ivp

    from hybridlog.estimators import prepare
    from hybridlog.model.compiled import compile_continuous
    from hybridlog.model.loader import load_model
    from hybridlog.simulate import simulate

    model = load_model("three_tank_valves")
    steps = 6_000 if quick else STEPS
    log = simulate(model, steps=steps, seed=7, noise=False)
    signals = log.signals(model)
    prepared = prepare(model, None)
    prepared.run(model, signals)  # warm: compile or load the machine code
    best = min(prepared.run(model, signals).runtime_s for _ in range(repeat))
    result = prepared.run(model, signals)
    rows: list[Result] = [
        (
            "three_tank_valves · sliding-mode",
            steps,
            best,
            "≥ 10^6 steps/s",
            steps / best >= TARGET_STEPS_PER_S,
            f"{steps / best:,.0f} integration steps/s; {steps * model.dt:g} s of log at "
            f"{model.timebase.step * 1e3:g} ms; mode accuracy "
            f"{np.mean(result.modes == log.modes):.4f} (noise-free)",
        )
    ]

    code = compile_continuous(model)
    assert code.G is not None and code.D is not None
    n = min(REFERENCE_STEPS, steps)
    h = model.timebase.step
    deltas = np.stack(
        [c.values for c in result.timeline_columns if c.name.startswith("delta_tilde.")], axis=1
    )
    w = np.zeros((n + 1, 3))
    matrix = np.zeros((3, 3))
    for k in range(n + 1):
        code.D(0, log.outputs[k], log.inputs[k], matrix)
        w[k] = matrix @ deltas[k]
    g = np.zeros((n, 3))
    for k in range(n):
        code.G(0, log.outputs[k], log.inputs[k], g[k])

    def rhs(t: float, _z: np.ndarray) -> np.ndarray:
        k = min(int(t / h), n - 1)
        share = t / h - k
        return g[k] + w[k] + share * (w[k + 1] - w[k])

    start = time.perf_counter()
    # one call per step: the right-hand side is discontinuous at every sample
    z = result.state_means[0].copy()
    reference = [z.copy()]
    for k in range(n):
        z = solve_ivp(rhs, (k * h, (k + 1) * h), z, rtol=1e-12, atol=1e-15).y[:, -1]
        reference.append(z.copy())
    took = time.perf_counter() - start
    difference = np.abs(np.array(reference) - result.state_means[: n + 1]).max()
    ratio = took / n / (best / steps)
    rows.append(
        (
            "three_tank_valves · solve_ivp, same observer RHS",
            n,
            took,
            "–",
            None,
            f"{n / took:,.0f} steps/s (RK45, rtol 1e-12, one call per step); largest difference "
            f"of z (hybridlog − solve_ivp) {difference:.3g} m over {n * h:g} s (Euler on the "
            f"piecewise linear w: h²·V_M/2 a step); hybridlog is {ratio:,.0f}× faster a step",
        )
    )
    return rows


def main(argv: Sequence[str] | None = None) -> None:
    """Print the rows as a Markdown table."""
    quick = "--quick" in (sys.argv[1:] if argv is None else argv)
    print("| benchmark | steps | time (s) | target | met | notes |")
    print("|---|---|---|---|---|---|")
    for label, n, t, target, met, notes in bench_sliding_mode(quick, 3):
        shown = "–" if met is None else ("yes" if met else "**NO**")
        print(f"| {label} | {n:,} | {t:.4f} | {target} | {shown} | {notes} |")


if __name__ == "__main__":
    main()
