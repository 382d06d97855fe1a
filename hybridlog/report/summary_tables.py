"""The summaries' tables (``compare``, ``batch``, ``cluster``): for people, for spreadsheets.

:func:`markdown_table` formats numbers per column for reading (thousands separators, the
same decimals down a column); :func:`write_summary_csv` keeps the raw values.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Callable, Sequence
from pathlib import Path

from hybridlog.report.markdown import FIXED_LIMIT, escape_markdown

__all__ = ["MAX_EXTRA_DIGITS", "SIGNIFICANT_DIGITS", "markdown_table", "write_summary_csv"]


SIGNIFICANT_DIGITS = 4
"""Markdown tables show every number of a column with at least this many significant digits."""


MAX_EXTRA_DIGITS = 17 - SIGNIFICANT_DIGITS
"""Digits a column of a Markdown table gains, at most, so that different values differ.

With them its smallest non-zero magnitude has 17 significant digits, which tell any two
different float64 values apart (the cap was 4: VAFs of 99.9999999912 and 99.9999999934
both read ``100.000000``, neither being 100).  A column gains only the digits it needs."""


def _reads_whole(value: float, spec: str) -> bool:
    """Whether ``value`` formatted by ``spec`` reads as a whole, 1 or 100, that it is not.

    A mode accuracy of 0.9999997 is no ``1.0000`` and a VAF of 99.99568 % no ``100.00``
    (report.md's rule, :func:`~hybridlog.report.markdown.format_percent`).
    """
    shown = float(format(value, spec).replace(",", ""))
    return shown in (1.0, 100.0) and value != shown


def _column_format(values: Sequence[object], *, distinct: bool) -> Callable[[object], str]:
    """One format for a whole column of a table for people (CSV files keep raw values).

    Integers get thousands separators.  Floats get the same number of decimals, enough for
    :data:`SIGNIFICANT_DIGITS` digits of the smallest non-zero magnitude (``1,668,410``,
    ``87.39``, ``0.6013``), with thousands separators; a column spanning more than six
    decades, needing more than six decimals, or reaching :data:`FIXED_LIMIT`, is written in
    scientific notation.  With ``distinct``, then more digits, up to
    :data:`MAX_EXTRA_DIGITS`, while two different values of the column would print alike:
    side by side, a VAF of 99.9721 and one of 99.9655 must not both read ``99.97``.  And
    always more, as far, while a value would read as a whole, 1 or 100, it is not
    (:func:`_reads_whole`).
    """
    finite = {
        float(v)
        for v in values
        if isinstance(v, float) and not isinstance(v, bool) and math.isfinite(v)
    }
    floats = [abs(v) for v in finite if v != 0.0]
    spec = ",.0f"
    if floats:
        small, big = min(floats), max(floats)
        decimals = SIGNIFICANT_DIGITS - 1 - math.floor(math.log10(small))
        wide = decimals > 6 or big / small > 1e6 or big >= FIXED_LIMIT
        digits = SIGNIFICANT_DIGITS - 1 if wide else max(decimals, 0)
        for extra in range(MAX_EXTRA_DIGITS + 1):
            spec = f".{digits + extra}e" if wide else f",.{digits + extra}f"
            apart = not distinct or len({format(v, spec) for v in finite}) == len(finite)
            if apart and not any(_reads_whole(v, spec) for v in finite):
                break

    def cell(value: object) -> str:
        if value is None:
            return "n/a"
        if isinstance(value, bool):
            return str(value)
        if isinstance(value, int):
            return f"{value:,}"
        if isinstance(value, float):
            return format(value, spec) if math.isfinite(value) else str(value)
        return escape_markdown(str(value), line_start=False)  # a cell starts no block

    return cell


def markdown_table(
    header: Sequence[str],
    rows: Sequence[Sequence[object]],
    *,
    distinct: bool = False,
    escape_header: bool = True,
) -> str:
    """A GitHub-flavoured Markdown table, numbers formatted per column for people.

    Columns holding numbers are right-aligned; see :func:`_column_format` for the digits.
    ``distinct``: different values of a column never print alike (a few rows compared side by
    side, as ``compare``'s; a batch of many logs would grow every column's digits).
    The header's cells are text, escaped as the rows' are: a column named after a state
    ``_x_`` (``state_rmse._x_``) read ``state_rmse.`` and an emphasised ``x`` in
    comparison.md; ``escape_header=False`` for a header of fixed words written as Markdown
    (``cluster``'s on the terminal).
    """
    if escape_header:
        header = [escape_markdown(name, line_start=False) for name in header]
    formats = [
        _column_format([row[j] for row in rows], distinct=distinct) for j in range(len(header))
    ]
    numeric = [
        any(isinstance(row[j], int | float) and not isinstance(row[j], bool) for row in rows)
        for j in range(len(header))
    ]
    lines = [
        "| " + " | ".join(header) + " |",
        "|" + "".join("---:|" if n else "---|" for n in numeric),
    ]
    lines += [
        "| " + " | ".join(f(v) for f, v in zip(formats, row, strict=True)) + " |" for row in rows
    ]
    return "\n".join(lines)


def write_summary_csv(path: Path, header: Sequence[str], rows: Sequence[Sequence[object]]) -> None:
    r"""A small summary table as CSV: raw values, an empty cell for a missing one.

    Written with :mod:`csv` (quoting as RFC 4180 asks, newline line ends), not polars: the
    batch process of ``batch --jobs N`` writes ``summary.csv`` and otherwise needs no polars
    (:mod:`hybridlog.jobs.batch`), for a table of one row per log.  Floats are written with
    their shortest round-trip digits (``repr``), booleans as ``true``/``false``, non-finite
    floats as ``NaN``/``inf``/``-inf``: what polars reads back as the same values.

    Each row is made with ``\r\n`` line ends, which end in ``\n``: :mod:`csv` quotes a
    cell only for the characters of its own line end, and with ``\n`` alone a log named
    with a carriage return was written bare, a line break to every reader (the csv module,
    polars and spreadsheets split the row there).
    """
    row_text = io.StringIO()
    writer = csv.writer(row_text, lineterminator="\r\n")
    with path.open("w", encoding="utf-8", newline="") as file:
        cells: list[list[object]] = [list(header)]
        cells += ([_csv_cell(value) for value in row] for row in rows)
        for row in cells:
            row_text.seek(0)
            row_text.truncate()
            writer.writerow(row)
            file.write(row_text.getvalue()[:-2] + "\n")


def _csv_cell(value: object) -> object:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float) and math.isnan(value):
        return "NaN"
    return value
