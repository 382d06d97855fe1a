"""The mode of a run's last sample is drawn: a switch at the last sample shows in modes.png."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from hybridlog.report.plot_data import ModeTimelines
from hybridlog.report.plot_reducer import reduce_result
from tests.support.figures import patch_save

from .test_report_files import DT, T0, make_run


@pytest.mark.parametrize("n", [3, 4, 200])
def test_a_mode_entered_at_the_last_sample_has_a_bar_inside_the_panel(
    n: int, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Each sample's mode is drawn up to the next sample's time: the last one's had no
    width, so a 4-sample log that switched at its end showed one mode throughout."""
    from hybridlog.report import plot_figures, plots

    result, signals = make_run(n)
    modes = np.zeros(n, dtype=np.int64)
    modes[-1] = 2
    result = dataclasses.replace(result, modes=modes)
    data = reduce_result(result, signals)
    assert isinstance(data.modes, ModeTimelines) and data.span is not None
    first, last = data.modes.estimated[2]
    assert first.tolist() == last.tolist() == [len(data.edges) - 2]
    start, end = data.edges[first[0]], data.edges[last[0] + 1]
    assert start == pytest.approx(T0 + (n - 1) * DT)
    assert end == pytest.approx(start + DT) and data.span == (T0, end)

    drawn: dict[str, Any] = {}
    save = plot_figures.save

    def keep_then_save(fig: Any, path: Path) -> Path:
        drawn[path.name] = fig
        return save(fig, path)

    patch_save(monkeypatch, keep_then_save)
    plots.draw_plots(tmp_path, data)
    from matplotlib.colors import to_rgba

    ax = drawn["modes.png"].axes[0]
    lo, hi = ax.get_xlim()
    red = to_rgba("tab:red")
    shown = []  # (row, width inside the panel) of each estimated bar
    for bars in ax.collections:
        if tuple(bars.get_facecolor()[0]) != red:
            continue
        for path in bars.get_paths():
            x, y = path.vertices[:, 0], path.vertices[:, 1]
            shown.append((round(float(y.mean())), min(x.max(), hi) - max(x.min(), lo)))
    assert [row for row, width in shown if width > 0] == [0, 2]
