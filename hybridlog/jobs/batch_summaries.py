"""A batch's summaries: ``summary.md``, ``summary.csv``, ``summary.png`` and the JUnit file.

:func:`summarise` writes them from the logs' outcomes, in natural order;
:func:`withdraw_summaries` removes an earlier run's before any log is analysed;
:func:`summaries_ours` tells the files the batch may replace; :func:`made_elsewhere_note`
names the reused reports made from a log at another path.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Sequence
from pathlib import Path

from hybridlog.errors import as_name, as_text, excerpt, first_few, names_apart
from hybridlog.jobs.batch_job import BatchJob
from hybridlog.jobs.batch_names import SUMMARY_NAMES
from hybridlog.jobs.batch_others import OtherFolder
from hybridlog.jobs.batch_outcomes import BatchOutcome, LogOutcome
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.outputs import PathLike, atomic_files, output_path, record_path, wrote_file
from hybridlog.outputs.records import remove_written
from hybridlog.report import evaluate_gates
from hybridlog.report.gates import Gate
from hybridlog.report.junit import is_junit_of_ours, write_junit
from hybridlog.report.summary import batch_markdown, batch_rows_csv
from hybridlog.report.summary_offline import offline_label, offline_metrics
from hybridlog.report.summary_rows import BatchRow

__all__ = ["made_elsewhere_note", "summaries_ours", "summarise", "withdraw_summaries"]


def summaries_ours(root: Path) -> Callable[[Path], bool]:
    """Whether a summary file (or the JUnit file) may be replaced by this batch's.

    The summaries in the batch folder are rewritten by every run, but not one a user changed
    since the batch wrote it (notes added to summary.md: gone at the next nightly run):
    recorded beside it when written (:func:`~hybridlog.outputs.record_file`), it must be
    that very file still; one without a record (an older version's) is the batch's.  A JUnit
    file elsewhere is the batch's by its content.
    """

    def ours(path: Path) -> bool:
        if path.parent != root:
            return is_junit_of_ours(path)
        return wrote_file(path) if record_path(path).exists() else True

    return ours


def withdraw_summaries(root: Path, junit: PathLike | None) -> None:
    """Remove the summaries (and JUnit file) of an earlier run, before any log is analysed.

    They are of the reports that run left: a batch that then ended without writing its own
    (killed, interrupted, its cluster lost) left them beside the reports it had replaced
    already, so summary.csv showed the earlier numbers for the reports it links to, and the
    JUnit file a CI step publishes even after a failure (``if: always()``) the earlier
    gates passed.  Such a batch now leaves no summary; the next run writes them.  Only
    files :func:`~hybridlog.jobs.batch_plan.plan` took for the batch's
    (:func:`summaries_ours`) are removed.

    Raises
    ------
    OutputError
        When one cannot be removed, naming it.
    """
    ours = summaries_ours(root)
    targets = [root / name for name in SUMMARY_NAMES]
    if junit is not None:
        targets.append(output_path(junit))
    for target in targets:
        if not target.is_file() or target.is_symlink() or not ours(target):
            continue
        remove_written(target, "the previous run's file", "would be left beside this run's reports")


def _made_from(outcome: LogOutcome) -> str | None:
    """The path a skipped log's reused report names, when it is not the log's path now.

    A log of unchanged content is skipped wherever it lies (its provenance records no
    path, so that a batch folder restored elsewhere resumes), but the report reused names
    the path an earlier run read it at (``logs/r1.csv``, its folder renamed ``logs_b``
    since): its title and report.json's ``log`` then disagree with the summaries.  A path
    that names the log's file still (``logs/r1.csv`` then, ``/abs/logs/r1.csv`` now; a
    link) is no other path.
    """
    if outcome.status != "skipped" or outcome.report is None:
        return None
    recorded = outcome.report.log
    if os.path.normpath(recorded) == os.path.normpath(as_text(outcome.log)):
        return None
    with contextlib.suppress(OSError, ValueError):  # gone, or no path (an edited report)
        if os.path.samefile(recorded, outcome.log):
            return None
    return recorded


_MOVED_SHOWN = 3
"""How many logs whose reused reports name another path the note names."""


def made_elsewhere_note(outcomes: Sequence[LogOutcome]) -> list[str]:
    """The note (none, or one line) on the reports reused from the log at another path."""
    moved = [(o.log, made) for o in outcomes if (made := _made_from(o)) is not None]
    if not moved:
        return []
    pairs = first_few(
        moved,
        _MOVED_SHOWN,
        lambda pair: f"{excerpt(os.fspath(pair[0]), 60)} read as {excerpt(pair[1], 60)}",
    )
    if len(moved) > 1:
        return [
            f"{len(moved)} logs were skipped, their content the one an earlier run analysed at "
            f"another path ({pairs}): their reused report.md and report.json name that "
            "path; remove a report folder to redo its log under its path now (summary.md "
            "lists them)"
        ]
    return [
        "a log was skipped, its content the one an earlier run analysed at another path "
        f"({pairs}): its reused report.md and report.json name that path; remove its report "
        "folder to redo it under its path now"
    ]


def summarise(
    root: Path,
    model: HybridModel,
    job: BatchJob,
    gates: Sequence[Gate],
    outcomes: Sequence[LogOutcome],
    junit: PathLike | None,
    others: Sequence[OtherFolder] = (),
) -> BatchOutcome:
    """Write the summary files (and the JUnit file) from the outcomes, in natural order.

    ``others``: the folders of no log of the batch
    (:func:`~hybridlog.jobs.batch_others.other_folders`), which summary.md names.
    """
    # a byte that is not UTF-8 as \xNN, a backslash \\, names alike but for their Unicode
    # form (NFC, NFD) written apart: no two logs read alike
    logs = names_apart([as_name(o.log) for o in outcomes])
    # their report folders too (summary.md's report column, summary.csv's folder)
    folders = names_apart([as_name(Path(o.folder).relative_to(root).as_posix()) for o in outcomes])
    rows = [
        BatchRow(
            log=log,
            folder=folder,
            status=o.status,
            report=o.report,
            error=None if o.error is None else as_text(o.error),
            gates=tuple(
                (f"{gate.option} {gate.spec}", next(iter(evaluate_gates(o.report, [gate])), None))
                for gate in gates
            )
            if o.report is not None
            else (),
            made_from=_made_from(o),
            seconds=o.seconds,
        )
        for o, log, folder in zip(outcomes, logs, folders, strict=True)
    ]
    title = f"{model.name} · {job.estimator}"
    smoothed = {
        offline_label(o.report.smoothing)
        for o in outcomes
        if o.report is not None and o.report.smoothing is not None
    }
    if smoothed:  # the modes and states summarised are then the smoothed ones
        title += f" · {' / '.join(sorted(smoothed))}"
    # with an offline pass, each log's filter's own metrics beside the offline ones
    compared = (
        offline_metrics(model.states, [c.name for c in model.components]) if job.offline else None
    )
    gated = [g.metric for g in gates]
    table, text = batch_markdown(
        title,
        rows,
        [f"{g.option} {g.spec}" for g in gates],
        compared,
        gated,
        others=[(as_name(other.name), other.kind) for other in others],
    )
    targets: list[PathLike] = [root / name for name in SUMMARY_NAMES]
    if junit is not None:
        targets.append(junit)

    junit_path = None if junit is None else output_path(junit)
    with atomic_files(
        targets,
        force=True,
        ours=summaries_ours(root),
        recorded=lambda path: path == junit_path or path.parent == root,
    ) as staged:
        staged[0].write_text(text, encoding="utf-8")
        batch_rows_csv(staged[1], rows, compared, gated)
        from hybridlog.report.summary_plot import write_summary_plot

        write_summary_plot(staged[2], title, rows)
        if junit is not None:
            write_junit(staged[3], f"hybridlog batch: {title}", rows, compared)
    # one line each on the terminal: a line break of a log's name written \n, not a space
    failures = [
        f"{excerpt(row.log, len(row.log) * 6)[1:-1]}: {failure}"
        for row in rows
        for _, failure in row.gates
        if failure is not None
    ]
    return BatchOutcome(logs=list(outcomes), table=table, gate_failures=failures)
