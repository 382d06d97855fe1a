"""``hybridlog cluster``'s picture draws the true modes in the model's order.

The levels of the true mode were its ids sorted as text: a model of modes "2" and "10" had
mode "10" drawn below mode "2".
"""

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from hybridlog.jobs import cluster_plot


def test_true_modes_are_drawn_in_the_models_order(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    figures: list[Any] = []
    monkeypatch.setattr(
        cluster_plot, "save_reproducibly", lambda fig, path, *, dpi: figures.append(fig)
    )
    phi = np.random.default_rng(5).normal(size=(30, 2))
    truth = ["10" if k % 3 else "2" for k in range(30)]
    cluster_plot.plot_clusters(
        tmp_path / "clusters.png",
        time=np.arange(30.0),
        phi=phi,
        names=("y(k)", "y(k-1)"),
        clusters=np.arange(30) % 2,
        centers=phi[:2],
        cluster_modes=("2", "10"),
        decision_values=np.array([0.5, 1.5]),
        mode_ids=("1", "2", "10"),  # mode "1" never occurs: no level
        truth=truth,
    )
    twin = figures[0].axes[-1]
    assert [t.get_text() for t in twin.get_yticklabels()] == ["true 2", "true 10"]
    levels = twin.get_lines()[0].get_ydata()
    assert list(levels[:3]) == [0, 1, 1]  # "2" at the bottom, "10" above it
