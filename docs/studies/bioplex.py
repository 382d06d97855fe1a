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
from hybridlog.signals import AlignedSignals
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


def main(argv: Sequence[str] | None = None) -> None:
    """Print the study's tables (module doc)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10, help="number of seeds (0..N-1)")
    parser.add_argument("--beam", type=int, default=20, help="beam width of unknown-mode")
    args = parser.parse_args(argv)
    model = load_model("bioplex_pgc")
    assert model.scenario is not None
    times = model.scenario.parameter_values()
    print(f"# BIO-Plex study: unknown-mode, beam {args.beam}\n")

    # 0. The plant under its controller: true CO2 on the sample log, by phase.
    print(co2_table(SAMPLE, times) + "\n")

    # 1. The sample log, read as a user's log.
    signals = load_signals(SAMPLE, SignalSpec.of(model))
    start = time.perf_counter()
    result = estimate(model, signals, beam=args.beam)
    seconds = time.perf_counter() - start
    sample = detections(component_modes(model, result), times)
    print(f"Sample log {SAMPLE.name} ({signals.n_samples} samples): {seconds:.1f} s\n")
    print(f"notes: {'; '.join(result.notes)}\n")

    # 2. Seeds.
    start = time.perf_counter()
    per_seed: dict[str, list[int | None]] = {event: [] for event in EVENTS}
    off_runs: list[dict[str, list[str]]] = []
    truths: list[ComponentsLog] = []
    for seed in range(args.seeds):
        log = simulate_components(model, seed=seed)
        truths.append(log)
        seed_signals = signals_of(model, log, f"seed {seed}")
        found = detections(
            component_modes(model, estimate(model, seed_signals, beam=args.beam)), times
        )
        for event in EVENTS:
            per_seed[event].append(found[event])
        off = estimate(model, seed_signals, beam=args.beam, unknown_mode=False)
        off_runs.append(component_modes(model, off))
        print(f"seed {seed}: {found} ({time.perf_counter() - start:.0f} s)", file=sys.stderr)

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

    # 3. Without the unknown mode: what explains the drift (rows drift_start..drift_end).
    drift = range(int(times["drift_start"]), int(times["drift_end"]))
    print(
        "\nWithout the unknown mode (unknown_mode = false), steps of the drift window "
        f"{drift.start}..{drift.stop - 1} by estimated mode, summed over {args.seeds} seeds:\n"
    )
    print("| component | estimated modes in the drift window | wrong outside it |")
    print("|---|---|---|")
    for component in model.components:
        counts: Counter[str] = Counter()
        wrong = 0
        for modes, truth in zip(off_runs, truths, strict=True):
            labels = modes[component.name]
            counts.update(labels[k] for k in drift)
            true = truth.modes[component.name]
            wrong += sum(1 for k in range(len(labels)) if k not in drift and labels[k] != true[k])
        share = ", ".join(
            f"{mode} {100.0 * n / sum(counts.values()):.1f} %" for mode, n in counts.most_common()
        )
        print(f"| {component.name} | {share} | {wrong} steps |")


if __name__ == "__main__":
    main()
