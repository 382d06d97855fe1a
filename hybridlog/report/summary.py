"""Summary tables for people and for spreadsheets: ``compare``, ``batch`` and ``cluster``.

:func:`markdown_table` formats numbers per column for reading (thousands separators, the
same decimals down a column); :func:`write_summary_csv` keeps the raw values;
:func:`comparison_markdown` is ``comparison.md`` of ``hybridlog compare``;
:func:`batch_markdown` and :func:`batch_rows_csv` are ``summary.md`` and ``summary.csv`` of
``hybridlog batch``, from one :class:`BatchRow` per log.

A batch with an offline pass (``--smooth``, ``--mode-sequence``; ``offline`` given)
shows beside each log's offline mode accuracy the filter's own, and per state both RMSEs
(:data:`OFFLINE_COLUMNS`, :meth:`BatchRow.offline_metrics`), and summary.md the gain over
the batch (:func:`offline_gains`): per metric the medians, the median change and the logs
where the offline estimate is worse than the filter's, by name.  Where a smoother ran,
summary.csv says on how many samples it left the forward estimate standing and how much of
the smoothed estimates' weight those steps carry (:data:`FALLBACK_COLUMNS`), and summary.md
lists those logs, the largest share first (:func:`fallback_logs`).  A batch without one
writes the same columns as before.

A report's notes that start ``WARNING:`` (:func:`warning_notes`: the innovations' test of a
filter, a true mode silent longer than ``--max-gap``, a signal bridged across gaps) are
counted per log in summary.csv's ``warnings`` column (per estimator in comparison.csv's),
and summary.md and comparison.md list the logs (estimators) with warnings, the first of each
(:func:`warnings_section`): in a batch of 1,000 logs the few whose sensor is scaled are
otherwise seen only by opening each report.md.
"""

from __future__ import annotations

import csv
import math
import statistics
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from hybridlog.report.coverage import mode_coverage
from hybridlog.report.gates import metric as report_metric
from hybridlog.report.markdown import (
    FIXED_LIMIT,
    WARNING_PREFIX,
    code_span,
    escape_markdown,
    plural,
)

if TYPE_CHECKING:
    from hybridlog.estimators.result import Fallbacks
    from hybridlog.report.document import Report
    from hybridlog.report.report_parts import Smoothing, SmoothingMetrics

__all__ = [
    "FALLBACK_COLUMNS",
    "MAX_EXTRA_DIGITS",
    "MAX_NAMED",
    "SIGNIFICANT_DIGITS",
    "BatchRow",
    "OfflineGain",
    "batch_markdown",
    "batch_rows_csv",
    "common_notes",
    "comparison_markdown",
    "fallback_cells",
    "fallback_logs",
    "gate_cell",
    "gated_columns",
    "markdown_table",
    "offline_columns",
    "offline_gains",
    "offline_label",
    "offline_metrics",
    "offline_samples_apart",
    "state_columns",
    "warning_notes",
    "warnings_section",
    "write_summary_csv",
]

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


def common_notes(reports: Iterable[Report]) -> list[str]:
    """The notes every one of ``reports`` has, in the first one's order (none: ``[]``)."""
    reports = list(reports)
    if not reports:
        return []
    others = [set(report.notes) for report in reports[1:]]
    return [note for note in dict.fromkeys(reports[0].notes) if all(note in o for o in others)]


def warning_notes(report: Report | None) -> list[str]:
    """The notes of ``report`` that warn (they start :data:`WARNING_PREFIX`), in order.

    Every kind alike: the summaries count and list them without knowing which test wrote
    them.  None for a log that could not be analysed (``report`` ``None``).
    """
    return [] if report is None else [n for n in report.notes if n.startswith(WARNING_PREFIX)]


