"""The grid's phase is that of the held signals' jittering clock, not one message's jitter.

A log whose topics are each published once per step around ``k*dt``, jittering
independently by up to 20 % of ``dt``, had its grid started at the latest first message
(0.106 s after a tick with ``dt = 1 s``).  Input samples then lay up to 0.306 s from their
grid point, beyond the ``dt/4`` that :func:`~hybridlog.io.resampling.jittered_index` takes as
jitter, and the zero-order hold took every one that came after its point a step late:
57 of 300 input samples were not used, a random one-step delay the estimator cannot tell
from the plant.  The grid now starts on the held signals' phase, where each point takes its
own sample; a log whose grid already gives every held sample a point within ``dt/4`` (a
latency, all late, keeps the hold's delay) keeps its grid.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from hybridlog.io.align import align_signals
from hybridlog.io.source import Series
from hybridlog.signals import AlignedSignals

N, DT_NS = 300, 1_000_000_000


def _jittered(rng: np.random.Generator, jitter_ns: int, first_ns: int | None = None) -> np.ndarray:
    """Times ``k*dt + e``, ``e`` uniform in ``±jitter_ns``; the first one at ``first_ns``."""
    times = np.arange(N, dtype=np.int64) * DT_NS + rng.integers(-jitter_ns, jitter_ns + 1, N)
    if first_ns is not None:
        times[0] = first_ns
    return times


def _align(u: np.ndarray, *outputs: np.ndarray, notes: dict[str, Any]) -> AlignedSignals:
    return align_signals(
        source="s",
        dt=1.0,
        inputs={"u": Series("u", u, np.arange(u.size, dtype=np.float64))},
        outputs={
            f"y{j}": Series(f"y{j}", times, np.arange(times.size, dtype=np.float64))
            for j, times in enumerate(outputs, start=1)
        },
        notes=notes,
    )


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_independently_jittering_topics_give_each_point_its_own_input(seed: int) -> None:
    rng = np.random.default_rng(seed)
    u, y1 = _jittered(rng, DT_NS // 5), _jittered(rng, DT_NS // 5)
    y2 = _jittered(rng, DT_NS // 5, first_ns=106_000_000)  # the latest first message
    notes: dict[str, Any] = {}
    aligned = _align(u, y1, y2, notes=notes)
    assert "skipped" not in notes
    assert set(notes["jitter"]) == {"input u"}
    np.testing.assert_array_equal(aligned.inputs[:, 0], np.arange(aligned.n_samples))
    for column in aligned.outputs.T:  # each output's own sample, the nearest
        np.testing.assert_array_equal(column, np.arange(aligned.n_samples))
    # on the inputs' phase, their median offset: within the jitter of the ticks
    assert np.abs(aligned.time - np.rint(aligned.time)).max() < 0.1
    assert aligned.n_samples >= N - 1


def test_a_latency_keeps_the_hold_s_delay() -> None:
    """Inputs published 20 to 30 ms after the outputs' ticks, the first one on its tick."""
    rng = np.random.default_rng(5)
    ticks = np.arange(N, dtype=np.int64) * DT_NS
    u = ticks + rng.integers(20_000_000, 30_000_000, N)
    u[0] = 0
    notes: dict[str, Any] = {}
    aligned = _align(u, ticks, notes=notes)
    np.testing.assert_array_equal(aligned.time, np.arange(N))
    np.testing.assert_array_equal(aligned.inputs[1:, 0], np.arange(N - 1))  # a step late
    assert "jitter" not in notes and "skipped" not in notes


def test_inputs_every_other_step_keep_the_latest_first_sample() -> None:
    """Not once per step: no jittering clock for ``jittered_index``, the grid as before."""
    rng = np.random.default_rng(6)
    u = np.arange(0, N, 2, dtype=np.int64) * DT_NS + rng.integers(-DT_NS // 5, DT_NS // 5, N // 2)
    y = _jittered(rng, DT_NS // 10, first_ns=150_000_000)
    aligned = _align(u, y, notes={})
    assert aligned.time[0] == max(u[0], y[0]) / 1e9


def test_a_point_before_a_held_series_first_sample_takes_that_sample() -> None:
    """The grid on the phase starts 0.15 s before u's first sample; over the outputs' four
    points u has two samples, too few for ``jittered_index``: the hold read index -1, u's
    last sample (299), at the first point."""
    rng = np.random.default_rng(0)
    steps = np.array([0, 3, *range(4, N)])
    u = steps * DT_NS + rng.integers(-DT_NS // 5, DT_NS // 5, steps.size)
    u[0] = 150_000_000
    y = np.arange(4, dtype=np.int64) * DT_NS
    y[0] = -100_000_000
    aligned = align_signals(
        source="s",
        dt=1.0,
        inputs={"u": Series("u", u, steps.astype(np.float64))},
        outputs={"y": Series("y", y, np.arange(4.0))},
    )
    assert aligned.time[0] < u[0] / 1e9
    assert aligned.inputs[0, 0] == 0.0
