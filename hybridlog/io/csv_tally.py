"""A CSV log a block of lines at a time, and what ``inspect`` says of its columns.

Polars is handed a CSV log :data:`CSV_BYTES_AT_ONCE` of lines at a time
(:func:`csv_blocks`), never the whole file.  ``inspect`` parsed a CSV log whole, every cell a
polars string, to describe it: a 1.3 GB file of 10^7 rows peaked at 4.1 GB, a 2.2 GB file of
300 columns at 6.2 GB.  It now describes it a block at a time, keeping of each column only
what :meth:`~hybridlog.io.tables.TableSource.describe` reports (:class:`ColumnTally`): its
counts and range, which rows hold a cell (a bit a row, and only for blocks where some row
holds none), and the cells that ``analyze`` may refuse as numbers a ``float64`` does not
hold: 0.57 GB and 0.27 GB for those two files, with the same description.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from hybridlog.errors import LogError
from hybridlog.io.exact import beyond_exact
from hybridlog.io.source import usable_values
from hybridlog.polars_import import pl
from hybridlog.signals import IntArray

CSV_BYTES_AT_ONCE = 1 << 24
"""Bytes of CSV lines polars reads at a time (16 MiB).

Below glibc's largest threshold for mapping an allocation of its own (32 MiB), so that each
block's bytes reuse the memory of the one before: blocks of 64 MiB, each mapped and faulted
in afresh, read 5 of 2.2 GB's columns in 8 s, against 4.5 s for polars given the file (and
its pages mapped beside the columns); of 16 MiB in 4.6 s.  Described by ``inspect``, 300
columns take a quarter longer than in blocks of 64 MiB (more blocks, each column's work per
block), and half the time of the file read whole."""

BOOLEANS = ("true", "false")
"""Cells that, a column of nothing else, read as 1 and 0 (any case)."""

Mask = np.ndarray[Any, np.dtype[np.bool_]]


def csv_blocks(path: Path) -> Iterator[bytes]:
    """The header line followed by the next :data:`CSV_BYTES_AT_ONCE` of lines, in turn.

    Each block ends where a line does (the last where the file does), so polars reads its
    lines as it reads them in the whole file: a record a line (a quoted line break is
    refused before, ``csv_lines.check_record_widths``), a blank line a row of empty cells.

    Raises
    ------
    LogError
        When the file cannot be read.
    """
    try:
        with path.open("rb") as handle:
            header = handle.readline()
            # joined, not added: one copy of the block (added twice took half as long again)
            block = handle.read(CSV_BYTES_AT_ONCE)
            yield b"".join((header, block, handle.readline()))  # the header alone if no more
            while block := handle.read(CSV_BYTES_AT_ONCE):
                yield b"".join((header, block, handle.readline()))
    except OSError as err:
        raise LogError(f"{path}: cannot be read ({err.strerror})") from err


def stripped_cells(column: pl.Series) -> pl.Series:
    """A text column's cells without the blanks around them; a cell of nothing else null."""
    text = column.cast(pl.String).str.strip_chars()
    return pl.select(pl.when(text != "").then(text)).to_series().alias(column.name)


def cell_numbers(cells: pl.Series) -> pl.Series:
    """A column's cells (as written) as ``Float64``: null where empty or not a number."""
    return stripped_cells(cells).cast(pl.Float64, strict=False)


