"""What the plots of one run draw, reduced from the result a chunk of rows at a time.

The figures (:mod:`hybridlog.report.plots`) are drawn from a :class:`PlotData`: a small,
picklable value of NumPy arrays, strings and numbers, whose size does not grow with the run
beyond one reduction per pixel column.  It is made here with NumPy only (no matplotlib), so
the process that analyses a long run can reduce it and leave the drawing to another process
that receives only the reduced data.  :class:`PlotReducer` takes the estimator's result in
consecutive chunks of rows, as a streamed analysis yields it (a chunk's arrays may be
overwritten by the next chunk: whatever is kept is copied), beside the aligned signals of
the whole run; :func:`reduce_result` is the same for a whole result.

A PNG cannot show more than one value range per pixel column, so long runs are reduced to
what it can show before drawing (:func:`envelope`): the samples are cut into time bins, one
per pixel column of the panel (whose x range is the run's time span: :class:`PixelBins`),
and each bin is drawn through its first sample, its minimum, its maximum and its last
sample (the "M4" reduction: every extreme the full curve reaches in a column is kept, so
the picture is the same).  The mode timelines are drawn from their runs (:func:`mode_runs`),
the runs of each mode merged where they touch the same pixel column (:func:`mode_bars`): a
run shorter than a pixel still shows as one pixel column.  At most :data:`MAX_PANELS`
outputs/states are drawn, so only those are reduced.

Chunks are reduced exactly as the whole run is: the bins are cut once, from the whole run's
sample times; a bin cut by a chunk's boundary gets the minimum and maximum of both parts,
its first sample from the earlier chunk and its last from the later one (:class:`CurveReducer`,
:class:`BandReducer`); a mode's pixel columns in one chunk are joined to those of the chunks
before where they touch, as the run that continues across the boundary joins them
(:class:`BarsReducer`).  A curve short enough not to be reduced is kept whole.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from hybridlog.estimators.result import EstimationResult, TimelineColumn
from hybridlog.signals import NO_TRUE_MODE, AlignedSignals, ComponentTruth, FloatArray, IntArray
from hybridlog.times import format_time

__all__ = [
    "COMPONENT_PREFIX",
    "FIGURE_DPI",
    "FIGURE_WIDTH_IN",
    "MAX_PANELS",
    "PANEL_LEFT",
    "PANEL_RIGHT",
    "BandReducer",
    "Bars",
    "BarsReducer",
    "ComponentTimeline",
    "Components",
    "CurveReducer",
    "Envelope",
    "ModeRuns",
    "ModeTimelines",
    "OutputCurves",
    "PixelBins",
    "PlotData",
    "PlotReducer",
    "SigmaBand",
    "StateCurves",
    "column_maxima",
    "envelope",
    "mode_bars",
    "mode_runs",
    "pixel_columns",
    "plain_text",
    "reduce_result",
    "time_bins",
    "time_label",
    "time_origin",
    "time_unit",
]

MAX_PANELS = 16
"""Outputs and states drawn (and reduced) at most, one panel each."""
FIGURE_DPI = 100
FIGURE_WIDTH_IN = 10.0
PANEL_LEFT, PANEL_RIGHT = 0.09, 0.98
"""The panels' horizontal extent as fractions of the figure's width: with the width and the
resolution, it fixes the pixel columns the curves are reduced to (:func:`pixel_columns`)."""
COMPONENT_PREFIX = "mode."
"""Timeline columns ``mode.<component>`` hold a ``[components]`` model's per-component modes."""


def plain_text(text: str) -> str:
    r"""``text`` (a mode id, a name from a model, a log path) as matplotlib shows it, as it is.

    matplotlib reads a text with an even number of unescaped ``$`` as mathtext: the mode
    ``$x_1$`` was drawn as x₁ (beside a mode ``x_1``, two identical tick labels), and one
    mathtext cannot parse (``$\frac$``, ``$\undefined{$``) raised while the figure was
    saved, which lost the whole report.  Every ``$`` written ``\$`` is a text without math,
    shown with the dollars as they were (matplotlib unescapes ``\$`` there and nothing else).
    Every label, tick label and title of user text in a figure goes through this.

    A character the figures' fonts cannot draw (``閉``, ``🚰``: matplotlib's fonts have no
    CJK or emoji) is written as its escape, ``\u9589``: drawn, it was an empty box, and two
    ids of as many such characters looked the same (:mod:`hybridlog.report.glyphs`, which
    loads matplotlib's fonts, is imported only for text that is not ASCII or holds ``\u`` or
    ``\U``); where it writes an escape or the text holds ``\u`` or ``\U``, its backslashes are
    written twice, so that no text is drawn as another's escape (``\u9589`` as ``\\u9589``).
    """
    if not text.isascii() or "\\u" in text or "\\U" in text:
        from hybridlog.report.glyphs import escape_undrawable

        text = escape_undrawable(text)
    return text.replace("$", r"\$")