def warnings_section(
    named: Sequence[tuple[str, Report | None]],
    shared: Sequence[str],
    *,
    kind: str,
    every: str,
) -> list[str]:
    """The Markdown lines listing which of ``named`` warn, the first warning of each.

    ``named``: ``(name, report)`` in the summary's order, the name as Markdown already
    (a log escaped, an estimator in backticks); ``None`` for a report not written.
    ``shared``: the notes said once under ``every`` (the heading of
    :func:`common_notes`' section): a warning every report has is not repeated per name,
    and a name whose warnings are all shared ones is not listed (each would be).  ``kind``:
    what the reports are of, ``analysed log`` or ``estimator`` (``1 of 3 analysed logs``).
    At most :data:`MAX_NAMED` names, the others counted.  Empty when no report warns.
    """
    written = [(name, report) for name, report in named if report is not None]
    warned = [(name, found) for name, report in written if (found := warning_notes(report))]
    if not warned:
        return []
    lines = ["", f"## Warnings ({len(warned):,} of {plural(len(written), kind)})", ""]
    common = [note for note in shared if note.startswith(WARNING_PREFIX)]
    own = [(name, [n for n in found if n not in common], len(found)) for name, found in warned]
    own = [entry for entry in own if entry[1]]
    if common:
        lines += [
            f"Every {kind} has the {'warning' if len(common) == 1 else 'warnings'} under "
            f'"{every}"' + ("; none has others." if not own else "; those with others:"),
        ]
        lines += [""] if own else []
    lines += [
        f"- {name} ({plural(count, 'warning')}): "
        + escape_markdown(first[0].removeprefix(WARNING_PREFIX), line_start=False)
        for name, first, count in own[:MAX_NAMED]
    ]
    if len(own) > MAX_NAMED:
        lines.append(f"- and {len(own) - MAX_NAMED:,} more (the `warnings` column)")
    if own:
        lines += ["", "The first warning of each; all are in its report.md."]
    return lines


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
    r"""One log of a batch, as its summaries show it.

    Attributes
    ----------
    log:
        The log's path as given, as :func:`~hybridlog.errors.as_name` writes it (a byte
        that is not UTF-8 ``\xNN``, a backslash ``\\``).
    folder:
        Its report folder, relative to the batch folder (written the same way).
    status:
        ``done``, ``skipped`` (an earlier report of the same run reused) or ``failed``.
    report:
        The report (``None`` when the log could not be analysed).
    error:
        The one-line error of a failed log.
    gates:
        ``(gate, failure)`` per CI gate, e.g. ``("--fail-under vaf=90", "vaf = 87.2 is under
        the bound 90")``; ``failure`` is ``None`` for a gate met.  Empty for a failed log.
    made_from:
        For a log skipped whose reused report an earlier run made from its content read at
        another path (the logs' folder renamed since), the path that report names.
    seconds:
        The log's wall time in this run (JUnit's ``time``): reading, estimating and writing.
    """

    log: str
    folder: str
    status: str
    report: Report | None
    error: str | None
    gates: tuple[tuple[str, str | None], ...] = ()
    made_from: str | None = None
    seconds: float = 0.0

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

    def values(self, metrics: Sequence[str]) -> list[object]:
        """The report's value of each of ``metrics`` (gate names: ``fit``, ``state_rmse.x1``).

        ``None`` where the report holds ``null``, and for a failed log.
        """
        r = self.report
        return [None if r is None else report_metric(r, name) for name in metrics]

    def offline_pairs(self, metrics: Sequence[str]) -> list[tuple[str, float | None, float | None]]:
        """``(metric, offline, filter's own)`` for each of ``metrics`` (:func:`offline_metrics`).

        Read from the report's ``smoothing`` block (``smoothed``, ``filtered``); ``None``
        where a side is unknown (no true mode or state, a failed log, a report of the filter
        alone).
        """
        smoothing = None if self.report is None else self.report.smoothing
        if smoothing is None:
            return [(metric, None, None) for metric in metrics]
        return [
            (
                metric,
                _side_value(smoothing.smoothed, metric),
                _side_value(smoothing.filtered, metric),
            )
            for metric in metrics
        ]

    def samples_apart(self, metric: str) -> tuple[int, int] | None:
        """The two sample counts of a ``state_rmse.<x>`` metric over other samples, else ``None``.

        ``(filter's samples, offline samples)``, :meth:`Smoothing.samples_apart`.
        """
        smoothing = None if self.report is None else self.report.smoothing
        base, _, state = metric.partition(".")
        if smoothing is None or base != "state_rmse":
            return None
        return smoothing.samples_apart(state)

    def offline_cells(self, metrics: Sequence[str]) -> list[object]:
        """The cells of :func:`offline_columns` (empty for a failed log)."""
        smoothing = None if self.report is None else self.report.smoothing
        cells: list[object] = []
        for metric, offline, own in self.offline_pairs(metrics):
            cells += [own] if metric == "mode_accuracy" else [offline, own]
        fallbacks = None if smoothing is None else smoothing.fallbacks
        return [
            *cells,
            None if smoothing is None else offline_label(smoothing),
            *fallback_cells(fallbacks),
        ]


