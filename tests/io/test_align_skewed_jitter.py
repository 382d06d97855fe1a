"""A clock whose latency is skewed (mostly small, up to 0.43 ``dt``) gives each step its sample.

Every input sample lay within ``dt/4`` of a grid point of its own, the middle of their
spread, as README promises the jittering clock's reading; but the phase was the median of
their offsets, 0.12 ``dt`` late, from which the latest samples lay 0.31 ``dt`` away: the
clock was not taken, the zero-order hold took about 120 of 500 input samples a step late,
a random one-step delay the estimator cannot tell from the plant.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from hybridlog.io.align import align_signals
from hybridlog.io.source import Series

N, DT_NS = 500, 10_000_000


@pytest.mark.parametrize("seed", [7, 8, 9])
def test_each_point_takes_its_own_late_sample(seed: int) -> None:
    rng = np.random.default_rng(seed)
    latency = np.round(0.45 * DT_NS * rng.beta(1.0, 2.2, N)).astype(np.int64)
    latency[0] = int(0.135 * DT_NS)
    times = np.arange(N, dtype=np.int64) * DT_NS + latency
    assert latency.max() - latency.min() < DT_NS // 2  # all within dt/4 of their middle
    values = np.arange(N, dtype=np.float64)
    notes: dict[str, Any] = {}
    aligned = align_signals(
        source="s",
        dt=DT_NS / 1e9,
        inputs={"u": Series("u", times, values)},
        outputs={"y": Series("y", times, values)},
        notes=notes,
    )
    assert aligned.inputs[:, 0].tolist() == list(range(aligned.time.size))
    assert aligned.outputs[:, 0].tolist() == list(range(aligned.time.size))
    assert "skipped" not in notes
    assert set(notes["jitter"]) == {"input u"}
