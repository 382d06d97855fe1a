"""A run's curves and ±2σ bands reduced to what a PNG's pixel columns can show, in pieces.

Each bin of a curve (:class:`~hybridlog.report.pixel_bins.PixelBins`: one pixel column) is
drawn through its first sample, its minimum, its maximum and its last sample (the "M4"
reduction: every extreme the full curve reaches in a column is kept, so the picture is the
same: :func:`envelope`, :class:`CurveReducer`); a state estimate's ±2σ band through its
lowest and highest edge (:class:`BandReducer`).  Pieces of the samples are reduced exactly
as the whole run is: a bin cut by a piece's boundary gets the minimum and maximum of both
parts, its first sample from the earlier piece and its last from the later one.  A curve
short enough not to be reduced is kept whole.  :func:`column_maxima` is a curve's largest
value per pixel column (a heat map's cells).  NumPy only, no matplotlib.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from hybridlog.report.pixel_bins import PixelBins, blocks, local_starts
from hybridlog.signals import FloatArray

__all__ = [
    "BandReducer",
    "CurveReducer",
    "Envelope",
    "SigmaBand",
    "column_maxima",
    "envelope",
]


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
        for lo, rows in blocks(values.shape[0]):
            # a column of a chunk's 2-D array is strided: reduced in a contiguous copy, the
            # reductions take a third of the time (0.5 MB, as the block's other temporaries)
            block = np.ascontiguousarray(values[rows])
            at = start + lo
            a, b = bins.spanned(at, block.shape[0])
            usable = np.isfinite(block)
            finite = (
                block if usable.all() else np.where(usable, block, np.nan)
            )  # no copy if all are
            local = local_starts(bins, a, b, at)
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
        for lo, rows in blocks(mean.shape[0]):
            at = start + lo
            part = np.ascontiguousarray(mean[rows])  # as CurveReducer's block
            two_sigma = np.maximum(variance[rows], 0.0)
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
            local = local_starts(bins, a, b, at)
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