BATCH_METRICS = ("samples", "vaf", "mse", "mode_accuracy")
"""The metrics of each log in the batch summaries (report keys)."""


def gated_columns(gated: Sequence[str], shown: Sequence[str]) -> tuple[str, ...]:
    """The gated metrics a batch summary adds as columns: those it does not show already.

    Once each, in the gates' order: a batch gated on ``fit`` or ``state_rmse.x1`` shows each
    log's value, not only, for a log that missed the gate, the message that says so.
    """
    return tuple(dict.fromkeys(name for name in gated if name not in shown))


def state_columns(reports: Iterable[Report | None]) -> tuple[str, ...]:
    """``state_rmse.<x>`` for each state some report has an RMSE of (a true state in the log).

    compare's table and batch's summary.csv showed no state's RMSE unless gated (or, in a
    batch, smoothed), though for an observer the states are what it estimates; a state no
    report could be scored on gets no column.
    """
    states = dict.fromkeys(
        x
        for report in reports
        if report is not None
        for x, state in report.states.items()
        if state.rmse is not None
    )
    return tuple(f"state_rmse.{x}" for x in states)


MAX_NAMED = 20
"""summary.md names at most this many logs per metric where the offline estimate is worse
than the filter's (the worst first); summary.csv has every log's values."""


def offline_label(smoothing: Smoothing) -> str:
    """The offline pass in a few words: ``kim-rts, argmax``, ``viterbi``."""
    return ", ".join(n for n in (smoothing.method, smoothing.mode_sequence) if n)


def offline_metrics(states: Sequence[str], components: Sequence[str] = ()) -> tuple[str, ...]:
    """The metrics a batch with an offline pass compares, named as the gates name them.

    ``mode_accuracy``, then ``mode_accuracy.<c>`` per component of a ``[components]`` model
    (where the joint accuracy hides most of a gain: docs/smoothing.md), then
    ``state_rmse.<x>`` per state.
    """
    return (
        "mode_accuracy",
        *(f"mode_accuracy.{c}" for c in components),
        *(f"state_rmse.{x}" for x in states),
    )


def _side_value(side: SmoothingMetrics, metric: str) -> float | None:
    """One side's value of a metric of :func:`offline_metrics` (``None`` when unknown)."""
    base, _, qualifier = metric.partition(".")
    if base == "state_rmse":
        state = side.states.get(qualifier)
        return None if state is None else state.rmse
    if qualifier:
        component = side.components.get(qualifier)
        return None if component is None else component.mode_accuracy
    return side.mode_accuracy


