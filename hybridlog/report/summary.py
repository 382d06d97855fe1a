"""The summaries' documents: ``comparison.md`` of ``compare``, ``summary.md``/``.csv`` of ``batch``.

:func:`comparison_markdown` is ``comparison.md`` of ``hybridlog compare``;
:func:`batch_markdown` and :func:`batch_rows_csv` are ``summary.md`` and ``summary.csv`` of
``hybridlog batch``, from one :class:`~hybridlog.report.summary_rows.BatchRow` per log.
Their parts live in modules of their own: the tables' digits and the CSV writer in
:mod:`~hybridlog.report.summary_tables`, the notes every report has and the warnings in
:mod:`~hybridlog.report.summary_notes`, a log's row and the columns in
:mod:`~hybridlog.report.summary_rows`, and a batch's offline pass against the filter (the
gains, where the smoother fell back) in :mod:`~hybridlog.report.summary_offline`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from hybridlog.report.coverage import mode_coverage
from hybridlog.report.markdown import code_span, escape_markdown, plural
from hybridlog.report.summary_budget import SUMMARY_BYTES, Listing, within_budget
from hybridlog.report.summary_notes import (
    MAX_NAMED,
    common_notes,
    warning_notes,
    warnings_section,
)
from hybridlog.report.summary_offline import offline_columns, offline_section
from hybridlog.report.summary_rows import (
    BATCH_METRICS,
    BatchRow,
    gate_cell,
    gated_columns,
    state_columns,
)
from hybridlog.report.summary_tables import markdown_table, write_summary_csv

if TYPE_CHECKING:
    from hybridlog.report.document import Report

__all__ = ["batch_markdown", "batch_rows_csv", "comparison_markdown"]


def comparison_markdown(
    title: str,
    table: str,
    reports: Mapping[str, Report],
    failures: Mapping[str, str] | None = None,
    *,
    sections: Sequence[str] = (),
    gates: Sequence[str] = (),
) -> str:
    """``comparison.md``: the table, where each report is, and the notes.

    Notes every report has (the log's: a true mode that starts late; the model's: twin
    modes) are written once, under "Notes on every estimator"; each estimator's own after.
    ``failures``: the estimators whose run failed (no report), each with its reason, listed
    under "Failed estimators" as a batch's summary lists its failed logs.  The estimators
    whose report warns are listed under "Warnings", the first warning each
    (:func:`warnings_section`), right after the failed ones.  ``sections``: Markdown lines
    put after those (:mod:`hybridlog.report.comparison`: the samples each number is over,
    why a cell is ``n/a``).  ``gates``: the CI gates as given (``--fail-under fit=50``),
    named under the table as summary.md names them: its ``gates`` column's ``pass (2)`` did
    not say which two.
    """
    failures = failures or {}
    lines = [f"# {escape_markdown(title)}", "", table, ""]
    if gates:
        lines += ["Gates: " + ", ".join(code_span(gate) for gate in gates) + ".", ""]
    lines += [f"- `{name}`: [{name}/report.md]({name}/report.md)" for name in reports]
    if failures:
        count = f"{len(failures)} of {len(reports) + len(failures)}"
        lines += ["", f"## Failed estimators ({count})", ""]
        lines += [f"- `{name}`: {escape_markdown(why)}" for name, why in failures.items()]
    shared = common_notes(reports.values()) if len(reports) > 1 else []
    every = "Notes on every estimator"
    lines += warnings_section(
        [(f"`{name}`", report) for name, report in reports.items()],
        shared,
        kind="estimator",
        every=every,
    )
    lines += sections
    if shared:
        lines += ["", f"## {every}", ""]
        lines += [f"- {escape_markdown(note)}" for note in shared]
    for name, report in reports.items():
        own = [note for note in report.notes if note not in shared]
        if own:
            notes = [f"- {escape_markdown(note)}" for note in own]
            lines += ["", f"## Notes on `{name}`", "", *notes]
    return "\n".join(lines) + "\n"


def _miss_line(row: BatchRow) -> str:
    """A log's item among the missed gates: the gates it missed, with its values."""
    return f"- {escape_markdown(row.log)}: {escape_markdown('; '.join(row.missed))}"


