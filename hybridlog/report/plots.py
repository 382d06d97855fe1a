"""PNG plots of one run, drawn with matplotlib's Agg canvas (no pyplot, no global state).

``outputs.png``
    One panel per output: measured ``y`` and the one-step-ahead prediction ``ŷ``.
``modes.png``
    The estimated mode timeline (and the true one when known) as runs, one row per mode, and
    the mode probabilities; for a ``[components]`` result (``unknown-mode``) one timeline per
    component (``unknown`` in its own colour) and the joint assignment.
``states.png``
    One panel per state: the estimate with a ±2σ band (where a variance is defined) and the
    true state when known.

A smoothed run (``result.post_processing``) draws the smoothed estimates as above and the
causal filter's own over them, thin and dashed: its mode runs as a thin bar inside the
estimated one, its mode probabilities and state estimates as dashed curves (translucent
bands where a long run is drawn as bands, below).

A PNG cannot show more than one value range per pixel column, so long runs are reduced to
what it can show before drawing (:func:`envelope`): the samples are cut into time bins, one
per pixel column of the panel (whose x range is the run's time span: :func:`pixel_bins`),
and each bin is drawn through its first sample, its minimum, its maximum and its last
sample (the "M4" reduction: every extreme the full curve reaches in a column is kept, so
the picture is the same).  Such a reduced curve, with more than two points per pixel
column, fills each column from its minimum to its maximum and is drawn as that band
(:func:`draw_curve`).  The mode timelines are drawn from their runs (:func:`mode_runs`),
the runs of each mode merged where they touch the same pixel column (:func:`mode_bars`): a
run shorter than a pixel still shows as one pixel column.  At most ``MAX_PANELS``
outputs/states are drawn.  matplotlib
is imported when the first figure is made, so code that writes no plot does not load it.
"""

from __future__ import annotations

import threading
from collections import Counter
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from hybridlog.estimators.result import EstimationResult
from hybridlog.signals import AlignedSignals, FloatArray, IntArray

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

__all__ = [
    "MAX_PANELS",
    "PNG_COMPRESS_LEVEL",
    "Envelope",
    "ModeRuns",
    "draw_curve",
    "envelope",
    "make_ticks_ahead",
    "mode_bars",
    "mode_runs",
    "pixel_bins",
    "pixel_columns",
    "plot_modes",
    "plot_outputs",
    "plot_states",
    "time_bins",
    "write_plots",
]

MAX_PANELS = 16
PNG_COMPRESS_LEVEL = 1
"""zlib level of the PNG files (Pillow's default is 6).  The pixels are the same at any level;
on the three figures of a 10^6-sample run level 1 encoded in half the time (0.10 s against
0.19 s) for files 3 % larger in total (638 KB against 620 KB)."""
_MATPLOTLIB = threading.Lock()
"""Held while one run's figures are drawn: the report may draw them in a thread
(:func:`hybridlog.report.writer.write_report`), and matplotlib's font cache is not safe
to use from two threads at once (a Dask worker runs several logs side by side)."""
_BLOCK = 1 << 16
"""Samples per block of the reductions (:func:`time_bins`, :func:`envelope`, the ±2σ band):
their temporaries are 0.5 MB, not 8 MB per array of a 10^6-sample run.  The plots are drawn
beside the metrics and tables (in a thread, or a forked child whose resident set is the
parent's at the fork plus its own), so what they hold adds to the run's peak."""
_DPI = 100
_WIDTH_IN = 10.0
_LEFT, _RIGHT = 0.09, 0.98


def pixel_columns() -> int:
    """Width in pixels of a panel's plotting area: the bins of :func:`time_bins`."""
    return int(np.ceil(_WIDTH_IN * _DPI * (_RIGHT - _LEFT)))


