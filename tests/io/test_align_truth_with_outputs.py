"""A sampled true mode logged in the outputs' rows is read at their grid points.

Inputs on a 0.1 s clock, outputs, true states and a sampled true mode logged together 10 ms
after each tick: the outputs lie around the inputs' ticks (within ``dt/8``), so the grid is
on the ticks and each output sample is its tick's (the nearest).  The true mode was held
(the last sample at or before the tick): each point took the sample of the row before, one
step behind the outputs and true states of its own row, without a word; every true switch
was scored a step late.  Logged 30 ms after, the grid was on the outputs and the true mode
in step: 10 ms and 30 ms of latency gave different answers.
"""

from __future__ import annotations

import numpy as np
import pytest

from hybridlog.io.align import align_signals
from hybridlog.io.source import LabelSeries, Series, seconds_to_ns

N = 40
MODES = np.array([(k // 5) % 2 for k in range(N)])


def _align(latency: float, switches_only: bool = False) -> tuple[np.ndarray, np.ndarray]:
    ticks = np.round(np.arange(N) * 0.1, 6)
    rows = np.round(ticks + latency, 6)
    values = np.arange(N, dtype=np.float64)
    if switches_only:  # a mode published when it changes: held, as its silence says
        changed = np.flatnonzero(np.diff(MODES, prepend=-1) != 0)
        mode = LabelSeries("mode", seconds_to_ns(rows[changed]), MODES[changed], ("a", "b"))
    else:
        mode = LabelSeries("mode", seconds_to_ns(rows), MODES, ("a", "b"))
    aligned = align_signals(
        source="log", dt=0.1, inputs={"u": Series("u", seconds_to_ns(ticks), values)},
        outputs={"y": Series("y", seconds_to_ns(rows), values)}, truth_mode=mode,
        states=("x",), truth_states={"x": Series("x", seconds_to_ns(rows), values)},
    )  # fmt: skip
    assert aligned.truth_modes is not None and aligned.truth_states is not None
    row = aligned.outputs[:, 0].astype(np.int64)  # the log's row each point took
    np.testing.assert_array_equal(aligned.truth_states[:, 0], row)
    return aligned.truth_modes, row


@pytest.mark.parametrize("latency", [0.0, 0.005, 0.01, 0.03, -0.01])
def test_a_sampled_true_mode_is_read_in_step_with_the_outputs_of_its_rows(
    latency: float,
) -> None:
    modes, row = _align(latency)
    np.testing.assert_array_equal(modes, MODES[row])


def test_a_true_mode_recorded_at_its_switches_is_still_held() -> None:
    """Its switch at 0.51 s says nothing of the mode at 0.5 s: the old one, held."""
    modes, _ = _align(0.01, switches_only=True)
    assert modes[5] == MODES[4] and modes[6] == MODES[5]