def _failure_line(row: BatchRow) -> str:
    """A failed log's item: its error, led by the log's name once.

    An error names the log it is about, as it does on ``analyze``'s terminal: the item
    read ``- alog/bad.csv: alog/bad.csv, line 3, column 'y1': ...`` where the error began
    with the name; such an error is the item alone, another is put after the name.
    """
    error = row.error or ""
    if error.startswith(row.log) and error[len(row.log) : len(row.log) + 1] in (":", ","):
        return f"- {escape_markdown(error)}"
    return f"- {escape_markdown(row.log)}: {escape_markdown(error)}"


def _partial_section(rows: Sequence[BatchRow]) -> list[str]:
    """summary.md's logs whose mode accuracy is over part of the log (a late true mode)."""
    partial = [
        (row.log, part)
        for row in rows
        if row.report is not None and (part := mode_coverage(row.report)) is not None
    ]
    if not partial:
        return []
    analysed = sum(row.report is not None for row in rows)
    lines = [
        "",
        f"## Mode accuracy over part of the log ({len(partial):,} of {analysed:,})",
        "",
        "These logs' true mode starts after their first sample or has no sample within "
        "dt/2 of some samples (a gap): `mode_accuracy` (and the gates on it, and with an "
        "offline pass the filter's own too) is over the samples with a true mode, counted in "
        "summary.csv's `mode_samples`.",
        "",
    ]
    lines += [
        f"- {escape_markdown(log)}: over {escape_markdown(part)}"
        for log, part in partial[:MAX_NAMED]
    ]
    if len(partial) > MAX_NAMED:
        lines.append(f"- and {len(partial) - MAX_NAMED:,} more (summary.csv's `mode_samples`)")
    return lines


NOTES_ON_EVERY_LOG = "Notes on every analysed log"
"""summary.md's heading of the notes every analysed log's report has."""


def _notes_section(shared: Sequence[str]) -> list[str]:
    """summary.md's notes every analysed log's report has (the model's: twin modes), once.

    ``shared``: :func:`common_notes` of the analysed logs' reports.  A log's own notes stay
    in its report.md (its warnings are listed too, :func:`warnings_section`): a batch of 100
    logs would repeat a model's note 100 times.
    """
    if not shared:
        return []
    return [
        "",
        f"## {NOTES_ON_EVERY_LOG}",
        "",
        *(f"- {escape_markdown(note)}" for note in shared),
        "",
        "Each log's other notes are in its report.md.",
    ]


def _gate_cell(row: BatchRow) -> str:
    if row.status == "failed":
        return "not analysed"
    return gate_cell(len(row.gates), row.missed)


