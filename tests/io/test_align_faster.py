"""A series sampled faster than the model's grid: the samples the grid leaves unused are said.

The grid takes one sample per point (SPEC §5), so a 10 Hz log analysed with a model of
``dt = 1 s`` used 1 sample in 10 with nothing in the report.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from hybridlog.io.align import align_signals
from hybridlog.io.source import Series
from hybridlog.report.reading_notes import report_reading_notes

SECOND = 1_000_000_000


def _align(step_ns: int, *, output_step_ns: int | None = None) -> dict[str, Any]:
    times = np.arange(0, 30 * SECOND + 1, step_ns, dtype=np.int64)
    output_times = np.arange(0, 30 * SECOND + 1, output_step_ns or step_ns, dtype=np.int64)
    notes: dict[str, Any] = {}
    align_signals(
        source="s",
        dt=1.0,
        inputs={"u": Series("u", times, np.sin(times / SECOND))},
        outputs={"y": Series("y", output_times, np.cos(output_times / SECOND))},
        notes=notes,
    )
    return notes


def test_a_ten_times_faster_log_is_counted_and_said() -> None:
    notes = _align(SECOND // 10)
    assert notes["faster"] == {
        "u": {"kind": "input", "samples": 301, "points": 31},
        "y": {"kind": "output", "samples": 301, "points": 31},
    }
    (said,) = [n for n in report_reading_notes(notes) if "sample times analysed" in n]
    assert said.startswith(
        "NOTE: input u, output y each have 301 samples over the 31 sample times analysed "
        "(9.71 a sample time): each sample time takes one (the last at or before it or the "
        "nearest, SPEC §5), so at least 270 of each are not used"
    )


def test_a_log_at_the_grids_rate_or_slower_gets_no_note() -> None:
    assert "faster" not in _align(SECOND)
    notes = _align(SECOND, output_step_ns=SECOND // 2)  # only the output is faster
    assert notes["faster"] == {"y": {"kind": "output", "samples": 61, "points": 31}}
    (said,) = [n for n in report_reading_notes(notes) if "sample times analysed" in n]
    assert said.startswith("NOTE: output y has 61 samples") and "(the nearest, SPEC" in said
