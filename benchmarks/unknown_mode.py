"""Speed of the ``unknown-mode`` estimator (paper 002) on the BIO-Plex experiment (issue 10 p. 4).

    .venv/bin/python -m benchmarks.unknown_mode
    .venv/bin/python -m benchmarks.run --only unknown_mode

The built-in model ``bioplex_pgc`` (paper 002 §4: six components, three states, three outputs,
CO2 controller in the loop) on its sample log ``sample_logs/bioplex_pgc.csv`` (1,500 samples:
regulator 2 drifts towards its limit from k = 700 with no model of the drift, a light bank
fails at 900, repairs at 1100 and 1300), read as a user's log.  Rows: the estimator's
``runtime_s`` (decompositions and compiled cluster filters cached by a first, untimed run:
the time after compilation) at beam widths 5, 20 and 50, steps/s, and the cache hit rate of
the timed run; the first run's compile time in the notes.  ``--quick`` uses the first 300
samples.  Target: the 1,500-step scenario at beam 20 in under 1 s.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Sequence
from pathlib import Path

from hybridlog.estimators.cpha.options import UnknownModeOptions
from hybridlog.estimators.cpha.unknown_mode import run_unknown_mode
from hybridlog.io import load_signals
from hybridlog.io.load import SignalSpec
from hybridlog.model.cache import load_model
from hybridlog.signals import AlignedSignals

MODEL = "bioplex_pgc"
SAMPLE = Path(__file__).resolve().parents[1] / "sample_logs" / "bioplex_pgc.csv"
STEPS = 1500
BEAMS = (5, 20, 50)
TARGET_BEAM = 20
TARGET_S = 1.0


def head(signals: AlignedSignals, n: int) -> AlignedSignals:
    """The first ``n`` samples of ``signals`` (the commands the estimator reads too)."""
    return signals.rows(0, n)


def bench_unknown_mode(
    quick: bool, repeat: int
) -> list[tuple[str, int, float, str, bool | None, str]]:
    """Rows ``(label, steps, seconds, target, met, notes)`` for :mod:`benchmarks.run`."""
    model = load_model(MODEL)
    signals = load_signals(SAMPLE, SignalSpec.of(model))
    if quick:
        signals = head(signals, 300)
    steps = signals.n_samples
    rows = []
    for beam in BEAMS:
        options = UnknownModeOptions(beam=beam)
        first = run_unknown_mode(model, signals, options)
        runs = [run_unknown_mode(model, signals, options) for _ in range(repeat)]
        best = min(runs, key=lambda r: r.runtime_s)
        target = f"{STEPS:,} steps < {TARGET_S:g} s" if beam == TARGET_BEAM else ""
        met = best.runtime_s < TARGET_S if beam == TARGET_BEAM and not quick else None
        notes = (
            f"beam {beam}; first run compiled {first.compile_s:.2f} s; timed run: "
            f"{best.notes[0]}; load {os.getloadavg()[0]:.2f}"
        )
        rows.append((f"unknown-mode · beam {beam}", steps - 1, best.runtime_s, target, met, notes))
    return rows


def main(argv: Sequence[str] | None = None) -> int:
    """Print the rows as a Markdown table."""
    quick = "--quick" in (sys.argv[1:] if argv is None else argv)
    print("| row | steps | time (s) | steps/s | target | notes |")
    print("|---|---|---|---|---|---|")
    for label, n, t, target, met, notes in bench_unknown_mode(quick, 2):
        mark = "" if met is None else (" yes" if met else " **NO**")
        print(f"| {label} | {n:,} | {t:.3f} | {n / t:,.0f} | {target}{mark} | {notes} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
