"""Summary tables for people and for spreadsheets: ``compare``, ``batch`` and ``cluster``.

:func:`markdown_table` formats numbers per column for reading (thousands separators, the
same decimals down a column); :func:`write_summary_csv` keeps the raw values;
:func:`comparison_markdown` is ``comparison.md`` of ``hybridlog compare``;
:func:`batch_markdown` and :func:`batch_rows_csv` are ``summary.md`` and ``summary.csv`` of
``hybridlog batch``, from one :class:`BatchRow` per log.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from hybridlog.errors import as_text
from hybridlog.report.markdown import FIXED_LIMIT, escape_markdown

if TYPE_CHECKING:
    from hybridlog.report.document import Report

__all__ = [
    "MAX_EXTRA_DIGITS",
    "SIGNIFICANT_DIGITS",
    "BatchRow",
    "batch_markdown",
    "batch_rows_csv",
    "comparison_markdown",
    "gate_cell",
    "markdown_table",
    "write_summary_csv",
]

SIGNIFICANT_DIGITS = 4
"""Markdown tables show every number of a column with at least this many significant digits."""

MAX_EXTRA_DIGITS = 4
"""Digits a column of a Markdown table gains, at most, so that different values differ."""


def _column_format(values: Sequence[object], *, distinct: bool) -> Callable[[object], str]:
    """One format for a whole column of a table for people (CSV files keep raw values).

    Integers get thousands separators.  Floats get the same number of decimals, enough for
    :data:`SIGNIFICANT_DIGITS` digits of the smallest non-zero magnitude (``1,668,410``,
    ``87.39``, ``0.6013``), with thousands separators; a column spanning more than six
    decades, needing more than six decimals, or reaching :data:`FIXED_LIMIT`, is written in
    scientific notation.  With ``distinct``, then more digits, up to
    :data:`MAX_EXTRA_DIGITS`, while two different values of the column would print alike:
    side by side, a VAF of 99.9721 and one of 99.9655 must not both read ``99.97``.
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
        for extra in range(MAX_EXTRA_DIGITS + 1 if distinct else 1):
            spec = f".{digits + extra}e" if wide else f",.{digits + extra}f"
            if len({format(v, spec) for v in finite}) == len(finite):
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
        return escape_markdown(str(value))

    return cell


def markdown_table(
    header: Sequence[str], rows: Sequence[Sequence[object]], *, distinct: bool = False
) -> str:
    """A GitHub-flavoured Markdown table, numbers formatted per column for people.

    Columns holding numbers are right-aligned; see :func:`_column_format` for the digits.
    ``distinct``: different values of a column never print alike (a few rows compared side by
    side, as ``compare``'s; a batch of many logs would grow every column's digits).
    """
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


def comparison_markdown(title: str, table: str, reports: Mapping[str, Report]) -> str:
    """``comparison.md``: the table, where each report is, and each estimator's notes."""
    lines = [f"# {escape_markdown(title)}", "", table, ""]
    lines += [f"- `{name}`: [{name}/report.md]({name}/report.md)" for name in reports]
    for name, report in reports.items():
        if report.notes:
            lines += ["", f"## Notes on `{name}`", "", *(f"- {as_text(n)}" for n in report.notes)]
    return "\n".join(lines) + "\n"


def write_summary_csv(path: Path, header: Sequence[str], rows: Sequence[Sequence[object]]) -> None:
    """A small summary table as CSV: raw values, an empty cell for a missing one.

    Written with :mod:`csv` (quoting as RFC 4180 asks, newline line ends), not polars: the
    batch process of ``batch --jobs N`` writes ``summary.csv`` and otherwise needs no polars
    (:mod:`hybridlog.jobs.batch`), for a table of one row per log.  Floats are written with
    their shortest round-trip digits (``repr``), booleans as ``true``/``false``, non-finite
    floats as ``NaN``/``inf``/``-inf``: what polars reads back as the same values.
    """
    with path.open("w", encoding="utf-8", newline="") as file:
        writer = csv.writer(file, lineterminator="\n")
        writer.writerow(header)
        writer.writerows([_csv_cell(value) for value in row] for row in rows)


def _csv_cell(value: object) -> object:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float) and math.isnan(value):
        return "NaN"
    return value


# --- hybridlog batch ----------------------------------------------------------------------------