def time_bins(time: FloatArray, columns: int) -> IntArray:
    """Start index of each non-empty bin when ``[t_0, t_end]`` is cut into ``columns`` equal bins.

    ``time`` must not decrease; sample ``k`` is in bin ``⌊(t_k − t_0) / (t_end − t_0) ·
    columns⌋`` (the last sample in the last bin).  A panel's x range is ``[t_0, t_end]``
    (:func:`pixel_bins`), so each bin is one of its pixel columns.  Returns the
    indices (ascending, starting with 0) where a new bin begins; empty for no samples.
    """
    n = time.shape[0]
    if n == 0:
        return np.zeros(0, dtype=np.int64)
    t0, t1 = float(time[0]), float(time[-1])
    if not t1 > t0:
        return np.zeros(1, dtype=np.int64)
    starts = [np.zeros(1, dtype=np.int64)]
    previous = None  # the last bin of the block before: a new bin may begin at a block's start
    for lo in range(0, n, _BLOCK):
        block = time[lo : lo + _BLOCK]
        column = np.minimum(((block - t0) / (t1 - t0) * columns).astype(np.int64), columns - 1)
        if previous is not None and column[0] != previous:
            starts.append(np.array([lo], dtype=np.int64))
        starts.append(np.flatnonzero(column[1:] != column[:-1]) + 1 + lo)
        previous = column[-1]
    return np.concatenate(starts)


