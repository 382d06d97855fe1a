"""Batch reprocessing: one estimator over many logs, each into its own report folder.

A failing log never stops the others: any exception while analysing a log, and a worker
process that dies, is recorded as that log's one-line error in the summary.

**Resume by content.**  Every report a batch writes records its provenance (report key
``batch``, :func:`provenance`): the SHA-256 of the log's bytes (of every file of a bag
folder), of the model file (or built-in model text), the settings that change results
(estimator and its options, ``--set`` parameters, read options with the content of every
``--msg-dir``, the centres file's content, the table format), hybridlog's version and a hash
of its source (:func:`~hybridlog.jit.package_fingerprint`: an estimator fixed without a new
version number gives new numbers, which a resumed batch must not hide), and the versions of
Python and of the libraries that compute the numbers
(:func:`~hybridlog.jobs.provenance.library_versions`).  A log is skipped
(its report reused) only when its folder's report records exactly the provenance of the run
about to be made and the folder holds every file hybridlog wrote there, unchanged
(:func:`_intact`); otherwise it is redone.  ``force`` redoes every log.  The log and the
model file are hashed before they are read, and a log read with a model file, centres file
or ``--msg-dir`` whose content is no longer the one the batch hashed (edited while it runs)
fails (:func:`_check_unchanged`): a report never records a content it was not made from.

**Folder names** (:func:`folder_names`) are the log paths relative to their common folder,
suffix kept: ``d2/run.csv`` → ``<out>/d2/run.csv/``.  They depend on each log's own path and
on the common folder only, never on the order of the arguments.

**Throughput.**  Workers stay warm: each process loads the model, prepares the estimator and
compiles its code once per batch (:func:`_warm`) and reuses them for every log it analyses;
per-log plots are drawn only as ``plots`` asks (``none`` by default, ``failed``: logs that miss
a gate, ``all``).  ``jobs > 1`` analyses logs in worker processes
(:mod:`hybridlog.jobs.workers`), ``scheduler`` on a Dask cluster
(:mod:`hybridlog.jobs.dask_backend`); the results are the same.  Logs are processed and
summarised in natural order (``s1, s2, s10``).  The batch process of ``jobs > 1`` or of a
cluster imports neither polars nor numba (``tests/jobs/test_batch_process.py``): it checks,
hands out the logs and writes the summaries, whose CSV it writes with :mod:`csv`
(:func:`hybridlog.report.summary.write_summary_csv`); the report's writer is imported
where a log is analysed.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import os
import shutil
import threading
import time
import uuid
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any, Literal, TypeVar

from hybridlog import __version__
from hybridlog.cluster.progress import current_wait
from hybridlog.environment import usable_cores
from hybridlog.errors import (
    HybridlogError,
    LogError,
    ModelError,
    OptionError,
    OutputError,
    ReportError,
    as_name,
    as_text,
    excerpt,
    first_few,
    names_apart,
    shortened,
)
from hybridlog.estimators import Prepared
from hybridlog.io import ReadOptions
from hybridlog.jit import package_fingerprint
from hybridlog.jobs import arguments
from hybridlog.jobs.analysis import (
    FILE_OPTIONS,
    Overrides,
    check_signals,
    estimator_inputs,
    gates_for,
    input_paths,
    memory_reserved,
    parse_sets,
    prepare_estimators,
    read_log,
)
from hybridlog.jobs.batch_junit import record_junit, withdraw_previous_junit
from hybridlog.jobs.batch_lock import batch_folder_lock
from hybridlog.jobs.batch_logs import (
    FoundLogs,
    batch_logs,
    missing_pattern_hint,
    natural_key,
    recover_applies,
    recover_note,
)
from hybridlog.jobs.batch_others import (
    PROVENANCE_KEY,
    OtherFolder,
    folder_kind_text,
    other_folders,
    others_note,
    report_folders,
)
from hybridlog.jobs.estimator_calls import warm_up_told
from hybridlog.jobs.origins import given_in_chunks, given_values, run_values
from hybridlog.jobs.provenance import (
    content_hash,
    folder_stamp,
    library_versions,
    log_stamp,
    model_hash,
)
from hybridlog.memory import available_memory, size_text
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.outputs import (
    MARKER,
    PathLike,
    atomic_files,
    check_apart,
    check_dir_target,
    check_distinct,
    check_file_name,
    check_file_target,
    edited_files,
    is_ours,
    output_path,
    record_path,
    recorded_files,
    remove_stale_temporaries,
    temporary_name,
    write_marker,
    wrote_file,
)
from hybridlog.outputs.file_targets import check_followable
from hybridlog.report import Report, evaluate_gates, parse_gates, read_report
from hybridlog.report.gates import Gate
from hybridlog.report.junit import check_junit_target, is_junit_of_ours, write_junit
from hybridlog.report.summary import (
    BatchRow,
    batch_markdown,
    batch_rows_csv,
    offline_label,
    offline_metrics,
    warning_notes,
)
from hybridlog.report.table_format import check_table_format

T = TypeVar("T")

__all__ = [
    "PLOT_CHOICES",
    "BatchJob",
    "BatchOutcome",
    "LogOutcome",
    "analyze_log",
    "batch_logs",
    "folder_names",
    "natural_key",
    "run_batch",
]

PLOT_CHOICES = ("none", "failed", "all")
"""``--plots``: no per-log plots (the default in batch), logs that miss a gate, every log."""

_ERROR_LIMIT = 300


@dataclass(frozen=True)
class LogOutcome:
    """How one log of a batch ended: ``done``, ``skipped`` (already done) or ``failed``."""

    log: str
    folder: str
    status: str
    report: Report | None
    error: str | None
    memory_wait_s: float = 0.0
    """How long the log waited for memory the other workers' logs held (``--jobs N``)."""
    seconds: float = 0.0
    """The log's wall time in this run, from its task's start to its outcome (reading,
    estimating, writing its report, waiting for memory; a reused report's check alone):
    JUnit's ``time`` of its cases.  0 for a log whose worker died."""


