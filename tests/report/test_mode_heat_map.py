"""modes.png of many modes: the probabilities as a heat map on the mode panel's rows.

32 modes were 32 crossing curves, their colours repeating from the 21st, over a six-column
legend no curve could be matched to.  Past
:data:`~hybridlog.report.mode_plots.MOST_PROBABILITY_LINES` modes the probabilities are a heat
map, a row per mode, drawn from the reduced curves.
"""

from __future__ import annotations

import dataclasses
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from hybridlog.estimators.result import EstimationResult, PostProcessing
from hybridlog.report.curve_envelopes import column_maxima, envelope
from hybridlog.report.pixel_bins import PixelBins
from hybridlog.report.plot_data import ModeTimelines
from hybridlog.report.plot_reducer import reduce_result
from hybridlog.signals import AlignedSignals
from tests.support.figures import drawn_figures

from .test_mode_keys import LONG_IDS, _assert_inside, _legend_below_panels
from .test_report_files import make_run


def _many_modes(
    n: int, n_modes: int, *, smoothed: bool = False, ids: tuple[str, ...] | None = None
) -> tuple[EstimationResult, AlignedSignals]:
    """``make_run``'s run of ``n`` samples with ``n_modes`` modes, each probable in turn."""
    result, signals = make_run(n)
    rng = np.random.default_rng(5)
    ids = ids or tuple(f"m{j}" for j in range(n_modes))
    modes = (np.arange(n) * n_modes // n).astype(np.int64)  # every mode, in order
    probabilities = 0.05 * rng.random((n, n_modes)) ** 8 + np.eye(n_modes)[modes]
    probabilities /= probabilities.sum(axis=1, keepdims=True)
    result = dataclasses.replace(
        result, mode_ids=ids, modes=modes, mode_probabilities=probabilities
    )
    signals = dataclasses.replace(signals, truth_modes=np.roll(modes, 3))
    if smoothed:  # the filter's own probabilities lag the smoothed ones
        filtered = dataclasses.replace(
            result, mode_probabilities=np.roll(probabilities, n // (2 * n_modes), axis=0)
        )
        post = PostProcessing("kim-rts", "argmax", "test", filtered)
        result = dataclasses.replace(result, post_processing=post)
    return result, signals


def _modes_figure(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, run: tuple[EstimationResult, AlignedSignals]
) -> Any:
    from hybridlog.report import mode_plots

    data = reduce_result(*run)
    draw = lambda: mode_plots.plot_modes(data, tmp_path / "modes.png")  # noqa: E731
    return drawn_figures(monkeypatch, draw)["modes.png"]


def _column_maxima_of(values: np.ndarray, time: np.ndarray) -> np.ndarray:
    """Per pixel column of a run over ``time``, the largest of ``values`` (from the samples)."""
    bins = PixelBins.of_run(time)
    return np.array(
        [np.max(values[a : b + 1]) for a, b in zip(bins.starts, bins.ends, strict=True)]
    )


def _heat_map(fig: Any) -> tuple[Any, Any, Any]:
    """The mode panel, the probabilities' panel and its one image."""
    ax_mode, ax_prob = fig.axes[:2]
    (image,) = ax_prob.get_images()
    return ax_mode, ax_prob, image


@pytest.mark.parametrize("n", [300, 20_000])  # curves kept whole, and reduced (M4)
def test_many_modes_are_a_heat_map_of_the_mode_rows_and_their_reduced_probabilities(
    n: int, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    run = _many_modes(n, 32)
    result, signals = run
    fig = _modes_figure(monkeypatch, tmp_path, run)
    ax_mode, ax_prob, image = _heat_map(fig)
    assert not [line for line in ax_prob.get_lines() if line.get_label().startswith("p(")]
    # the rows are the mode panel's: same labels, same order, same y range and height
    ids = [f"m{j}" for j in range(32)]
    for ax in (ax_mode, ax_prob):
        assert [t.get_text() for t in ax.get_yticklabels()] == ids
        assert list(ax.get_yticks()) == list(range(32))
        assert ax.get_ylim() == (-0.5, 31.5)
    renderer = fig.canvas.get_renderer()
    heights = {round(ax.get_window_extent(renderer).height, 6) for ax in (ax_mode, ax_prob)}
    assert len(heights) == 1
    # row j is mode j's probability, its cells the pixel columns' maxima of the samples
    cells = image.get_array()
    bins = PixelBins.of_run(signals.time)
    assert cells.shape == (32, bins.starts.shape[0])
    assert np.array_equal(image._Ay, np.arange(33) - 0.5)
    assert np.array_equal(image._Ax, bins.edges)
    for j in (0, 7, 31):
        direct = _column_maxima_of(result.mode_probabilities[:, j], signals.time)
        assert np.array_equal(cells[j].filled(np.nan), direct)
    # a probable mode's cells are bright where its bar is, the others dark
    column = bins.starts.shape[0] // 2
    on = int(result.modes[bins.starts[column]])
    assert cells[on, column] > 0.7 and np.delete(cells[:, column], on).max() < 0.3
    # one colour bar, from 0 to 1, labelled: no legend of 32 entries
    (bar,) = [ax for ax in fig.axes[2:] if ax.get_xlabel() == "probability"]
    assert bar.get_xlim() == (0.0, 1.0)
    assert image.norm.vmin == 0.0 and image.norm.vmax == 1.0
    assert image.get_cmap().name.startswith("viridis")
    assert fig.legends == []
    _assert_inside(fig)


def test_the_filters_own_probability_is_the_middle_third_of_each_row(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """--smooth overlaid the filter's curves, dashed: in a heat map, each mode's row holds the
    filter's cells in its middle third (as its mode is a thin bar in the panel above)."""
    run = _many_modes(600, 24, smoothed=True)
    result, signals = run
    assert result.post_processing is not None
    filtered = result.post_processing.filtered.mode_probabilities
    fig = _modes_figure(monkeypatch, tmp_path, run)
    image = _heat_map(fig)[2]
    cells = image.get_array().filled(np.nan)
    assert cells.shape[0] == 3 * 24
    rows = np.stack([np.arange(24) - 0.5, np.arange(24) - 1 / 6, np.arange(24) + 1 / 6], axis=1)
    assert np.allclose(image._Ay, np.append(rows.ravel(), 23.5))
    for j in (0, 11, 23):
        smoothed = _column_maxima_of(result.mode_probabilities[:, j], signals.time)
        own = _column_maxima_of(filtered[:, j], signals.time)
        assert np.array_equal(cells[3 * j], smoothed)
        assert np.array_equal(cells[3 * j + 1], own)
        assert np.array_equal(cells[3 * j + 2], smoothed)
    assert _legend_below_panels(fig) == ["filtered: the middle third of each row"]
    _assert_apart(fig)


def test_long_ids_are_keyed_alike_in_both_panels(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    ids = (*LONG_IDS, *(f"m{j}" for j in range(22)))
    fig = _modes_figure(monkeypatch, tmp_path, _many_modes(300, len(ids), ids=ids, smoothed=True))
    ax_mode, ax_prob, _ = _heat_map(fig)
    keys = [f"[{k + 1}]" for k in range(len(ids))]
    for ax in (ax_mode, ax_prob):
        assert [t.get_text() for t in ax.get_yticklabels()] == keys
    entries = _legend_below_panels(fig)
    assert entries[:3] == [f"[{k + 1}]: {m}" for k, m in enumerate(LONG_IDS)]
    assert entries[-1] == "filtered: the middle third of each row"
    _assert_inside(fig)
    _assert_apart(fig)


def _assert_apart(fig: Any) -> None:
    """The colour bar, with its ticks and label, lies below the panels and above the legend."""
    renderer = fig.canvas.get_renderer()
    bar = fig.axes[2]
    box = bar.get_tightbbox(renderer)
    lowest = min(ax.get_tightbbox(renderer).y0 for ax in fig.axes[:2])
    assert box.y1 <= lowest
    for legend in fig.legends:
        assert legend.get_window_extent(renderer).y1 <= box.y0
    assert box.x0 >= 0.0 and box.y0 >= 0.0


@pytest.mark.parametrize(("n_modes", "heat_map"), [(20, False), (21, True)])
def test_up_to_twenty_modes_keep_their_curves(
    n_modes: int, heat_map: bool, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Up to 20 modes each curve has a colour of its own (tab20), and they are drawn as before."""
    fig = _modes_figure(monkeypatch, tmp_path, _many_modes(300, n_modes))
    ax_prob = fig.axes[1]
    curves = [line for line in ax_prob.get_lines() if line.get_label().startswith("p(")]
    assert len(ax_prob.get_images()) == int(heat_map)
    assert len(curves) == (0 if heat_map else n_modes)
    assert len(fig.axes) == (3 if heat_map else 2)  # the colour bar
    if not heat_map:
        assert ax_prob.get_ylabel() == "probability"
        assert _legend_below_panels(fig) == [f"p(m{j})" for j in range(n_modes)]


def test_column_maxima_are_those_of_the_samples_reduced_or_whole() -> None:
    rng = np.random.default_rng(0)
    for n in (50, 3_000, 40_000):  # fewer samples than columns, kept whole, reduced
        time = np.cumsum(rng.uniform(0.2, 1.8, n))
        values = rng.random(n)
        values[rng.random(n) < 0.2] = np.nan
        values[: n // 10] = np.nan  # columns without a value
        bins = PixelBins.of_run(time)
        curve = envelope(values, bins)
        assert curve.reduced == (n == 40_000)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # a column without a value: NaN
            direct = np.array(
                [np.nanmax(values[a : b + 1]) for a, b in zip(bins.starts, bins.ends, strict=True)]
            )
        assert np.array_equal(column_maxima(curve, bins.edges), direct, equal_nan=True)
        assert np.isnan(direct[0])


def test_a_many_mode_run_of_one_sample_is_drawn(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A cell of no width set the panel's x range to one time (matplotlib warned)."""
    result, signals = _many_modes(1, 25)
    data = reduce_result(result, signals)
    assert isinstance(data.modes, ModeTimelines)
    assert data.span is not None and data.span[0] == data.span[1]
    fig = _modes_figure(monkeypatch, tmp_path, (result, signals))
    ax_prob = fig.axes[1]
    assert ax_prob.get_images() == []  # no width to draw, as the bars have none
    assert [t.get_text() for t in ax_prob.get_yticklabels()] == [f"m{j}" for j in range(25)]
    assert fig.axes[2].get_xlabel() == "probability"
