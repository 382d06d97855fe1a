"""A table column's numbers as ``float64``, and the numbers a ``float64`` does not hold refused.

:func:`to_float` makes a column ``Float64`` (a CSV column's text parsed by
:mod:`.csv_numbers`); :func:`refuse_inexact` refuses an integer beyond 2^53 it lost digits of
(:mod:`.exact`), :func:`refuse_overflow` a CSV number beyond the range of a ``float64``, each
naming its line or row; :func:`unheld_value` is ``inspect``'s word for either.
:class:`ColumnBlock` holds the numeric columns of a read in one NumPy allocation.
"""

from __future__ import annotations

import numpy as np

from hybridlog.errors import LogError, excerpt
from hybridlog.io.column_types import NARROW_INTEGERS, holds_numbers, holds_text
from hybridlog.io.csv_frames import read_csv_strings
from hybridlog.io.csv_numbers import parse_floats
from hybridlog.io.exact import WHOLE_NUMBER, any_beyond_exact, beyond_exact, inexact
from hybridlog.io.table_file import TableFile
from hybridlog.polars_import import pl
from hybridlog.signals import FloatArray, IntArray


def to_float(table: TableFile, column: pl.Series, rows: IntArray) -> pl.Series:
    """``column`` as ``Float64``; ``rows``: the data row of each cell (for a CSV text's error)."""
    if column.dtype == pl.Float64:
        return column
    if holds_numbers(column.dtype):
        return column.cast(pl.Float64)
    return parse_floats(table.file, column, rows)


def refuse_overflow(
    table: TableFile, column: pl.Series, rows: IntArray, written: pl.Series | None = None
) -> None:
    """Refuse a CSV number too large for a float64 (``1e400``), which parsed as infinite.

    A number beyond 1.8e308 was reported as ``inf``, which the cell does not say; with
    ``--drop-nonfinite`` it is dropped as infinite (it is out of range in any case).
    ``written``: ``column``'s cells as written, if known (else read from the file).

    Raises
    ------
    LogError
        Naming the line and column of the first such cell.
    """
    name = column.name
    infinite = column.is_infinite().fill_null(False).to_numpy()
    if written is None:
        text = read_csv_strings(table.file, [name], checked=True).get_column(name)
        written = text.gather(rows[infinite])
    else:
        written = written.filter(pl.Series(infinite))
    cells = written.str.strip_chars().str.to_lowercase()
    spelled = cells.str.strip_chars_start("+-").is_in(["inf", "infinity"]).to_numpy()
    if not spelled.all():
        first = int(np.argmin(spelled))
        row = int(rows[infinite][first])
        raise LogError(
            f"{table.path}, {table.row_label(row)}, column {excerpt(name)}: "
            f"{excerpt(written[first], 40)} is beyond the range of a float64 (about 1.8e308)"
        )


def refuse_inexact(
    table: TableFile,
    taken: pl.Series,
    column: pl.Series,
    rows: IntArray,
    values: FloatArray | None = None,
) -> None:
    """Refuse a number ``column`` (``taken`` as ``Float64``) does not hold (:mod:`.exact`).

    An ``int64``/``uint64`` or decimal Parquet value, or a CSV cell written as a whole
    number, beyond 2^53 lost its last digits as a ``float64``.  Only the cells whose
    value reached 2^53 are looked at again.  ``values``: ``column`` as NumPy, if at hand.

    Raises
    ------
    LogError
        Naming the line or row and column of the first such cell in the file.
    """
    if table.format == "parquet" and not (
        isinstance(taken.dtype, pl.Decimal)
        or (taken.dtype.is_integer() and taken.dtype not in NARROW_INTEGERS)
    ):
        return
    if values is None:
        values = column.to_numpy()
    if not any_beyond_exact(values):
        return
    found = np.flatnonzero(beyond_exact(values))
    if not found.size:
        return
    found = found[np.argsort(rows[found], kind="stable")]  # in the file's order
    if table.format == "csv":
        if holds_text(taken.dtype):  # the cells as written (inspect)
            written = taken.gather(found)
        else:
            text = read_csv_strings(table.file, [column.name], checked=True)
            written = text.get_column(column.name).gather(rows[found])
        whole = written.str.contains(WHOLE_NUMBER).fill_null(False).to_numpy()
        found, cells = found[whole], written.filter(pl.Series(whole)).to_list()
    else:
        cells = taken.gather(found).to_list()
    for index, cell in zip(found.tolist(), cells, strict=True):
        reason = inexact(cell)
        if reason is not None:
            raise LogError(
                f"{table.path}, {table.row_label(int(rows[index]))}, column "
                f"{excerpt(column.name)}: {reason}"
            )


def unheld_value(table: TableFile, taken: pl.Series, rows: IntArray) -> str | None:
    """The first value of a numeric column that ``analyze`` refuses as not held, if any.

    The checks :meth:`~hybridlog.io.tables.TableSource.read` makes of a number it reads,
    made here too: an integer beyond 2^53 that a ``float64`` cannot hold
    (:func:`refuse_inexact`), a CSV number beyond the range of a ``float64``
    (:func:`refuse_overflow`).  Inspect, which parsed the column on its own, gave such a
    column's range as though it held the number, and ``analyze`` then refused the log naming
    a line inspect said nothing of.  ``rows``: the data row of each of ``taken``'s cells.
    ``None`` when every value is held.
    """
    if holds_text(taken.dtype):
        column = taken.str.strip_chars().cast(pl.Float64, strict=False)
    elif holds_numbers(taken.dtype):
        column = taken.cast(pl.Float64)
    else:
        return None
    try:
        refuse_inexact(table, taken, column, rows)
        if table.format == "csv" and column.is_infinite().any():
            refuse_overflow(table, column, rows, taken)
    except LogError as err:
        return str(err).removeprefix(f"{table.path}, ")
    return None


class ColumnBlock:
    """One NumPy allocation holding the numeric columns of a read, a row per column.

    Allocated on the first :meth:`take` (a read whose columns all have empty cells needs
    none), uninitialised: every row used is written once.
    """

    def __init__(self, columns: int, length: int) -> None:
        self._shape = (columns, length)
        self._block: FloatArray | None = None
        self._used = 0

    def take(self, values: pl.Series) -> FloatArray:
        """A copy of ``values`` (``Float64``, no nulls) in the next row of the block.

        Copied a chunk at a time (each a NumPy view of polars' memory), with no array of
        them put end to end in between.
        """
        if self._block is None:
            self._block = np.empty(self._shape, dtype=np.float64)
        row: FloatArray = self._block[self._used]
        start = 0
        for chunk in values.get_chunks():
            row[start : start + chunk.len()] = chunk.to_numpy()
            start += chunk.len()
        self._used += 1
        return row