def batch_markdown(
    title: str,
    rows: Sequence[BatchRow],
    gates: Sequence[str],
    offline: Sequence[str] | None = None,
    gated: Sequence[str] = (),
    *,
    others: Sequence[tuple[str, str]] = (),
) -> tuple[str, str]:
    """``summary.md`` of a batch: failures first, then natural order; and its table alone.

    ``rows`` come in natural order; the table lists the logs that could not be analysed,
    then those that missed a gate, then the others, each group in that order, with the gate
    results per log.  Right after it come why each failed log failed, the gates each log
    missed and the logs with warnings; then the rest (the logs scored over part of their
    length, the offline pass, the notes every log has): a CI job summary of a batch with an
    offline pass put a failed log's error under its comparison of the two sides.  Fit for a
    CI job summary (GitHub-flavoured Markdown).
    ``offline``: the metrics compared when the run has an offline pass
    (:func:`offline_metrics`; ``None`` otherwise): the table then has the filter's own mode
    accuracy beside the offline one, and a section compares the two sides over the batch
    (:func:`offline_section`).  ``gated``: the metrics of the gates, those not shown already
    each a column (:func:`gated_columns`).  ``others``: ``(name, kind)`` of the report
    folders in the batch folder of no log of this run (:data:`OTHER_KINDS`), listed last,
    by kind: they are not summarised, and read as this run's otherwise.
    """
    failed = [row for row in rows if row.status == "failed"]
    missed = [row for row in rows if row.status != "failed" and row.missed]
    passed = [row for row in rows if row.passed]
    counts = ", ".join(
        f"{n:,} {what}"
        for n, what in (
            (sum(r.status == "done" for r in rows), "analysed"),
            (sum(r.status == "skipped" for r in rows), "skipped (unchanged)"),
            (len(failed), "failed"),
            (len(missed), "missed a gate"),
        )
        if n
    )
    # "all passed" of a batch without gates read as gates checked and met (summary.png
    # said "no gate given"): without a gate result, a log is analysed or not
    gated_rows = any(row.gates for row in rows)
    word = "passed" if gated_rows else "analysed"
    verdict = (
        f"all {word}" if len(passed) == len(rows) else f"{len(rows) - len(passed):,} not {word}"
    )
    filtered = ("filtered_mode_accuracy",) if offline is not None else ()
    extra = gated_columns(gated, (*BATCH_METRICS, *filtered))
    header = ("log", "status", "gates", *BATCH_METRICS, *filtered, *extra, "report")
    table = markdown_table(
        header,
        [
            [
                row.log,
                row.status,
                _gate_cell(row),
                *row.metrics(),
                *(row.offline_pairs(["mode_accuracy"])[0][2] for _ in filtered),
                *row.values(extra),
                "n/a" if row.report is None else f"{row.folder}/report.md",
            ]
            for row in [*failed, *missed, *passed]
        ],
    )
    lines = [
        f"# Batch: {escape_markdown(title)}",
        "",
        f"**{plural(len(rows), 'log')}: {verdict}** ({counts}).",
    ]
    if gates:
        lines += ["", "Gates: " + ", ".join(f"`{gate}`" for gate in gates) + "."]
    elif not gated_rows and len(failed) < len(rows):
        lines += ["", "No gate given."]
    head, rule, *table_rows = table.split("\n")
    shown = Listing(
        table_rows,
        lambda n: (
            f"\nThe table leaves out its last {plural(n, 'log')} (summary.csv "
            f"lists every log): {_BUDGET_REASON}."
        ),
    )
    listed_failures = Listing(
        [_failure_line(row) for row in failed],
        lambda n: f"- and {n:,} more (summary.csv's `error` column)",
    )
    listed_misses = Listing(
        [_miss_line(row) for row in missed],
        lambda n: f"- and {n:,} more (summary.csv's `gate_failures` column)",
    )
    parts: list[str | Listing] = [*lines, "", head, rule, shown]
    if failed:
        parts += ["", f"## Failed logs ({len(failed):,} of {len(rows):,})", "", listed_failures]
    if missed:
        parts += ["", f"## Missed gates ({len(missed):,} of {len(rows):,})", "", listed_misses]
    lines = []
    shared = common_notes(row.report for row in rows if row.report is not None)
    lines += warnings_section(
        [(escape_markdown(row.log), row.report) for row in rows],
        shared,
        kind="analysed log",
        every=NOTES_ON_EVERY_LOG,
    )
    lines += _partial_section(rows)
    if offline is not None:
        lines += offline_section(rows, offline)
    lines += _notes_section(shared)
    lines += _made_elsewhere_section(rows)
    lines += _others_section(others)
    fitted = within_budget([*parts, *lines], [shown, listed_misses, listed_failures])
    return table, "\n".join(fitted) + "\n"


_BUDGET_REASON = (
    f"summary.md is kept within {SUMMARY_BYTES:,} bytes, what a CI job summary shows "
    "(GitHub's: 1 MiB)"
)


