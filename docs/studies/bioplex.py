"""Detection times of ``unknown-mode`` on paper 002's BIO-Plex experiment (docs/bioplex.md).

Run from the repository root::

    .venv/bin/python docs/studies/bioplex.py               # sample log + seeds 0..9
    .venv/bin/python docs/studies/bioplex.py --seeds 20 --beam 20

It runs the ``unknown-mode`` estimator (through the registry, as ``analyze`` does) on

1. the sample log ``sample_logs/bioplex_pgc.csv`` (read by ``hybridlog.io``, as a user's log);
2. fresh runs of the model's scenario, one per seed (``simulate_components``, the code behind
   ``hybridlog simulate bioplex_pgc --seed S``);
3. the same with ``unknown_mode = false``: how the drift is explained without the unknown mode.

and prints Markdown tables: the paper's detection times beside hybridlog's.  The events and
how a time is read from the most likely joint assignment (``result.mode_ids[result.modes[k]]``,
``"<fr1>|<fr2>|<piv1>|<piv2>|<ls>|<pgc>"``):

* unknown mode        first k >= drift_start with fr2 = ``unknown``                (paper 727)
* stuck-open          first k of the run of ``stuck_open`` that lasts until the repair
                      (drift_end − 1): "prefers this mode from k onwards"           (paper 769)
* light fault         first k >= light_fault with ls = ``one_bank_out``           (paper 904)
* regulator repaired  first k >= drift_end with fr2 = ``partly_open``              (paper 1101)
* light repaired      first k >= light_repair with ls = ``full``                   (paper 1301)

Nothing is tuned here: the model file, its scenario and the estimator's defaults (but the beam
width, an option) are used as they are.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections import Counter
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

if __package__ in (None, ""):  # run as a file: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from hybridlog.estimators.registry import prepare
from hybridlog.estimators.result import EstimationResult
from hybridlog.io import load_signals
from hybridlog.io.load import SignalSpec
from hybridlog.model.cache import load_model
from hybridlog.model.components import UNKNOWN
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.signals import AlignedSignals, FloatArray
from hybridlog.simulate_components import ComponentsLog, simulate_components

ROOT = Path(__file__).resolve().parents[2]
SAMPLE = ROOT / "sample_logs" / "bioplex_pgc.csv"
PAPER = {
    "unknown mode": 727,
    "stuck-open": 769,
    "light fault": 904,
    "regulator repaired": 1101,
    "light repaired": 1301,
}
EVENTS = tuple(PAPER)


def component_modes(model: HybridModel, result: EstimationResult) -> dict[str, list[str]]:
    """Per component, its mode in the most likely joint assignment at every step."""
    names = [c.name for c in model.components]
    joint = [result.mode_ids[q].split("|") for q in result.modes]
    return {name: [row[i] for row in joint] for i, name in enumerate(names)}


def first(labels: Sequence[str], label: str, start: int, end: int | None = None) -> int | None:
    """First step k in ``[start, end)`` whose label is ``label``."""
    stop = len(labels) if end is None else min(end, len(labels))
    return next((k for k in range(start, stop) if labels[k] == label), None)


def settled(labels: Sequence[str], label: str, start: int, end: int) -> int | None:
    """First k in ``[start, end)`` from which ``label`` holds up to ``end − 1``."""
    if end > len(labels) or labels[end - 1] != label:
        return None
    k = end - 1
    while k > start and labels[k - 1] == label:
        k -= 1
    return k


def detections(
    modes: Mapping[str, Sequence[str]], times: Mapping[str, float]
) -> dict[str, int | None]:
    """The detection time of every event (module doc) under the scenario's times."""
    drift_start, drift_end = int(times["drift_start"]), int(times["drift_end"])
    fault, repair = int(times["light_fault"]), int(times["light_repair"])
    fr2, ls = modes["fr2"], modes["ls"]
    return {
        "unknown mode": first(fr2, UNKNOWN, drift_start, drift_end),
        "stuck-open": settled(fr2, "stuck_open", drift_start, drift_end),
        "light fault": first(ls, "one_bank_out", fault, repair),
        "regulator repaired": first(fr2, "partly_open", drift_end),
        "light repaired": first(ls, "full", repair),
    }


def signals_of(model: HybridModel, log: ComponentsLog, source: str) -> AlignedSignals:
    """A simulated run as the estimator's input (the measured inputs and outputs)."""
    return AlignedSignals(
        source=source,
        time=log.time,
        input_names=model.inputs,
        output_names=model.outputs,
        inputs=log.inputs,
        outputs=log.outputs,
        command_names=model.commands,
        commands=log.commands,
    )


def estimate(model: HybridModel, signals: AlignedSignals, **options: object) -> EstimationResult:
    """``unknown-mode`` with ``options`` over ``signals``, through the registry."""
    return prepare(model, "unknown-mode", options).run(model, signals)