@dataclass(frozen=True)
class BatchOutcome:
    """The whole batch: per-log outcomes, the summary table and the missed CI gates."""

    logs: list[LogOutcome]
    table: str
    gate_failures: list[str]
    notes: list[str] = dataclasses.field(default_factory=list)
    """What the user should know of how the batch ran (``--jobs`` capped, Dask's memory)."""

    @property
    def failed(self) -> int:
        """Number of logs that could not be analysed."""
        return sum(1 for log in self.logs if log.status == "failed")

    @property
    def warned(self) -> list[LogOutcome]:
        """The analysed logs whose report has a note that warns (:func:`warning_notes`).

        A log reused by a resumed batch counts by its report.json's notes.
        """
        return [log for log in self.logs if warning_notes(log.report)]

    @property
    def waited_for_memory(self) -> list[LogOutcome]:
        """The logs that waited for memory the other workers' logs held (``--jobs N``)."""
        return [log for log in self.logs if log.memory_wait_s > 0.0]


SUMMARY_NAMES = ("summary.md", "summary.csv", "summary.png")
"""The summaries every run of a batch writes into its batch folder."""


_RESERVED = frozenset({*SUMMARY_NAMES, MARKER})


def _escaped(part: str, top: bool) -> str:
    """A path component as a folder name: never hidden, never a batch file's name.

    A component whose text after leading ``_`` starts with ``.`` (or, at the top, is a batch
    file's name) gets one more ``_``; every other is kept.  The mapping is one-to-one: a
    kept name never looks like an escaped one.
    """
    bare = part.lstrip("_")
    if bare.startswith(".") or not bare or (top and bare in _RESERVED):
        return "_" + part
    return part


def folder_names(logs: Sequence[PathLike], searched: Sequence[PathLike] = ()) -> list[str]:
    """Each log's report folder, relative to the batch folder: its path from the logs' root.

    The root is the deepest folder holding every log and every folder of logs ``searched``
    (:func:`~hybridlog.jobs.batch_logs.batch_logs`), so ``d2/run.csv`` and ``d2/run.parquet``
    get ``run.csv`` and ``run.parquet`` (the suffix is kept), whatever the order of the
    arguments, and the logs found in ``runs/`` are named from ``runs/``, whichever of its
    subfolders hold them today.  Hidden names and names of the batch's own files are escaped
    (:func:`_escaped`).

    Raises
    ------
    OptionError
        When a log is given twice, or lies inside another log (a file inside a bag folder).
    """
    absolute = [os.path.abspath(log) for log in logs]
    if not absolute:
        return []
    folders = [os.path.dirname(path) for path in absolute]
    root = os.path.commonpath([*folders, *(os.path.abspath(f) for f in searched)])
    names: list[str] = []
    seen: dict[str, PathLike] = {}
    for log, path in zip(logs, absolute, strict=True):
        parts = Path(os.path.relpath(path, root)).parts
        name = "/".join(_escaped(part, k == 0) for k, part in enumerate(parts))
        if name in seen:
            raise OptionError(f"log {excerpt(str(log))} is given twice{_how_twice(path, searched)}")
        seen[name] = log
        names.append(name)
    for name in names:
        parent = name.rpartition("/")[0]
        while parent:
            if parent in seen:
                raise OptionError(
                    f"log {excerpt(str(seen[name]))} lies inside the log "
                    f"{excerpt(str(seen[parent]))}; give one of them"
                )
            parent = parent.rpartition("/")[0]
    return names


def _how_twice(path: str, searched: Sequence[PathLike]) -> str:
    """How a log came to be given twice: the folders of logs given that hold it, if any.

    ``batch runs runs/sub`` found ``runs/sub/b.csv`` in both folders; "log 'runs/sub/b.csv'
    is given twice" named a file the user never typed, and not the arguments to change.
    """
    holding = [
        excerpt(os.fspath(folder))
        for folder in searched
        if path.startswith(os.path.join(os.path.abspath(folder), ""))
    ]
    if not holding:
        return ""
    if len(set(holding)) == 1 and len(holding) > 1:
        return f" (the folder of logs {holding[0]} is given twice); give it once"
    if len(holding) == 1:
        return f" (as itself, and in the folder of logs {holding[0]}); give it once"
    return f" (in the folders of logs {', '.join(holding[:-1])} and {holding[-1]}); give it once"


def _one_line(text: str) -> str:
    """A log's error on one line of at most :data:`_ERROR_LIMIT` characters.

    A longer one is cut in the middle, not at the end: an error starts with the log's path
    (or the report folder's, as long) and ends with what is wrong, which must stay (between
    words where one is near, :func:`~hybridlog.errors.shortened`).  The end
    keeps two thirds of the room: the summaries name the log in a column of its own, and a
    reason of 150 characters behind a long path lost its first half when the end kept one.
    """
    return shortened(text, _ERROR_LIMIT, end_share=2 / 3)


# --- what is shared by the logs -----------------------------------------------------------------


