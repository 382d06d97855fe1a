"""Every legend of every figure stands off the panels' data and off the figure's title.

A legend in a panel's upper right corner hid what ran there: a state's estimate or an output
ending at its largest value, the most probable mode's probability near 1, a component's
mode bars.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from hybridlog.estimators.result import EstimationResult
from hybridlog.signals import AlignedSignals
from tests.support.figures import drawn_figures

from .test_plot_data import _run
from .test_report_files import make_run


def _rising(n: int) -> tuple[EstimationResult, AlignedSignals]:
    """``make_run``'s run with every curve at its largest at the end (under upper right)."""
    result, signals = make_run(n)
    ramp = np.linspace(0.0, 1.0, n)[:, None]
    signals = dataclasses.replace(signals, outputs=ramp + 0.0 * signals.outputs)
    result = dataclasses.replace(
        result,
        state_means=ramp + 0.0 * result.state_means,
        output_predictions=ramp + 0.0 * result.output_predictions,
    )
    return result, signals


RUNS = {
    "rising": lambda: _rising(300),
    "smoothed": lambda: _run(400, seed=1, smoothed=True),
    "no truth": lambda: _run(400, seed=2, truth=False),
    "components": lambda: _run(500, seed=2, components=True),
    "components smoothed": lambda: _run(500, seed=3, components=True, smoothed=True),
}


def _figures(monkeypatch: pytest.MonkeyPatch, tmp_path: Path, run: Any) -> dict[str, Any]:
    """The figures of ``run`` as saved, drawn (so that text has its place)."""
    from hybridlog.report import plots

    return drawn_figures(monkeypatch, lambda: plots.write_plots(tmp_path, *run()))


@pytest.mark.parametrize("name", list(RUNS))
def test_no_legend_covers_a_panel_or_the_title(
    name: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    figures = _figures(monkeypatch, tmp_path, RUNS[name])
    assert sorted(figures) == ["modes.png", "outputs.png", "states.png"]
    for file, fig in figures.items():
        renderer = fig.canvas.get_renderer()
        legends = [*fig.legends, *(ax.get_legend() for ax in fig.axes)]
        boxes = [legend.get_window_extent(renderer) for legend in legends if legend is not None]
        assert boxes, file  # every figure says what its lines and bars are
        title = fig._suptitle.get_window_extent(renderer)
        for box in boxes:
            assert box.x0 >= 0.0 and box.x1 <= fig.bbox.width, file
            assert box.y0 >= 0.0 and box.y1 <= fig.bbox.height, file
            assert not box.overlaps(title), file
            for ax in fig.axes:
                assert not box.overlaps(ax.get_window_extent(renderer)), (file, ax.get_ylabel())


def test_the_states_title_names_only_what_is_drawn(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """'estimate ±2σ vs truth' was the title of a Luenberger observer's states (no σ) on a
    log without true states."""
    result, signals = _run(200, seed=4, truth=False)
    result = dataclasses.replace(result, state_variances=np.full_like(result.state_means, np.nan))
    figures = _figures(monkeypatch, tmp_path, lambda: (result, signals))
    assert figures["states.png"].get_suptitle() == "States: estimate"
    (tmp_path / "b").mkdir()
    figures = _figures(monkeypatch, tmp_path / "b", lambda: _rising(200))
    assert figures["states.png"].get_suptitle() == "States: estimate ±2σ vs truth"