def shown(value: float | None) -> str:
    """A time or a median as text; ``—`` when not detected."""
    return "—" if value is None else f"{value:g}"


def co2_table(path: Path, times: Mapping[str, float]) -> str:
    """Markdown: the true CO2's deviation from the set-point in each phase of the log."""
    import polars as pl

    co2 = pl.read_csv(path)["xc3"].to_numpy() - times["setpoint"]
    drift, repair = int(times["drift_start"]), int(times["drift_end"])
    fault, fixed = int(times["light_fault"]), int(times["light_repair"])
    phases = {
        f"nominal 100..{drift - 1}": slice(100, drift),
        f"regulator 2 drifting {drift}..{fault - 1}": slice(drift, fault),
        f"drift and a light bank out {fault}..{repair - 1}": slice(fault, repair),
        f"light bank out, regulator repaired {repair}..{fixed - 1}": slice(repair, fixed),
        f"nominal again {fixed}..{len(co2) - 1}": slice(fixed, len(co2)),
    }
    lines = [
        "| phase (sample log) | mean CO2 − set-point [ppm] | std [ppm] | max abs [ppm] |",
        "|---|---|---|---|",
    ]
    for name, rows in phases.items():
        part = co2[rows]
        lines.append(
            f"| {name} | {part.mean():+.1f} | {part.std():.1f} | {np.abs(part).max():.1f} |"
        )
    return "\n".join(lines)


def truth_of(path: Path, model: HybridModel) -> dict[str, list[str]]:
    """The true mode of every component per row of a simulated log (``mode.<component>``)."""
    import polars as pl

    frame = pl.read_csv(path)
    return {c.name: frame[f"mode.{c.name}"].to_list() for c in model.components}


def agreement(
    model: HybridModel,
    runs: Sequence[tuple[Mapping[str, Sequence[str]], Mapping[str, Sequence[str]]]],
    drift: range,
) -> str:
    """Markdown: per component, estimated modes in the drift window and errors elsewhere."""
    lines = [
        "| component | estimated modes in the drift window | steps ≠ truth outside it |",
        "|---|---|---|",
    ]
    for component in model.components:
        counts: Counter[str] = Counter()
        wrong = total = 0
        for modes, truth in runs:
            labels, true = modes[component.name], truth[component.name]
            counts.update(labels[k] for k in drift)
            outside = [k for k in range(len(labels)) if k not in drift]
            wrong += sum(1 for k in outside if labels[k] != true[k])
            total += len(outside)
        share = ", ".join(
            f"{mode} {100.0 * n / sum(counts.values()):.1f} %" for mode, n in counts.most_common()
        )
        lines.append(
            f"| {component.name} | {share} | {wrong} of {total} ({100.0 * wrong / total:.2f} %) |"
        )
    return "\n".join(lines)


def regulator_table(
    rows: Sequence[tuple[str, EstimationResult, EstimationResult, FloatArray]],
    model: HybridModel,
    drift: range,
) -> str:
    """Markdown: regulator 2 with and without the unknown mode, run by run.

    First step of ``stuck_open`` in the drift window, and the RMS error of the estimated flow
    ``xc2`` (the mean of the most likely hypothesis) against the true flow over the window's
    samples where it was estimated (:func:`_rms_estimated`).
    """
    index = model.states.index("xc2")
    lines = [
        "| run | stuck_open from (with unknown) | without unknown | "
        "RMS error of xc2 [g/min], with | without |",
        "|---|---|---|---|---|",
    ]
    for name, on, off, truth in rows:
        cells = []
        for result in (on, off):
            labels = component_modes(model, result)["fr2"]
            cells.append(shown(first(labels, "stuck_open", drift.start, drift.stop)))
        errors = [_rms_estimated(r, index, truth, drift) for r in (on, off)]
        lines.append(f"| {name} | {cells[0]} | {cells[1]} | {errors[0]} | {errors[1]} |")
    return "\n".join(lines)


def _rms_estimated(result: EstimationResult, index: int, truth: FloatArray, drift: range) -> str:
    """The RMS error of state ``index`` over the window's samples where it was estimated.

    A held state (in no filter cluster, ``states_not_estimated``) is no estimate: the
    samples left out are counted after the number.
    """
    window = slice(drift.start, drift.stop)
    error = result.estimated_state_means()[window, index] - truth[window]
    estimated = ~np.isnan(error)
    rms = float(np.sqrt(np.mean(error[estimated] ** 2))) if estimated.any() else math.nan
    held = int((~estimated).sum())
    return f"{rms:.3f}" + (f" ({held} held)" if held else "")


