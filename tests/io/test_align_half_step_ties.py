"""An output sampled half a step off the grid is read alike wherever the log's clock starts.

Such an output is at ``dt/2`` of every grid point: its samples are within half a step (the
tie goes to the earlier sample).  At Unix-epoch times float seconds carry a few hundred
nanoseconds of rounding, and the test ``2 * distance > dt`` put some points just beyond:
the same log, moved along the epoch, was warned of as "bridged" at 0 to 23 of 29 points,
and its grid was 29 or 30 points long.  ``dt/2`` now has the clock's tolerance, as
``max_gap`` has (:func:`~hybridlog.io.time_grid.past_half_step`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from hybridlog.io import ReadOptions, SignalSpec, load_signals
from hybridlog.io.time_grid import past_half_step

SPEC = SignalSpec(inputs=("u",), outputs=("y", "z"), mode_ids=("1",), dt=0.1)


@pytest.mark.parametrize("base", [0.0, 1.7e9, 1.7e9 + 0.37, 1.7e9 + 3.7, 1.7e9 + 4.07])
def test_an_output_half_a_step_off_the_grid_has_no_gap(tmp_path: Path, base: float) -> None:
    log = tmp_path / "log.csv"
    rows = [f"{base + 0.1 * k:.2f},{k},{k},\n" for k in range(30)]
    rows += [f"{base + 0.1 * k + 0.05:.2f},,,{k}\n" for k in range(30)]
    log.write_text("t,u,y,z\n" + "".join(sorted(rows, key=lambda r: float(r.split(",")[0]))))
    notes: dict[str, Any] = {}
    signals = load_signals(log, SPEC, ReadOptions(sort=True), notes=notes)
    # the grid starts at z's first sample; y's samples sit half a step before and after
    assert signals.n_samples == 30
    assert "bridged" not in notes
    np.testing.assert_array_equal(signals.outputs[:, 0], np.arange(30))  # the earlier
    np.testing.assert_array_equal(signals.outputs[:, 1], np.arange(30))


def test_half_a_step_has_the_clocks_tolerance() -> None:
    dt = 100_000_000
    assert not past_half_step(dt // 2 + 1000, dt)  # float seconds at the epoch: ~0.2 us
    assert past_half_step(dt // 2 + 100_001, dt)  # beyond dt/1000
