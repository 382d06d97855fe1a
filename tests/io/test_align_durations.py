"""Durations a reading records and its notes say: to the digits the times hold (times.py)."""

from __future__ import annotations

from typing import Any

import numpy as np

from hybridlog.io.align import align_signals
from hybridlog.io.source import Series, seconds_to_ns
from hybridlog.report.reading_notes import report_reading_notes

UNIX = 1_700_000_000.0


def _series(name: str, seconds: np.ndarray, values: np.ndarray) -> Series:
    return Series(name, seconds_to_ns(seconds), np.asarray(values, dtype=float))


def test_a_hold_and_a_span_left_out_of_a_unix_time_log_are_to_the_microsecond() -> None:
    """Float times near 1.7e9 s hold the microsecond: their difference was recorded as it
    fell (a 29.54 s hold as 29.539999961, 2.03 s left out as 2.029999971) and the note
    wrote it with :g; both are now rounded to what the times hold."""
    seconds = UNIX + np.round(np.arange(0.0, 40.01, 0.1), 10)
    y = _series("level", seconds, np.cos(seconds - UNIX))
    on_change = UNIX + np.array([2.03, 5.0, 10.49])  # then silent to the end
    u = _series("cmd", on_change, np.array([1.0, 2.0, 3.0]))
    notes: dict[str, Any] = {}
    align_signals(source="log", dt=0.1, inputs={"u": u}, outputs={"y": y}, notes=notes)
    held, start = notes["held"]["u"], notes["span"]["start"]
    assert (held["end"] - held["start"], start["at"] - start["log"]) != (29.54, 2.03)
    assert (held["seconds"], start["left_out"]) == (29.54, 2.03)
    said = report_reading_notes(notes)
    assert any("the longest from t = 1700000010.49 to 1700000040.03 s (29.54 s)" in n for n in said)
    assert any(n.endswith(": 2.03 s of the log not analysed") for n in said)


def test_a_long_hold_is_written_to_its_digits_not_to_six() -> None:
    """:g wrote a hold of 123456.75 s as 123457 s and 0.51 s of a Unix-time log's floats as
    0.509999762 (or, with more digits, as they fell)."""
    notes = {
        "held": {"u": {"start": UNIX + 0.25, "end": UNIX + 123457.0, "seconds": 123456.75}},
        "truth_held": {"mode": {"start": UNIX, "end": UNIX + 0.51, "seconds": 0.509999762}},
    }
    said = report_reading_notes(notes)
    assert "(123456.75 s, longer than max_gap)" in said[0]
    assert "(0.51 s, longer than max_gap)" in said[1]


def test_inspect_writes_spans_steps_and_gaps_to_their_digits(tmp_path) -> None:
    """``inspect`` wrote them with .6g: a gap of 123456.25 s read 123456 s, the span
    123457 s, the median step 61728.4 s."""
    from hybridlog.io import format_inspection, inspect_log

    log = tmp_path / "long.csv"
    log.write_text("t,y\n0,1\n0.5,2\n123456.75,3\n")
    text = format_inspection(inspect_log(log))
    assert "0 s to 123456.75 s (123456.75 s)" in text
    assert "median step 61728.375 s" in text and "steps 0.5 s to 123456.25 s" in text
    assert "0.5 s to 123456.75 s (123456.25 s)" in text
