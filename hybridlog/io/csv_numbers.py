"""A CSV log's cells read as numbers: parsed, or refused with a hint of what they are.

A cell that is not a number names its line and column, and says when it is a number
written otherwise: a decimal comma, digits grouped by thousands, a date without seconds,
``true`` among numbers.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from hybridlog.errors import LogError, excerpt
from hybridlog.io.csv_tally import BOOLEANS, ColumnTally, stripped_cells
from hybridlog.io.table_times import ISO_DATE
from hybridlog.polars_import import pl
from hybridlog.signals import IntArray

_DECIMAL_COMMA = re.compile(r"[+-]?\d*,\d+(?:[eE][+-]?\d+)?")


_GROUPED = re.compile(r"[+-]?\d{1,3}(?:[,.' \u00a0\u202f]\d{3})+(?:[.,]\d*)?")
"""Digits grouped by thousands (``1,000``, ``1.234.567,5``, ``1 000``): the comma is not
only a decimal comma, whose hint alone led a user to write ``1.000`` for one thousand."""


def parse_floats(
    path: Path, column: pl.Series, rows: IntArray, *, booleans: bool = False
) -> pl.Series:
    """Convert a text column to ``Float64``; empty cells become nulls, others must parse.

    With ``booleans`` (a signal, not the time), a column whose every cell is ``true`` or
    ``false`` (any case: polars and pandas write booleans so) reads as 1 and 0, as a
    Parquet boolean column, a ROS ``bool`` or a JSON ``true`` do; such a cell among numbers
    is refused, as any other text.
    """
    text = stripped_cells(column)
    values = text.cast(pl.Float64, strict=False)
    bad = (values.is_null() & text.is_not_null()).to_numpy()
    if bad.any():
        lowered = text.str.to_lowercase()
        if booleans and bool(lowered.drop_nulls().is_in(BOOLEANS).all()):
            return (lowered == "true").cast(pl.Float64).alias(column.name)
        first = int(np.argmax(bad))
        raise LogError(
            f"{path}, line {int(rows[first]) + 2}, column {excerpt(column.name)}: "
            f"{_not_a_number(str(text[first]), booleans=booleans)}"
        )
    return values


def _not_a_number(cell: str, *, booleans: bool) -> str:
    """``'0x10' is not a number``, with a hint where the cell is a number written otherwise.

    ``booleans``: true and false count as numbers in a column of nothing else.
    ``analyze``'s refusal of the cell (:func:`parse_floats`) and ``inspect``'s note of the
    first such cell of a column of numbers (:func:`.table_description.describe_csv`) alike.
    """
    hint = ""
    if booleans and cell.lower() in BOOLEANS:
        hint = " (true and false read as 1 and 0 only in a column of nothing else)"
    elif ISO_DATE.match(cell):  # 2024-01-01T00:00: no seconds
        hint = " (a date and time is read with its seconds, e.g. 2024-01-01T00:00:00)"
    elif _GROUPED.fullmatch(cell):  # "1,000": one thousand, or one?
        hint = (
            " (digits grouped by thousands, or a decimal comma? hybridlog reads digits "
            "alone, with a point as the decimal separator)"
        )
    elif _DECIMAL_COMMA.fullmatch(cell):  # "1,5" quoted, as Excel writes it
        hint = " (a decimal comma? hybridlog reads a point as the decimal separator)"
    return f"{excerpt(cell)} is not a number{hint}"


def texts_among_numbers(tally: ColumnTally) -> list[str]:
    """Where a CSV column of numbers has cells that are not: the first, in analyze's words.

    ``inspect`` showed such a column as ``string`` and said no more, and ``analyze`` then
    refused it: ``line 4, column 'y': '0x10' is not a number``.  Nothing for a column
    without a number (labels), nor for one of booleans.
    """
    if tally.first_text is None or not tally.numbers or tally.dtype != "string":
        return []
    row, cell = tally.first_text
    return [
        f"line {row + 2}, column {excerpt(tally.name)}: {_not_a_number(cell, booleans=True)}; "
        f"{tally.numbers} of its {tally.count} cells are numbers: analyze takes it as mode "
        "ids, not as a signal"
    ]