RELATIVE_FROM_S = 1e6
"""A run starting this far from 0 (seconds, either way) is drawn from its first sample
(:func:`time_origin`): a log stamped in Unix time (1.7e9 s) had x ticks ``1.7000``,
``1.7002``, ... over a ``1e9`` in the corner, which placed a switch no closer than 200,000 s."""
RELATIVE_SPAN_RATIO = 1e4
"""A run starting this many of its spans from 0 is drawn from its first sample too: a 10 ms
excerpt at t = 500 s needs seven digits a tick, which matplotlib wrote as an offset."""


def time_origin(start: float, end: float) -> float:
    """The time the figures' x axes count from: ``0.0``, or ``start`` for absolute times.

    ``start`` when it is at least :data:`RELATIVE_FROM_S` or :data:`RELATIVE_SPAN_RATIO`
    spans ``end - start`` from 0, whose ticks would not read as times (see those); the
    axis is then labelled with it (:func:`time_label`).  The drawn times are ``t - start``,
    exact for float times within a factor of two of ``start`` (Sterbenz), and so within the
    run's reduction to pixel columns.
    """
    if abs(start) >= RELATIVE_FROM_S or abs(start) >= RELATIVE_SPAN_RATIO * (end - start):
        return start
    return 0.0


SHORT_SPAN_S = 1e-3
"""A time axis spanning less than this (seconds) counts in a smaller unit (:func:`time_unit`)."""
_PREFIXES = {0: "", -3: "m", -6: "µ", -9: "n", -12: "p", -15: "f"}
"""SI prefixes of the time axes' units, by the power of ten of a second they stand for."""


def time_unit(span: float) -> int:
    """The power of ten of a second that a time axis spanning ``span`` seconds counts in.

    ``0`` (seconds) for a span of :data:`SHORT_SPAN_S` or more; else the SI prefix's
    (ms, µs, ns, ps, fs) in which the span reads as at least 1: matplotlib writes a tick
    below 1e-8 as 0, so every tick of a run of 300 samples 1 ps apart read ``0.00000000000``.
    """
    if not span > 0.0 or span >= SHORT_SPAN_S:
        return 0
    return max(min(_PREFIXES), 3 * math.floor(math.log10(span) / 3))


def time_label(origin: float, unit: int = 0) -> str:
    """The x label of times drawn from ``origin`` (:func:`time_origin`), in ``10**unit`` s.

    ``unit`` is :func:`time_unit`'s power of ten (0: seconds); ``origin`` is in seconds.
    """
    name = f"{_PREFIXES[unit]}s"
    if origin == 0.0:
        return f"t ({name})"
    return f"t − t₀ ({name}), t₀ = {format_time(origin)} s"


_BLOCK = 1 << 16
"""Samples per block of the reductions (:func:`time_bins` and the reducers' ``add``): their
temporaries are 0.5 MB, not 8 MB per array of a 10^6-sample run.  The plots are reduced
beside the metrics and tables, so what they hold adds to the run's peak."""


def pixel_columns() -> int:
    """Width in pixels of a panel's plotting area: the bins of :func:`time_bins`."""
    return int(np.ceil(FIGURE_WIDTH_IN * FIGURE_DPI * (PANEL_RIGHT - PANEL_LEFT)))