@dataclass(frozen=True)
class BatchJob:
    """Everything the logs of a batch share; sent with each log to the worker analysing it.

    Attributes
    ----------
    model_ref, model_sha256, model_name, sets, estimator:
        The model (file path or built-in name), its content hash and name, the ``--set``
        values and the estimator's registry name.
    read, table_format, fail_under, fail_over, plots, force:
        The run's options (``plots``: one of :data:`PLOT_CHOICES`).
    smooth, mode_sequence:
        ``--smooth`` and ``--mode-sequence`` (estimator options: recorded in ``settings``).
    offline:
        Whether the estimator's options ask for an offline pass
        (:attr:`~hybridlog.estimators.Prepared.offline`, also from ``--set`` or the model
        file): the summaries then show the filter's own metrics beside the offline ones.
    settings:
        The settings that change results, as canonical JSON (part of :func:`provenance`).
    msg_dir_stamps:
        What ``stat`` said of each ``--msg-dir`` before it was hashed into ``settings``.
    """

    model_ref: str
    model_sha256: str
    model_name: str
    sets: tuple[str, ...]
    estimator: str
    read: ReadOptions
    table_format: str
    fail_under: tuple[str, ...]
    fail_over: tuple[str, ...]
    plots: str
    force: bool
    settings: str
    smooth: bool = False
    mode_sequence: str | None = None
    offline: bool = False
    msg_dir_stamps: tuple[str, ...] = ()
    """:func:`~hybridlog.jobs.provenance.folder_stamp` of each ``--msg-dir`` when the batch
    hashed them: each log checks them cheaply (:func:`_check_unchanged`)."""
    run: str = ""
    """This run of the batch (a random token), recorded beside the provenance (key
    ``batch.run``) and not compared by a later run: a log's task that Dask ran a second
    time, its first result lost with a worker that died before the client collected it,
    finds the report its first run wrote, and the log is ``done``, as it is without Dask,
    not ``skipped`` (:func:`_reusable`)."""

    def provenance(self, log_sha256: str) -> dict[str, Any]:
        """What a report of this batch for a log of this content records (key ``batch``).

        The key also holds :attr:`run`, which a later run does not compare.
        """
        return {
            "log_sha256": log_sha256,
            "model_sha256": self.model_sha256,
            "settings": json.loads(self.settings),
            "hybridlog_version": __version__,
            # the code that made the numbers: an edit of an estimator (a development install,
            # a patched build) keeps the version but not the results
            "hybridlog_code": package_fingerprint(),
            "libraries": library_versions(),
        }


def _settings(
    prepared: Prepared, overrides: Overrides, read: ReadOptions, table_format: str
) -> str:
    """The settings that change a batch's results, as canonical JSON text."""
    files = {name: content_hash(path, what=what) for name, what, path in _input_files(prepared)}
    reading: dict[str, Any] = dataclasses.asdict(read)
    reading["msg_dirs"] = [
        [folder, content_hash(folder, what="--msg-dir folder")] for folder in read.msg_dirs
    ]
    settings = {
        "estimator": prepared.name,
        "options": prepared.options_dict(),
        "parameters": dict(overrides.parameters),
        "files": files,
        "read": reading,
        "table_format": table_format,
    }
    return json.dumps(settings, sort_keys=True, default=str)


@dataclass(frozen=True)
class _Warm:
    """What a worker keeps between the logs of a batch."""

    model: HybridModel
    prepared: Prepared
    inputs: dict[str, Any]
    gates: list[Gate]
    values: dict[str, Any]
    """``report.json``'s ``parameters`` and ``origins`` (:func:`run_values`)."""
    given: dict[str, str]
    """The command-line values the run uses, which its errors name (:func:`given_values`)."""
    warmed_up: threading.Event = dataclasses.field(default_factory=threading.Event)
    """Set once the estimator's machine code is loaded in this process (:func:`_warm`)."""


_WARM: dict[tuple[object, ...], _Warm] = {}
_WARM_LOCK = threading.Lock()


def _warm_key(job: BatchJob) -> tuple[object, ...]:
    return (
        job.model_ref,
        job.model_sha256,
        job.sets,
        job.estimator,
        job.smooth,
        job.mode_sequence,
        job.fail_under,
        job.fail_over,
    )


def _warm(job: BatchJob) -> _Warm:
    """The loaded model, prepared estimator, its input files and gates, once per process.

    Kept for the batch's model, ``--set`` values and estimator (one batch at a time: a new
    key replaces the old one), so a worker loads and compiles nothing after its first log.
    The estimator is warmed up here once, its machine code loaded or, on the model's first
    run, compiled, the installed reporter told
    (:func:`~hybridlog.jobs.estimator_calls.warm_up_told`: the console script says so on a
    terminal, above its bar), also in the batch's own
    process, whose rest :func:`_plan` made, when it runs the logs itself.
    """
    key = _warm_key(job)
    with _WARM_LOCK:
        warm = _WARM.get(key)
        if warm is None:
            # hashed before it is read: a report never records a model it was not made from
            if model_hash(job.model_ref) != job.model_sha256:
                raise ModelError(
                    f"{job.model_ref}: the model file changed since the batch started, so "
                    "this log was not analysed with the model the batch checked and records; "
                    "run the batch again"
                )
            model, overrides = parse_sets(job.sets, job.model_ref)
            (prepared,) = prepare_estimators(
                model,
                [job.estimator],
                overrides,
                smooth=job.smooth,
                mode_sequence=job.mode_sequence,
            )
            _check_unchanged(job, _input_files(prepared))
            gates = gates_for(model, [prepared], job.fail_under, job.fail_over)
            values = run_values(model, prepared, overrides.parameter_texts)
            given = given_values(overrides.parameter_texts, prepared)
            inputs = estimator_inputs(prepared, model)
            warm = _Warm(model, prepared, inputs, gates, values, given)
            _WARM.clear()
            _WARM[key] = warm
        if not warm.warmed_up.is_set():
            warm.warmed_up.set()
            # on rows of zeros: what it raises, the run raises again if the log makes it so
            with contextlib.suppress(Exception):
                warm_up_told(warm.prepared, warm.model)
        return warm


def _input_files(prepared: Prepared) -> list[tuple[str, str, str]]:
    """The files the estimator's options name: ``(option, what it is, path)`` each."""
    return [
        (name, what, value)
        for name, (what, _) in FILE_OPTIONS.items()
        if (value := getattr(prepared.options, name, None))
    ]


def _check_unchanged(job: BatchJob, files: Sequence[tuple[str, str, str]]) -> None:
    """Refuse input files and ``--msg-dir`` folders whose content changed since the batch started.

    The batch hashed them for its reports' provenance (:func:`_settings`) before any worker
    reads them; one edited since would be read by the workers that start, or the logs read,
    after the edit, their reports recording the content checked before.  Called before they
    are read (a report never records a content it was not made from).

    Raises
    ------
    OptionError
        Naming the file or folder.
    """
    settings = json.loads(job.settings)
    changed = [
        f"{what} {excerpt(path)}"
        for name, what, path in files
        if content_hash(path, what=what) != settings["files"].get(name)
    ]
    changed += [
        f"--msg-dir folder {excerpt(folder)}"
        for (folder, digest), stamp in zip(
            settings["read"]["msg_dirs"], job.msg_dir_stamps, strict=True
        )
        # read only when stat says it changed: a --msg-dir may be a whole ROS install
        if folder_stamp(folder) != stamp and content_hash(folder, what="--msg-dir folder") != digest
    ]
    if changed:
        raise OptionError(
            f"{changed[0]}: changed since the batch started, so this log was not analysed "
            "with the content the batch checked and records; run the batch again"
        )


