"""A series recorded once per step on a jittering clock, with samples the log dropped.

Each grid point takes its own sample; a point whose sample is missing holds the one before,
and is counted; a sampled true mode's has none (a gap, ``truth_gaps``), as a gap of any
length leaves it.  One dropped sample used to send the whole series back to the zero-order
hold, whose random one-step delays on every late sample then came back without a word.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from hybridlog.io.align import align_signals
from hybridlog.io.source import LabelSeries, Series
from hybridlog.report.reading_notes import report_reading_notes
from hybridlog.signals import NO_TRUE_MODE

N, DT_NS = 300, 10_000_000


def _jittered(seed: int = 7) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    jitter = rng.integers(-100_000, 100_000, N)  # ±1 % of dt, about half of them late
    jitter[0] = 0
    grid = np.arange(N, dtype=np.int64) * DT_NS
    return grid, grid + jitter


def test_dropped_samples_hold_the_one_before_and_the_others_take_their_own() -> None:
    grid, times = _jittered()
    values = np.arange(N, dtype=np.float64) ** 2
    dropped = np.array([40, 41, 120, 299])
    keep = np.ones(N, dtype=bool)
    keep[dropped] = False
    u = Series("u", times[keep], values[keep])
    truth = LabelSeries(
        "mode", times[keep], (np.arange(N)[keep] // 50).astype(np.int32), tuple("abcdefg")
    )
    notes: dict[str, Any] = {}
    aligned = align_signals(
        source="s",
        dt=0.01,
        inputs={"u": u},
        outputs={"y": Series("y", grid, values)},
        truth_mode=truth,
        notes=notes,
    )
    expected = values.copy()
    expected[dropped] = values[dropped - 1]
    expected[41] = values[39]  # two dropped in a row: both hold the last sample
    np.testing.assert_array_equal(aligned.inputs[:, 0], expected)
    codes = np.arange(N) // 50
    codes[dropped] = NO_TRUE_MODE  # a step from the samples around: no true mode there
    np.testing.assert_array_equal(aligned.truth_modes, codes)
    assert set(notes["jitter"]) == {"input u", "the true mode"}
    assert notes["jitter_held"] == {"input u": {"points": 4, "of": N}}  # the mode holds none
    assert notes["truth_gaps"]["mode"]["points"] == 4
    assert notes["truth_gaps"]["mode"]["gaps"] == 3
    said = " ".join(report_reading_notes(notes))
    assert "4 of 300 sample times have no sample of their own (dropped by the log) and hold" in said
    notes["jitter_held"]["input u"]["points"] = 1
    said = " ".join(report_reading_notes(notes))
    assert "1 of 300 sample times has no sample of its own (dropped by the log) and holds" in said


@pytest.mark.parametrize(
    "case", ["two at one point", "between points", "half the points", "all late"]
)
def test_a_series_not_recorded_once_per_step_is_held(case: str) -> None:
    grid, times = _jittered()
    values = np.arange(N, dtype=np.float64)
    if case == "two at one point":  # a faster or duplicated stream: not once per step
        times = np.sort(np.append(times, times[100] + 1_000_000))
        values = np.arange(times.size, dtype=np.float64)
    elif case == "between points":  # a message at its own time among the per-step ones
        times = np.sort(np.append(times, times[100] + DT_NS // 2))
        values = np.arange(times.size, dtype=np.float64)
    elif case == "half the points":  # published at its own, slower rate
        times, values = times[::2], values[::2]
    else:  # a constant latency: the hold's consistent one-step delay (SPEC §5)
        times = grid + np.abs(times - grid) + 200_000
        times[0] = 0
    u = Series("u", times, values)
    notes: dict[str, Any] = {}
    aligned = align_signals(
        source="s",
        dt=0.01,
        inputs={"u": u},
        outputs={"y": Series("y", grid, np.zeros(N))},
        notes=notes,
    )
    hold = values[np.searchsorted(times, grid + 10_000, side="right") - 1]
    np.testing.assert_array_equal(aligned.inputs[:, 0], hold)
    assert "jitter" not in notes
    assert "jitter_held" not in notes
