"""The bins of a run's samples: one per pixel column of the panels its curves are drawn in.

A PNG cannot show more than one value range per pixel column, so long runs are reduced to
what it can show before drawing: the samples are cut into time bins, one per pixel column
of the panel (whose x range is the run's time span: :class:`PixelBins`, :func:`time_bins`),
as many as the figures' width and resolution and the panels' extent give
(:func:`pixel_columns`).  Every reduction works a block of :data:`BLOCK` samples at a time
(:func:`blocks`, :func:`local_starts`).  NumPy only, no matplotlib.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from hybridlog.report.plot_time_axis import time_origin
from hybridlog.signals import FloatArray, IntArray

__all__ = [
    "BLOCK",
    "FIGURE_DPI",
    "FIGURE_WIDTH_IN",
    "PANEL_LEFT",
    "PANEL_RIGHT",
    "PixelBins",
    "blocks",
    "local_starts",
    "pixel_columns",
    "time_bins",
]


FIGURE_DPI = 100
FIGURE_WIDTH_IN = 10.0
PANEL_LEFT, PANEL_RIGHT = 0.09, 0.98
"""The panels' horizontal extent as fractions of the figure's width: with the width and the
resolution, it fixes the pixel columns the curves are reduced to (:func:`pixel_columns`)."""


BLOCK = 1 << 16
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
    for lo in range(0, n, BLOCK):
        block = time[lo : lo + BLOCK]
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


def blocks(count: int) -> Iterator[tuple[int, slice]]:
    """The blocks of at most :data:`BLOCK` rows that a chunk of ``count`` is reduced in.

    Each as its first row and its rows' slice: the reductions take both from here, so
    :data:`BLOCK` is read in this module alone.
    """
    for lo in range(0, count, BLOCK):
        yield lo, slice(lo, min(lo + BLOCK, count))


def local_starts(bins: PixelBins, a: int, b: int, start: int) -> IntArray:
    """Where bins ``a .. b - 1`` begin in a block from sample ``start`` (the first at 0).

    The first bin may have begun in an earlier block: its part in this block begins at 0.
    """
    local = bins.starts[a:b] - start
    local[0] = 0
    return local