def main(argv: Sequence[str] | None = None) -> None:
    """Print the study's tables (module doc)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10, help="number of seeds (0..N-1)")
    parser.add_argument(
        "--off-seeds", type=int, default=3, help="seeds also run without the unknown mode"
    )
    parser.add_argument("--beam", type=int, default=20, help="beam width of unknown-mode")
    args = parser.parse_args(argv)
    model = load_model("bioplex_pgc")
    assert model.scenario is not None
    times = model.scenario.parameter_values()
    drift = range(int(times["drift_start"]), int(times["drift_end"]))
    print(f"# BIO-Plex study: unknown-mode, beam {args.beam}\n")

    # 0. The plant under its controller: true CO2 on the sample log, by phase.
    print(co2_table(SAMPLE, times) + "\n")

    # 1. The sample log, read as a user's log.
    signals = load_signals(SAMPLE, SignalSpec.of(model))
    sample_truth = truth_of(SAMPLE, model)
    result = estimate(model, signals, beam=args.beam)
    sample_modes = component_modes(model, result)
    sample = detections(sample_modes, times)
    print(f"Sample log: {signals.n_samples} samples, estimator loop {result.runtime_s:.2f} s")
    print(f"({'; '.join(result.notes)})\n")
    sample_off_result = estimate(model, signals, beam=args.beam, unknown_mode=False)
    sample_off = component_modes(model, sample_off_result)
    import polars as pl

    regulator_rows = [("sample", result, sample_off_result, pl.read_csv(SAMPLE)["xc2"].to_numpy())]

    # 2. Seeds.
    start = time.perf_counter()
    per_seed: dict[str, list[int | None]] = {event: [] for event in EVENTS}
    on_runs = [(sample_modes, sample_truth)]
    off_runs = [(sample_off, sample_truth)]
    runtimes = []
    for seed in range(args.seeds):
        log = simulate_components(model, seed=seed)
        truth = {name: list(labels) for name, labels in log.modes.items()}
        seed_signals = signals_of(model, log, f"seed {seed}")
        on = estimate(model, seed_signals, beam=args.beam)
        runtimes.append(on.runtime_s)
        modes = component_modes(model, on)
        on_runs.append((modes, truth))
        found = detections(modes, times)
        for event in EVENTS:
            per_seed[event].append(found[event])
        if seed < args.off_seeds:
            off = estimate(model, seed_signals, beam=args.beam, unknown_mode=False)
            off_runs.append((component_modes(model, off), truth))
            regulator_rows.append((f"seed {seed}", on, off, log.states[:, 1]))
        print(f"seed {seed}: {found} ({time.perf_counter() - start:.0f} s)", file=sys.stderr)

    print(f"Seeds 0..{args.seeds - 1}: estimator loop median {np.median(runtimes):.2f} s a run\n")
    print("| event | paper | sample log | median over seeds | min – max | detected |")
    print("|---|---|---|---|---|---|")
    for event in EVENTS:
        found_times = [t for t in per_seed[event] if t is not None]
        median = float(np.median(found_times)) if found_times else None
        spread = f"{min(found_times)} – {max(found_times)}" if found_times else "—"
        print(
            f"| {event} | {PAPER[event]} | {shown(sample[event])} | {shown(median)} | "
            f"{spread} | {len(found_times)}/{args.seeds} |"
        )
    print("\nPer run (sample log first); the last columns count the steps outside the drift")
    print("window whose estimated mode differs from the true one:\n")
    components = [c.name for c in model.components]
    print("| run | " + " | ".join([*EVENTS, *(f"{c} ≠ truth" for c in components)]) + " |")
    print("|---|" + "---|" * (len(EVENTS) + len(components)))
    names = ["sample", *(f"seed {seed}" for seed in range(args.seeds))]
    found_all = [sample, *({e: per_seed[e][seed] for e in EVENTS} for seed in range(args.seeds))]
    for name, found, (modes, truth) in zip(names, found_all, on_runs, strict=True):
        wrong = [
            sum(1 for k in range(len(truth[c])) if k not in drift and modes[c][k] != truth[c][k])
            for c in components
        ]
        cells = [shown(found[e]) for e in EVENTS] + [str(w) for w in wrong]
        print(f"| {name} | " + " | ".join(cells) + " |")

    # 3. With and without the unknown mode: what explains the drift, and errors elsewhere.
    print(
        f"\nWith the unknown mode, drift window {drift.start}..{drift.stop - 1} (true mode of "
        f"fr2: unknown), the sample log and {args.seeds} seeds:\n"
    )
    print(agreement(model, on_runs, drift))
    print(
        f"\nWithout the unknown mode (unknown_mode = false), the sample log and "
        f"{args.off_seeds} seeds:\n"
    )
    print(agreement(model, off_runs, drift))
    print("\nRegulator 2 in the drift window, with and without the unknown mode:\n")
    print(regulator_table(regulator_rows, model, drift))


if __name__ == "__main__":
    main()
