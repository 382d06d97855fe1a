"""Paper 003's valve three-tank: ``sliding-mode`` on TEST 1, 2 and 3 (§V), measured.

Run from the repository root::

    .venv/bin/python docs/studies/three_tank_valves.py        # ~1-2 min

It prints the Markdown tables quoted in ``docs/three_tank_valves.md``:

* the plant's bounds along the scenario: ‖D‖, σ_min(D) (so D_2 of (4) and the bound (33)),
  D_1 = max ‖dD/dt‖ (finite differences along the noise-free run) and Φ̄ = D_1 √3 (19);
* TEST 1 (no disturbance, no noise) and TEST 3 (disturbance (49) with a = 2e-4 1/s,
  ω = 2π rad/s, and 1 µm measurement noise) for three V_M (TEST 2: the transient after a
  switch), on the sample logs' schedule and on five other scenarios (random schedules of 24
  dwells of 0.5 s, seeds 101-105, half of them with another inflow than the model file's);
* eq. (20) as printed (one V_M for every channel, α* = 1) beside the model's options;
* the measurement-noise level TEST 3 tolerates, and the paper's disturbance amplitude 0.1.

Agreement: the share of samples with σ̂ = σ outside the 50 ms after each switch (issue 11);
transient: per switch, the samples until σ̂ = σ for the rest of the dwell (median, max).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

if __package__ in (None, ""):  # run as a file: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from hybridlog.estimators import prepare
from hybridlog.model.builtins import builtin_text
from hybridlog.model.compiled import compile_continuous
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.model.loader import load_model, parse_model
from hybridlog.simulate import SimulatedLog, simulate
from hybridlog.simulation_inputs import Disturbance

SETTLE = 50
DISTURBANCE = Disturbance(2e-4, 2 * np.pi)
NOISE_STD = 1e-6
V_M = (0.25, 0.5, 1.0)
SEEDS = (101, 102, 103, 104, 105)
OTHER_INFLOW = "1.0e-5*(1 + 0.2*cos(2*pi*t/3))"


def agreement(log: SimulatedLog, modes: np.ndarray) -> float:
    """Share of samples with σ̂ = σ outside the first 50 ms after each switch."""
    keep = np.ones(log.modes.shape[0], dtype=bool)
    keep[:SETTLE] = False
    for switch in np.flatnonzero(np.diff(log.modes)) + 1:
        keep[switch - 1 : switch + SETTLE] = False
    return float(np.mean(modes[keep] == log.modes[keep]))


def transients(log: SimulatedLog, modes: np.ndarray) -> np.ndarray:
    """Per switch: samples (ms) until σ̂ = σ for the rest of the dwell."""
    lengths = []
    switches = np.flatnonzero(np.diff(log.modes)) + 1
    for start, end in zip(switches, [*switches[1:], log.modes.shape[0]], strict=True):
        wrong = np.flatnonzero(modes[start:end] != log.modes[start:end])
        lengths.append(int(wrong[-1]) + 1 if wrong.size else 0)
    return np.array(lengths)


def noisy(log: SimulatedLog, std: float, seed: int) -> SimulatedLog:
    """The run with white measurement noise of ``std`` on every level (h = x)."""
    rng = np.random.default_rng(seed)
    outputs = log.states + std * rng.standard_normal(log.states.shape)
    return SimulatedLog(log.time, log.inputs, outputs, log.modes, log.states)


def scenarios(models: dict[str, HybridModel]) -> list[tuple[str, HybridModel, str, int]]:
    """(label, model, schedule, seed): the sample logs' run and five others."""
    base = models["file"]
    cases = [("sample logs' schedule, seed 2009", base, base.simulation_schedule, 2009)]
    for index, seed in enumerate(SEEDS):
        rng = np.random.default_rng(seed)
        modes = [int(rng.integers(8))]
        while len(modes) < 24:
            modes.append(int((modes[-1] + rng.integers(1, 8)) % 8))
        model = models["other"] if index % 2 else base
        inflow = "other inflow" if index % 2 else "file's inflow"
        schedule = ",".join(f"{q}:500" for q in modes)
        cases.append((f"random schedule, seed {seed}, {inflow}", model, schedule, seed))
    return cases


def run(model: HybridModel, log: SimulatedLog, overrides: dict[str, object]) -> np.ndarray:
    """σ̂ of ``sliding-mode`` with the model's options and ``overrides``, never refused."""
    return vouched_run(model, log, overrides)[0]


def vouched_run(
    model: HybridModel, log: SimulatedLog, overrides: dict[str, object]
) -> tuple[np.ndarray, float]:
    """σ̂ and the share of samples Lemma 1 cannot vouch for (``max_unvouched = 1``)."""
    options = {**overrides, "max_unvouched": 1.0}
    result = prepare(model, "sliding-mode", options).run(model, log.signals(model))
    vouched = {c.name: c.values for c in result.timeline_columns}["vouched"]
    return result.modes, float(1.0 - vouched.mean())