def _plots(job: BatchJob, gates: Sequence[Gate]) -> bool | Callable[[Report], bool]:
    """``write_report``'s ``plots`` for a log of the batch: none, all, or where a gate missed.

    ``none`` is ``False``, so that nothing is reduced for plots no one draws.
    """
    if job.plots == "failed":
        return lambda report: bool(evaluate_gates(report, gates))
    return job.plots == "all"


def _wants_plots(job: BatchJob, gates: Sequence[Gate], report: Report) -> bool:
    """Whether the log of ``report`` gets plots (:func:`_plots`)."""
    plots = _plots(job, gates)
    return plots(report) if callable(plots) else plots


# --- one log ------------------------------------------------------------------------------------


def _intact(folder: Path) -> bool:
    """Whether ``folder`` still holds every file hybridlog wrote there, each unchanged.

    A report folder missing its timeline, or whose report.json was edited since (a VAF
    raised by hand), is not a report of this run whatever its provenance says: reused, its
    numbers would reach the summaries and the gates.  A folder whose marker lists no files
    (hidden files left out of a CI artifact) cannot be checked, and is taken as before.
    """
    written = recorded_files(folder)
    if written is None:
        return True
    return all((folder / name).is_file() for name in written) and not edited_files(folder)


def _reusable(job: BatchJob, folder: Path, log: str, log_sha256: str) -> LogOutcome | None:
    """The finished outcome of a log whose folder holds a report of this very run, if any."""
    report_file = folder / "report.json"
    if job.force or not report_file.is_file():
        return None
    try:
        report = read_report(report_file)
    except ReportError:
        return None  # an unreadable or malformed earlier report is redone
    if (report.model, report.estimator) != (job.model_name, job.estimator):
        return LogOutcome(
            log,
            str(folder),
            "failed",
            None,
            f"{folder} holds a report of {report.estimator} with model {report.model}; "
            "use --force to replace it, or another --out",
        )
    recorded = report.extra.get(PROVENANCE_KEY)
    recorded = dict(recorded) if isinstance(recorded, dict) else {}
    run = recorded.pop("run", None)
    if recorded != job.provenance(log_sha256):
        return None
    if not _intact(folder):
        return None  # redone: replaced if only a file is gone, refused if one was edited
    # checked without loading the model, so that resuming a finished batch costs no start-up
    gates = parse_gates(job.fail_under, job.fail_over) if job.plots == "failed" else []
    if _wants_plots(job, gates, report) and not (folder / "plots").is_dir():
        return None
    # written by this very run: the log's task run again (on Dask) is the log analysed now
    status = "done" if job.run and run == job.run else "skipped"
    return LogOutcome(log, str(folder), status, report, None)


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


def _check_apart_from_reports(folder: Path) -> None:
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


def _analyze_checked(job: BatchJob, log: str, folder: str) -> LogOutcome:
    path = Path(folder)
    # creatable (not under a file nor in another log's report), and a folder hybridlog did
    # not write is never replaced, with or without --force
    _check_apart_from_reports(path)
    check_dir_target(path, force=True, replacing=False)
    # The log's bytes are hashed before they are read, and what stat says of it is the same
    # before the hash and after the read (:func:`_check_log_unchanged`), so a report never
    # records a content it was not made from.
    stamp = log_stamp(log)
    log_sha256 = content_hash(log)
    if path.exists():
        reused = _reusable(job, path, log, log_sha256)
        if reused is not None:
            return reused
    from hybridlog.jobs.dask_backend import stopped

    batch_stopped = stopped()  # on a Dask worker: the batch may be stopped meanwhile
    _unless_stopped(batch_stopped, log)
    warm = _warm(job)
    if job.read.msg_dirs:  # read with each log: checked before each
        _check_unchanged(job, [])
    reading: dict[str, Any] = {}
    read = job.read
    if read.recover and not recover_applies(log):  # another format: said by recover_note
        read = dataclasses.replace(read, recover=False)
    signals = read_log(log, warm.model, read, reading)
    _check_log_unchanged(log, stamp)
    check_signals([warm.prepared], warm.model, signals)  # before waiting for memory
    from hybridlog.report import write_report  # polars: where a log is analysed only

    # in a pool, the memory the other workers' logs hold counts too (memory.MemoryLedger)
    with memory_reserved(log, warm.model, [warm.prepared], signals) as waited:
        # (a result computed whole is computed here, by stream: inside the reservation)
        run = partial(warm.prepared.stream, warm.model, signals, **warm.inputs)
        chunks = given_in_chunks(run, warm.given)
        if batch_stopped is not None:  # checked between chunks: the report folder removed
            chunks = _chunks_unless_stopped(chunks, batch_stopped, log)
        report = write_report(
            path,
            chunks,
            signals,
            log=as_text(log),
            model_name=warm.model.name,
            dt=warm.model.dt,
            table_format=job.table_format,
            force=True,
            reading=reading,
            extra={**warm.values, PROVENANCE_KEY: {**job.provenance(log_sha256), "run": job.run}},
            plots=_plots(job, warm.gates),
            model=warm.model,
        )
    return LogOutcome(log, folder, "done", report, None, memory_wait_s=waited)


def _check_log_unchanged(log: str, stamp: str) -> None:
    """Refuse a log whose size or modification time changed since it was hashed (:func:`log_stamp`).

    Read after the change, the log's report would record the content hashed before: numbers
    of a cut-off read (a recorder still writing the log) under a content they are not of.

    Raises
    ------
    LogError
        Naming the log.
    """
    if log_stamp(log) != stamp:
        raise LogError(
            f"{log}: changed while the batch read it (its size, modification time or file "
            "differ from when it was hashed), so it was not analysed; run the batch again "
            "once it is complete"
        )