class ColumnTally:
    """One CSV column as ``inspect`` describes it, its blocks of rows added in order.

    The blocks are added to every column at once (:func:`tally_block`).

    A column is ``float64`` when every non-empty cell is a number, else ``boolean`` when
    every one (at least one) is ``true`` or ``false`` in any case (read as 1 and 0), else
    ``string``; ``count``, ``nonfinite`` and the usable range are those of its values, as
    ``column_summary.describe_column`` gives them for the column read whole.  ``numbers`` counts
    the non-empty cells that are numbers, ``first_text`` is the row and text of the first
    that is not (``None`` while every one is): where a column of numbers has a cell
    ``analyze`` refuses (``'0x10' is not a number``), which ``inspect`` names.
    """

    def __init__(self, name: str) -> None:
        self.name = name
        self.rows = 0
        self.count = 0
        self._numbers = True  # every non-empty cell so far a number
        self._booleans = True  # every non-empty cell so far true or false
        self._nonfinite = 0
        self._low, self._high = math.inf, -math.inf
        self._truths: set[bool] = set()
        self._holes: list[tuple[int, int, np.ndarray[Any, np.dtype[np.uint8]]]] = []
        self._suspect_rows: list[IntArray] = []
        self._suspect_cells: list[pl.Series] = []
        self.numbers = 0  # non-empty cells that are numbers
        self.first_text: tuple[int, str] | None = None  # row and cell of the first other

    @property
    def dtype(self) -> str:
        """``float64``, ``boolean`` or ``string``."""
        if self._numbers:
            return "float64"
        return "boolean" if self._booleans and self.count else "string"

    def values(self) -> dict[str, Any]:
        """``count``, ``nonfinite``, ``min`` and ``max`` (``None`` where not numbers)."""
        info: dict[str, Any] = {"count": self.count, "nonfinite": None, "min": None, "max": None}
        dtype = self.dtype
        if dtype == "boolean":
            info.update(nonfinite=0, min=float(min(self._truths)), max=float(max(self._truths)))
        elif dtype == "float64":
            info["nonfinite"] = self._nonfinite
            if self._low <= self._high:
                info.update(min=self._low, max=self._high)
        return info

    def present(self) -> Mask:
        """Which rows hold a cell of the column."""
        present = np.ones(self.rows, dtype=np.bool_)
        for first, length, bits in self._holes:
            present[first : first + length] = np.unpackbits(bits, count=length).view(np.bool_)
        return present

    @property
    def suspicious(self) -> bool:
        """Whether there are :meth:`suspects`: a cell beyond 2^53 or infinite."""
        return bool(self._suspect_rows)

    def suspects(self) -> tuple[pl.Series, IntArray]:
        """The cells as written that may stand for numbers a ``float64`` does not hold.

        Those whose number reaches 2^53 or is infinite but for infinities spelled so
        (``inf``, ``-Infinity``), with their rows: ``analyze`` refuses them unless they are
        held exactly (``table_numbers.unheld_value``).
        """
        if not self._suspect_rows:
            return pl.Series(self.name, [], dtype=pl.String), np.zeros(0, dtype=np.int64)
        return pl.concat(self._suspect_cells), np.concatenate(self._suspect_rows)


def tally_block(
    tallies: Sequence[ColumnTally], frame: pl.DataFrame, keep: str | None = None
) -> pl.Series | None:
    """Count the next block of rows (``frame``, cells as written) of each tally's column.

    Return column ``keep``'s cells as numbers (``Float64``, null where empty or not a
    number, as :func:`cell_numbers` reads them), if it is one of the tallies'.

    Every column at once: the columns end to end as one series, its cells stripped and read
    as numbers in one pass each, and each column's counts a row of a NumPy array
    (:class:`_Block`).  A column at a time, each column's dozen polars operations a block
    took about a millisecond whatever its rows: ``inspect`` of a CSV of 3 rows and 20,000
    columns took 22.6 s.
    """
    rows = frame.height
    names = [tally.name for tally in tallies]
    if not tallies or not rows:
        return cell_numbers(frame.get_column(keep)) if keep in names else None
    block = _Block([frame.get_column(name) for name in names], rows)
    candidates: list[int] = []  # columns that may still be of booleans: true or false alone
    for index, tally in enumerate(tallies):
        held = int(block.held[index])
        numbers = bool(block.numbers[index])
        if held < rows:
            tally._holes.append((tally.rows, rows, np.packbits(block.present[index])))
        if tally._numbers and numbers:
            block.add_numbers(tally, index, frame.get_column(tally.name))
        elif held:
            tally._numbers = False
        if not numbers and tally.first_text is None:  # once a column: no cost when clean
            tally.first_text = (tally.rows + block.first_text(index), block.text(index))
        tally.numbers += int(block.parsed[index])
        if tally._booleans and held:
            tally._booleans = not numbers
            candidates += [index] if not numbers else []
        tally.rows += rows
        tally.count += held
    if candidates:
        _add_booleans([tallies[index] for index in candidates], block.cells_of(candidates))
    return block.numbers_of(names.index(keep)).alias(str(keep)) if keep in names else None


