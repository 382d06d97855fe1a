"""The rows of a run reduced a block at a time, each column's blocks merged along a tree.

:class:`Columns` takes ``(rows, columns)`` pairs ``y``, ``ŷ`` in consecutive chunks and
reduces each column's usable rows (``y`` finite, ``ŷ`` not NaN) a block of
:data:`_BLOCK_ROWS` rows of the run at a time, into whatever part its reduction makes
(:class:`~hybridlog.report.metrics.OutputAccumulator`'s output parts,
:class:`~hybridlog.report.state_error.StateAccumulator`'s error powers), so that the result
depends on the rows alone, never on how they were handed over.

"""

from __future__ import annotations

from collections.abc import Callable
from typing import Generic, Protocol, Self, TypeVar

import numpy as np
import numpy.typing as npt

from hybridlog.signals import FloatArray


def _as_2d(a: npt.ArrayLike, name: str) -> FloatArray:
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim == 1:
        arr = arr[:, np.newaxis]
    if arr.ndim != 2:
        raise ValueError(f"{name} must be 1-D or 2-D; got {arr.ndim} dimensions")
    return arr


def paired(y: npt.ArrayLike, y_hat: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
    """``y`` and ``y_hat`` as 2-D float64 arrays of one shape (a 1-D array one column)."""
    y2 = _as_2d(y, "y")
    yh2 = _as_2d(y_hat, "y_hat")
    if y2.shape != yh2.shape:
        raise ValueError(f"y has shape {y2.shape} but y_hat has shape {yh2.shape}")
    return y2, yh2


_BLOCK_ROWS = 1 << 16
"""Rows of the run per block, the unit in which the output and state metrics reduce.

A block's usable rows are reduced with the operations (and NumPy's pairwise sums) that
reduced a whole column before the metrics were streamed, so a run of at most one block has
the same bits as then; blocks are then merged (:class:`Squares`, :class:`Spread`).  2^16
rows: 512 KiB per array, a block's temporaries in a core's L2 cache.
"""


class _Mergeable(Protocol):
    """A summary of some rows that merges with the summary of the rows after them."""

    def merged(self, later: Self) -> Self: ...


_Part = TypeVar("_Part", bound=_Mergeable)

_Reduce = Callable[[FloatArray, FloatArray, FloatArray], _Part]
"""A block's usable ``y`` and ``ŷ`` (contiguous) to its part, given ``(2, rows)`` scratch."""


def _merged(first: _Part | None, later: _Part | None) -> _Part | None:
    """``first.merged(later)``, a missing part (no usable row) taken as nothing."""
    if first is None:
        return later
    return first if later is None else first.merged(later)


_PIECE_ROWS = 1 << 13
"""Rows selected at a time: temporaries of 64 KiB, below glibc's threshold for mapping an
allocation (128 KiB), so they are reused from the heap, not mapped and faulted in anew."""


def _select(v: FloatArray, usable: npt.NDArray[np.bool_], out: FloatArray) -> None:
    """Write the entries of ``v`` where ``usable``, in order, to ``out`` (as many)."""
    if out.size == v.size:
        out[:] = v
        return
    filled = 0
    for start in range(0, v.size, _PIECE_ROWS):
        piece = v[start : start + _PIECE_ROWS][usable[start : start + _PIECE_ROWS]]
        out[filled : filled + piece.size] = piece
        filled += piece.size


class _Column(Generic[_Part]):
    """One column's usable rows, reduced a block of the run's rows at a time.

    A block is :data:`_BLOCK_ROWS` consecutive rows of the run; its usable rows (``y`` and
    ``ŷ`` finite) are reduced to a part (``None`` when none was usable) once the block is
    complete: selected into the columns' shared scratch when one call brings the whole
    block, else from the rows kept (copied) since the block opened.  Closed parts merge
    as a binary counter counts: a part merges with the last closed one while both stand
    for the same number of blocks (1 and 1, then 2 and 2, ...), so the parts merge along
    a balanced binary tree (the pairwise algorithm of Chan, Golub and LeVeque: rounding
    grows with the tree's height, log2 of the number of blocks, not with their number).
    The blocks and the tree depend on the rows alone, never on how they were handed over.
    """

    def __init__(self, reduce: _Reduce[_Part]) -> None:
        self._reduce = reduce
        self._kept = np.empty((2, 0))  # the open block's usable y and ŷ so far, and room
        self._filled = 0
        self._closed: list[tuple[int, _Part | None]] = []  # (log2 of its blocks, part)

    def extend(self, y: FloatArray, y_hat: FloatArray, complete: bool, work: FloatArray) -> None:
        """Take rows of the open block (one column's, any strides); ``complete``: its last.

        ``work``: ``(4, _BLOCK_ROWS)`` scratch, shared by the columns.
        """
        # An infinite ŷ is a prediction that diverged, not a missing one (NaN): it is used,
        # and its error makes MSE and fit infinite (null, "diverged") and VAF 0, so that a
        # filter that blew up is never scored on the rows before it did.
        usable = np.isfinite(y)
        usable &= ~np.isnan(y_hat)
        count = int(np.count_nonzero(usable))
        if complete and not self._filled:  # the whole block: reduced from the caller's rows
            if count:
                _select(y, usable, work[0, :count])
                _select(y_hat, usable, work[1, :count])
            self._close(self._open_part(work[:2, :count], work[2:]))
            return
        filled = self._filled + count
        if filled > self._kept.shape[1]:  # grown by doubling, up to a block
            grown = np.empty((2, min(max(filled, 2 * self._kept.shape[1]), _BLOCK_ROWS)))
            grown[:, : self._filled] = self._kept[:, : self._filled]
            self._kept = grown
        _select(y, usable, self._kept[0, self._filled : filled])
        _select(y_hat, usable, self._kept[1, self._filled : filled])
        self._filled = filled
        if complete:
            self._close(self._open_part(self._kept[:, :filled], work[2:]))
            self._filled = 0

    def _open_part(self, rows: FloatArray, scratch: FloatArray) -> _Part | None:
        return self._reduce(rows[0], rows[1], scratch) if rows.shape[1] else None

    def _close(self, part: _Part | None) -> None:
        height = 0
        while self._closed and self._closed[-1][0] == height:
            part = _merged(self._closed.pop()[1], part)
            height += 1
        self._closed.append((height, part))

    def part(self, scratch: FloatArray) -> _Part | None:
        """The part of every row taken so far (the open block reduced, kept open)."""
        whole = self._open_part(self._kept[:, : self._filled], scratch)
        for _, part in reversed(self._closed):
            whole = _merged(part, whole)
        return whole


class Columns(Generic[_Part]):
    """The :class:`_Column` of every column of ``(rows, columns)`` pairs ``y``, ``ŷ``.

    The rows of an ``add`` are taken a block at a time (or what completes the open block),
    each column in turn, and a column's block reduced as soon as it is complete, in one
    scratch of four block-sized rows: no temporary is larger, whatever the rows handed
    over, and the only rows kept between calls are the usable ones of an incomplete block
    (none when the calls bring whole blocks of :data:`_BLOCK_ROWS` rows).
    """

    def __init__(self, columns: int, reduce: _Reduce[_Part]) -> None:
        if columns < 0:
            raise ValueError(f"the number of columns must be >= 0; got {columns}")
        self._columns = [_Column(reduce) for _ in range(columns)]
        self._open_rows = 0  # rows of the run in the open block
        self._work = np.empty((4, _BLOCK_ROWS))  # reused: its pages are faulted in once

    def add(self, y: npt.ArrayLike, y_hat: npt.ArrayLike) -> None:
        """Take the next rows of the run, ``(rows, columns)`` (or ``(rows,)`` for one)."""
        y2, yh2 = paired(y, y_hat)
        if y2.shape[1] != len(self._columns):
            raise ValueError(f"expected {len(self._columns)} columns; got {y2.shape[1]}")
        start = 0
        while start < y2.shape[0]:
            stop = min(y2.shape[0], start + _BLOCK_ROWS - self._open_rows)
            self._open_rows = (self._open_rows + stop - start) % _BLOCK_ROWS
            complete = not self._open_rows
            for j, column in enumerate(self._columns):
                column.extend(y2[start:stop, j], yh2[start:stop, j], complete, self._work)
            start = stop

    def parts(self) -> list[_Part | None]:
        """Each column's part of every row taken so far (``None``: no usable row)."""
        return [column.part(self._work[2:]) for column in self._columns]