@dataclass(frozen=True)
class BatchRow:
    """One log of a batch, as its summaries show it.

    Attributes
    ----------
    log:
        The log's path as given.
    folder:
        Its report folder, relative to the batch folder.
    status:
        ``done``, ``skipped`` (an earlier report of the same run reused) or ``failed``.
    report:
        The report (``None`` when the log could not be analysed).
    error:
        The one-line error of a failed log.
    gates:
        ``(gate, failure)`` per CI gate, e.g. ``("--fail-under vaf=90", "vaf = 87.2 is under
        the bound 90")``; ``failure`` is ``None`` for a gate met.  Empty for a failed log.
    """

    log: str
    folder: str
    status: str
    report: Report | None
    error: str | None
    gates: tuple[tuple[str, str | None], ...] = ()

    @property
    def missed(self) -> list[str]:
        """The failure messages of the gates this log missed."""
        return [failure for _, failure in self.gates if failure is not None]

    @property
    def passed(self) -> bool:
        """Analysed, and every gate met."""
        return self.status != "failed" and not self.missed

    def metrics(self) -> list[object]:
        """The key metrics shown for every log: samples, VAF, MSE, mode accuracy."""
        r = self.report
        if r is None:
            return [None, None, None, None]
        return [r.samples, r.vaf, r.mse, r.modes.accuracy]


BATCH_METRICS = ("samples", "vaf", "mse", "mode_accuracy")
"""The metrics of each log in the batch summaries (report keys)."""


def gate_cell(n_gates: int, missed: Sequence[str]) -> str:
    """The gates of one run in a summary table: ``pass (2)``, ``FAIL: vaf = 87.2 is ...``.

    Empty when no gate was given.
    """
    if not n_gates:
        return ""
    if not missed:
        return f"pass ({n_gates})"
    return "FAIL: " + "; ".join(missed)


def _gate_cell(row: BatchRow) -> str:
    if row.status == "failed":
        return "not analysed"
    return gate_cell(len(row.gates), row.missed)


def batch_markdown(title: str, rows: Sequence[BatchRow], gates: Sequence[str]) -> tuple[str, str]:
    """``summary.md`` of a batch: failures first, then natural order; and its table alone.

    ``rows`` come in natural order; the table lists the logs that could not be analysed,
    then those that missed a gate, then the others, each group in that order, with the gate
    results per log.  Fit for a CI job summary (GitHub-flavoured Markdown).
    """
    failed = [row for row in rows if row.status == "failed"]
    missed = [row for row in rows if row.status != "failed" and row.missed]
    passed = [row for row in rows if row.passed]
    counts = ", ".join(
        f"{n} {what}"
        for n, what in (
            (sum(r.status == "done" for r in rows), "analysed"),
            (sum(r.status == "skipped" for r in rows), "skipped (unchanged)"),
            (len(failed), "failed"),
            (len(missed), "missed a gate"),
        )
        if n
    )
    verdict = "all passed" if len(passed) == len(rows) else f"{len(rows) - len(passed)} not passed"
    header = ("log", "status", "gates", *BATCH_METRICS, "report")
    table = markdown_table(
        header,
        [
            [
                row.log,
                row.status,
                _gate_cell(row),
                *row.metrics(),
                "n/a" if row.report is None else f"{row.folder}/report.md",
            ]
            for row in [*failed, *missed, *passed]
        ],
    )
    lines = [
        f"# Batch: {escape_markdown(title)}",
        "",
        f"**{len(rows)} logs: {verdict}** ({counts}).",
    ]
    if gates:
        lines += ["", "Gates: " + ", ".join(f"`{gate}`" for gate in gates) + "."]
    lines += ["", table]
    if failed:
        lines += ["", f"## Failed logs ({len(failed)} of {len(rows)})", ""]
        lines += [
            f"- {escape_markdown(row.log)}: {escape_markdown(row.error or '')}" for row in failed
        ]
    if missed:
        lines += ["", f"## Missed gates ({len(missed)} of {len(rows)})", ""]
        lines += [
            f"- {escape_markdown(row.log)}: {escape_markdown('; '.join(row.missed))}"
            for row in missed
        ]
    return table, "\n".join(lines) + "\n"


def batch_rows_csv(path: Path, rows: Sequence[BatchRow]) -> None:
    """``summary.csv`` of a batch: one row per log in natural order, raw values.

    ``folder`` is empty for a failed log, as summary.md's link is ``n/a``: it has no report.
    """
    header = ("log", "status", *BATCH_METRICS, "gate_failures", "error", "folder")
    write_summary_csv(
        path,
        header,
        [
            [
                row.log,
                row.status,
                *row.metrics(),
                "; ".join(row.missed) or None,
                row.error,
                row.folder if row.report is not None else None,  # a failed log has none
            ]
            for row in rows
        ],
    )
