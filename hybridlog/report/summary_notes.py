"""The notes the summaries of ``compare`` and ``batch`` give: those every report has, and warnings.

:func:`common_notes` are the notes every report has, said once in comparison.md and
summary.md.  A report's notes that start ``WARNING:`` (:func:`warning_notes`: the
innovations' test of a filter, a true mode silent longer than ``--max-gap``, a signal bridged
across gaps) are counted per log in summary.csv's ``warnings`` column (per estimator in
comparison.csv's), and summary.md and comparison.md list the logs (estimators) with warnings,
the first of each (:func:`warnings_section`): in a batch of 1,000 logs the few whose sensor is
scaled are otherwise seen only by opening each report.md.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING

from hybridlog.report.markdown import WARNING_PREFIX, escape_markdown, plural

if TYPE_CHECKING:
    from hybridlog.report.document import Report

__all__ = ["MAX_NAMED", "common_notes", "warning_notes", "warnings_section"]


MAX_NAMED = 20
"""summary.md names at most this many logs in a list (the logs that warn, those whose offline
estimate is worse than the filter's, the worst first, or that fell back on the filter's, ...),
and counts the rest; summary.csv has every log's values."""


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