def _unless_stopped(batch_stopped: Callable[[], bool] | None, log: str) -> None:
    """Raise when the Dask batch this log's task belongs to was stopped (interrupted)."""
    if batch_stopped is not None and batch_stopped():
        raise OutputError(f"{log}: not analysed: the batch was stopped")


def _chunks_unless_stopped(
    chunks: Iterable[T], batch_stopped: Callable[[], bool], log: str
) -> Iterator[T]:
    """The estimator's ``chunks``, raising before the next one once the batch was stopped."""
    for chunk in chunks:
        _unless_stopped(batch_stopped, log)
        yield chunk


def analyze_log(job: BatchJob, log: str, folder: str) -> LogOutcome:
    """Analyse one log of a batch into ``folder``; every failure becomes its one-line error.

    The task a worker runs (a local process or a Dask worker): it returns, never raises.
    """
    start = time.perf_counter()
    try:
        outcome = _analyze_checked(job, log, folder)
    except HybridlogError as err:
        error = _one_line(str(err))
        outcome = LogOutcome(log, folder, "failed", None, error + missing_pattern_hint(log))
    except Exception as err:  # a reader or estimator bug must not stop the other logs
        why = _one_line(f"{type(err).__name__}: {err}")
        outcome = LogOutcome(log, folder, "failed", None, why)
    return dataclasses.replace(outcome, seconds=time.perf_counter() - start)


# --- the batch ----------------------------------------------------------------------------------


def _prepare_root(root: Path, folders: Sequence[Path], locks: contextlib.ExitStack) -> _Made:
    """Create the batch folder and the folders holding log folders, or check they are ours.

    The batch folder is locked for this batch into ``locks`` (:func:`batch_folder_lock`) once
    it exists, before anything is written in it: another batch running into it is refused,
    and what this run made is left to that batch.  Returns what it made, to be removed
    should the batch be refused later (:func:`_plan`).
    """
    # creatable (its name, its parent), not a file or a link, not someone else's folder
    check_dir_target(root, force=True, replacing=False)
    if root.exists() and any(root.iterdir()) and not is_ours(root):
        raise OutputError(
            f"output directory {root} holds files hybridlog did not write (no {MARKER} "
            "file); choose another --out or empty the folder yourself"
        )
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
            # a folder fail, each naming it (:func:`_check_apart_from_reports`, check_dir_target)
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
    """What :func:`_prepare_root` made: the marker (if this run wrote it) and the folders."""

    root: Path
    marker: bool
    folders: list[Path]
    """Deepest first."""

    def undo(self) -> None:
        """Remove it all: the batch is refused after the folder was made (:func:`_plan`)."""
        with contextlib.suppress(OSError):
            if self.marker:
                (self.root / MARKER).unlink()
        for folder in self.folders:  # empty unless someone else wrote there meanwhile
            with contextlib.suppress(OSError):
                folder.rmdir()


def _remove_previous_report(job: BatchJob, outcome: LogOutcome) -> None:
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
    if outcome.status != "failed" or folder.is_symlink() or not folder.is_dir():
        return
    if _report_kind(folder / "report.json") != (job.model_name, job.estimator):
        return
    try:
        check_dir_target(folder, force=True, replacing=True)
    except OutputError:
        return
    aside = temporary_name(folder, kind="old")
    with contextlib.suppress(OSError):
        os.rename(folder, aside)
        shutil.rmtree(aside, ignore_errors=True)


