"""``--drop-nonfinite`` that drops a signal's first or last sample says the span moved.

The grid starts at the latest first sample of the inputs and outputs and ends within half a
step of the outputs' earliest last one (SPEC §5).  An output whose first and last samples
were NaN, read with ``--drop-nonfinite``, was analysed from its second sample to its last
but one: report.md said "--drop-nonfinite dropped NaN or infinite samples: y 2", which read
like two samples from inside the log, and nothing said that the analysed span had lost its
first and last step (``reading.span`` speaks only past ``--max-gap``).  Now the end it moved
is recorded (``reading.nonfinite_span``) and said.  A gap in an output that dropped samples
made is refused saying so.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, load_signals
from hybridlog.report.reading_notes import report_reading_notes

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1",), dt=0.1)


def read(path: Path, u_nan: set[int], y_nan: set[int]) -> tuple[Any, dict[str, Any]]:
    cells = [
        f"{0.1 * k:.1f},{'nan' if k in u_nan else k},{'nan' if k in y_nan else 10 * k}\n"
        for k in range(20)
    ]
    path.write_text("t,u,y\n" + "".join(cells))
    notes: dict[str, Any] = {}
    return load_signals(path, SPEC, ReadOptions(drop_nonfinite=True), notes=notes), notes


def test_an_output_without_its_first_and_last_samples_says_the_span_moved(
    tmp_path: Path,
) -> None:
    signals, notes = read(tmp_path / "log.csv", set(), {0, 19})
    assert (signals.time[0], signals.time[-1]) == (0.1, 1.8)
    assert notes["nonfinite_span"] == {
        "start": {"signal": "output 'y' (column 'y')", "at": 0.1, "dropped": 1, "from": 0.0},
        "end": {"signal": "output 'y' (column 'y')", "at": 1.8, "dropped": 1, "from": 1.9},
    }
    said = [n for n in report_reading_notes(notes) if "--drop-nonfinite kept" in n]
    assert said == [
        "NOTE: the analysed span starts at t = 0.1 s, the first sample --drop-nonfinite kept "
        "of output 'y' (column 'y'): it dropped the 1 sample before it (from t = 0 s)",
        "NOTE: the analysed span ends at t = 1.8 s, the last sample --drop-nonfinite kept of "
        "output 'y' (column 'y'): it dropped the 1 sample after it (to t = 1.9 s)",
    ]


def test_an_input_without_its_first_sample_starts_the_span_later(tmp_path: Path) -> None:
    signals, notes = read(tmp_path / "log.csv", {0, 1}, set())
    assert signals.time[0] == 0.2
    assert notes["nonfinite_span"] == {
        "start": {"signal": "input 'u' (column 'u')", "at": 0.2, "dropped": 2, "from": 0.0}
    }


def test_drops_that_leave_the_span_are_not_said_to_move_it(tmp_path: Path) -> None:
    # an input's last sample (the input does not end the grid), a sample inside the log
    signals, notes = read(tmp_path / "log.csv", {19}, {7})
    assert (signals.time[0], signals.time[-1]) == (0.0, 1.9)
    assert notes["nonfinite_dropped"] == {"u": 1, "y": 1}
    assert "nonfinite_span" not in notes


def test_a_gap_made_by_dropped_samples_says_so(tmp_path: Path) -> None:
    """The log has a sample every 0.1 s: "no sample from t=0.4 s to t=1.5 s" sent the user
    looking for a gap that is a run of NaN, which --drop-nonfinite dropped."""
    log = tmp_path / "log.csv"
    log.write_text(
        "t,u,y\n" + "".join(f"{0.1 * k:.1f},{k},{'nan' if 5 <= k < 15 else k}\n" for k in range(30))
    )
    with pytest.raises(LogError) as raised:
        load_signals(log, SPEC, ReadOptions(drop_nonfinite=True))
    assert str(raised.value) == (
        f"{log}: gap in output 'y' (column 'y'): no usable sample from t=0.4 s to t=1.5 s "
        "(1.1 s > max_gap 0.5 s); --drop-nonfinite dropped the 10 NaN, infinite or "
        "out-of-range samples it has there; --max-gap SECONDS accepts longer gaps, "
        "--split-gaps analyses the longest piece between them"
    )