FALLBACK_COLUMNS = ("smoothing_fallback_samples", "smoothing_fallback_weight")
"""summary.csv's columns, after ``smoothing``, of where the smoother left the forward
estimate standing (report.json's ``smoothing.fallbacks``: ``samples`` and ``weight``, the
share of the smoothed estimates' weight the refused steps carry, 0 to 1); empty where no
smoother ran (``--mode-sequence viterbi`` alone) and for a failed log.  A batch of 1,000
logs whose "smoothed" estimate is the filter's on one of them (the double cart: 99.1 % of
the weight) is found by sorting on ``smoothing_fallback_weight``."""


def fallback_cells(fallbacks: Fallbacks | None) -> list[object]:
    """The cells of :data:`FALLBACK_COLUMNS` (``None``: empty, no smoother ran)."""
    if fallbacks is None:
        return [None, None]
    return [fallbacks.samples, fallbacks.weight]


def offline_columns(metrics: Sequence[str]) -> tuple[str, ...]:
    """summary.csv's columns of a batch with an offline pass, after ``mode_accuracy``.

    For ``metrics`` (:func:`offline_metrics`): ``filtered_mode_accuracy`` (the filter's
    own, beside ``mode_accuracy``, which is the offline estimates'), then for each further
    metric ``m`` (``mode_accuracy.<c>``, ``state_rmse.<x>``) ``m`` and ``filtered_m`` (empty
    without a true mode or state), ``smoothing``, the pass (:func:`offline_label`), and
    :data:`FALLBACK_COLUMNS`, where the smoother fell back to the forward estimate.
    """
    columns: list[str] = []
    for metric in metrics:
        columns += (
            [f"filtered_{metric}"]
            if metric == "mode_accuracy"
            else [
                metric,
                f"filtered_{metric}",
            ]
        )
    return (*columns, "smoothing", *FALLBACK_COLUMNS)


@dataclass(frozen=True)
class OfflineGain:
    """One metric of a batch with an offline pass: the offline estimates against the filter's.

    Attributes
    ----------
    metric:
        ``mode_accuracy`` or ``state_rmse.<x>``.
    logs:
        Analysed logs where both sides are known.
    filtered, offline:
        Medians over those logs of the filter's own value and of the offline one.
    change:
        Median over those logs of offline minus filter's (a gain for the accuracy, a
        loss for an RMSE).
    better, equal:
        Logs where the offline value is better than the filter's, and exactly equal.
    worse:
        ``(log, offline, filter's)`` of each log where it is worse, the worst first.
    """

    metric: str
    logs: int
    filtered: float
    offline: float
    change: float
    better: int
    equal: int
    worse: tuple[tuple[str, float, float], ...]


def offline_gains(rows: Sequence[BatchRow], metrics: Sequence[str]) -> list[OfflineGain]:
    """Per metric with both sides known on at least one log, the gain over the batch.

    Higher is better for a mode accuracy, lower for a state's RMSE.  A log whose two RMSEs
    of a state are over other samples (:func:`offline_samples_apart`) is left out of that
    state's.
    """
    gains = []
    per_metric: dict[str, list[tuple[str, float, float]]] = {}
    for row in rows:
        for metric, offline, own in row.offline_pairs(metrics):
            known = per_metric.setdefault(metric, [])
            if offline is not None and own is not None and row.samples_apart(metric) is None:
                known.append((row.log, offline, own))
    for metric, known in per_metric.items():
        if not known:
            continue
        sign = -1.0 if metric.startswith("state_rmse.") else 1.0
        worse = sorted(
            (entry for entry in known if sign * (entry[1] - entry[2]) < 0),
            key=lambda entry: sign * (entry[1] - entry[2]),
        )
        gains.append(
            OfflineGain(
                metric=metric,
                logs=len(known),
                filtered=statistics.median(own for _, _, own in known),
                offline=statistics.median(offline for _, offline, _ in known),
                change=statistics.median(offline - own for _, offline, own in known),
                better=sum(sign * (offline - own) > 0 for _, offline, own in known),
                equal=sum(offline == own for _, offline, own in known),
                worse=tuple(worse),
            )
        )
    return gains


