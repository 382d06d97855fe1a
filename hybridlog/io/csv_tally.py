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
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from hybridlog.errors import LogError
from hybridlog.io.exact import beyond_exact
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


class ColumnTally:
    """One CSV column as ``inspect`` describes it, its blocks of rows added in order.

    A column is ``float64`` when every non-empty cell is a number, else ``boolean`` when
    every one (at least one) is ``true`` or ``false`` in any case (read as 1 and 0), else
    ``string``; ``count``, ``nonfinite`` and the finite range are those of its values, as
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

    def add(self, cells: pl.Series) -> pl.Series:
        """Count the next block of the column's cells (as written); return them as numbers.

        The numbers (``Float64``) are null where a cell is empty or not a number.
        """
        text = stripped_cells(cells)
        present = text.is_not_null()
        held = int(present.sum())
        if held < text.len():
            self._holes.append((self.rows, text.len(), np.packbits(present.to_numpy())))
        parsed = text.cast(pl.Float64, strict=False)
        numbers = parsed.null_count() == text.null_count()
        if self._numbers and numbers:
            self._add_numbers(cells, parsed)
        elif held:
            self._numbers = False
        if not numbers and self.first_text is None:  # once a column: no cost when clean
            other = parsed.is_null() & present
            first = int(other.arg_true()[0])
            self.first_text = (self.rows + first, str(text[first]))
        self.numbers += text.len() - parsed.null_count()
        if self._booleans and held:
            self._add_booleans(text, numbers)
        self.rows += text.len()
        self.count += held
        return parsed

    def _add_booleans(self, text: pl.Series, numbers: bool) -> None:
        """Note which of true and false non-empty ``text`` holds, or that it holds others."""
        lowered = text.drop_nulls().str.to_lowercase()
        self._booleans = not numbers and bool(lowered.is_in(BOOLEANS).all())
        if self._booleans:
            self._truths.update(lowered.unique().eq("true").to_list())

    def _add_numbers(self, cells: pl.Series, parsed: pl.Series) -> None:
        values = parsed.drop_nulls().to_numpy()
        finite = values[np.isfinite(values)]
        self._nonfinite += int(values.size - finite.size)
        if finite.size:
            self._low = min(self._low, float(finite.min()))
            self._high = max(self._high, float(finite.max()))
        # beyond 2^53 or infinite (not NaN, nor an empty cell): what analyze looks at again
        suspect = beyond_exact(parsed.to_numpy())
        if suspect.any():
            self._suspect_rows.append(np.flatnonzero(suspect) + self.rows)
            self._suspect_cells.append(cells.filter(pl.Series(suspect)))

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

    def suspects(self) -> tuple[pl.Series, IntArray]:
        """The cells as written that may stand for numbers a ``float64`` does not hold.

        Those whose number reaches 2^53 or is infinite, with their rows: ``analyze`` refuses
        them unless they are held exactly, or spelled as infinite
        (``TableSource._unheld_value``).
        """
        if not self._suspect_rows:
            return pl.Series(self.name, [], dtype=pl.String), np.zeros(0, dtype=np.int64)
        return pl.concat(self._suspect_cells), np.concatenate(self._suspect_rows)
