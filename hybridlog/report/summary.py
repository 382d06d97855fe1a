"""Summary tables for people and for spreadsheets: ``compare``, ``batch`` and ``cluster``.

:func:`markdown_table` formats numbers per column for reading (thousands separators, the
same decimals down a column); :func:`write_summary_csv` keeps the raw values;
:func:`comparison_markdown` is ``comparison.md`` of ``hybridlog compare``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import polars as pl

if TYPE_CHECKING:
    from hybridlog.report.document import Report

__all__ = [
    "SIGNIFICANT_DIGITS",
    "comparison_markdown",
    "markdown_table",
    "write_summary_csv",
]

SIGNIFICANT_DIGITS = 4
"""Markdown tables show every number of a column with at least this many significant digits."""


def _column_format(values: Sequence[object]) -> Callable[[object], str]:
    """One format for a whole column of a table for people (CSV files keep raw values).

    Integers get thousands separators.  Floats get the same number of decimals, enough for
    :data:`SIGNIFICANT_DIGITS` digits of the smallest non-zero magnitude (``1,668,410``,
    ``87.39``, ``0.6013``), with thousands separators; a column spanning more than six
    decades, or needing more than six decimals, is written in scientific notation.
    """
    floats = [
        abs(float(v))
        for v in values
        if isinstance(v, float) and not isinstance(v, bool) and math.isfinite(v) and v != 0.0
    ]
    spec = ",.0f"
    if floats:
        small, big = min(floats), max(floats)
        decimals = SIGNIFICANT_DIGITS - 1 - math.floor(math.log10(small))
        wide = decimals > 6 or big / small > 1e6
        spec = ".3e" if wide else f",.{max(decimals, 0)}f"

    def cell(value: object) -> str:
        if value is None:
            return "n/a"
        if isinstance(value, bool):
            return str(value)
        if isinstance(value, int):
            return f"{value:,}"
        if isinstance(value, float):
            return format(value, spec) if math.isfinite(value) else str(value)
        return str(value).replace("|", "\\|")

    return cell


def markdown_table(header: Sequence[str], rows: Sequence[Sequence[object]]) -> str:
    """A GitHub-flavoured Markdown table, numbers formatted per column for people.

    Columns holding numbers are right-aligned; see :func:`_column_format` for the digits.
    """
    formats = [_column_format([row[j] for row in rows]) for j in range(len(header))]
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


def comparison_markdown(title: str, table: str, reports: Mapping[str, Report]) -> str:
    """``comparison.md``: the table, where each report is, and each estimator's notes."""
    lines = [f"# {title}", "", table, ""]
    lines += [f"- `{name}`: [{name}/report.md]({name}/report.md)" for name in reports]
    for name, report in reports.items():
        if report.notes:
            lines += ["", f"## Notes on `{name}`", "", *(f"- {note}" for note in report.notes)]
    return "\n".join(lines) + "\n"


def write_summary_csv(path: Path, header: Sequence[str], rows: Sequence[Sequence[object]]) -> None:
    """A small summary table as CSV (empty cells for missing values)."""
    frame = pl.DataFrame(
        [[None if v is None else v for v in row] for row in rows],
        schema=list(header),
        orient="row",
        infer_schema_length=None,
    )
    frame.write_csv(path)
