"""``--split-gaps``: a piece reads each output's samples beside it, as the whole log would.

The outputs were cut to the piece's span alone.  The piece's grid starts at the latest first
sample and takes each output's nearest sample within half a step: an output whose sample
lay just before the piece's start lost it, and the grid started a whole sample step late,
later than the piece ``reading.analysed`` named; an output with no sample inside a short
piece (its samples straddle it, a step no cut refuses) had "no samples".  And a log whose
signals overlap only inside an output gap was refused as "no stretch of the outputs is free
of gaps", naming neither the output nor when.
"""

from __future__ import annotations

import numpy as np
import pytest

from hybridlog.errors import LogError
from hybridlog.io.align import align_signals
from hybridlog.io.source import Series, seconds_to_ns


def series(name: str, seconds: list[float], values: list[float] | None = None) -> Series:
    times = np.asarray(seconds, dtype=np.float64)
    data = times if values is None else np.asarray(values, dtype=np.float64)
    return Series(name, seconds_to_ns(times), data)


def test_the_grid_starts_where_the_piece_does() -> None:
    # y2 every 2 s from 0.40 s, y1 every 1 s from 0.41 s with a gap from 8.41 to 15.41 s:
    # the first piece starts at 0.41 s, and y2's sample at 0.40 s is its nearest there
    y1 = [0.41 + k for k in range(9)] + [15.41 + k for k in range(4)]
    y2 = [0.40 + 2 * k for k in range(10)]
    notes: dict[str, object] = {}
    aligned = align_signals(
        source="log.csv",
        dt=1.0,
        inputs={"u": series("u", [float(k) for k in range(20)])},
        outputs={"y1": series("y1", y1), "y2": series("y2", y2)},
        split_gaps=True,
        notes=notes,
    )
    assert notes["analysed"] == {"start": 0.41, "end": 8.41, "duration": 8.0}
    np.testing.assert_allclose(aligned.time, [0.41 + k for k in range(9)], rtol=0, atol=1e-9)
    assert aligned.outputs[0, 1] == 0.40


def test_an_output_without_a_sample_inside_a_short_piece_reads_those_beside_it() -> None:
    # y2's pieces are 0 … 1 s, 10 s and 20 s (max_gap 1 s); y1's samples at -0.45 and
    # 1.45 s straddle the first, each within half a step of a grid point
    aligned = align_signals(
        source="log.csv",
        dt=1.0,
        inputs={"u": series("u", [float(k) for k in range(21)])},
        outputs={"y1": series("y1", [-0.45, 1.45]), "y2": series("y2", [0.0, 1.0, 10.0, 20.0])},
        max_gap=1.0,
        split_gaps=True,
        notes={},
    )
    np.testing.assert_array_equal(aligned.time, [0.0, 1.0])
    np.testing.assert_array_equal(aligned.outputs[:, 0], [-0.45, 1.45])


def test_signals_that_meet_only_inside_a_gap_are_refused_naming_it() -> None:
    y1 = [float(t) for t in range(36) if t <= 5 or t >= 30]
    with pytest.raises(LogError) as raised:
        align_signals(
            source="log.csv",
            dt=1.0,
            inputs={"u": series("u", [float(t) for t in range(36)])},
            outputs={"y1": series("y1", y1), "y2": series("y2", [float(t) for t in range(10, 26)])},
            split_gaps=True,
            notes={},
        )
    assert str(raised.value) == (
        "log.csv: --split-gaps: no piece: the signals overlap from t=10 s to t=25 s, where "
        "output 'y1' (column 'y1') has no sample from t=5 s to t=30 s, a gap longer than max_gap"
    )


def test_signals_that_never_meet_are_refused_so_with_split_gaps() -> None:
    with pytest.raises(LogError, match=r"signals do not overlap in time \('u' starts at t=20"):
        align_signals(
            source="log.csv",
            dt=1.0,
            inputs={"u": series("u", [20.0, 21.0])},
            outputs={"y": series("y", [0.0, 1.0, 2.0, 10.0, 11.0, 12.0])},
            split_gaps=True,
            notes={},
        )
