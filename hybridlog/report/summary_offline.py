"""A batch's offline pass in its summaries: both sides' metrics, the gains and the fallbacks.

A batch with an offline pass (``--smooth``, ``--mode-sequence``; ``offline`` given)
shows beside each log's offline mode accuracy the filter's own, and per state both RMSEs
(:func:`offline_columns`, :meth:`~hybridlog.report.summary_rows.BatchRow.offline_pairs`),
and summary.md the gain over the batch (:func:`offline_gains`, :func:`offline_section`): per
metric the medians, the median change and the logs where the offline estimate is worse than
the filter's, by name.  Where a smoother ran, summary.csv says on how many samples it left
the forward estimate standing and how much of the smoothed estimates' weight those steps
carry (:data:`FALLBACK_COLUMNS`), and summary.md lists those logs, the largest share first
(:func:`fallback_logs`).  A batch without one writes the same columns as before.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from hybridlog.report.markdown import escape_markdown, plural
from hybridlog.report.summary_notes import MAX_NAMED
from hybridlog.report.summary_tables import markdown_table

if TYPE_CHECKING:
    from hybridlog.estimators.result import Fallbacks
    from hybridlog.report.report_parts import Smoothing
    from hybridlog.report.summary_rows import BatchRow

__all__ = [
    "FALLBACK_COLUMNS",
    "OfflineGain",
    "fallback_cells",
    "fallback_logs",
    "offline_columns",
    "offline_gains",
    "offline_label",
    "offline_metrics",
    "offline_samples_apart",
    "offline_section",
]


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
                filtered=_median(own for _, _, own in known),
                offline=_median(offline for _, offline, _ in known),
                change=_median(offline - own for _, offline, own in known),
                better=sum(sign * (offline - own) > 0 for _, offline, own in known),
                equal=sum(offline == own for _, offline, own in known),
                worse=tuple(worse),
            )
        )
    return gains


def _median(values: Iterable[float]) -> float:
    """The median, whose two middle values are halved before they are added.

    ``statistics.median`` adds them first: two state RMSEs above 9e307 (finite, of a filter
    gone far off) had the median ``inf``, a number of neither; the same to the bit otherwise
    (halving a normal float is exact).
    """
    ordered = sorted(values)
    middle = len(ordered) // 2
    if len(ordered) % 2:
        return ordered[middle]
    return ordered[middle - 1] / 2 + ordered[middle] / 2


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


def offline_section(rows: Sequence[BatchRow], metrics: Sequence[str]) -> list[str]:
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
