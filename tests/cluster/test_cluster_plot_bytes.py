"""``hybridlog cluster``'s picture is the same bytes every run, in every format it draws.

matplotlib stamped an SVG with the time it was drawn and salted its element ids with a random
UUID, and stamped a PDF with its creation date (``SOURCE_DATE_EPOCH`` when set): the same
log gave the same centers.json and PNG but another SVG or PDF each run.
"""

from pathlib import Path

import numpy as np
import pytest

from hybridlog.jobs.cluster import PLOT_SUFFIXES
from hybridlog.jobs.cluster_plot import plot_clusters


def _draw(path: Path) -> bytes:
    rng = np.random.default_rng(3)
    phi = rng.normal(size=(40, 2))
    plot_clusters(
        path,
        time=np.arange(40.0),
        phi=phi,
        names=("y(k)", "y(k-1)"),
        clusters=np.arange(40) % 2,
        centers=phi[:2],
        cluster_modes=("1", "2"),
        decision_values=np.array([0.5, 1.5]),
        mode_ids=("1", "2"),
        truth=["1" if k % 3 else "2" for k in range(40)],
        accuracy="mode accuracy of the decision rule on this log: chiu 0.5000",
    )
    return path.read_bytes()


@pytest.mark.parametrize("suffix", PLOT_SUFFIXES)
def test_the_same_clusters_draw_the_same_bytes(
    suffix: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1000000000")
    first = _draw(tmp_path / f"a{suffix}")
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1700000000")
    second = _draw(tmp_path / f"b{suffix}")
    assert first == second
