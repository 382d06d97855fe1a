"""A sample half a step from two grid points is measured at one of them, not both.

A log sampled every ``1.5*dt`` puts every other sample exactly between two grid points,
within ``dt/2`` of each (the tie the alignment allows), and with no other sample beside
it both took it: one measurement counted twice, with no warning, where a sample a
microsecond further off was warned of as bridged and left out of the metrics.  The later
point is now bridged (``unmeasured_outputs``, ``notes["bridged"]``; a true state NaN there),
whatever the resampling and wherever the clock starts.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from hybridlog.io import ReadOptions, SignalSpec, load_signals

SPEC = SignalSpec(inputs=("u",), outputs=("y", "z"), mode_ids=("1",), dt=1.0, states=("x",))


@pytest.mark.parametrize("resample", ["nearest", "linear"])
@pytest.mark.parametrize("base", [0.0, 1.7e9])
def test_a_sample_between_two_points_is_measured_once(
    tmp_path: Path, resample: str, base: float
) -> None:
    log = tmp_path / "log.csv"
    # y, z and the true x every 1.5 s (dt = 1 s); u every step
    rows = {round(k * 1.0, 1): [f"{k}", "", "", ""] for k in range(13)}
    for k in range(9):
        rows.setdefault(round(1.5 * k, 1), ["", "", "", ""])[1:] = [f"{k}", f"{-k}", f"{k}"]
    lines = [f"{base + t:.1f},{','.join(cells)}\n" for t, cells in sorted(rows.items())]
    log.write_text("t,u,y,z,x\n" + "".join(lines))
    notes: dict[str, Any] = {}
    signals = load_signals(log, SPEC, ReadOptions(resample=resample), notes=notes)
    assert signals.n_samples == 13  # 0 .. 12 s
    # points 1 and 2 both lie 0.5 s from the sample at 1.5 s: 2 takes it a second time
    twice = [2, 5, 8, 11]
    measured = signals.measured_outputs()
    expected = np.ones(13, dtype=bool)
    expected[twice] = False
    np.testing.assert_array_equal(np.isfinite(measured[:, 0]), expected)
    np.testing.assert_array_equal(np.isfinite(measured[:, 1]), expected)
    every = {"points": 4, "of": 13, "every": 1.5, "steps": 1.5}  # a sample every 1.5 steps
    assert notes["bridged"] == {"y": every, "z": every}
    assert signals.truth_states is not None
    np.testing.assert_array_equal(np.isfinite(signals.truth_states[:, 0]), expected)
    # the measured points hold the log's samples, taken once each
    taken = measured[expected, 0]
    if resample == "nearest":
        np.testing.assert_array_equal(taken, np.arange(9))


def test_a_log_half_a_step_off_the_grid_keeps_every_point(tmp_path: Path) -> None:
    """Each point's own sample half a step away (ties to the earlier): none taken twice."""
    log = tmp_path / "log.csv"
    rows = [f"{k}.0,{k},,\n" for k in range(10)] + [f"{k}.5,,{k},{k}\n" for k in range(10)]
    log.write_text("t,u,y,z\n" + "".join(sorted(rows, key=lambda r: float(r.split(",")[0]))))
    spec = SignalSpec(inputs=("u",), outputs=("y", "z"), mode_ids=("1",), dt=1.0)
    notes: dict[str, Any] = {}
    signals = load_signals(log, spec, ReadOptions(sort=True), notes=notes)
    assert "bridged" not in notes
    assert signals.unmeasured_outputs is None
