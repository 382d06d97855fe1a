"""The batch folder and the report folders in it: made before the logs, tidied after them.

:func:`prepare_root` makes and locks the batch folder and the folders that hold report
folders; :func:`check_apart_from_reports` refuses a log's report folder inside or around
another report; :func:`report_kind` reads the model and estimator a report.json names.
Once the logs are analysed, :func:`remove_previous_report`, :func:`remove_empty_parents`
and :func:`remove_temporaries_left` remove what an earlier run left for a log that failed
in this one, and what ended workers left.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from hybridlog.errors import OutputError, excerpt
from hybridlog.jobs.batch_job import BatchJob
from hybridlog.jobs.batch_lock import batch_folder_lock
from hybridlog.jobs.batch_others import PROVENANCE_KEY, folder_kind_text, report_folders
from hybridlog.jobs.batch_outcomes import LogOutcome
from hybridlog.outputs import (
    MARKER,
    check_dir_target,
    recorded_files,
    remove_stale_temporaries,
    temporary_name,
    write_marker,
)
from hybridlog.outputs.file_targets import path_too_long

__all__ = [
    "check_apart_from_reports",
    "prepare_root",
    "remove_empty_parents",
    "remove_previous_report",
    "remove_temporaries_left",
    "report_kind",
]


def _enclosing_report(folder: Path) -> Path | None:
    """The report folder ``folder`` would lie inside, below its batch folder, if any.

    The nearest folder above with hybridlog's :data:`MARKER` decides: one listing its files
    (:func:`~hybridlog.outputs.recorded_files`: a report, a comparison) is returned; one
    without the list is the batch folder, and ``folder`` lies in no report.  A log's folder
    inside the report folder an earlier run left for a log since renamed (``runs/b.csv``
    now a folder holding ``c.csv``: ``<out>/b.csv/c.csv``) was written into that report,
    which then held a stranger: its log, back, could not be redone, and the nested report
    was in no summary's "Other report folders".
    """
    for parent in folder.parents:
        if (parent / MARKER).is_file():
            return None if recorded_files(parent) is None else parent
    return None


def _unmarked_folder(path: Path) -> bool:
    """Whether ``path`` is a folder (not a link to one) without hybridlog's :data:`MARKER`."""
    return path.is_dir() and not path.is_symlink() and not (path / MARKER).exists()


def check_apart_from_reports(folder: Path) -> None:
    """Refuse a log's report folder that would lie inside, or hold, another log's report.

    The report an earlier run left for a log since renamed or moved (``runs/b.csv`` now a
    folder of logs, or ``runs/sub/`` now a bag): :func:`_enclosing_report`, or a folder
    without hybridlog's marker holding one (which ``check_dir_target`` refused as files
    hybridlog did not write); or a report ``analyze``, a comparison ``compare`` or another
    batch wrote there, each named as what it is (:func:`folder_kind_text`).

    Raises
    ------
    OutputError
        Naming both folders.
    """
    report = _enclosing_report(folder)
    relation = "would lie inside"
    if report is None and _unmarked_folder(folder):
        report = next(report_folders(folder), None)
        relation = "holds"
    if report is not None:
        raise OutputError(
            f"report folder {excerpt(str(folder))} {relation} {excerpt(str(report))}, "
            f"{folder_kind_text(report)}; move that folder out of --out, or choose another --out"
        )


def prepare_root(root: Path, folders: Sequence[Path], locks: contextlib.ExitStack) -> _Made:
    """Create the batch folder and the folders holding log folders, or check they are ours.

    The batch folder is locked for this batch into ``locks`` (:func:`batch_folder_lock`) once
    it exists, before anything is written in it: another batch running into it is refused,
    and what this run made is left to that batch.  Returns what it made, to be removed
    should the batch be refused later (:func:`~hybridlog.jobs.batch_plan.plan`).
    """
    # creatable (its name, its parent), not a file or a link, not someone else's folder
    check_dir_target(root, force=True, replacing=False)  # a folder of someone else's refused
    if root.exists() and recorded_files(root) is not None:
        # its marker lists the files of one run (analyze, compare, a simulated bag): the
        # batch's folders and summaries went in among them, without --force and without a word
        raise OutputError(
            f"output directory {root} is the output of another hybridlog command (an analyze "
            "or compare report, a simulated bag), not a batch folder; choose another --out"
        )
    parents = sorted({folder.parent for folder in folders} | {root})
    made = [path for path in [*root.parents, *parents] if not path.exists()]
    undo = _Made(
        root,
        not (root / MARKER).is_file(),
        sorted(set(made), key=lambda p: len(p.parts), reverse=True),
    )
    try:
        root.mkdir(parents=True, exist_ok=True)
        locks.enter_context(batch_folder_lock(root))
        if undo.marker:
            write_marker(root)
        for parent in parents:
            # made here, before any worker starts, so that no worker removes one another uses;
            # not inside a report of an earlier run, nor where a file stands: the logs of such
            # a folder fail, each naming it (:func:`check_apart_from_reports`, check_dir_target)
            if _enclosing_report(parent) is None:
                with contextlib.suppress(FileExistsError, NotADirectoryError):
                    parent.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        # a full disk: the folder made and its marker cut short would stay, half written
        undo.undo()
        raise OutputError(f"cannot create output directory {root}: {err.strerror}") from err
    for parent in parents:
        remove_stale_temporaries(parent)
    return undo


