"""A mode timeline reduced to the pixel columns each mode occupies, in pieces.

The mode timelines are drawn from their runs (:func:`mode_runs`), the runs of each mode
merged where they touch the same pixel column (:func:`mode_bars`): a run shorter than a
pixel still shows as one pixel column.  A mode's pixel columns in one piece of the sequence
are joined to those of the pieces before where they touch, as the run that continues
across the boundary joins them (:class:`BarsReducer`).  NumPy only, no matplotlib.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from hybridlog.report.pixel_bins import PixelBins, blocks
from hybridlog.signals import IntArray

__all__ = ["Bars", "BarsReducer", "ModeRuns", "mode_bars", "mode_runs"]


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
        for lo, rows in blocks(modes.shape[0]):
            at = start + lo
            block = modes[rows]
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