def time_bins(time: FloatArray, columns: int) -> IntArray:
    """Start index of each non-empty bin when ``[t_0, t_end]`` is cut into ``columns`` equal bins.

    ``time`` must not decrease; sample ``k`` is in bin ``⌊(t_k − t_0) / (t_end − t_0) ·
    columns⌋`` (the last sample in the last bin).  A panel's x range is ``[t_0, t_end]``
    (:attr:`PixelBins.span`), so each bin is one of its pixel columns.  Returns the
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


class PixelBins:
    """The bins of a run's samples (``starts``: :func:`time_bins`) and the times drawn at them.

    Made once per run from its whole ``time``; every curve of the run is reduced over these
    bins, and the time arrays below are shared by all of them (one copy in a pickled
    :class:`PlotData`).

    Attributes
    ----------
    time:
        The run's sample times.
    starts, ends:
        Index of each bin's first and last sample.
    reduced:
        Whether the curves are reduced (:func:`envelope`): not when the bins hold at most
        four samples each on average, where nothing is gained.
    origin:
        The time the drawn times below count from (:func:`time_origin`): ``0.0``, or the
        first sample's time for a run in absolute time.
    span:
        ``(t_0, t_end)``, the panels' x range; ``None`` for no samples.  Unreduced, the
        end is one step (the last sampling interval) past the last sample, the time its
        mode is drawn over.
    edges:
        The time at each bin's start, then the run's end (``span``'s): the mode bars'
        edges (:func:`mode_bars`).
    curve_time:
        The times of a reduced curve's four points per bin (first sample, the bin's middle
        twice, last sample), or ``time``.
    band_time:
        The time of each bin's first and last sample (a reduced ±2σ band), or ``time``.
    """

    def __init__(self, time: FloatArray, starts: IntArray) -> None:
        n = time.shape[0]
        self.time = time
        self.starts = starts
        self.ends: IntArray = np.append(starts[1:], n) - 1
        self.reduced = n > 4 * starts.shape[0]
        end = time[-1:]
        if not self.reduced and n >= 2 and time[-1] > time[-2]:
            # A sample's mode is drawn up to the next sample: the last one's, up to the end,
            # had no width, and a switch at the last sample was not drawn at all (a third
            # of a 3-sample log).  It holds for one step more, like the one before it.
            end = time[-1:] + (time[-1] - time[-2])
        self.origin = time_origin(float(time[0]), float(end[0])) if n else 0.0
        drawn = time - self.origin if self.origin else time
        end = end - self.origin
        self.span = (float(drawn[0]), float(end[0])) if n else None
        self.edges: FloatArray = np.append(drawn[starts], end)
        self.curve_time = drawn
        self.band_time = drawn
        if self.reduced:
            first, last = drawn[starts], drawn[self.ends]
            middle = 0.5 * (first + last)
            self.curve_time = np.stack([first, middle, middle, last], axis=1).ravel()
            self.band_time = np.stack([first, last], axis=1).ravel()

    @classmethod
    def of_run(cls, time: FloatArray) -> PixelBins:
        """The bins of a run whose panels span ``time``: one per pixel column."""
        return cls(time, time_bins(time, pixel_columns()))

    def spanned(self, start: int, count: int) -> tuple[int, int]:
        """The bins ``[a, b)`` that hold samples ``start .. start + count - 1`` (``count > 0``)."""
        first = int(np.searchsorted(self.starts, start, side="right")) - 1
        last = int(np.searchsorted(self.starts, start + count - 1, side="right"))
        return first, last


def _blocks(count: int) -> range:
    """Starts of the blocks of at most :data:`_BLOCK` rows that a chunk is reduced in."""
    return range(0, count, _BLOCK)


def _local_starts(bins: PixelBins, a: int, b: int, start: int) -> IntArray:
    """Where bins ``a .. b - 1`` begin in a block from sample ``start`` (the first at 0).

    The first bin may have begun in an earlier block: its part in this block begins at 0.
    """
    local = bins.starts[a:b] - start
    local[0] = 0
    return local


class Envelope(NamedTuple):
    """A curve, ``reduced`` to four points per bin (first, extreme, extreme, last; see module)."""

    time: FloatArray
    values: FloatArray
    reduced: bool = False


class CurveReducer:
    """A curve's :class:`Envelope` over ``bins``, from consecutive pieces of its samples.

    Per bin: the first sample, the minimum and the maximum of its finite samples (in the
    order that makes the shorter path from the first to the last sample), and the last
    sample, each at its own time (minimum and maximum at the bin's middle time).  A
    non-finite first or last sample stays non-finite, so the curve breaks there as the full
    curve does; a bin without a finite sample is all NaN.  A curve the bins do not reduce
    is kept whole.
    """

    def __init__(self, bins: PixelBins) -> None:
        self._bins = bins
        self._whole = np.full(0 if bins.reduced else bins.time.shape[0], np.nan)
        n_bins = bins.starts.shape[0] if bins.reduced else 0
        self._first = np.full(n_bins, np.nan)
        self._low = np.full(n_bins, np.nan)
        self._high = np.full(n_bins, np.nan)
        self._last = np.full(n_bins, np.nan)

    def add(self, values: FloatArray, start: int) -> None:
        """Take samples ``start .. start + len(values) - 1`` of the curve (copied or reduced)."""
        bins = self._bins
        if not bins.reduced:
            self._whole[start : start + values.shape[0]] = values
            return
        for lo in _blocks(values.shape[0]):
            # a column of a chunk's 2-D array is strided: reduced in a contiguous copy, the
            # reductions take a third of the time (0.5 MB, as the block's other temporaries)
            block = np.ascontiguousarray(values[lo : lo + _BLOCK])
            at = start + lo
            a, b = bins.spanned(at, block.shape[0])
            usable = np.isfinite(block)
            finite = (
                block if usable.all() else np.where(usable, block, np.nan)
            )  # no copy if all are
            local = _local_starts(bins, a, b, at)
            with np.errstate(invalid="ignore"):
                np.fmin(self._low[a:b], np.fmin.reduceat(finite, local), out=self._low[a:b])
                np.fmax(self._high[a:b], np.fmax.reduceat(finite, local), out=self._high[a:b])
            begun = bins.starts[a:b] >= at  # the bins whose first sample is in this block
            self._first[a:b][begun] = block[local[begun]]
            ended = bins.ends[a:b] < at + block.shape[0]  # and whose last is
            self._last[a:b][ended] = block[bins.ends[a:b][ended] - at]

    def finish(self) -> Envelope:
        """The curve's envelope, once every sample was added."""
        bins = self._bins
        if not bins.reduced:
            return Envelope(bins.curve_time, self._whole)
        first, last = self._first, self._last
        rising = ~(first > last)  # down to the minimum first, then up, when the bin rises
        points = np.empty((first.shape[0], 4), dtype=np.float64)
        points[:, 0] = first
        points[:, 1] = np.where(rising, self._low, self._high)
        points[:, 2] = np.where(rising, self._high, self._low)
        points[:, 3] = last
        return Envelope(bins.curve_time, points.ravel(), reduced=True)


def envelope(values: FloatArray, bins: PixelBins) -> Envelope:
    """Reduce a whole curve over ``bins`` to M4 points (:class:`CurveReducer`)."""
    reducer = CurveReducer(bins)
    reducer.add(values, 0)
    return reducer.finish()


def column_maxima(curve: Envelope, edges: FloatArray) -> FloatArray:
    """The largest value of ``curve`` in each pixel column: one cell per column of a heat map.

    ``edges`` are the columns' edges (:attr:`PixelBins.edges`, :attr:`PlotData.edges`), the
    bins ``curve`` was reduced over.  A reduced curve's four points per bin hold the bin's
    maximum (:class:`CurveReducer`); a curve kept whole (at most four samples a column on
    average) is reduced here over the same bins, found from their first samples' times.
    NaN where the column holds no finite value.

    The maximum, not the mean, as everything else the figures draw per column: a mode that
    was probable for a few samples of a column holding a thousand (a 10^6-sample run on
    some 900 columns) shows there, as its bar in the mode panel does (a run shorter than a
    pixel still takes one column) and as its curve's band reaches its peak; a mean would
    dilute it a thousandfold and hide the very switches the figure is looked at for.  The
    cells of a column may then sum to more than 1: where the mode changed within it.
    """
    n_columns = edges.shape[0] - 1
    if curve.reduced:
        points = curve.values.reshape(n_columns, 4)
        return np.fmax.reduce(points, axis=1)  # type: ignore[no-any-return]
    if n_columns <= 0 or curve.values.shape[0] == 0:
        return np.full(max(n_columns, 0), np.nan)
    # each column from its first sample: the first of its time (a time is in one column)
    starts = np.searchsorted(curve.time, edges[:-1], side="left")
    return np.fmax.reduceat(curve.values, starts)


class SigmaBand(NamedTuple):
    """The ±2σ band of a state estimate: times and lower and upper edges, NaN outside it."""

    time: FloatArray
    low: FloatArray
    high: FloatArray


class BandReducer:
    """The ±2σ band of an estimate over ``bins``, from consecutive pieces of its samples.

    ``mean ± 2·sqrt(max(variance, 0))`` where both are finite (``max`` keeps NaN, no
    variance defined, and clips tiny negative round-off), NaN elsewhere.  A long run gets
    per bin its lowest and highest edge over the bin's time span (drawn from the bin's first
    to its last sample's time); a short one is kept whole.
    """

    def __init__(self, bins: PixelBins) -> None:
        self._bins = bins
        size = bins.starts.shape[0] if bins.reduced else bins.time.shape[0]
        self._low = np.full(size, np.nan)
        self._high = np.full(size, np.nan)
        self._banded = False

    def add(self, mean: FloatArray, variance: FloatArray, start: int) -> None:
        """Take samples ``start .. start + len(mean) - 1`` of the estimate and its variance."""
        bins = self._bins
        for lo in _blocks(mean.shape[0]):
            at = start + lo
            part = np.ascontiguousarray(mean[lo : lo + _BLOCK])  # as CurveReducer's block
            two_sigma = np.maximum(variance[lo : lo + _BLOCK], 0.0)
            np.sqrt(two_sigma, out=two_sigma)
            two_sigma *= 2.0
            band = np.isfinite(two_sigma) & np.isfinite(part)
            self._banded = self._banded or bool(band.any())
            low = part - two_sigma
            high = np.add(part, two_sigma, out=two_sigma)
            np.invert(band, out=band)
            low[band] = np.nan
            high[band] = np.nan
            if not bins.reduced:
                self._low[at : at + part.shape[0]] = low
                self._high[at : at + part.shape[0]] = high
                continue
            a, b = bins.spanned(at, part.shape[0])
            local = _local_starts(bins, a, b, at)
            with np.errstate(invalid="ignore"):
                np.fmin(self._low[a:b], np.fmin.reduceat(low, local), out=self._low[a:b])
                np.fmax(self._high[a:b], np.fmax.reduceat(high, local), out=self._high[a:b])

    def finish(self) -> SigmaBand | None:
        """The band, once every sample was added; ``None`` where the estimate has none."""
        if not self._banded:
            return None
        if not self._bins.reduced:
            return SigmaBand(self._bins.band_time, self._low, self._high)
        low, high = np.repeat(self._low, 2), np.repeat(self._high, 2)
        return SigmaBand(self._bins.band_time, low, high)


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


Bars = tuple[tuple[IntArray, IntArray], ...]
"""Per mode, the ``(first bin, last bin)`` ranges of the pixel columns it occupies
(:func:`mode_bars`)."""


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


class BarsReducer:
    """The :func:`mode_bars` of a mode sequence over ``bins``, from consecutive pieces of it.

    Each piece's runs give its bars over the bins it spans; a mode's first bar in a piece
    joins its last bar before where they share or touch a pixel column (a run that continues
    across the pieces' boundary, or runs a pixel column apart), as over the whole sequence.
    Only the bars are kept: at most one per pixel column and mode, however many runs.
    """

    def __init__(self, bins: PixelBins, n_modes: int) -> None:
        self._bins = bins
        self._first: list[list[int]] = [[] for _ in range(n_modes)]
        self._last: list[list[int]] = [[] for _ in range(n_modes)]

    def add(self, modes: IntArray, start: int) -> None:
        """Take the modes of samples ``start .. start + len(modes) - 1``."""
        for lo in _blocks(modes.shape[0]):
            at = start + lo
            block = modes[lo : lo + _BLOCK]
            a, b = self._bins.spanned(at, block.shape[0])
            runs = mode_runs(block)
            runs = ModeRuns(runs.start + at, runs.end + at, runs.mode)
            bars = mode_bars(runs, self._bins.starts[a:b], len(self._first))
            for (first, last), kept_first, kept_last in zip(
                bars, self._first, self._last, strict=True
            ):
                if not first.size:
                    continue
                new_first, new_last = (first + a).tolist(), (last + a).tolist()
                if kept_last and new_first[0] <= kept_last[-1] + 1:
                    kept_last[-1] = new_last[0]  # the bar continues
                    new_first, new_last = new_first[1:], new_last[1:]
                kept_first.extend(new_first)
                kept_last.extend(new_last)

    def finish(self) -> Bars:
        """The bars of each mode, once every sample was added."""
        return tuple(
            (np.array(first, dtype=np.int64), np.array(last, dtype=np.int64))
            for first, last in zip(self._first, self._last, strict=True)
        )


class OutputCurves(NamedTuple):
    """One panel of ``outputs.png``: the measured output and its one-step-ahead prediction.

    ``explained``: of a result with ``post_processing``, the output its offline estimate
    explains, ``h_q̂(k)(x̂(k|N), u(k))`` (:mod:`hybridlog.estimators.explained`: an
    a-posteriori fit, not a prediction); ``None`` otherwise, or where the result does not
    carry it.
    """

    name: str
    measured: Envelope
    predicted: Envelope
    explained: Envelope | None = None


class StateCurves(NamedTuple):
    """One panel of ``states.png``: the estimate, its ±2σ band, the truth and the filter's.

    ``band`` is ``None`` where no variance is defined, ``truth`` where the log has no finite
    true value of the state, ``filtered`` for a result without ``post_processing`` or whose
    pass left the filter's estimate of the state as it was (the Viterbi path alone).
    """

    name: str
    band: SigmaBand | None
    truth: Envelope | None
    estimate: Envelope
    filtered: Envelope | None


class ModeTimelines(NamedTuple):
    """``modes.png``: the mode timelines as bars, and the mode probabilities.

    Attributes
    ----------
    mode_ids:
        The model's modes, one row each.
    label:
        The legend of the estimated mode: ``estimated``, ``smoothed``, ``viterbi`` or
        ``kbest``.
    estimated, truth, filtered:
        The bars of the estimated mode, of the true one (``None`` when unknown), and of the
        causal filter's own (``None`` without ``post_processing``).
    probabilities, filtered_probabilities:
        One curve per mode; the filter's are ``None`` without ``post_processing`` or where
        the pass left the filter's probabilities as they were (``viterbi``, ``kbest``
        without ``smooth``).
    """

    mode_ids: tuple[str, ...]
    label: str
    estimated: Bars
    truth: Bars | None
    filtered: Bars | None
    probabilities: tuple[Envelope, ...]
    filtered_probabilities: tuple[Envelope, ...] | None


class ComponentTimeline(NamedTuple):
    """The bars of one component's modes (its ``mode.<component>`` column), one row per label.

    ``labels`` are the column's, then those of the log's true modes of the component that
    the column does not have; ``truth`` the bars of the true mode (``None`` when the log has
    none), ``filtered`` those of the causal filter's own column (``None`` without
    ``post_processing``).
    """

    name: str
    labels: tuple[str, ...]
    bars: Bars
    truth: Bars | None = None
    filtered: Bars | None = None


class Components(NamedTuple):
    """``modes.png`` of a ``[components]`` result: a timeline per component, and the joint one.

    ``joint_ids`` are the joint assignments the estimate or the causal filter visited (in
    the model's order), ``joint`` the estimate's bars of them, ``joint_filtered`` the
    filter's (``None`` without ``post_processing``); ``label`` the estimate's legend, as
    :attr:`ModeTimelines.label`.
    """

    columns: tuple[ComponentTimeline, ...]
    joint_ids: tuple[str, ...]
    joint: Bars
    joint_filtered: Bars | None = None
    label: str = "estimated"


@dataclass(frozen=True)
class PlotData:
    """Everything the three figures of a run draw, reduced (see module); picklable.

    Attributes
    ----------
    n_samples:
        Samples of the run.
    time_origin:
        The time every time below counts from (:func:`time_origin`; the x label says it,
        :func:`time_label`).
    span:
        ``(t_0, t_end)``: the panels' x range; ``None`` for no samples.
    edges:
        Time of each pixel column's first sample, then the run's end: the bars' edges.
    output_names, state_names:
        All outputs and states (the figure's title says how many of them are drawn).
    outputs, states:
        One panel each, for at most :data:`MAX_PANELS` of them.
    state_label:
        The legend of the state estimate: ``estimate`` or ``smoothed``.
    modes:
        The mode timelines, a ``[components]`` result's per-component ones, or ``None``
        for no samples.
    explained_label:
        Which estimate the outputs' ``explained`` curves are of: ``smoothed``, ``viterbi``
        or ``kbest`` (``""`` without them).
    """

    n_samples: int
    time_origin: float
    span: tuple[float, float] | None
    edges: FloatArray
    output_names: tuple[str, ...]
    outputs: tuple[OutputCurves, ...]
    state_names: tuple[str, ...]
    state_label: str
    states: tuple[StateCurves, ...]
    modes: ModeTimelines | Components | None
    explained_label: str = ""


def _mode_label(result: EstimationResult) -> str:
    """The legend of the estimated mode: ``estimated``, ``smoothed``, ``viterbi`` or ``kbest``."""
    post = result.post_processing
    if post is None:
        return "estimated"
    return "smoothed" if post.mode_sequence == "argmax" else post.mode_sequence


class _FilteredReducers:
    """The reductions of a smoothed result's causal filter (``post_processing.filtered``).

    A pass may leave some of the filter's estimates as they were: the Viterbi path changes
    only the modes, ``kbest`` without ``smooth`` keeps the filter's mode probabilities.  Such
    a curve would be drawn twice, once labelled as the filter's, as if the pass had changed
    it; ``states_differ`` and ``probabilities_differ`` record whether any row of the filter's
    differs from the estimate's, and only those curves are overlaid (:meth:`PlotReducer.finish`).
    """

    def __init__(self, bins: PixelBins, n_modes: int, n_states: int, timelines: bool) -> None:
        self.modes = BarsReducer(bins, n_modes)  # or, of a [components] result, the joint ones
        self.probabilities = [CurveReducer(bins) for _ in range(n_modes if timelines else 0)]
        self.means = [CurveReducer(bins) for _ in range(n_states)]
        self.states_differ = [False] * n_states
        self.probabilities_differ = False

    def add(self, filtered: EstimationResult, estimate: EstimationResult, start: int) -> None:
        """Take the filter's rows ``start .. start + filtered.n_samples - 1``.

        ``estimate``: the offline estimate's same rows, against which each curve of the
        filter's is compared.
        """
        self.modes.add(filtered.modes, start)
        for j, curve in enumerate(self.probabilities):
            curve.add(filtered.mode_probabilities[:, j], start)
        if self.probabilities and not self.probabilities_differ:
            self.probabilities_differ = not np.array_equal(
                filtered.mode_probabilities, estimate.mode_probabilities, equal_nan=True
            )
        filtered_means = filtered.estimated_state_means()  # NaN where not estimated
        means = estimate.estimated_state_means()
        for i, curve in enumerate(self.means):
            curve.add(filtered_means[:, i], start)
            if not self.states_differ[i]:
                self.states_differ[i] = not np.array_equal(
                    filtered_means[:, i], means[:, i], equal_nan=True
                )


class _ComponentReducers:
    """The bars of one component of a ``[components]`` result: estimated, true and filtered.

    Rows are the column's labels, then the true ones it lacks (:class:`ComponentTimeline`);
    ``truth_rows`` and ``filtered_rows`` take the truth's and the filter's label codes there.
    """

    def __init__(
        self,
        bins: PixelBins,
        column: TimelineColumn,
        truth: ComponentTruth | None,
        filtered: TimelineColumn | None,
    ) -> None:
        self.column = column.name
        self.labels = tuple(dict.fromkeys((*column.labels, *(truth.labels if truth else ()))))
        row = {label: i for i, label in enumerate(self.labels)}
        self.estimated = BarsReducer(bins, len(self.labels))
        self.truth = None if truth is None else BarsReducer(bins, len(self.labels))
        self.truth_rows = np.array([row[label] for label in truth.labels] if truth else [])
        self.filtered = None
        self.filtered_rows = np.zeros(0, dtype=np.int64)
        if filtered is not None and all(label in row for label in filtered.labels):
            self.filtered = BarsReducer(bins, len(self.labels))
            self.filtered_rows = np.array([row[label] for label in filtered.labels])

    def finish(self) -> ComponentTimeline:
        return ComponentTimeline(
            self.column.removeprefix(COMPONENT_PREFIX),
            self.labels,
            self.estimated.finish(),
            None if self.truth is None else self.truth.finish(),
            None if self.filtered is None else self.filtered.finish(),
        )


class PlotReducer:
    """Reduce a run's result, given in consecutive chunks of rows, to its :class:`PlotData`.

    The result's arrays are taken a chunk at a time (:meth:`add`; only their reductions are
    kept, so a chunk's arrays may be reused for the next one), and with each chunk the same
    rows of the aligned signals (measured outputs, truth): :meth:`finish` only assembles
    the data, so the drawing that waits for it starts at once.
    The first chunk says whether the result has ``post_processing`` (the filter's curves are
    then reduced too, from each chunk's ``post_processing.filtered`` over the same rows) and
    per-component mode columns (``unknown-mode``: its timelines replace the modes'); a result
    that has them may come as one chunk, the whole result.

    Parameters
    ----------
    signals:
        The aligned signals of the whole run: the bins are cut from their ``time``.
    mode_ids, state_names, output_names:
        The result's modes, states and outputs.
    """

    def __init__(
        self,
        signals: AlignedSignals,
        mode_ids: Sequence[str],
        state_names: Sequence[str],
        output_names: Sequence[str],
    ) -> None:
        self._signals = signals
        self._bins = PixelBins.of_run(signals.time)
        self._mode_ids = tuple(mode_ids)
        self._state_names = tuple(state_names)
        self._output_names = tuple(output_names)
        n_outputs = min(len(self._output_names), MAX_PANELS)
        n_states = min(len(self._state_names), MAX_PANELS)
        self._predicted = [CurveReducer(self._bins) for _ in range(n_outputs)]
        self._means = [CurveReducer(self._bins) for _ in range(n_states)]
        self._bands = [BandReducer(self._bins) for _ in range(n_states)]
        self._modes = BarsReducer(self._bins, len(self._mode_ids))
        # The signals' curves are reduced with the result's rows, not all at once in finish:
        # the drawing waits for finish, and the chunks come slower than they are reduced.
        self._measured = [CurveReducer(self._bins) for _ in range(n_outputs)]
        truth = signals.truth_states
        self._truth = [] if truth is None else [CurveReducer(self._bins) for _ in range(n_states)]
        self._truth_seen = [False] * len(self._truth)
        self._truth_modes: BarsReducer | None = None
        # Set by the first chunk (:meth:`_begin`).
        self._begun = False
        self._mode_label = "estimated"
        self._state_label = "estimate"
        self._explained: list[CurveReducer] = []
        self._explained_label = ""
        self._probabilities: list[CurveReducer] = []
        self._components: list[_ComponentReducers] = []
        self._filtered: _FilteredReducers | None = None
        self._next = 0

    def _begin(self, first: EstimationResult) -> None:
        """Set up what depends on the kind of result: the labels, components, filter."""
        self._begun = True
        post = first.post_processing
        self._mode_label = _mode_label(first)
        self._state_label = "smoothed" if post is not None and post.smoothing else "estimate"
        filtered = {} if post is None else {c.name: c for c in post.filtered.timeline_columns}
        self._components = [
            _ComponentReducers(
                self._bins,
                column,
                self._signals.truth_components.get(column.name.removeprefix(COMPONENT_PREFIX)),
                filtered.get(column.name),
            )
            for column in first.timeline_columns
            if column.name.startswith(COMPONENT_PREFIX) and column.labels
        ]
        timelines = not self._components  # the figure of the modes, not of the components
        n_modes = len(self._mode_ids)
        self._probabilities = [CurveReducer(self._bins) for _ in range(n_modes if timelines else 0)]
        if post is not None:
            self._filtered = _FilteredReducers(self._bins, n_modes, len(self._means), timelines)
            if post.explained is not None:
                self._explained = [CurveReducer(self._bins) for _ in self._predicted]
                self._explained_label = "smoothed" if post.smoothing else self._mode_label
        if timelines and self._signals.truth_modes is not None:
            self._truth_modes = BarsReducer(self._bins, n_modes)

    def add(self, chunk: EstimationResult, start: int) -> None:
        """Reduce ``chunk``: the result's rows ``start .. start + chunk.n_samples - 1``.

        Raises
        ------
        ValueError
            When ``chunk`` does not continue the rows added before, runs past the signals'
            end, or has ``post_processing`` (or its filter's rows) where the first chunk did
            not, or the other way round.
        """
        stop = start + chunk.n_samples
        if start != self._next or stop > self._signals.n_samples:
            raise ValueError(
                f"plots: chunk of rows [{start}, {stop}) added where row {self._next} of "
                f"{self._signals.n_samples} was expected"
            )
        if not self._begun:
            self._begin(chunk)
        post = chunk.post_processing
        if (
            (post is None) != (self._filtered is None)
            or (post is not None and post.filtered.n_samples != chunk.n_samples)
            or (post is not None and (post.explained is None) == bool(self._explained))
        ):
            raise ValueError(
                f"plots: rows [{start}, {stop}) have post-processing where the first chunk "
                "had none, or none where it had, or a filter's result of other rows, or "
                "explained outputs where the first chunk had none, or none where it had"
            )
        for j, curve in enumerate(self._predicted):
            curve.add(chunk.output_predictions[:, j], start)
        if post is not None and post.explained is not None:
            for j, curve in enumerate(self._explained):
                curve.add(post.explained[:, j], start)
        means = chunk.estimated_state_means()  # NaN (no curve, no band) where not estimated
        for i, (curve, band) in enumerate(zip(self._means, self._bands, strict=True)):
            curve.add(means[:, i], start)
            band.add(means[:, i], chunk.state_variances[:, i], start)
        self._modes.add(chunk.modes, start)
        for j, curve in enumerate(self._probabilities):
            curve.add(chunk.mode_probabilities[:, j], start)
        if self._components:
            columns = {column.name: column for column in chunk.timeline_columns}
            filtered = {} if post is None else {c.name: c for c in post.filtered.timeline_columns}
            for component in self._components:
                values = columns[component.column].values
                component.estimated.add(np.asarray(values, dtype=np.int64), start)
                if component.filtered is not None:
                    codes = np.asarray(filtered[component.column].values, dtype=np.int64)
                    component.filtered.add(component.filtered_rows[codes], start)
        if post is not None and self._filtered is not None:
            self._filtered.add(post.filtered, chunk, start)
        self._add_signals(start, stop)
        self._next = stop

    def _add_signals(self, start: int, stop: int) -> None:
        """Reduce the signals' rows ``start .. stop - 1``: measured outputs and the truth."""
        signals = self._signals
        measured = signals.rows(start, stop).measured_outputs()  # no line across a gap bridged
        for j, curve in enumerate(self._measured):
            curve.add(measured[:, j], start)
        truth = signals.truth_states
        if truth is not None:
            for i, curve in enumerate(self._truth):
                rows = truth[start:stop, i]
                curve.add(rows, start)
                self._truth_seen[i] = self._truth_seen[i] or bool(np.isfinite(rows).any())
        if self._truth_modes is not None and signals.truth_modes is not None:
            self._truth_modes.add(signals.truth_modes[start:stop], start)
        for component in self._components:
            name = component.column.removeprefix(COMPONENT_PREFIX)
            if component.truth is not None:
                codes = signals.truth_components[name].codes[start:stop]
                known = codes != NO_TRUE_MODE
                true_rows: IntArray = np.full(codes.shape, NO_TRUE_MODE, dtype=np.int64)
                true_rows[known] = component.truth_rows[codes[known]]
                component.truth.add(true_rows, start)  # mode_bars draws no NO_TRUE_MODE bar

    def finish(self) -> PlotData:
        """The run's :class:`PlotData`, once every row was added.

        Raises
        ------
        ValueError
            When rows of the run were not added.
        """
        bins = self._bins
        n = self._signals.n_samples
        if self._next != n:
            raise ValueError(f"plots: rows [{self._next}, {n}) of the result were not added")
        outputs = tuple(
            OutputCurves(
                name,
                measured.finish(),
                curve.finish(),
                self._explained[j].finish() if self._explained else None,
            )
            for j, (name, measured, curve) in enumerate(
                zip(self._output_names, self._measured, self._predicted, strict=False)
            )
        )
        filtered = self._filtered
        states = tuple(
            StateCurves(
                name,
                band.finish(),
                self._truth[i].finish() if self._truth and self._truth_seen[i] else None,
                curve.finish(),
                filtered.means[i].finish()
                if filtered is not None and filtered.states_differ[i]
                else None,
            )
            for i, (name, curve, band) in enumerate(
                zip(self._state_names, self._means, self._bands, strict=False)
            )
        )
        return PlotData(
            n_samples=n,
            time_origin=bins.origin,
            span=bins.span,
            edges=bins.edges,
            output_names=self._output_names,
            outputs=outputs,
            state_names=self._state_names,
            state_label=self._state_label,
            states=states,
            modes=self._finish_modes() if n else None,
            explained_label=self._explained_label,
        )

    def _finish_modes(self) -> ModeTimelines | Components:
        """The mode timelines, or the per-component ones of a ``[components]`` result."""
        estimated = self._modes.finish()
        filtered = self._filtered
        if self._components:
            joint_filtered = None if filtered is None else filtered.modes.finish()
            visited = [
                m
                for m, (first, _) in enumerate(estimated)
                if first.size or (joint_filtered is not None and joint_filtered[m][0].size)
            ]
            return Components(
                columns=tuple(component.finish() for component in self._components),
                joint_ids=tuple(self._mode_ids[m] for m in visited),
                joint=tuple(estimated[m] for m in visited),
                joint_filtered=None
                if joint_filtered is None
                else tuple(joint_filtered[m] for m in visited),
                label=self._mode_label,
            )
        truth = self._truth_modes
        return ModeTimelines(
            mode_ids=self._mode_ids,
            label=self._mode_label,
            estimated=estimated,
            truth=None if truth is None else truth.finish(),
            filtered=None if filtered is None else filtered.modes.finish(),
            probabilities=tuple(curve.finish() for curve in self._probabilities),
            filtered_probabilities=tuple(curve.finish() for curve in filtered.probabilities)
            if filtered is not None and filtered.probabilities_differ
            else None,
        )


def reduce_result(result: EstimationResult, signals: AlignedSignals) -> PlotData:
    """The :class:`PlotData` of a whole result (one chunk of a :class:`PlotReducer`)."""
    reducer = PlotReducer(signals, result.mode_ids, result.state_names, result.output_names)
    reducer.add(result, 0)
    return reducer.finish()