@dataclass(frozen=True)
class _Made:
    """What :func:`prepare_root` made: the marker (if this run wrote it) and the folders."""

    root: Path
    marker: bool
    folders: list[Path]
    """Deepest first."""

    def undo(self) -> None:
        """Remove it all: the batch is refused after the folder was made.

        Called by :func:`~hybridlog.jobs.batch_plan.plan`.
        """
        with contextlib.suppress(OSError):
            if self.marker:
                (self.root / MARKER).unlink()
        for folder in self.folders:  # empty unless someone else wrote there meanwhile
            with contextlib.suppress(OSError):
                folder.rmdir()


def remove_previous_report(job: BatchJob, outcome: LogOutcome) -> None:
    """Remove the report an earlier run left in the folder of a log that failed in this one.

    A log that fails gets no report folder (summary.csv's ``folder`` is empty), but its
    folder from an earlier run (another content of the log, other options, a model since
    edited) stayed, and read as this run's to whoever opened the batch folder or its CI
    artifact: a report.md with numbers, beside a summary saying the log failed.  Such a
    folder is never a report of this run (one of this run would have been reused), so it
    is removed: renamed aside, then deleted.  Kept: a folder holding a report of another
    estimator or model (refused without ``--force``), one hybridlog did not write, one
    holding a file that is not hybridlog's or was edited since (refused with that message,
    the edit kept), and a link.
    """
    folder = Path(outcome.folder)
    if outcome.status != "failed" or path_too_long(folder, folder=True) is not None:
        return  # (a path too long for the system: no folder there)
    if folder.is_symlink() or not folder.is_dir():
        return
    if report_kind(folder / "report.json") != (job.model_name, job.estimator):
        return
    try:
        check_dir_target(folder, force=True, replacing=True)
    except OutputError:
        return
    aside = temporary_name(folder, kind="old")
    with contextlib.suppress(OSError):
        os.rename(folder, aside)
        shutil.rmtree(aside, ignore_errors=True)


def remove_empty_parents(root: Path, outcome: LogOutcome) -> None:
    """Remove the folders left empty above the report folder of a log that failed.

    The folders that hold report folders (``d2/deep/`` for ``d2/deep/run.csv``) are made
    before any log is read (:func:`prepare_root`); a log that failed got no report folder,
    and those made for it stayed in the batch folder, empty: an output of nothing, kept by
    every later run.  Each is removed while empty, from the innermost up to (not including)
    the batch folder; one holding anything (another log's report, a file) stops it.
    """
    if outcome.status != "failed":
        return
    folder = Path(outcome.folder)
    try:
        inside = folder.relative_to(root)
    except ValueError:
        return
    for parent in list((root / inside).parents)[: len(inside.parts) - 1]:
        try:
            parent.rmdir()
        except OSError:  # not empty (or not a folder, or gone): the folders above hold it
            return


def remove_temporaries_left(folders: Sequence[Path], workers: Sequence[int]) -> None:
    """Remove what the ended ``workers`` (process ids) left in ``folders``, and dead processes'.

    A worker stopped by a signal removes its own temporary folder (:mod:`.workers`), unless
    it is killed first (after :data:`~hybridlog.jobs.workers.STOP_GRACE_S`, or by the
    system) or a thread of its task still writes into the folder while it is removed.
    """
    for folder in folders:
        remove_stale_temporaries(folder, ours=frozenset(workers))


def report_kind(report: Path, *, of_a_batch: bool = False) -> tuple[str, str] | None:
    """The model and estimator a report.json names, or None if it is none of ours to read.

    ``of_a_batch``: None too for a report no batch wrote (no :data:`PROVENANCE_KEY`: one of
    ``analyze`` or ``compare``).
    """
    try:
        with report.open(encoding="utf-8") as handle:
            data = json.load(handle)
    except (OSError, ValueError):
        return None
    if not isinstance(data, dict):
        return None
    if of_a_batch and not isinstance(data.get(PROVENANCE_KEY), dict):
        return None
    model, estimator = data.get("model"), data.get("estimator")
    return (model, estimator) if isinstance(model, str) and isinstance(estimator, str) else None
