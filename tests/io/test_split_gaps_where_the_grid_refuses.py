"""--split-gaps cuts a log where its grid refuses a gap, and only there.

It cut at every step between two output samples longer than ``max(max_gap, dt)``.  A step
shorter than about ``2*dt`` leaves a grid point more than ``dt/2`` from both samples, the
reading's gap, or not, by where the grid lies: a log on a clock jittering by 20 % of
``dt``, read whole with ``--max-gap`` equal to ``dt``, came in 105 pieces with
``--split-gaps``, which analysed 5 of its 301 samples.  And a sample alone between two gaps
was a piece when it was the log's last, and not when it was its first or one in between.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from hybridlog.io.align import align_signals
from hybridlog.io.source import Series
from hybridlog.signals import AlignedSignals

NS = 1_000_000_000


def _align(times_ns: np.ndarray, *, split: bool, notes: dict[str, Any]) -> AlignedSignals:
    values = np.arange(times_ns.size, dtype=np.float64)
    return align_signals(
        source="s",
        dt=1.0,
        inputs={"u": Series("u", times_ns, values)},
        outputs={"y": Series("y", times_ns, 10 * values)},
        max_gap=1.0,
        split_gaps=split,
        notes=notes,
    )


def test_a_jittered_log_read_whole_is_not_cut() -> None:
    jitter = np.random.default_rng(0).integers(-NS // 5, NS // 5, 301)
    times = np.arange(301, dtype=np.int64) * NS + jitter
    whole = _align(times, split=False, notes={})
    notes: dict[str, Any] = {}
    split = _align(times, split=True, notes=notes)
    assert split.n_samples == whole.n_samples == 301
    np.testing.assert_array_equal(split.outputs, whole.outputs)
    assert "segments" not in notes


def test_a_step_the_grid_refuses_is_cut() -> None:
    """1.9 s between two samples: the grid point 1 s after the first is 0.9 s from the next."""
    times = np.array([*range(0, 11), *np.arange(11, 40) + 0.9]) * NS
    times = np.round(times).astype(np.int64)
    notes: dict[str, Any] = {}
    aligned = _align(times, split=True, notes=notes)
    assert notes["gaps"] == [{"start": 10.0, "end": 11.9}]
    np.testing.assert_allclose(aligned.time, np.arange(11, 40) + 0.9)


def test_a_sample_alone_between_gaps_is_a_piece_wherever_it_lies() -> None:
    seconds = [0, *range(10, 21), 30, *range(40, 45), 60]
    notes: dict[str, Any] = {}
    aligned = _align(np.array(seconds, dtype=np.int64) * NS, split=True, notes=notes)
    assert [(p["start"], p["end"]) for p in notes["segments"]] == [
        (0.0, 0.0),
        (10.0, 20.0),
        (30.0, 30.0),
        (40.0, 44.0),
        (60.0, 60.0),
    ]
    np.testing.assert_allclose(aligned.time, np.arange(10, 21))
