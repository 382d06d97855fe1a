"""The figures' time axes read as times: absolute (Unix) times from the first sample, plain
tick labels, none cut off at the figure's right edge."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from hybridlog.estimators.result import EstimationResult
from hybridlog.report.plot_data import ModeTimelines
from hybridlog.report.plot_reducer import reduce_result
from hybridlog.report.plot_time_axis import time_origin, time_unit
from hybridlog.signals import AlignedSignals
from tests.support.figures import drawn_figures

from .test_plot_data import _run
from .test_report_files import make_run

UNIX_T0 = 1_700_000_000.25


def _retimed(
    run: tuple[EstimationResult, AlignedSignals], time: np.ndarray
) -> tuple[EstimationResult, AlignedSignals]:
    result, signals = run
    return dataclasses.replace(result, time=time), dataclasses.replace(signals, time=time)


def _figures(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, run: tuple[EstimationResult, AlignedSignals]
) -> dict[str, Any]:
    """The figures of ``run`` as saved, drawn (so that their text has its place)."""
    from hybridlog.report import plots

    return drawn_figures(monkeypatch, lambda: plots.write_plots(tmp_path, *run))


def _time_axes(fig: Any) -> Any:
    """The lowest panel of a figure: the one with the time axis's label."""
    return min(fig.axes, key=lambda ax: ax.get_position().y0)


def test_time_origin_is_zero_for_times_that_read_as_they_are() -> None:
    assert time_origin(0.0, 300.0) == 0.0
    assert time_origin(12.5, 1e6) == 0.0
    assert time_origin(3600.0, 7200.0) == 0.0
    assert time_origin(UNIX_T0, UNIX_T0 + 300.0) == UNIX_T0
    assert time_origin(500.0, 500.01) == 500.0  # a 10 ms excerpt: seven digits a tick


@pytest.mark.parametrize("components", [False, True], ids=["modes", "components"])
def test_a_run_in_unix_time_is_drawn_from_its_first_sample(
    components: bool, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """A log stamped in Unix time had ticks 1.7000 ... 1.7010 over ``1e9`` in the corner:
    no switch could be placed closer than the tick spacing (200,000 s in a 10^6 s log)."""
    run = _run(400, seed=1, components=components) if components else make_run(400)
    time = UNIX_T0 + np.arange(400) * 2.5
    run = _retimed(run, time)
    data = reduce_result(*run)
    assert data.time_origin == UNIX_T0 and data.span is not None
    assert data.span[0] == 0.0 and data.span[1] == pytest.approx(400 * 2.5)
    assert data.edges[0] == 0.0 and data.edges[-1] == data.span[1]
    if isinstance(data.modes, ModeTimelines):
        assert data.modes.probabilities[0].time[-1] == 399 * 2.5

    figures = _figures(monkeypatch, tmp_path, run)
    assert set(figures) == {"outputs.png", "modes.png", "states.png"}
    for name, fig in figures.items():
        ax = _time_axes(fig)
        assert ax.get_xlabel() == "t − t₀ (s), t₀ = 1700000000.25 s", name
        assert ax.xaxis.get_offset_text().get_text() == "", name
        texts = [t.get_text() for t in ax.get_xticklabels() if t.get_text()]
        ticks = [float(text.replace("−", "-")) for text in texts]
        assert ticks and min(ticks) >= 0.0 and max(ticks) <= 1000.0, (name, ticks)


def test_tick_labels_are_plain_and_inside_the_figure(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """A 10^6 s run's ticks read 0.2 ... 1.0 over ``1e6``; written out, the label at the
    right end (1000000) ran past the figure's edge, as 1.7010 of a Unix-time run did."""
    run = _retimed(make_run(300), np.arange(300) * (1e6 / 299))
    for name, fig in _figures(monkeypatch, tmp_path, run).items():
        ax = _time_axes(fig)
        assert ax.get_xlabel() == "t (s)"
        assert ax.xaxis.get_offset_text().get_text() == "", name
        renderer = fig.canvas.get_renderer()
        shown = [t for t in ax.get_xticklabels() if t.get_text() and t.get_visible()]
        lo, hi = ax.get_xlim()
        inside = [t for t in shown if lo <= t.get_position()[0] <= hi]
        assert "1000000" in [t.get_text() for t in inside], name
        right = max(t.get_window_extent(renderer).x1 for t in inside)
        assert right <= fig.bbox.width, (name, right, fig.bbox.width)


def test_the_cluster_plot_draws_a_run_in_unix_time_from_its_first_sample(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """``hybridlog cluster``'s picture had the ticks 1.7000 ... 1.7010 over ``1e9`` too."""
    from hybridlog.jobs import cluster_plot

    figures: list[Any] = []
    save = cluster_plot.save_reproducibly

    def keep_then_save(fig: Any, path: Path, *, dpi: int) -> None:
        fig.canvas.draw()
        figures.append(fig)
        save(fig, path, dpi=dpi)

    monkeypatch.setattr(cluster_plot, "save_reproducibly", keep_then_save)
    phi = np.random.default_rng(2).normal(size=(400, 2))
    cluster_plot.plot_clusters(
        tmp_path / "clusters.png",
        time=UNIX_T0 + np.arange(400) * 2.5,
        phi=phi,
        names=("y(k)", "y(k-1)"),
        clusters=np.arange(400) % 2,
        centers=phi[:2],
        cluster_modes=("1", "2"),
        decision_values=np.array([0.5, 1.5]),
        mode_ids=("1", "2"),
        truth=["1" if k % 3 else "2" for k in range(400)],
    )
    right = figures[0].axes[1]
    assert right.get_xlabel() == "t − t₀ (s), t₀ = 1700000000.25 s"
    assert right.xaxis.get_offset_text().get_text() == ""
    lo, hi = right.get_xlim()
    assert -100.0 < lo < 0.0 and 997.5 < hi < 1100.0, (lo, hi)


def test_time_unit_is_seconds_but_for_spans_below_a_millisecond() -> None:
    assert [time_unit(s) for s in (0.0, 1e-3, 300.0)] == [0, 0, 0]
    assert [time_unit(s) for s in (5e-4, 2.99e-7, 3e-10, 1e-20)] == [-6, -9, -12, -15]


@pytest.mark.parametrize(("start", "label"), [(0.0, "t (ps)"), (5.0, "t − t₀ (ps), t₀ = 5 s")])
def test_a_run_shorter_than_a_nanosecond_is_ticked_in_picoseconds(
    start: float, label: str, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """Samples 1 ps apart: matplotlib writes a tick below 1e-8 as 0, so every tick read
    ``0.00000000000`` and the switches had no time."""
    run = _retimed(make_run(300), start + np.arange(300) * 1e-12)
    for name, fig in _figures(monkeypatch, tmp_path, run).items():
        ax = _time_axes(fig)
        assert ax.get_xlabel() == label, name
        assert not ax.xaxis.get_offset_text().get_visible(), name
        lo, hi = ax.get_xlim()
        texts = [t.get_text() for t in ax.get_xticklabels() if lo <= t.get_position()[0] <= hi]
        ticks = [float(text.replace("−", "-")) for text in texts]
        assert len(set(texts)) == len(texts) >= 3 and 200.0 <= max(ticks) <= 300.0, (name, texts)