def offline_samples_apart(
    rows: Sequence[BatchRow], metrics: Sequence[str]
) -> list[tuple[str, str, int, int]]:
    """``(metric, log, filter's samples, offline samples)`` of each RMSE over other samples.

    Each side's RMSE of a state is over the samples where it estimated the state
    (:meth:`Smoothing.samples_apart`): over other samples the two are no gain or loss, so
    :func:`offline_gains` leaves the log out of that metric and summary.md names it.
    """
    return [
        (metric, row.log, *counts)
        for metric in metrics
        for row in rows
        if (counts := row.samples_apart(metric)) is not None
    ]


def _apart_lines(rows: Sequence[BatchRow], metrics: Sequence[str]) -> list[str]:
    """summary.md's logs left out of a state's gain (:func:`offline_samples_apart`)."""
    apart = offline_samples_apart(rows, metrics)
    if not apart:
        return []
    lines = [
        "",
        "### Logs left out: the two RMSEs are over other samples",
        "",
        "Each side's RMSE is over the samples where it estimated the state (the reports' "
        "warnings say where one did not); over other samples they are not compared.",
        "",
    ]
    for metric in dict.fromkeys(m for m, *_ in apart):
        logs = [entry for entry in apart if entry[0] == metric]
        named = ", ".join(
            f"{escape_markdown(log)} ({offline:,} samples against the filter's {own:,})"
            for _, log, own, offline in logs[:MAX_NAMED]
        )
        more = len(logs) - MAX_NAMED
        if more > 0:
            named += f"; and {more} more (their reports)"
        lines.append(f"- {escape_markdown(metric)} ({len(logs)}): {named}")
    return lines


def _offline_section(rows: Sequence[BatchRow], metrics: Sequence[str]) -> list[str]:
    """summary.md's lines on the offline pass against the filter (:func:`offline_gains`)."""
    passes = sorted(
        {offline_label(r.report.smoothing) for r in rows if r.report and r.report.smoothing}
    )
    lines = [
        "",
        "## Offline estimates against the filter's own",
        "",
        "The mode accuracies and state RMSEs of the reports (and of the gates) are those of "
        f"the offline estimates ({escape_markdown(' / '.join(passes) or 'none analysed')}); "
        "`filtered_mode_accuracy` and summary.csv's other `filtered_*` columns are the "
        "filter's own. VAF and MSE are the filter's one-step-ahead prediction either way.",
    ]
    gains = offline_gains(rows, metrics)
    if not gains:
        apart = _apart_lines(rows, metrics)
        if apart:
            said = "No metric has both sides over the same samples on any log."
        elif any(r.report is not None for r in rows):
            said = (
                "No analysed log has a true mode or state: the offline estimates cannot be "
                "compared with the filter's here."
            )
        else:
            said = "No log was analysed: there are no offline estimates to compare."
        return [*lines, "", said, *apart, *_fallback_section(rows)]
    table = markdown_table(
        (
            "metric",
            "logs",
            "filter's median",
            "offline median",
            "median change",
            "better",
            "equal",
            "worse",
        ),
        [
            [g.metric, g.logs, g.filtered, g.offline, g.change, g.better, g.equal, len(g.worse)]
            for g in gains
        ],
    )
    lines += [
        "",
        table,
        "",
        "Per metric over the analysed logs where both are known (a true mode, a true state); "
        "the change is offline minus the filter's, per log (better: a higher accuracy, a "
        "lower RMSE).",
    ]
    worse = [g for g in gains if g.worse]
    if worse:
        lines += ["", "### Logs where the offline estimate is worse than the filter's", ""]
    for g in worse:
        named = ", ".join(
            f"{escape_markdown(log)} ({offline:.6g} against the filter's {own:.6g})"
            for log, offline, own in g.worse[:MAX_NAMED]
        )
        more = len(g.worse) - MAX_NAMED
        if more > 0:
            named += f"; and {more} more (summary.csv)"
        lines.append(f"- {escape_markdown(g.metric)} ({len(g.worse)} of {g.logs}): {named}")
    return [*lines, *_apart_lines(rows, metrics), *_fallback_section(rows)]


