"""``--resample linear`` draws no line across a gap longer than ``max_gap``.

A grid point within half a step of the sample before (or after) such a gap takes that
sample, as a point past a series' last sample takes the last: the gap says nothing of the
signal inside it.  It read part of the way to the sample across the gap.
"""

from __future__ import annotations

import numpy as np

from hybridlog.io.align import align_signals
from hybridlog.io.source import Series, seconds_to_ns


def series(name: str, seconds: list[float], values: list[float]) -> Series:
    return Series(name, seconds_to_ns(np.asarray(seconds)), np.asarray(values, dtype=np.float64))


def test_a_true_state_beside_a_long_gap_takes_its_nearest_sample() -> None:
    grid = [float(k) for k in range(8)]
    truth = series("x", [0.0, 1.0, 2.0, 2.6, 7.4], [0.0, 10.0, 20.0, 26.0, 1000.0])
    aligned = align_signals(
        source="s",
        dt=1.0,
        inputs={"u": series("u", grid, [0.0] * 8)},
        outputs={"y": series("y", grid, grid)},
        states=("x",),
        truth_states={"x": truth},
        resample="linear",
        max_gap=2.0,
    )
    assert aligned.truth_states is not None
    # 3 and 7 are within half a step of the samples around a 4.8 s gap: those samples (3
    # read 26 + 0.4/4.8 * 974 = 107.2, 7 read 937.1); 4 to 6 have none within half a step
    np.testing.assert_array_equal(
        aligned.truth_states[:, 0], [0.0, 10.0, 20.0, 26.0, np.nan, np.nan, np.nan, 1000.0]
    )


def test_split_gaps_reads_an_output_and_its_true_state_alike_at_a_piece_end() -> None:
    # the piece's output was cut at the gap and took its last sample at the piece's last
    # point; the true state of the same field, read whole, drew the line across the gap
    times = [0.0, 1.0, 2.0, 3.0, 3.6, 20.0, 21.0]
    values = [0.0, 1.0, 2.0, 3.0, 3.6, 100.0, 101.0]
    aligned = align_signals(
        source="s",
        dt=1.0,
        inputs={"u": series("u", [0.0, 21.0], [0.0, 0.0])},
        outputs={"y": series("y", times, values)},
        states=("x",),
        truth_states={"x": series("x", times, values)},
        resample="linear",
        split_gaps=True,
        notes={},
    )
    assert aligned.truth_states is not None
    np.testing.assert_array_equal(aligned.outputs[:, 0], [0.0, 1.0, 2.0, 3.0, 3.6])
    np.testing.assert_array_equal(aligned.truth_states[:, 0], aligned.outputs[:, 0])
