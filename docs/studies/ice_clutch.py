"""Paper 004's switching observer on its engine with clutch: the numbers of docs/ice_clutch.md.

Run from the repository root::

    .venv/bin/python docs/studies/ice_clutch.py        # ~15 s (7 s warm)

The plant is the built-in ``ice_clutch`` written again with NumPy and integrated by SciPy
(``tests/support/clutch.py``: DOP853, rtol 1e-10, throttle held over each 10 ms sample),
engaging and releasing the clutch every 0.5 s with the jumps (45)-(46).  True
x(0) = (0.08 g, 140 rad/s, 15 N m); the observer starts at the model's prior
(0.1 g, 150 rad/s, 12 N m).  For each eigenvalue set Λ it fits the decay rate of the error
‖(x − x̂)/s‖ (s = 0.1 g, 100 rad/s, 10 N m) from the peak of the initial transient to 30x
its floor, per dwell and over the switches and jumps, and sets it beside Λ's slowest
eigenvalue and the frozen-time spectral abscissa of the linearised error dynamics
M = ∂(f + gα)/∂x − Q⁻¹K ∂h/∂x along the true trajectory.  Then: κ₁(Q), the effect of
measurement noise and of the hold of y, and plants with other parameters than the model's
(the observer keeps the model's).  It prints Markdown and writes docs/ice_clutch_error.png
and docs/ice_clutch_states.png.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

if __package__ in (None, ""):  # run as a file: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from hybridlog.estimators.hybrid_observer import brunovsky_gain, run_switching_observer
from hybridlog.estimators.hybrid_observer_options import SwitchingObserverOptions
from hybridlog.estimators.result import EstimationResult
from hybridlog.model.builtins import builtin_text
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.model.loader import parse_model
from hybridlog.signals import AlignedSignals
from tests.support import clutch

ROOT = Path(__file__).resolve().parents[2]
DT = 0.01
DWELL = 50  # samples: 0.5 s
SEGMENTS = 6
SCALE = np.array([0.1, 100.0, 10.0])
X0 = (0.08, 140.0, 15.0)
EIGENVALUES = ("-10,-20,-30", "-4,-8,-12", "-2,-4,-6")


def throttle(t: np.ndarray) -> np.ndarray:
    """The throttle α(t) of the scenario."""
    alpha: np.ndarray = 0.4 + 0.1 * np.sin(2 * t)
    return alpha


def make_log(
    values: dict[str, float], noise: float = 0.0, seed: int = 0, torque: float = X0[2]
) -> tuple[AlignedSignals, np.ndarray]:
    """The scenario's log (σ, α, y and the true states) and the true states."""
    modes = clutch.schedule_modes([(i % 2, DWELL) for i in range(SEGMENTS)])
    x0 = (X0[0], X0[1], torque)
    times, alpha, states = clutch.trajectory(values, modes, x0, throttle, DT)
    signals = clutch.signals(times, alpha, states, modes)
    if noise:
        noisy = signals.outputs + noise * np.random.default_rng(seed).standard_normal(
            signals.outputs.shape
        )
        signals = AlignedSignals(**{**signals.__dict__, "outputs": noisy})
    return signals, states


def error_norm(result: EstimationResult, states: np.ndarray) -> np.ndarray:
    """‖(x − x̂)/s‖ per sample."""
    return np.asarray(np.linalg.norm((result.state_means - states) / SCALE, axis=1))


def fit(times: np.ndarray, norm: np.ndarray) -> tuple[float, float]:
    """Slope of log ‖e‖ and 3 standard errors of it."""
    (slope, _), cov = np.polyfit(times, np.log(norm), 1, cov=True)
    return float(slope), 3.0 * float(np.sqrt(cov[0, 0]))