class _Block:
    """A block of rows of several columns, read as numbers, each column's counts at once.

    ``present`` (columns by rows) tells the non-empty cells; ``held`` counts them,
    ``parsed`` those that are numbers, and ``numbers`` is whether all of them are.
    """

    def __init__(self, columns: list[pl.Series], rows: int) -> None:
        self._rows = rows
        cells = pl.concat([column.cast(pl.String) for column in columns], rechunk=False)
        self._text = cells.str.strip_chars()
        shape = (len(columns), rows)
        self.present: Mask = (
            self._text.str.len_bytes().gt(0).fill_null(False).to_numpy().reshape(shape)
        )
        numbers = self._text.cast(pl.Float64, strict=False)
        self._numbers = numbers
        self._unparsed: Mask = numbers.is_null().to_numpy().reshape(shape)
        self._values = numbers.to_numpy().reshape(shape)  # NaN where null
        self.held = self.present.sum(axis=1)
        self.parsed = rows - self._unparsed.sum(axis=1)
        self.numbers = self.parsed == self.held
        values = self._values
        finite = np.isfinite(values)
        usable = usable_values(values)
        self._nonfinite = (~usable & ~self._unparsed).sum(axis=1)
        self._low = np.where(usable, values, np.inf).min(axis=1)
        self._high = np.where(usable, values, -np.inf).max(axis=1)
        # beyond 2^53 or infinite (not NaN, nor an empty cell): what analyze looks at again,
        # but for infinities spelled so (inf, -Infinity), which it takes
        self._suspect = beyond_exact(values)
        infinite = np.flatnonzero(self._suspect & ~finite)
        if infinite.size:
            spelled = self._text.gather(infinite).str.to_lowercase().str.strip_chars_start("+-")
            self._suspect.ravel()[infinite[spelled.is_in(["inf", "infinity"]).to_numpy()]] = False

    def add_numbers(self, tally: ColumnTally, index: int, cells: pl.Series) -> None:
        """Add column ``index``'s values (all numbers) to ``tally``; ``cells`` as written."""
        tally._nonfinite += int(self._nonfinite[index])
        if self._low[index] <= self._high[index]:  # a usable value
            tally._low = min(tally._low, float(self._low[index]))
            tally._high = max(tally._high, float(self._high[index]))
        suspect = self._suspect[index]
        if suspect.any():
            tally._suspect_rows.append(np.flatnonzero(suspect) + tally.rows)
            tally._suspect_cells.append(cells.filter(pl.Series(suspect)))

    def first_text(self, index: int) -> int:
        """The row of column ``index``'s first non-empty cell that is not a number."""
        return int(np.argmax(self._unparsed[index] & self.present[index]))

    def text(self, index: int) -> str:
        """Column ``index``'s :meth:`first_text` cell, stripped."""
        return str(self._text[index * self._rows + self.first_text(index)])

    def numbers_of(self, index: int) -> pl.Series:
        """Column ``index``'s cells as numbers, null where empty or not a number."""
        return self._numbers.slice(index * self._rows, self._rows)

    def cells_of(self, indices: list[int]) -> pl.Series:
        """The stripped cells of columns ``indices``, end to end."""
        rows = self._rows
        return pl.concat([self._text.slice(index * rows, rows) for index in indices])


def _add_booleans(tallies: list[ColumnTally], text: pl.Series) -> None:
    """Note which of true and false each column's non-empty cells hold, or that it holds others.

    ``text``: the columns' stripped cells end to end, none of the columns all numbers.
    """
    shape = (len(tallies), text.len() // len(tallies))
    lowered = text.str.to_lowercase()
    truths = lowered.eq("true").fill_null(False).to_numpy().reshape(shape)
    falsehoods = lowered.eq("false").fill_null(False).to_numpy().reshape(shape)
    booleans = (truths | falsehoods).sum(axis=1)
    present = text.str.len_bytes().gt(0).fill_null(False).to_numpy().reshape(shape).sum(axis=1)
    any_true: list[bool] = np.any(truths, axis=1).tolist()
    any_false: list[bool] = np.any(falsehoods, axis=1).tolist()
    for tally, truth, falsehood, count, held in zip(
        tallies, any_true, any_false, booleans, present, strict=True
    ):
        tally._booleans = bool(count == held)
        if tally._booleans:
            tally._truths.update([True] if truth else [])
            tally._truths.update([False] if falsehood else [])