def _bin_blocks(starts: IntArray, n: int) -> list[tuple[int, int]]:
    """Ranges ``[a, b)`` of the bins beginning at ``starts``, about :data:`_BLOCK` samples each.

    A reduction over one range of bins needs only that range's samples: its temporaries are
    about a block long, whatever the run's length (a bin longer than a block is one range).
    """
    per_block = max(1, _BLOCK * starts.shape[0] // max(n, 1))
    return [(a, min(a + per_block, starts.shape[0])) for a in range(0, starts.shape[0], per_block)]


class Envelope(NamedTuple):
    """A curve, ``reduced`` to four points per bin (first, extreme, extreme, last; see module)."""

    time: FloatArray
    values: FloatArray
    reduced: bool = False


def envelope(time: FloatArray, values: FloatArray, starts: IntArray) -> Envelope:
    """Reduce ``values`` over the bins beginning at ``starts`` (:func:`time_bins`) to M4 points.

    Per bin: the first sample, the minimum and the maximum of its finite samples (in the
    order that makes the shorter path from the first to the last sample), and the last
    sample, each at its own time (minimum and maximum at the bin's middle time).  A
    non-finite first or last sample stays non-finite, so the curve breaks there as the full
    curve does; a bin without a finite sample is all NaN.  When the bins hold at most four
    samples each on average, nothing is gained and the curve is returned as it is.
    """
    n = values.shape[0]
    if n <= 4 * starts.shape[0]:
        return Envelope(time, values)
    ends = np.append(starts[1:], n) - 1
    low = np.empty(starts.shape[0], dtype=np.float64)
    high = np.empty(starts.shape[0], dtype=np.float64)
    for a, b in _bin_blocks(starts, n):  # a block of bins at a time (:func:`_bin_blocks`)
        lo = int(starts[a])
        chunk = values[lo : int(ends[b - 1]) + 1]
        usable = np.isfinite(chunk)
        finite = chunk if usable.all() else np.where(usable, chunk, np.nan)  # no copy if all are
        with np.errstate(invalid="ignore"):
            low[a:b] = np.fmin.reduceat(finite, starts[a:b] - lo)
            high[a:b] = np.fmax.reduceat(finite, starts[a:b] - lo)
    first, last = values[starts], values[ends]
    rising = ~(first > last)  # down to the minimum first, then up, when the bin rises
    points = np.empty((starts.shape[0], 4), dtype=np.float64)
    points[:, 0] = first
    points[:, 1] = np.where(rising, low, high)
    points[:, 2] = np.where(rising, high, low)
    points[:, 3] = last
    middle = 0.5 * (time[starts] + time[ends])
    times = np.stack([time[starts], middle, middle, time[ends]], axis=1)
    return Envelope(times.ravel(), points.ravel(), reduced=True)


def draw_curve(ax: Axes, curve: Envelope, **style: Any) -> list[Line2D]:
    """Draw ``curve`` on ``ax``: a line, or a band where it is reduced and dense.

    A reduced curve (:func:`envelope`) with over two points per pixel column is a long run:
    its zigzag through each bin's first, minimum, maximum and last sample fills the bin's
    column from minimum to maximum.  The band (:func:`_band`) fills the same columns as one
    polygon, outlined with the line's width, instead of stroking thousands of column-high
    segments: on a 10^6-sample run the three figures' 15 zigzags took 0.31 s to draw, the
    bands 0.08 s.  The line returned carries the style (the legend shows it); for a band it
    holds no points.
    """
    if not curve.reduced or curve.time.shape[0] <= 2 * pixel_columns():
        return ax.plot(curve.time, curve.values, **style)
    lines = ax.plot([], [], **style)
    _band(ax, curve, lines[0])
    return lines


DASHED_BAND_ALPHA = 0.7
"""Opacity of the band of a dashed line (the prediction over the measurement, the filter over
the smoother): a dashed zigzag of column-high segments covers its band almost wholly and hid
the curve under it, a translucent band lets it show through."""


def _band(ax: Axes, curve: Envelope, line: Line2D) -> None:
    """Fill each bin of a reduced ``curve`` over its time span from its minimum to its maximum.

    A bin without a finite value is a gap.  Colour, width, opacity and drawing order are the
    line's; the band of a dashed line is :data:`DASHED_BAND_ALPHA` opaque.  Drawn without
    antialiasing: smoothing the edges of a band a pixel column wide would only cost time.
    """
    points = curve.values.reshape(-1, 4)
    with np.errstate(invalid="ignore"):
        low = np.fmin.reduce(points, axis=1)
        high = np.fmax.reduce(points, axis=1)
    times = curve.time.reshape(-1, 4)[:, [0, 3]].ravel()
    alpha = line.get_alpha()
    if line.get_linestyle() not in ("-", "solid"):
        alpha = DASHED_BAND_ALPHA * (1.0 if alpha is None else alpha)
    ax.fill_between(
        times, np.repeat(np.nan_to_num(low), 2), np.repeat(np.nan_to_num(high), 2),
        where=np.repeat(np.isfinite(low), 2), color=line.get_color(), alpha=alpha,
        linewidth=line.get_linewidth(), antialiased=False, zorder=line.get_zorder(),
    )  # fmt: skip


class ModeRuns(NamedTuple):
    """Maximal runs of one mode in a mode sequence: samples ``start[i] .. end[i] - 1``."""

    start: IntArray
    end: IntArray
    mode: IntArray


def mode_runs(modes: IntArray) -> ModeRuns:
    """The runs of a mode sequence, from its change points (a run begins at each switch)."""
    n = modes.shape[0]
    if n == 0:
        empty = np.zeros(0, dtype=np.int64)
        return ModeRuns(empty, empty, empty)
    start = np.concatenate(([0], np.flatnonzero(modes[1:] != modes[:-1]) + 1))
    end = np.append(start[1:], n)
    return ModeRuns(start, end, modes[start])


def mode_bars(runs: ModeRuns, starts: IntArray, n_modes: int) -> list[tuple[IntArray, IntArray]]:
    """Per mode, the runs of bins (:func:`time_bins` ``starts``) where the mode occurs.

    A run covers every bin from the one holding its first sample to the one holding its
    last; the bins a mode covers (exactly those it occurs in) are merged into maximal
    ``(first bin, last bin)`` ranges, so every run lies inside a range of its mode and
    runs are joined only where they occur in the same or adjacent pixel columns.
    """
    n_bins = starts.shape[0]
    first = np.searchsorted(starts, runs.start, side="right") - 1
    last = np.searchsorted(starts, runs.end - 1, side="right") - 1
    bars = []
    for m in range(n_modes):
        mine = runs.mode == m
        cover = np.zeros(n_bins + 1, dtype=np.int64)
        np.add.at(cover, first[mine], 1)
        np.add.at(cover, last[mine] + 1, -1)
        inside = np.cumsum(cover[:-1]) > 0
        edges = np.diff(np.concatenate(([0], inside.astype(np.int8), [0])))
        bars.append((np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1))
    return bars


_READY: dict[tuple[int, float], list[tuple[Figure, list[Axes]]]] = {}
"""Empty figures made ahead by shape (:func:`prepare_figures`), each taken once by
:func:`_new_figure`."""
TICKS_AHEAD = 10
"""Major ticks made ahead per axis of a prepared figure.  Each tick is a handful of artists
(marks, grid line, labels): on the three figures of a 10^6-sample run the axes draw 8 per
axis (3 on the mode rows), and making them took 0.10-0.17 s of the plots' 0.8 s.  With them
made ahead, the three figures were drawn in 0.52-0.54 s against 0.58 s (fresh processes,
two runs each), byte for byte the same PNGs.  An axis whose locator asks for more makes the
rest when drawn."""


def figure_shapes(n_outputs: int, n_states: int, components: bool) -> list[tuple[int, float]]:
    """The ``(panels, panel height)`` of the figures :func:`write_plots` draws for a model.

    ``components``: the model describes concurrent components, whose ``modes.png`` (of
    ``unknown-mode``) has a shape that depends on the result; it is left out.
    """
    shapes = [(min(n_outputs, MAX_PANELS), 2.0), (min(n_states, MAX_PANELS), 2.0)]
    return shapes if components else [*shapes, (2, 2.4)]


def prepare_figures(shapes: Sequence[tuple[int, float]]) -> None:
    """Make the empty figures (margins, panels, shared axes, tick marks) of these shapes ahead.

    ``analyze`` does it in the thread that imports matplotlib while the estimator's compiled
    loop runs (:func:`hybridlog.report.writer.import_plotting`): 0.06-0.13 s of axes set-up
    that is then not on the plots' path, which the command waits for at its end.  A figure
    made ahead is the one :func:`_new_figure` would make, with :data:`TICKS_AHEAD` major
    ticks per axis already made (matplotlib makes them when it first draws an axis, as many
    as its locator asks for, and reuses them after); the same pixels are drawn on it.
    """
    wanted = Counter((max(n_panels, 1), panel_height) for n_panels, panel_height in shapes)
    with _MATPLOTLIB:
        for key, count in wanted.items():
            ready = _READY.setdefault(key, [])
            while len(ready) < count:  # as many as one run's plots take, however often asked
                fig, axes = _make_figure(*key)
                make_ticks_ahead(axes)
                ready.append((fig, axes))


def make_ticks_ahead(axes: Sequence[Axes]) -> None:
    """Make :data:`TICKS_AHEAD` major ticks on both axes of each of ``axes`` now.

    matplotlib makes them when it first draws an axis (each a copy of the first tick's
    properties) and reuses them after: made in a figure prepared ahead, they are not on the
    drawing's path, and the same pixels are drawn.
    """
    for ax in axes:
        ax.xaxis.get_major_ticks(TICKS_AHEAD)
        ax.yaxis.get_major_ticks(TICKS_AHEAD)


def _new_figure(n_panels: int, panel_height: float = 2.0) -> tuple[Figure, list[Axes]]:
    key = (max(n_panels, 1), panel_height)
    ready = _READY.get(key)
    return ready.pop() if ready else _make_figure(*key)


def _make_figure(n_panels: int, panel_height: float) -> tuple[Figure, list[Axes]]:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    # Fixed margins in inches rather than layout="constrained": the constrained layout
    # measured every tick label and took half of the report's writing time.
    height = 0.8 + panel_height * n_panels
    fig = Figure(figsize=(_WIDTH_IN, height))
    FigureCanvasAgg(fig)
    fig.subplots_adjust(
        left=_LEFT, right=_RIGHT, top=1.0 - 0.45 / height, bottom=0.45 / height, hspace=0.12
    )
    axes = fig.subplots(n_panels, 1, sharex=True, squeeze=False)[:, 0]
    return fig, list(axes)


def _save(fig: Figure, path: Path) -> Path:
    fig.savefig(path, dpi=_DPI, pil_kwargs={"compress_level": PNG_COMPRESS_LEVEL})
    return path


def _panel_title(fig: Figure, what: str, total: int) -> None:
    if total > MAX_PANELS:
        fig.suptitle(f"{what} (first {MAX_PANELS} of {total})")
    else:
        fig.suptitle(what)


def _empty(fig: Figure, ax: Axes, text: str) -> None:
    ax.text(0.5, 0.5, text, ha="center", va="center", transform=ax.transAxes)
    ax.set_axis_off()


def _panels(what: str, names: tuple[str, ...]) -> tuple[Figure, list[Axes], tuple[str, ...]]:
    """A figure titled ``what`` with one panel per name drawn (at most :data:`MAX_PANELS`)."""
    drawn = names[:MAX_PANELS]
    fig, axes = _new_figure(len(drawn))
    _panel_title(fig, what, len(names))
    return fig, axes, drawn


def pixel_bins(time: FloatArray, ax: Axes) -> IntArray:
    """The bins of a run's samples (:func:`time_bins`), one per pixel column of ``ax``.

    Sets the x range of ``ax`` (and of the axes sharing it) to the run's time span exactly,
    without matplotlib's margins, so that the bins are the panel's pixel columns: a band
    (:func:`draw_curve`) then paints the columns the curve reaches and no other.
    """
    t0, t1 = float(time[0]), float(time[-1])
    if t1 > t0:
        ax.set_xlim(t0, t1)
    return time_bins(time, pixel_columns())


def plot_outputs(result: EstimationResult, signals: AlignedSignals, path: Path) -> Path:
    """Draw measured outputs against their one-step-ahead predictions.

    Writes ``path`` (PNG) and returns it; the measured outputs come from ``signals``.
    """
    title = "Outputs: measured vs one-step-ahead prediction"
    fig, axes, names = _panels(title, result.output_names)
    if not names:
        _empty(fig, axes[0], "no outputs")
        return _save(fig, path)
    bins = pixel_bins(result.time, axes[0])
    for j, (ax, y) in enumerate(zip(axes, names, strict=True)):
        draw_curve(
            ax,
            envelope(result.time, signals.outputs[:, j], bins),
            lw=0.8,
            color="0.3",
            label=f"{y} measured",
        )
        draw_curve(
            ax,
            envelope(result.time, result.output_predictions[:, j], bins),
            lw=0.8,
            color="tab:blue",
            ls="--",
            label=f"{y} predicted",
        )
        ax.set_ylabel(y)
        ax.legend(loc="upper right", fontsize="small")
    axes[-1].set_xlabel("t (s)")
    return _save(fig, path)


def _draw_runs(
    ax: Axes,
    time: FloatArray,
    modes: IntArray,
    bins: IntArray,
    n_modes: int,
    *,
    height: float,
    color: str,
    label: str,
) -> None:
    """One bar per range of pixel columns a mode occupies, on the mode's row."""
    edges = np.append(time[bins], time[-1])
    labelled = False
    for m, (first, last) in enumerate(mode_bars(mode_runs(modes), bins, n_modes)):
        widths = edges[last + 1] - edges[first]
        spans = list(zip(edges[first].tolist(), widths.tolist(), strict=True))
        if spans:
            ax.broken_barh(
                spans, (m - height / 2, height), color=color, label=None if labelled else label
            )
            labelled = True


def _mode_label(result: EstimationResult) -> str:
    """The legend of the estimated mode: ``estimated``, ``smoothed``, ``viterbi`` or ``kbest``."""
    post = result.post_processing
    if post is None:
        return "estimated"
    return "smoothed" if post.mode_sequence == "argmax" else post.mode_sequence


def plot_modes(result: EstimationResult, signals: AlignedSignals, path: Path) -> Path:
    """Draw the estimated mode timeline (vs truth when known) and the mode probabilities.

    Writes ``path`` (PNG) and returns it; the true mode comes from ``signals``.  A result
    with per-component mode columns (``unknown-mode``: joint assignments as modes) gets
    :func:`plot_components` instead.
    """
    components = plot_components(result, path)
    if components is not None:
        return components
    fig, (ax_mode, ax_prob) = _new_figure(2, panel_height=2.4)
    fig.suptitle("Modes")
    ids = [str(m) for m in result.mode_ids]
    if result.n_samples == 0:
        _empty(fig, ax_mode, "no samples")
        _empty(fig, ax_prob, "no samples")
        return _save(fig, path)
    bins = pixel_bins(result.time, ax_mode)
    n_modes = len(ids)
    if signals.truth_modes is not None:
        truth, t = signals.truth_modes, result.time
        _draw_runs(ax_mode, t, truth, bins, n_modes, height=0.8, color="0.8", label="true")
    filtered = None if result.post_processing is None else result.post_processing.filtered
    _draw_runs(
        ax_mode, result.time, result.modes, bins, n_modes, height=0.3, color="tab:red",
        label=_mode_label(result),
    )  # fmt: skip
    if filtered is not None:
        _draw_runs(
            ax_mode, result.time, filtered.modes, bins, n_modes, height=0.08, color="k",
            label="filtered",
        )  # fmt: skip
    ax_mode.set_yticks(range(n_modes), ids)
    ax_mode.set_ylim(-0.5, n_modes - 0.5)
    ax_mode.set_ylabel("mode")
    ax_mode.legend(loc="upper right", fontsize="small")
    for j, m in enumerate(ids):
        (line,) = draw_curve(
            ax_prob,
            envelope(result.time, result.mode_probabilities[:, j], bins),
            lw=0.8,
            label=f"p({m})",
        )
        if filtered is not None:
            draw_curve(
                ax_prob,
                envelope(result.time, filtered.mode_probabilities[:, j], bins),
                lw=0.5,
                ls="--",
                color=line.get_color(),
                label=f"p({m}) filtered",
            )
    ax_prob.set_ylabel("probability")
    ax_prob.set_xlabel("t (s)")
    ax_prob.legend(loc="upper right", fontsize="small", ncol=min(n_modes, 6))
    return _save(fig, path)


def _sigma_band(
    time: FloatArray, mean: FloatArray, variance: FloatArray, bins: IntArray
) -> tuple[FloatArray, FloatArray, FloatArray] | None:
    """The ±2σ band of ``mean`` (times, lower and upper edge); ``None`` where it has none.

    ``mean ± 2·sqrt(max(variance, 0))`` where both are finite (``max`` keeps NaN, no
    variance defined, and clips tiny negative round-off), NaN elsewhere.  A long run gets
    per bin its lowest and highest edge over the bin's time span, worked out a block of bins
    at a time (:func:`_bin_blocks`): the temporaries are a block long, not the run's.
    """
    n = time.shape[0]
    reduce = n > 4 * bins.shape[0]
    blocks = _bin_blocks(bins, n) if reduce else [(0, bins.shape[0])]
    ends = np.append(bins[1:], n) - 1
    lows: list[FloatArray] = []
    highs: list[FloatArray] = []
    banded = False
    for a, b in blocks:
        lo, hi = (int(bins[a]), int(ends[b - 1]) + 1) if reduce else (0, n)
        two_sigma = np.maximum(variance[lo:hi], 0.0)
        np.sqrt(two_sigma, out=two_sigma)
        two_sigma *= 2.0
        band = np.isfinite(two_sigma) & np.isfinite(mean[lo:hi])
        banded = banded or bool(band.any())
        low = mean[lo:hi] - two_sigma
        high = np.add(mean[lo:hi], two_sigma, out=two_sigma)
        np.invert(band, out=band)
        low[band] = np.nan
        high[band] = np.nan
        if reduce:
            with np.errstate(invalid="ignore"):
                low = np.fmin.reduceat(low, bins[a:b] - lo)
                high = np.fmax.reduceat(high, bins[a:b] - lo)
        lows.append(low)
        highs.append(high)
    if not banded:
        return None
    if not reduce:
        return time, lows[0], highs[0]
    t = np.stack([time[bins], time[ends]], axis=1).ravel()
    return t, np.repeat(np.concatenate(lows), 2), np.repeat(np.concatenate(highs), 2)


def plot_states(result: EstimationResult, signals: AlignedSignals, path: Path) -> Path:
    """Draw state estimates with ±2σ bands, against the true states when known.

    Writes ``path`` (PNG) and returns it; the true states come from ``signals``.
    """
    fig, axes, names = _panels("States: estimate ±2σ vs truth", result.state_names)
    if not names:
        _empty(fig, axes[0], "no states")
        return _save(fig, path)
    bins = pixel_bins(result.time, axes[0])
    for i, (ax, x) in enumerate(zip(axes, names, strict=True)):
        mean = result.state_means[:, i]
        sigma_band = _sigma_band(result.time, mean, result.state_variances[:, i], bins)
        if sigma_band is not None:
            t_band, lo, hi = sigma_band
            ax.fill_between(
                t_band, np.nan_to_num(lo), np.nan_to_num(hi), where=np.isfinite(lo),
                color="tab:blue", alpha=0.2, label="±2σ",
            )  # fmt: skip
        if signals.truth_states is not None and np.isfinite(signals.truth_states[:, i]).any():
            draw_curve(
                ax,
                envelope(result.time, signals.truth_states[:, i], bins),
                lw=1.5,
                color="0.5",
                label="true",
            )
        smoothed = result.post_processing is not None and result.post_processing.smoothing
        draw_curve(
            ax,
            envelope(result.time, mean, bins),
            lw=0.8,
            color="tab:blue",
            label="smoothed" if smoothed else "estimate",
        )
        if result.post_processing is not None:
            draw_curve(
                ax,
                envelope(result.time, result.post_processing.filtered.state_means[:, i], bins),
                lw=0.5,
                ls="--",
                color="k",
                label="filtered",
            )
        ax.set_ylabel(x)
        ax.legend(loc="upper right", fontsize="small")
    axes[-1].set_xlabel("t (s)")
    return _save(fig, path)


COMPONENT_PREFIX = "mode."
"""Timeline columns ``mode.<component>`` hold a ``[components]`` model's per-component modes."""

UNKNOWN_LABEL = "unknown"
UNKNOWN_COLOR = "tab:red"
KNOWN_COLOR = "tab:blue"


def plot_components(result: EstimationResult, path: Path) -> Path | None:
    """Draw one mode timeline per component and the joint assignment (paper 002).

    For results with labelled ``mode.<component>`` timeline columns (``unknown-mode``); the
    ``unknown`` mode is drawn in its own colour.  The last panel shows the estimated joint
    assignment over the assignments it visited.  Returns ``None`` (nothing written) when the
    result has no such columns.
    """
    columns = [
        c for c in result.timeline_columns if c.name.startswith(COMPONENT_PREFIX) and c.labels
    ]
    if not columns or result.n_samples == 0:
        return None
    visited = np.unique(result.modes)
    fig, axes = _new_figure(len(columns) + 1, panel_height=max(1.0, 0.35 * len(visited)))
    fig.suptitle("Modes per component and joint assignment")
    bins = pixel_bins(result.time, axes[0])
    for ax, column in zip(axes, columns, strict=False):
        values = np.asarray(column.values, dtype=np.int64)
        n_labels = len(column.labels)
        for label_index, label in enumerate(column.labels):
            only = np.where(values == label_index, label_index, n_labels)
            color = UNKNOWN_COLOR if label == UNKNOWN_LABEL else KNOWN_COLOR
            edges = np.append(result.time[bins], result.time[-1])
            bars = mode_bars(mode_runs(only), bins, n_labels)[label_index]
            first, last = bars
            spans = list(
                zip(edges[first].tolist(), (edges[last + 1] - edges[first]).tolist(), strict=True)
            )
            if spans:
                ax.broken_barh(spans, (label_index - 0.35, 0.7), color=color)
        ax.set_yticks(range(n_labels), column.labels)
        ax.set_ylim(-0.5, n_labels - 0.5)
        ax.set_ylabel(column.name.removeprefix(COMPONENT_PREFIX))
    joint = axes[-1]
    rank = {int(m): i for i, m in enumerate(visited)}
    rows = np.array([rank[int(m)] for m in result.modes], dtype=np.int64)
    _draw_runs(
        joint, result.time, rows, bins, len(visited), height=0.6, color="0.3", label="estimated"
    )
    joint.set_yticks(
        range(len(visited)), [result.mode_ids[int(m)] for m in visited], fontsize="x-small"
    )
    joint.set_ylim(-0.5, len(visited) - 0.5)
    joint.set_ylabel("joint")
    joint.set_xlabel("t (s)")
    return _save(fig, path)


def write_plots(plot_dir: Path, result: EstimationResult, signals: AlignedSignals) -> list[Path]:
    """Write ``outputs.png``, ``modes.png`` and ``states.png`` into a directory.

    For a result with per-component mode columns (``unknown-mode``) ``modes.png`` is
    :func:`plot_components`.

    Parameters
    ----------
    plot_dir:
        Existing directory to write into.
    result:
        The estimation result.
    signals:
        The aligned signals it was computed from.

    Returns
    -------
    list of pathlib.Path
        The files written.

    """
    with _MATPLOTLIB:
        return [
            plot_outputs(result, signals, plot_dir / "outputs.png"),
            plot_modes(result, signals, plot_dir / "modes.png"),
            plot_states(result, signals, plot_dir / "states.png"),
        ]