def _remove_empty_parents(root: Path, outcome: LogOutcome) -> None:
    """Remove the folders left empty above the report folder of a log that failed.

    The folders that hold report folders (``d2/deep/`` for ``d2/deep/run.csv``) are made
    before any log is read (:func:`_prepare_root`); a log that failed got no report folder,
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


def _remove_temporaries_left(folders: Sequence[Path], workers: Sequence[int]) -> None:
    """Remove what the ended ``workers`` (process ids) left in ``folders``, and dead processes'.

    A worker stopped by a signal removes its own temporary folder (:mod:`.workers`), unless
    it is killed first (after :data:`~hybridlog.jobs.workers.STOP_GRACE_S`, or by the
    system) or a thread of its task still writes into the folder while it is removed.
    """
    for folder in folders:
        remove_stale_temporaries(folder, ours=frozenset(workers))


WORKER_BASELINE_BYTES = 150_000_000
"""What a local worker process holds before its first log: numpy, numba's compiler set up,
the filters, polars, the loaded model (70-150 MB measured; the larger figure is assumed)."""


def pool_size(jobs: int, logs: int, *, auto: bool = False) -> tuple[int, list[str]]:
    """The worker processes for ``--jobs jobs`` over ``logs`` logs, and a note per cap applied.

    Never more workers than logs, nor more than the memory available holds at
    :data:`WORKER_BASELINE_BYTES` each (``--jobs 500`` started 500 processes, which the
    kernel then killed or the machine swapped): each worker's logs need memory on top.
    ``auto``: ``jobs`` is ``--jobs auto``'s count of cores, which the notes name as such;
    fewer logs than cores is no note then (the user asked for no number of workers).
    """
    notes: list[str] = []
    size = jobs
    asked = f"auto ({jobs} core{'s' if jobs > 1 else ''})" if auto else str(jobs)
    if size > logs > 0:
        size = logs
        if not auto:
            notes.append(f"--jobs {jobs}: {logs} log{'s' if logs > 1 else ''}, so {logs} at once")
    available = available_memory()
    if available is not None and size > 1:
        fits = max(1, available // WORKER_BASELINE_BYTES)
        if size > fits:
            size = fits
            notes.append(
                f"--jobs {asked}: {fits} worker process{'es' if fits > 1 else ''}, as many as "
                f"the memory available ({size_text(available)}) holds at about "
                f"{WORKER_BASELINE_BYTES / 1e6:.0f} MB each before their logs"
            )
    return size, notes


def _died(log: str, folder: str) -> Callable[[str], LogOutcome]:
    return lambda reason: LogOutcome(log, folder, "failed", None, f"worker process died ({reason})")


def run_batch(
    logs: Sequence[PathLike] | FoundLogs,
    model_ref: str | Path,
    *,
    out_dir: PathLike,
    estimator: str | None = None,
    jobs: int | Literal["auto"] = 1,
    scheduler: str | None = None,
    sets: Sequence[str] = (),
    read: ReadOptions | None = None,
    fail_under: Sequence[str] = (),
    fail_over: Sequence[str] = (),
    table_format: str = "csv",
    plots: str = "none",
    junit: PathLike | None = None,
    force: bool = False,
    progress: Callable[[LogOutcome], None] | None = None,
    smooth: bool = False,
    mode_sequence: str | None = None,
) -> BatchOutcome:
    """Analyse every log into ``<out>/<log path>/``; write ``summary.md``/``.csv``/``.png``.

    ``logs`` are log files, bags and folders of logs (:func:`batch_logs`), or what
    :func:`batch_logs` found already.

    Everything shared by the logs (model, options, gates, the output folder, the JUnit file)
    is checked before the first log is read: the outputs must not be, contain or sit inside
    any log, the model file, a centres file or a ``--msg-dir``.  ``progress`` is called with
    each log's outcome as it finishes.  The installed reporter's ``wait``
    (:func:`~hybridlog.cluster.progress.reporting`), if any, is held around a model's
    first compiling, in this process or the workers (:meth:`WorkerPool.run
    <hybridlog.jobs.workers.WorkerPool.run>`); not on a Dask cluster's workers.  ``jobs``
    worker processes (``"auto"``: one per core this process may use,
    :func:`~hybridlog.environment.usable_cores`) analyse the logs, or the Dask cluster whose
    scheduler is at ``scheduler``.  ``junit`` names a JUnit XML file to write
    (:func:`hybridlog.report.junit.write_junit`).  ``smooth`` and ``mode_sequence`` are
    ``--smooth`` and ``--mode-sequence``
    (:func:`hybridlog.jobs.analysis.smoothing_overrides`); as estimator options they are part
    of the settings a resumed batch compares, so changing them redoes every log.

    With ``jobs > 1`` the workers are :mod:`multiprocessing` processes, which import the
    calling script's main module: as for any multiprocessing code, a script that calls this
    must run its own work under ``if __name__ == "__main__":`` (without it, each worker runs
    the script again and every log fails with multiprocessing's "bootstrapping phase" error).
    """
    read = arguments.common(
        model_ref,
        sets=sets,
        read=read,
        fail_under=fail_under,
        fail_over=fail_over,
        table_format=table_format,
        force=force,
        smooth=smooth,
        mode_sequence=mode_sequence,
    )
    if not isinstance(logs, FoundLogs):
        arguments.paths(logs, "logs")
    arguments.path(out_dir, "out_dir")
    arguments.path(junit, "junit", optional=True)
    arguments.text(estimator, "estimator", optional=True)
    arguments.text(scheduler, "scheduler", optional=True)
    arguments.text(plots, "plots")
    arguments.callback(progress, "progress")
    # "auto": one worker per core this process may use, named so in notes and errors (the
    # CLI passed the count, and a 2-core machine refused "--jobs 2" with --scheduler,
    # which a 1-core one took)
    auto = jobs == "auto"
    jobs = usable_cores() if auto else arguments.integer(jobs, "jobs")
    if jobs < 1:
        raise OptionError("--jobs: must be at least 1")
    if (auto or jobs > 1) and scheduler is not None:  # ignored, as if it held the cluster back
        raise OptionError(
            f"--jobs {'auto' if auto else jobs}: has no effect with --scheduler (the Dask "
            "workers' threads set how many logs run at once); leave it out"
        )
    if plots not in PLOT_CHOICES:
        raise OptionError(f"--plots: expected one of {', '.join(PLOT_CHOICES)}, got {plots!r}")
    found = logs if isinstance(logs, FoundLogs) else batch_logs(logs)
    paths, searched = found.paths, found.searched
    notes: list[str] = list(found.notes)
    if read is not None and read.recover:  # refused when it applies to no log
        recovered = recover_note(paths)
        notes += [] if recovered is None else [recovered]
    if scheduler is None and jobs > 1:
        jobs, capped = pool_size(jobs, len(paths), auto=auto)
        notes += capped
    pool = client = None
    # where the workers write: the report folders' parents, and an existing report folder
    # itself (refreshed in place, its temporaries inside it: outputs.publish_dir)
    staging: list[Path] = []
    if scheduler is not None:
        from hybridlog.jobs.dask_backend import check_out, check_workers, connect, run_on_dask

        client = connect(scheduler)  # before anything is written: an unreachable one fails alone
    elif jobs > 1 and len(paths) > 1:
        from hybridlog.jobs.workers import WorkerPool

        # entered first, so that the forkserver warms up while this process checks the
        # inputs; left on an error or a signal, it stops its workers, which remove their
        # temporary folders, and then removes what a worker stopped mid-task left
        pool = WorkerPool(
            jobs,
            clean_up=lambda workers: _remove_temporaries_left(staging, workers),
        )
    resource = contextlib.ExitStack()
    if pool is not None:
        resource.enter_context(pool)
    elif client is not None:
        resource.enter_context(contextlib.closing(client))
    workers: list[Any] = []  # the Dask workers' check (:func:`check_workers`, :func:`check_out`)

    def check_cluster(inputs: Sequence[tuple[str, PathLike]]) -> None:
        if client is not None and scheduler is not None:  # before anything is written
            paths = [(what, os.fspath(path)) for what, path in inputs]
            model = (str(model_ref), model_hash(model_ref))
            workers.append(check_workers(client, scheduler, paths, model))

    def check_cluster_out(root: Path) -> None:
        if client is not None and workers:  # the batch folder made: the workers must see it
            workers[0] = resource.enter_context(check_out(client, workers[0], root))

    # the batch folder's lock (:func:`_prepare_root`): held until the summaries are written
    with contextlib.ExitStack() as locks:
        with resource:
            job, model, gates, tasks = _plan(
                paths,
                searched,
                model_ref,
                out_dir=out_dir,
                estimator=estimator,
                sets=sets,
                read=read,
                fail_under=fail_under,
                fail_over=fail_over,
                table_format=table_format,
                plots=plots,
                junit=junit,
                force=force,
                smooth=smooth,
                mode_sequence=mode_sequence,
                check_inputs=check_cluster,
                check_out=check_cluster_out,
                locks=locks,
            )
            _withdraw_summaries(output_path(out_dir), junit)
            withdrawn = withdraw_previous_junit(output_path(out_dir), junit)
            notes += [] if withdrawn is None else [withdrawn]
            folders = {Path(folder) for _, _, folder in tasks}
            staging.extend(sorted(folders | {folder.parent for folder in folders}))
            died = [_died(log, folder) for _, log, folder in tasks]
            outcomes: list[LogOutcome]
            if client is not None or pool is not None:
                # this process needs no numba and only waits now (for the forkserver's warm-up,
                # then for the results, or for the cluster's): it imports what the summary plot
                # needs and makes its figure meanwhile (0.2 s less at the end)
                plotting = threading.Thread(
                    target=_prepare_summary_plot, args=(len(tasks),), daemon=True
                )
                plotting.start()
                if client is not None:
                    outcomes = run_on_dask(
                        analyze_log,
                        tasks,
                        client,
                        workers[0],
                        died=lambda i, why: died[i](why),
                        failed=lambda i, why: LogOutcome(
                            tasks[i][1], tasks[i][2], "failed", None, _one_line(why)
                        ),
                        done=progress,
                        kept=lambda outcome: outcome.status != "failed",
                    )
                elif pool is not None:
                    outcomes = pool.run(
                        analyze_log,
                        tasks,
                        died=lambda i, why: died[i](why),
                        done=progress,
                        wait=current_wait(),
                    )
                plotting.join()
            else:
                outcomes = []
                for task in tasks:
                    outcomes.append(analyze_log(*task))
                    if progress is not None:
                        progress(outcomes[-1])
        root = output_path(out_dir)
        for outcome in outcomes:
            _remove_previous_report(job, outcome)
            _remove_empty_parents(root, outcome)
        others = other_folders(root, [Path(o.folder) for o in outcomes])
        summary = _summarise(root, model, job, gates, outcomes, junit, others)
        record_junit(root, junit)  # withdrawn by the next run that does not write it
        notes += _made_elsewhere_note(outcomes)
        if others:
            notes.append(others_note(others))
        return dataclasses.replace(summary, notes=notes)


def _prepare_summary_plot(n_rows: int) -> None:
    from hybridlog.report.summary_plot import prepare_summary_figure

    prepare_summary_figure(n_rows)


def _plan(
    paths: Sequence[str],
    searched: Sequence[str],
    model_ref: str | Path,
    *,
    out_dir: PathLike,
    estimator: str | None,
    sets: Sequence[str],
    read: ReadOptions,
    fail_under: Sequence[str],
    fail_over: Sequence[str],
    table_format: str,
    plots: str,
    junit: PathLike | None,
    force: bool,
    smooth: bool = False,
    mode_sequence: str | None = None,
    check_inputs: Callable[[Sequence[tuple[str, PathLike]]], None] | None = None,
    check_out: Callable[[Path], None] | None = None,
    locks: contextlib.ExitStack | None = None,
) -> tuple[BatchJob, HybridModel, list[Gate], list[tuple[BatchJob, str, str]]]:
    """Check everything the logs share, prepare the batch folder; the job and its tasks.

    ``locks`` gets the batch folder's lock (:func:`_prepare_root`), to hold until the
    summaries are written.

    ``check_inputs`` is called with the files and folders the batch reads once all is
    checked, before anything is written (the Dask workers' check); ``check_out`` with the
    batch folder once it is made: when it raises, what this run made of it is removed.
    """
    # the model, the estimator and every --set value are checked before any work; the model
    # is hashed before it is read (as each worker does, :func:`_warm`): a report never
    # records a model it was not made from
    model_sha256 = model_hash(model_ref)
    model, overrides = parse_sets(sets, model_ref)
    (prepared,) = prepare_estimators(
        model, [estimator], overrides, smooth=smooth, mode_sequence=mode_sequence
    )
    gates = gates_for(model, [prepared], fail_under, fail_over)
    check_table_format(table_format)
    check_followable(out_dir)  # as given: output_path takes log.csv/../out for ./out
    root = output_path(out_dir)
    names = folder_names(paths, searched)
    summaries = [root / name for name in SUMMARY_NAMES]
    outputs: list[tuple[str, PathLike]] = [("--out", out_dir), *(("--out", s) for s in summaries)]
    if junit is not None:
        check_file_name(junit, "--junit")  # first: --junit j.xml/.. is the folder holding it
        outputs.append(("--junit", junit))
        check_distinct(outputs)
    inputs = input_paths(paths, model_ref, [prepared], read)
    check_apart(outputs, [*(("folder of logs", f) for f in searched), *inputs])
    if junit is not None:
        check_junit_target(junit)
    stamps = tuple(folder_stamp(folder) for folder in read.msg_dirs)  # before the hashes
    job = BatchJob(
        msg_dir_stamps=stamps,
        model_ref=str(model_ref),
        model_sha256=model_sha256,
        model_name=model.name,
        sets=tuple(sets),
        estimator=prepared.name,
        read=read,
        table_format=table_format,
        fail_under=tuple(fail_under),
        fail_over=tuple(fail_over),
        plots=plots,
        force=force,
        settings=_settings(prepared, overrides, read, table_format),
        smooth=smooth,
        mode_sequence=mode_sequence,
        offline=prepared.offline,
        run=uuid.uuid4().hex,
    )
    # the folder itself first (not a file, not a link): its summaries are checked as in it
    check_dir_target(root, force=True, replacing=False)
    ours = _summaries_ours(root)
    for summary in summaries:  # refused now, not once every log has been analysed
        if summary.is_file() and not summary.is_symlink() and not ours(summary):
            raise OutputError(
                f"{summary} changed since a batch wrote it, and every run of the batch "
                "rewrites it; move it out of the folder to keep it"
            )
        check_file_target(summary, force=True, ours=ours)
    folders = [root / name for name in names]
    if junit is not None:
        _check_junit_apart(junit, root, paths, folders)
    if not force:
        _check_same_run_kind(root, folders, job)
    if check_inputs is not None:
        check_inputs(inputs)
    made = _prepare_root(root, folders, contextlib.ExitStack() if locks is None else locks)
    if check_out is not None:
        try:
            check_out(root)
        except BaseException:  # refused (a Dask worker that does not see it), interrupted
            made.undo()
            raise
    with _WARM_LOCK:  # this process has it all loaded already
        _WARM.clear()
        values = run_values(model, prepared, overrides.parameter_texts)
        given = given_values(overrides.parameter_texts, prepared)
        _WARM[_warm_key(job)] = _Warm(
            model, prepared, estimator_inputs(prepared, model), gates, values, given
        )
    tasks = [(job, log, str(folder)) for log, folder in zip(paths, folders, strict=True)]
    return job, model, gates, tasks


def _check_junit_apart(
    junit: PathLike, root: Path, logs: Sequence[str], folders: Sequence[Path]
) -> None:
    """Refuse a JUnit file that is, lies in or holds a log's report folder.

    The batch folder may hold it beside the summaries, but a log's folder is replaced
    whole when the log is analysed (a file of the same name as one of its reports is
    refused only after every log was analysed, the summaries unwritten), and a JUnit file
    put in one is a stranger there that keeps the log from ever being redone.
    """
    target = str(output_path(junit))
    for log, folder in zip(logs, folders, strict=True):
        name = str(folder)
        relation = (
            "is"
            if target == name
            else "lies in"
            if target.startswith(name + os.sep)
            else "holds"
            if name.startswith(target + os.sep)
            else None
        )
        if relation is not None:
            raise OutputError(
                f"--junit {excerpt(os.fspath(junit))} {relation} the report folder "
                f"{excerpt(name)} of the log {excerpt(log)}; name a file outside the logs' "
                f"folders (e.g. {excerpt(str(root / 'junit.xml'))})"
            )


def _report_kind(report: Path, *, of_a_batch: bool = False) -> tuple[str, str] | None:
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


def _check_same_run_kind(root: Path, folders: Sequence[Path], job: BatchJob) -> None:
    """Refuse, before any log is read, a batch folder holding another estimator's reports.

    Each such log would fail (its folder is not replaced without ``--force``), and the
    summaries of that run, every such log failed, would replace the previous run's: the
    user's summaries lost for a run that wrote nothing.  The report folders of logs not in
    this run count too (:func:`~hybridlog.jobs.batch_others.report_folders`): a run over
    other logs would replace that batch's summaries with its own, of another estimator,
    beside that batch's reports.  Reports of the same estimator and model made with other
    options are redone as usual (:func:`_reusable`).  Among the others only this batch
    folder's reports count: ``analyze``, ``compare`` and another batch may write a new
    folder inside a batch folder
    (:func:`~hybridlog.outputs.folder_targets.check_outside_batch`), and such a report (a
    comparison's, of other estimators by nature; another batch's, of another estimator)
    made every later run of the batch fail, exit 2, while it replaced nothing of it; it
    is named among the other report folders instead (a batch folder inside this
    one is not searched).
    """
    own = [folder for folder in folders if not folder.is_symlink()]
    seen = {os.path.abspath(folder) for folder in own}
    others = [f for f in report_folders(root) if os.path.abspath(f) not in seen]
    other: dict[tuple[str, str], list[str]] = {}
    ordered = sorted(others, key=lambda f: natural_key(f.as_posix()))
    for folder, of_a_batch in [*((f, False) for f in own), *((f, True) for f in ordered)]:
        report = folder / "report.json"
        if not report.is_file():
            continue
        kind = _report_kind(report, of_a_batch=of_a_batch)
        if kind is not None and kind != (job.model_name, job.estimator):
            other.setdefault(kind, []).append(folder.relative_to(root).as_posix())
    if not other:
        return
    (model, estimator), names = next(iter(other.items()))
    count = sum(len(n) for n in other.values())
    more = f" and {count - 1} more" if count > 1 else ""
    raise OutputError(
        f"--out {excerpt(str(root), 240)[1:-1]} holds reports of {excerpt(estimator, 40)} "
        f"with model {excerpt(model, 60)} ({excerpt(names[0], 60)[1:-1]}{more}), not of "
        f"{job.estimator} with model {job.model_name}; use --force to replace them, or "
        "another --out"
    )


def _summaries_ours(root: Path) -> Callable[[Path], bool]:
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


def _withdraw_summaries(root: Path, junit: PathLike | None) -> None:
    """Remove the summaries (and JUnit file) of an earlier run, before any log is analysed.

    They are of the reports that run left: a batch that then ended without writing its own
    (killed, interrupted, its cluster lost) left them beside the reports it had replaced
    already, so summary.csv showed the earlier numbers for the reports it links to, and the
    JUnit file a CI step publishes even after a failure (``if: always()``) the earlier
    gates passed.  Such a batch now leaves no summary; the next run writes them.  Only
    files :func:`_plan` took for the batch's (:func:`_summaries_ours`) are removed.

    Raises
    ------
    OutputError
        When one cannot be removed, naming it.
    """
    ours = _summaries_ours(root)
    targets = [root / name for name in SUMMARY_NAMES]
    if junit is not None:
        targets.append(output_path(junit))
    for target in targets:
        if not target.is_file() or target.is_symlink() or not ours(target):
            continue
        try:
            target.unlink(missing_ok=True)
            record_path(target).unlink(missing_ok=True)
        except OSError as err:
            raise OutputError(
                f"{excerpt(str(target))[1:-1]}: cannot remove the previous run's file, which "
                f"would be left beside this run's reports: {err.strerror or err}"
            ) from err


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


def _made_elsewhere_note(outcomes: Sequence[LogOutcome]) -> list[str]:
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


def _summarise(
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
        ours=_summaries_ours(root),
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
