"""What the plots draw of a long run: every extreme per pixel column, every mode run."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from hybridlog.report import mode_metrics
from hybridlog.report.curve_envelopes import envelope
from hybridlog.report.pixel_bins import PixelBins, pixel_columns, time_bins
from hybridlog.report.plot_curves import DASHED_BAND_ALPHA, draw_curve
from hybridlog.report.plot_time_axis import set_time_span
from hybridlog.report.timeline_bars import mode_bars, mode_runs


def _per_column(
    t: np.ndarray, v: np.ndarray, t0: float, t1: float, columns: int
) -> dict[int, tuple[float, float]]:
    """(min, max) of the finite values in each pixel column of ``[t0, t1]``."""
    column = np.minimum(((t - t0) / (t1 - t0) * columns).astype(np.int64), columns - 1)
    out = {}
    for c in np.unique(column[np.isfinite(v)]):
        inside = v[(column == c) & np.isfinite(v)]
        out[int(c)] = (float(inside.min()), float(inside.max()))
    return out


@given(
    st.integers(2, 5_000),
    st.integers(1, 300),
    st.floats(0.001, 10.0),
    st.integers(0, 2**32 - 1),
    st.floats(0.0, 0.3),
)
@settings(max_examples=150, deadline=None)
def test_the_envelope_keeps_min_and_max_of_every_pixel_column(
    n: int, columns: int, dt: float, seed: int, missing: float
) -> None:
    rng = np.random.default_rng(seed)
    t = 5.0 + dt * np.cumsum(rng.integers(1, 4, n))  # gaps of 1..3 samples
    v = np.cumsum(rng.standard_normal(n)) * 10.0 ** rng.integers(-3, 4)
    v[rng.random(n) < missing] = np.nan
    bins = time_bins(t, columns)
    reduced = envelope(v, PixelBins(t, bins))
    t0, t1 = float(t[0]), float(t[-1])
    assert np.all(np.diff(reduced.time) >= 0.0)
    assert reduced.time[0] == t0 and reduced.time[-1] == t1
    assert _per_column(reduced.time, reduced.values, t0, t1, columns) == _per_column(
        t, v, t0, t1, columns
    )
    # Each bin lies inside one pixel column, and the reduction draws at most four points per bin.
    ends = np.append(bins[1:], n) - 1
    width = (t1 - t0) / columns
    assert np.all(t[ends] - t[bins] <= width * (1 + 1e-12))
    assert reduced.values.size <= max(n, 4 * bins.size)


def test_the_envelope_keeps_the_breaks_of_a_curve_and_a_short_curve_as_it_is() -> None:
    t = np.arange(10_000, dtype=np.float64)
    v = np.sin(t / 50.0)
    v[0] = np.nan  # row 0 of a prediction
    v[5_000:5_200] = np.nan  # a gap wider than a pixel column
    reduced = envelope(v, PixelBins(t, time_bins(t, 100)))
    assert np.isnan(reduced.values[0])
    gap = (reduced.time > 5_000) & (reduced.time < 5_199)
    assert gap.any() and np.isnan(reduced.values[gap]).all()
    short = envelope(v[:50], PixelBins(t[:50], time_bins(t[:50], pixel_columns())))
    assert short.values is v[:50] or np.array_equal(short.values, v[:50], equal_nan=True)


def test_a_long_curve_is_drawn_as_the_band_of_each_pixel_column() -> None:
    from matplotlib.figure import Figure

    rng = np.random.default_rng(3)
    t = np.arange(200_000) * 0.01
    v = np.cumsum(rng.standard_normal(t.size))
    v[50_000:60_000] = np.nan  # a gap of many pixel columns
    columns = pixel_columns()
    ax = Figure().add_subplot()
    curve = envelope(v, PixelBins(t, time_bins(t, columns)))
    (line,) = draw_curve(ax, curve, lw=0.8, color="k", ls="--")
    assert line.get_xydata().size == 0 and line.get_linestyle() == "--"  # the legend's entry
    (band,) = ax.collections
    assert band.get_alpha() == DASHED_BAND_ALPHA and band.get_linewidth()[0] == 0.8
    vertices = np.concatenate([path.vertices for path in band.get_paths()])
    t0, t1 = float(t[0]), float(t[-1])
    drawn = _per_column(vertices[:, 0], vertices[:, 1], t0, t1, columns)
    assert drawn == _per_column(t, v, t0, t1, columns)
    # A curve with at most two points per pixel column stays a line, as given.
    ax = Figure().add_subplot()
    (line,) = draw_curve(
        ax, envelope(v[:1_000], PixelBins(t[:1_000], time_bins(t[:1_000], columns)))
    )
    assert np.array_equal(line.get_ydata(), v[:1_000]) and not ax.collections


def test_the_band_paints_every_pixel_the_curve_reaches_in_each_column() -> None:
    """No holes where the curve jumps within or between pixel columns, and no ink elsewhere."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    rng = np.random.default_rng(5)
    n = 400_000
    t = np.arange(n) * 1e-3
    v = np.where((np.arange(n) // 7_919) % 2 == 0, 0.0, 100.0) + rng.standard_normal(n)
    v[123_456:123_460] = 300.0  # a spike of four samples
    v[200_000:] += np.cumsum(rng.standard_normal(n - 200_000))  # a random walk
    v[300_000:310_000] = np.nan
    fig = Figure(figsize=(10, 3), dpi=100)
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_axes((0.09, 0.1, 0.89, 0.85), frame_on=False)  # the panels' left and right
    bins = PixelBins.of_run(t)
    set_time_span(ax, bins.span)
    draw_curve(ax, envelope(v, bins), lw=0.8, color="k")
    ax.set_xticks([])
    ax.set_yticks([])
    canvas.draw()
    ink = np.asarray(canvas.buffer_rgba())[..., 0] < 128
    # Where each sample lands: pixel column, and its row counted from the top.
    finite = np.isfinite(v)
    x, y = ax.transData.transform(np.column_stack([t[finite], v[finite]])).T
    column, row = np.floor(x).astype(np.int64), ink.shape[0] - y
    top = np.full(ink.shape[1], np.inf)
    bottom = np.full(ink.shape[1], -np.inf)
    np.minimum.at(top, column, row)
    np.maximum.at(bottom, column, row)
    rows = np.arange(ink.shape[0])[:, None]
    inner = (rows >= np.ceil(top) + 1) & (rows <= np.floor(bottom) - 1)  # 1 pixel of rounding
    assert ink[inner].all()  # every pixel between a column's lowest and highest sample
    # Ink only within the rows of the column and its neighbours (the lines joining columns).
    highest = np.minimum(np.minimum(top, np.roll(top, 1)), np.roll(top, -1))
    lowest = np.maximum(np.maximum(bottom, np.roll(bottom, 1)), np.roll(bottom, -1))
    assert not ink[(rows < np.floor(highest) - 1) | (rows > np.ceil(lowest) + 1)].any()


mode_seqs = hnp.arrays(np.int64, st.integers(1, 3_000), elements=st.integers(0, 2))


@given(mode_seqs, st.integers(1, 400))
@settings(max_examples=150, deadline=None)
def test_mode_runs_have_the_switches_and_the_bars_cover_every_run(
    modes: np.ndarray, columns: int
) -> None:
    t = np.arange(modes.size) * 0.1
    ids = ("a", "b", "c")
    runs = mode_runs(modes)
    switches = mode_metrics.mode_switches(t, modes, ids)
    assert [float(t[s]) for s in runs.start[1:]] == [s["t"] for s in switches]
    assert [ids[m] for m in runs.mode[1:]] == [s["to"] for s in switches]
    assert np.array_equal(np.repeat(runs.mode, runs.end - runs.start), modes)
    bins = time_bins(t, columns)
    bin_of = np.searchsorted(bins, np.arange(modes.size), side="right") - 1
    bars = mode_bars(runs, bins, 3)
    for m, (first, last) in enumerate(bars):
        assert np.all(first <= last) and np.all(last[:-1] + 1 < first[1:])  # apart, ordered
        covered = np.zeros(bins.size, dtype=bool)
        for a, b in zip(first, last, strict=True):
            covered[a : b + 1] = True
        # A bin is covered exactly when the mode occurs in it.
        occurs = np.zeros(bins.size, dtype=bool)
        occurs[bin_of[modes == m]] = True
        assert np.array_equal(covered, occurs)
        for s, e, mode in zip(runs.start, runs.end, runs.mode, strict=True):
            if mode == m:
                assert covered[bin_of[s] : bin_of[e - 1] + 1].all()
    if bins.size == modes.size:  # one bin per sample: the bars are the runs
        for m, (first, last) in enumerate(bars):
            mine = runs.mode == m
            assert np.array_equal(first, runs.start[mine])
            assert np.array_equal(last, runs.end[mine] - 1)


@pytest.mark.parametrize("block", [7, 1000, 1 << 16])
def test_reductions_a_block_at_a_time_are_those_of_the_whole_run(
    block: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The reference: the whole-array reductions the block-wise ones replaced.
    from hybridlog.report import curve_envelopes, pixel_bins

    rng = np.random.default_rng(9)
    n, columns = 20_011, 97
    time = np.cumsum(rng.uniform(0.5, 1.5, n))
    values = rng.normal(size=n)
    values[rng.integers(0, n, 300)] = np.nan
    variance = rng.normal(1.0, 0.5, n)  # some negative (clipped), some NaN
    variance[rng.integers(0, n, 200)] = np.nan
    monkeypatch.setattr(pixel_bins, "BLOCK", block)  # every reduction's blocks

    column = np.minimum(((time - time[0]) / (time[-1] - time[0]) * columns).astype(np.int64), 96)
    bins = np.concatenate(([0], np.flatnonzero(column[1:] != column[:-1]) + 1))
    np.testing.assert_array_equal(pixel_bins.time_bins(time, columns), bins)

    ends = np.append(bins[1:], n) - 1
    finite = np.where(np.isfinite(values), values, np.nan)
    with np.errstate(invalid="ignore"):
        low, high = np.fmin.reduceat(finite, bins), np.fmax.reduceat(finite, bins)
    pixels = pixel_bins.PixelBins(time, bins)
    curve = curve_envelopes.envelope(values, pixels)
    points = curve.values.reshape(-1, 4)
    np.testing.assert_array_equal(points[:, 0], values[bins])
    np.testing.assert_array_equal(points[:, 3], values[ends])
    rising = ~(values[bins] > values[ends])
    np.testing.assert_array_equal(points[:, 1], np.where(rising, low, high))
    np.testing.assert_array_equal(points[:, 2], np.where(rising, high, low))

    two_sigma = 2.0 * np.sqrt(np.maximum(variance, 0.0))
    outside = ~(np.isfinite(two_sigma) & np.isfinite(values))
    edge_low, edge_high = values - two_sigma, values + two_sigma
    edge_low[outside] = np.nan
    edge_high[outside] = np.nan
    with np.errstate(invalid="ignore"):
        band_low = np.fmin.reduceat(edge_low, bins)
        band_high = np.fmax.reduceat(edge_high, bins)

    def sigma_band(mean: np.ndarray, variance: np.ndarray) -> curve_envelopes.SigmaBand | None:
        reducer = curve_envelopes.BandReducer(pixels)
        reducer.add(mean, variance, 0)
        return reducer.finish()

    band = sigma_band(values, variance)
    assert band is not None
    np.testing.assert_array_equal(band[0], np.stack([time[bins], time[ends]], axis=1).ravel())
    np.testing.assert_array_equal(band[1], np.repeat(band_low, 2))
    np.testing.assert_array_equal(band[2], np.repeat(band_high, 2))
    assert sigma_band(values, np.full(n, np.nan)) is None


def test_figures_made_ahead_draw_the_same_pngs_and_are_taken_once(tmp_path) -> None:
    """``prepare_figures`` (made in ``analyze``'s import thread): the same bytes as figures
    made on the spot, each taken by one plot, never more than one kept per shape."""
    from hybridlog.estimators.filter_options import ImmOptions
    from hybridlog.estimators.imm import run_imm
    from hybridlog.model.loader import load_model
    from hybridlog.report import plot_figures, plots
    from hybridlog.simulate import simulate

    model = load_model("three_tank_hstf")
    signals = simulate(model, steps=400, seed=3).signals(model, source="test")
    result = run_imm(model, signals, ImmOptions(smooth=True))
    fresh, ahead = tmp_path / "fresh", tmp_path / "ahead"
    fresh.mkdir()
    ahead.mkdir()
    plot_figures._READY.clear()
    plots.write_plots(fresh, result, signals)
    shapes = plots.figure_shapes(
        model.n_outputs, model.n_states, bool(model.components), model.n_modes
    )
    assert shapes == [(3, 2.0), (3, 2.0), (2, 2.4)]
    plot_figures.prepare_figures(shapes)
    plot_figures.prepare_figures(shapes)
    # as many per shape as the plots take, however often asked
    ready = plot_figures._READY
    assert {key: len(figures) for key, figures in ready.items()} == {(3, 2.0): 2, (2, 2.4): 1}
    ((made, _),) = ready[(2, 2.4)]
    assert plot_figures.new_figure(2, panel_height=2.4)[0] is made and not ready[(2, 2.4)]
    plot_figures.prepare_figures(shapes)
    plots.write_plots(ahead, result, signals)
    assert not any(plot_figures._READY.values())  # the three plots took what was made for them
    for name in ("outputs.png", "modes.png", "states.png"):
        assert (ahead / name).read_bytes() == (fresh / name).read_bytes(), name


def test_an_output_measured_every_third_sample_is_drawn_as_dots_without_lines() -> None:
    """Each measured sample between two unmeasured ones (NaN) shows; nothing joins them.

    A line through NaN breaks on both sides of such a sample and drew nothing at all:
    outputs.png of a log whose y3 came at a third of the model's rate had no measured y3.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    n = 300
    t = np.arange(n, dtype=np.float64)
    v = np.full(n, np.nan)
    v[::3] = np.where(np.arange(100) % 2 == 0, 0.0, 100.0)  # measured every third sample
    fig = Figure(figsize=(10, 3), dpi=100)
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_axes((0.05, 0.1, 0.9, 0.8), frame_on=False)
    bins = PixelBins.of_run(t)
    set_time_span(ax, bins.span)
    ax.set_ylim(-10, 110)
    draw_curve(ax, envelope(v, bins), lw=0.8, color="k", label="measured")
    ax.set_xticks([])
    ax.set_yticks([])
    canvas.draw()
    ink = np.asarray(canvas.buffer_rgba())[..., 0] < 128
    x, y = ax.transData.transform(np.column_stack([t[::3], v[::3]])).T
    column, row = np.floor(x).astype(np.int64), np.floor(ink.shape[0] - y).astype(np.int64)
    near = [ink[r - 1 : r + 2, c - 1 : c + 2].any() for r, c in zip(row, column, strict=True)]
    assert all(near)  # every measured sample shows
    middle = int(ink.shape[0] - ax.transData.transform((0.0, 50.0))[1])
    assert not ink[middle - 5 : middle + 5].any()  # and no line joins 0 to 100 across a NaN