def fallback_logs(rows: Sequence[BatchRow]) -> tuple[int, list[tuple[str, Fallbacks]]]:
    """The logs a smoother ran on, and ``(log, fallbacks)`` of those where it fell back.

    Those are the logs where a step that carries weight was refused and the forward estimate
    stood (``fallbacks.samples`` > 0), the largest share of the weight first (then the most
    samples; ties in the batch's order).
    """
    smoothed = [
        (row.log, fallbacks)
        for row in rows
        if row.report is not None
        and row.report.smoothing is not None
        and (fallbacks := row.report.smoothing.fallbacks) is not None
    ]
    fell = [(log, f) for log, f in smoothed if f.samples]
    fell.sort(key=lambda entry: (-entry[1].weight, -entry[1].samples))
    return len(smoothed), fell


def _fallback_section(rows: Sequence[BatchRow]) -> list[str]:
    """summary.md's logs where the smoother left the forward estimate standing, worst first.

    Nothing when no smoother ran (``--mode-sequence viterbi`` alone); one line when it never
    fell back.  At most :data:`MAX_NAMED` logs named; summary.csv has every log's.
    """
    smoothed, fell = fallback_logs(rows)
    if not smoothed:
        return []
    if not fell:
        return [
            "",
            f"The smoother never fell back to the forward estimate ({plural(smoothed, 'log')} "
            "smoothed).",
        ]
    lines = [
        "",
        f"### Logs where the smoother fell back to the forward estimate ({len(fell):,} of "
        f"{smoothed:,})",
        "",
        "On those samples a step of the backward pass was refused and the forward estimate "
        'stood in its place (docs/smoothing.md, "The algorithms"); the share is of the '
        "smoothed estimates' weight those steps carry (summary.csv's "
        "`smoothing_fallback_weight`), the largest first:",
        "",
    ]
    lines += [
        f"- {escape_markdown(log)}: {f.weight_text()} of the weight, on {f.samples:,} of "
        f"{f.of:,} samples"
        for log, f in fell[:MAX_NAMED]
    ]
    if len(fell) > MAX_NAMED:
        lines.append(f"- and {len(fell) - MAX_NAMED:,} more (summary.csv)")
    return lines


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
        f"## Mode accuracy over part of the log ({len(partial)} of {analysed})",
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
        lines.append(f"- and {len(partial) - MAX_NAMED} more (summary.csv's `mode_samples`)")
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
    (:func:`_offline_section`).  ``gated``: the metrics of the gates, those not shown already
    each a column (:func:`gated_columns`).  ``others``: ``(name, kind)`` of the report
    folders in the batch folder of no log of this run (:data:`OTHER_KINDS`), listed last,
    by kind: they are not summarised, and read as this run's otherwise.
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
    # "all passed" of a batch without gates read as gates checked and met (summary.png
    # said "no gate given"): without a gate result, a log is analysed or not
    gated_rows = any(row.gates for row in rows)
    word = "passed" if gated_rows else "analysed"
    verdict = f"all {word}" if len(passed) == len(rows) else f"{len(rows) - len(passed)} not {word}"
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
    shared = common_notes(row.report for row in rows if row.report is not None)
    lines += warnings_section(
        [(escape_markdown(row.log), row.report) for row in rows],
        shared,
        kind="analysed log",
        every=NOTES_ON_EVERY_LOG,
    )
    lines += _partial_section(rows)
    if offline is not None:
        lines += _offline_section(rows, offline)
    lines += _notes_section(shared)
    lines += _made_elsewhere_section(rows)
    lines += _others_section(others)
    return table, "\n".join(lines) + "\n"


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
        f"## Reports made from the log at another path ({len(moved)})",
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
    lines = ["", f"## Other report folders ({len(others)})"]
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