def bounds(model: HybridModel, log: SimulatedLog) -> str:
    """The table of D's bounds (3), (4), (19), (33) along ``log``."""
    code = compile_continuous(model)
    assert code.D is not None
    d = np.zeros((log.time.shape[0], 3, 3))
    for k in range(log.time.shape[0]):
        code.D(0, log.states[k], log.inputs[k], d[k])
    norms = np.linalg.norm(d, ord=2, axis=(1, 2))
    smallest = np.linalg.svd(d, compute_uv=False)[:, -1]
    rate = np.linalg.norm(np.diff(d, axis=0), ord=2, axis=(1, 2)) / model.dt
    # a switch changes no D (D depends on x, u only): the rate is that of the levels
    d1 = float(rate.max())
    lines = [
        "| quantity | value |",
        "|---|---|",
        f"| levels H1, H2, H3 (min-max, m) | {log.states.min():.3f} - {log.states.max():.3f} |",
        f"| ‖D‖ = D_0 of (3), max | {norms.max():.3g} m/s |",
        f"| σ_min(D), min | {smallest.min():.3g} m/s (D_2 = ‖D⁺‖ ≤ {1 / smallest.min():.0f} s/m) |",
        f"| bound (33) on ‖ε‖: 0.5/D_2 | {0.5 * smallest.min():.3g} m/s |",
        f"| D_1 = max ‖dD/dt‖ of (3) | {d1:.3g} m/s² |",
        f"| Φ̄ = D_1 √3 of (19) (ε̄_1 = 0) | {d1 * np.sqrt(3):.3g} m/s² |",
        f"| ‖ε‖ of (49), a = 2e-4 (TEST 3), max | "
        f"{2e-4 * np.sqrt(3) * np.abs(log.states).sum(axis=1).max():.3g} m/s |",
        f"| ‖ε‖ of (49), a = 0.1 (as printed), max | "
        f"{0.1 * np.sqrt(3) * np.abs(log.states).sum(axis=1).max():.3g} m/s |",
    ]
    return "\n".join(lines)


def main() -> None:
    """Print every table."""
    text = builtin_text("three_tank_valves")
    models = {
        "file": load_model("three_tank_valves"),
        "other": parse_model(
            text.replace('q = "q0*(1 + 0.25*sin(2*pi*t/5))"', f'q = "{OTHER_INFLOW}"'),
            origin="three_tank_valves (other inflow)",
        ),
    }
    base = models["file"]
    print("## The plant along the sample logs' run (TEST 1)\n")
    print(bounds(base, simulate(base, seed=2009, noise=False)))

    cases = scenarios(models)
    runs = []
    for label, model, schedule, seed in cases:
        clean = simulate(model, schedule=schedule, seed=seed, noise=False)
        disturbed = simulate(
            model, schedule=schedule, seed=seed, noise=False, disturbance=DISTURBANCE
        )
        runs.append((label, model, clean, noisy(disturbed, NOISE_STD, seed)))

    print("\n## TEST 1 and TEST 3 for three V_M (TEST 2: the transient)\n")
    print(
        'Model options (`channel_gains = "rows"`, α* = 0.28), V_M overridden with '
        "`--set v_max=...`.  Agreement outside 50 ms after each switch (%); transient "
        "median / max (ms).\n"
    )
    print(
        "| scenario | V_M (m/s²) | TEST 1 agreement | TEST 1 transient | TEST 3 agreement "
        "| TEST 3 transient |"
    )
    print("|---|---|---|---|---|---|")
    for label, model, clean, test3 in runs:
        for v in V_M:
            modes1 = run(model, clean, {"v_max": v})
            modes3 = run(model, test3, {"v_max": v})
            t1, t3 = transients(clean, modes1), transients(test3, modes3)
            a1, a3 = agreement(clean, modes1), agreement(test3, modes3)
            print(
                f"| {label} | {v:g} | {100 * a1:.2f} | {np.median(t1):.0f} / {t1.max()} | "
                f"{100 * a3:.2f} | {np.median(t3):.0f} / {t3.max()} |"
            )

    print("\n## Eq. (20) as printed: one V_M for every channel, α* = 1\n")
    print("| scenario | V_M (m/s²) | TEST 1 agreement | TEST 3 agreement |")
    print("|---|---|---|---|")
    for label, model, clean, test3 in runs[:3]:
        for v in (0.1, 0.2, 0.3):
            options = {"v_max": v, "channel_gains": "uniform", "alpha": 1.0}
            a1 = agreement(clean, run(model, clean, options))
            a3 = agreement(test3, run(model, test3, options))
            print(f"| {label} | {v:g} | {100 * a1:.2f} | {100 * a3:.2f} |")

    print("\n## Measurement noise and the disturbance amplitude (V_M = 0.5, model options)\n")
    print(
        "| case | agreement, mean of the 6 scenarios | min | unvouched (%), mean / max "
        "| refused at max_unvouched = 0.5 |"
    )
    print("|---|---|---|---|---|")

    def row(case: str, shares: list[float], unvouched: list[float]) -> str:
        refused = sum(u > 0.5 for u in unvouched)
        return (
            f"| {case} | {100 * np.mean(shares):.2f} | {100 * min(shares):.2f} | "
            f"{100 * np.mean(unvouched):.1f} / {100 * max(unvouched):.1f} | "
            f"{refused} of {len(unvouched)} |"
        )

    for std in (1e-7, 1e-6, 3e-6, 1e-5, 1e-4):
        shares, unvouched = [], []
        for _, model, clean, _ in runs:
            log = noisy(clean, std, 7)
            modes, share = vouched_run(model, log, {"v_max": 0.5})
            shares.append(agreement(log, modes))
            unvouched.append(share)
        print(row(f"white noise {std * 1e6:g} µm, no disturbance", shares, unvouched))
    for amplitude in (2e-4, 1e-3, 0.1):
        shares, unvouched = [], []
        for _, model, schedule, seed in cases:
            log = simulate(
                model,
                schedule=schedule,
                seed=seed,
                noise=False,
                disturbance=Disturbance(amplitude, 2 * np.pi),
            )
            modes, share = vouched_run(model, log, {"v_max": 0.5})
            shares.append(agreement(log, modes))
            unvouched.append(share)
        print(row(f"disturbance (49), a = {amplitude:g}, no noise", shares, unvouched))


if __name__ == "__main__":
    main()