def _made_elsewhere_section(rows: Sequence[BatchRow]) -> list[str]:
    """summary.md's section on the reports reused from the log at another path (``made_from``).

    The log's content is the one an earlier run analysed, so its report is reused, not
    redone; but that report's title and report.json's ``log`` name the path it was read at
    then, which this run's summaries do not.
    """
    moved = [row for row in rows if row.made_from is not None]
    if not moved:
        return []
    return [
        "",
        f"## Reports made from the log at another path ({len(moved):,})",
        "",
        "Unchanged since an earlier run analysed them at another path, so their reports were "
        "reused: report.md and report.json name that path.",
        "",
        *(
            f"- {escape_markdown(row.log)}: read as {escape_markdown(row.made_from or '')}"
            for row in moved
        ),
    ]


OTHER_KINDS = {
    "log": "Of logs not in this batch (renamed, moved or left out since an earlier run into "
    "this folder): kept, not summarised here.",
    "analyze": "Reports `hybridlog analyze` wrote into this folder: kept, not summarised here.",
    "compare": "Comparisons `hybridlog compare` wrote into this folder: kept, not summarised here.",
    "batch": "Folders of other batches inside this one: kept, not summarised here (their own "
    "summaries name their reports).",
}
"""What summary.md says of each kind of other report folder
(:func:`hybridlog.jobs.batch_others.other_folders`), in this order."""


def _others_section(others: Sequence[tuple[str, str]]) -> list[str]:
    """summary.md's "Other report folders": ``(name, kind)`` each, grouped by kind."""
    if not others:
        return []
    lines = ["", f"## Other report folders ({len(others):,})"]
    for kind, says in OTHER_KINDS.items():
        names = [name for name, of in others if of == kind]
        if names:
            lines += ["", says, "", *(f"- {escape_markdown(name)}" for name in names)]
    return lines


def batch_rows_csv(
    path: Path,
    rows: Sequence[BatchRow],
    offline: Sequence[str] | None = None,
    gated: Sequence[str] = (),
) -> None:
    """``summary.csv`` of a batch: one row per log in natural order, raw values.

    ``folder`` is empty for a failed log, as summary.md's link is ``n/a``: it has no report.
    ``mode_samples``, after ``mode_accuracy``: the samples it is over (``modes.samples``:
    fewer than ``samples`` where the true mode starts late; empty without a true mode).
    ``offline``: the metrics compared when the run has an offline pass
    (:func:`offline_metrics`), which adds :func:`offline_columns` after ``mode_accuracy``
    (empty cells for a failed log); ``None`` otherwise (then ``state_rmse.<x>`` after
    ``mode_samples`` for each state a report has an RMSE of, :func:`state_columns`).  ``gated``: the
    metrics of the gates; those without a column yet get one before ``gate_failures``
    (:func:`gated_columns`), the report's raw value.  ``warnings``, after ``gate_failures``:
    the number of the report's notes that warn (:func:`warning_notes`; empty for a failed
    log).
    """
    columns = () if offline is None else offline_columns(offline)
    # the states' RMSEs (with an offline pass, among its columns, each beside the filter's)
    states = state_columns(row.report for row in rows) if offline is None else ()
    extra = gated_columns(gated, (*BATCH_METRICS, *states, *columns))
    header = (
        "log",
        "status",
        *BATCH_METRICS,
        "mode_samples",
        *states,
        *columns,
        *extra,
        "gate_failures",
        "warnings",
        "error",
        "folder",
    )
    write_summary_csv(
        path,
        header,
        [
            [
                row.log,
                row.status,
                *row.metrics(),
                None if row.report is None else row.report.modes.samples,
                *row.values(states),
                *(() if offline is None else row.offline_cells(offline)),
                *row.values(extra),
                "; ".join(row.missed) or None,
                None if row.report is None else len(warning_notes(row.report)),
                row.error,
                row.folder if row.report is not None else None,  # a failed log has none
            ]
            for row in rows
        ],
    )