def window(norm: np.ndarray) -> np.ndarray:
    """From the peak of the initial transient to the last sample 30x above the floor."""
    floor = np.median(norm[-len(norm) // 5 :])
    start = int(np.argmax(norm))
    end = int(np.flatnonzero(norm > 30.0 * floor).max())
    return np.arange(start, end + 1)


def abscissa(
    values: dict[str, float],
    signals: AlignedSignals,
    eigenvalues: tuple[float, ...],
    rows: np.ndarray,
) -> np.ndarray:
    """Frozen-time spectral abscissa of M along the true trajectory on ``rows``."""
    matrices = clutch.linearised_error(values, brunovsky_gain(eigenvalues))
    assert signals.truth_modes is not None and signals.truth_states is not None
    return np.array(
        [
            np.linalg.eigvals(
                matrices(
                    int(signals.truth_modes[k]), signals.truth_states[k], signals.inputs[k, 0]
                )[2]
            ).real.max()
            for k in rows
        ]
    )


def decay_table(
    model: HybridModel, values: dict[str, float], signals: AlignedSignals, states: np.ndarray
) -> tuple[str, dict[str, tuple[EstimationResult, np.ndarray, float, float]]]:
    """The decay table for every Λ, and the runs for the figures."""
    lines = [
        "| Λ (eig. of A_b − K C_b) | λ1 | fitted rate over the switches (1/s) | fit window (s) "
        "| frozen-time abscissa of M on it (1/s) | rate per dwell (1/s) "
        "| error ratio across each jump | decades of decay | floor |",
        "|---|---:|---:|---|---|---|---|---:|---:|",
    ]
    runs = {}
    for text in EIGENVALUES:
        options = SwitchingObserverOptions(eigenvalues=text)
        result = run_switching_observer(model, signals, options)
        norm = error_norm(result, states)
        rows = window(norm)
        rate, resolution = fit(signals.time[rows], norm[rows])
        eigenvalues = options.eigenvalue_list(3)
        spectrum = abscissa(values, signals, eigenvalues, rows)
        per_dwell = []
        for s in range(SEGMENTS):
            seg = np.arange(s * DWELL + (1 if s else 0), (s + 1) * DWELL)
            seg = seg[np.isin(seg, rows)]
            if seg.size >= 10:
                per_dwell.append(f"{fit(signals.time[seg], norm[seg])[0]:.1f}")
        jumps = [
            f"{norm[s * DWELL] / norm[s * DWELL - 1]:.2f}"
            for s in range(1, SEGMENTS)
            if s * DWELL in rows
        ]
        floor = float(np.median(norm[-len(norm) // 5 :]))
        lines.append(
            f"| {text} | {eigenvalues[0]:g} | {rate:.2f} ± {resolution:.2f} "
            f"| {signals.time[rows[0]]:.2f}–{signals.time[rows[-1]]:.2f} "
            f"| {spectrum.min():.1f} … {spectrum.max():.1f} | {', '.join(per_dwell) or '–'} "
            f"| {', '.join(jumps) or '–'} | {np.log10(norm[rows[0]] / norm[rows[-1]]):.1f} "
            f"| {floor:.1e} |"
        )
        runs[text] = (result, norm, rate, float(signals.time[rows[0]]))
    return "\n".join(lines), runs


def conditioning(runs: dict[str, tuple[EstimationResult, np.ndarray, float, float]]) -> str:
    """The notes of the first run (κ₁(Q) along it)."""
    result = next(iter(runs.values()))[0]
    return "\n".join(f"- {note}" for note in result.notes)


def noise_table(model: HybridModel, values: dict[str, float]) -> str:
    """RMS errors over the second half with measurement noise, for both holds of y."""
    lines = [
        "| noise σ_y (rad/s) | output_hold | RMS error m (g) | RMS error ω (rad/s) "
        "| RMS error T (N m) |",
        "|---:|---|---:|---:|---:|",
    ]
    for noise in (0.0, 0.01, 0.1):
        signals, states = make_log(values, noise=noise, seed=1)
        for hold in ("first", "zero"):
            options = SwitchingObserverOptions(eigenvalues=EIGENVALUES[0], output_hold=hold)
            result = run_switching_observer(model, signals, options)
            late = slice(len(states) // 2, None)  # the second half: the initial error is gone
            rms = np.sqrt(np.mean((result.state_means[late] - states[late]) ** 2, axis=0))
            lines.append(f"| {noise:g} | {hold} | {rms[0]:.2e} | {rms[1]:.2e} | {rms[2]:.2e} |")
    return "\n".join(lines)


VARIATIONS = {
    "the model's": {},
    "T_E = 10, T_L = 20/3 (other torques, same ratio; true T(0) = 10 N m)": {
        "TE": 10.0,
        "TL": 20 / 3,
    },
    "T_L = 15 (the ratio T_E/(T_E+T_L) of (45)-(46) wrong)": {"TL": 15.0},
    "J_L = 0.2": {"JL": 0.2},
    "p = 0.07, β̄ = 330": {"p": 0.07, "beta_bar": 330.0},
}


def variation_table(model: HybridModel) -> str:
    """Plants other than the model (the observer keeps the model's parameters)."""
    lines = [
        "| plant parameters | peak error | error in the last 0.6 s (median) "
        "| RMS error in the last 0.6 s: m (g), ω (rad/s), T (N m) |",
        "|---|---:|---:|---|",
    ]
    base = {k: float(v) for k, v in model.parameters.items()}
    for label, change in VARIATIONS.items():
        values = {**base, **change}
        signals, states = make_log(values, torque=values["TE"])
        result = run_switching_observer(
            model, signals, SwitchingObserverOptions(eigenvalues=EIGENVALUES[0])
        )
        norm = error_norm(result, states)
        late = slice(-len(norm) // 5, None)
        rms = np.sqrt(np.mean((result.state_means[late] - states[late]) ** 2, axis=0))
        lines.append(
            f"| {label} | {norm.max():.2f} | {np.median(norm[late]):.1e} "
            f"| {rms[0]:.1e}, {rms[1]:.1e}, {rms[2]:.1e} |"
        )
    return "\n".join(lines)


def wrong_sigma_table(model: HybridModel) -> str:
    """The sample log run with switching signals that disagree with its outputs.

    The observer takes σ as given: the table shows what a wrong one costs, and that the
    one-step residual y − ŷ peaks where the plant switched and σ does not say so.
    """
    import csv

    from hybridlog.estimators import prepare

    with (ROOT / "sample_logs" / "ice_clutch.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    column = {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}
    true = column["mode"].astype(np.int64)
    late = np.concatenate((np.full(50, true[0]), true[:-50]))
    chatter = true.copy()
    chatter[100:200] = np.arange(100) % 2
    signals = {
        "the log's": true,
        "always 0 (no switch)": np.zeros_like(true),
        "0.5 s late": late,
        "inverted (1 - sigma)": 1 - true,
        "switching every sample on 1-2 s": chatter,
        "switching every sample": np.arange(len(true)) % 2,
    }
    y = column["y"]
    lines = [
        "| switching signal given | fit (%) | RMSE m (g), ω (rad/s), T (N m) | largest residual "
        "y − ŷ (rad/s) at t (s) |",
        "|---|---:|---|---|",
    ]
    for name, modes in signals.items():
        log = AlignedSignals(
            source="ice_clutch.csv",
            time=column["t"],
            input_names=("alpha",),
            output_names=("y",),
            inputs=column["alpha"].reshape(-1, 1),
            outputs=y.reshape(-1, 1),
            truth_modes=modes,
            state_names=("m", "omega", "T"),
            truth_states=np.column_stack([column["m"], column["omega"], column["T"]]),
        )
        result = prepare(model, "switching-observer").run(model, log)  # the file's options
        residual = (y - result.output_predictions[:, 0])[1:]
        score = 100.0 * (1.0 - np.linalg.norm(residual) / np.linalg.norm(y[1:] - y[1:].mean()))
        assert log.truth_states is not None
        rmse = np.sqrt(np.mean((result.state_means - log.truth_states) ** 2, axis=0))
        worst = int(np.argmax(np.abs(residual)))
        lines.append(
            f"| {name} | {score:.2f} | {', '.join(f'{v:.3g}' for v in rmse)} | "
            f"{residual[worst]:.3g} at {log.time[worst + 1]:.2f} |"
        )
    return "\n".join(lines)


def plots(
    signals: AlignedSignals,
    states: np.ndarray,
    runs: dict[str, tuple[EstimationResult, np.ndarray, float, float]],
) -> None:
    """docs/ice_clutch_error.png and docs/ice_clutch_states.png."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = signals.time
    assert signals.truth_modes is not None  # the simulated log has them
    switches = t[np.flatnonzero(np.diff(signals.truth_modes)) + 1]
    fig, ax = plt.subplots(figsize=(8, 4))
    for text, (_, norm, rate, start) in runs.items():
        (line,) = ax.semilogy(t, norm, label=f"Λ = {text}: fitted rate {rate:.1f} 1/s")
        k = int(np.searchsorted(t, start))
        ax.semilogy(
            t[k:], norm[k] * np.exp(rate * (t[k:] - start)), "--", color=line.get_color(), lw=0.8
        )
    for s in switches:
        ax.axvline(s, color="grey", lw=0.5)
    ax.set_ylim(1e-6, 10)
    ax.set_xlabel("t (s); grey: clutch switches with jumps (45)-(46)")
    ax.set_ylabel("‖(x − x̂)/s‖, s = (0.1 g, 100 rad/s, 10 N m)")
    ax.set_title("ice_clutch: observer error, dashed: fitted exponential")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(ROOT / "docs" / "ice_clutch_error.png", dpi=90)
    plt.close(fig)

    result = runs[EIGENVALUES[1]][0]
    fig, axes = plt.subplots(3, 1, figsize=(8, 6), sharex=True)
    for i, (ax, label) in enumerate(zip(axes, ("m (g)", "ω (rad/s)", "T (N m)"), strict=True)):
        ax.plot(t, states[:, i], "k", lw=1.2, label="true")
        ax.plot(
            t, result.state_means[:, i], "C1--", lw=1.0, label=f"observer, Λ = {EIGENVALUES[1]}"
        )
        for s in switches:
            ax.axvline(s, color="grey", lw=0.5)
        ax.set_ylabel(label)
    axes[0].legend(fontsize=8)
    axes[0].set_title("ice_clutch: true and observed states (paper 004, Figs. 1-2)")
    axes[-1].set_xlabel("t (s)")
    fig.tight_layout()
    fig.savefig(ROOT / "docs" / "ice_clutch_states.png", dpi=90)
    plt.close(fig)


def main() -> None:
    """Print the tables of docs/ice_clutch.md and write its figures."""
    model = parse_model(builtin_text("ice_clutch"), origin="ice_clutch")
    values = {k: float(v) for k, v in model.parameters.items()}
    signals, states = make_log(values)
    table, runs = decay_table(model, values, signals, states)
    print("## Decay of the error\n")
    print(table)
    print("\n## Conditioning of Q (Λ = " + EIGENVALUES[0] + ")\n")
    print(conditioning(runs))
    print("\n## Measurement noise and the hold of y\n")
    print(noise_table(model, values))
    print("\n## Plants with other parameters than the model\n")
    print(variation_table(model))
    print("\n## A switching signal that disagrees with the outputs\n")
    print(wrong_sigma_table(model))
    plots(signals, states, runs)


if __name__ == "__main__":
    main()
