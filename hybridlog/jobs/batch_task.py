"""One log of a batch: the task a worker runs (:func:`analyze_log`) and what it keeps.

Each process loads the model, prepares the estimator and compiles its code once per batch
(:func:`_warm`, kept in :data:`WARM`); a log whose folder holds an intact report of this
very run is skipped (:func:`_reusable`, :func:`_intact`); any other is hashed before it is
read, checked unchanged once read, along with the model and the input files
(:func:`_check_unchanged`, :func:`_check_log_unchanged`), and analysed into its folder.
Every failure becomes the log's one-line error.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import threading
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any, TypeVar

from hybridlog.errors import (
    HybridlogError,
    LogError,
    ModelError,
    OptionError,
    OutputError,
    ReportError,
    as_text,
    excerpt,
)
from hybridlog.estimators import Prepared
from hybridlog.io.formats import log_format
from hybridlog.jobs.batch_folders import check_apart_from_reports
from hybridlog.jobs.batch_job import BatchJob
from hybridlog.jobs.batch_logs import header_time_applies, missing_pattern_hint, recover_applies
from hybridlog.jobs.batch_others import PROVENANCE_KEY
from hybridlog.jobs.batch_outcomes import LogOutcome, error_line
from hybridlog.jobs.estimation import (
    FILE_OPTIONS,
    check_signals,
    estimator_inputs,
    memory_reserved,
    read_log,
)
from hybridlog.jobs.estimator_calls import warm_up_told
from hybridlog.jobs.gate_checks import gates_for
from hybridlog.jobs.origins import given_in_chunks, given_values, run_values
from hybridlog.jobs.overrides import parse_sets, prepare_estimators
from hybridlog.jobs.provenance import content_hash, folder_stamp, log_stamp, model_hash
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.outputs import check_dir_target, edited_files, recorded_files
from hybridlog.outputs.file_targets import check_path_length
from hybridlog.report import Report, evaluate_gates, parse_gates, read_report
from hybridlog.report.gates import Gate

__all__ = [
    "WARM",
    "WARM_LOCK",
    "Warm",
    "analyze_log",
    "check_read_unchanged",
    "input_files",
    "warm_key",
]


T = TypeVar("T")


@dataclass(frozen=True)
class Warm:
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


WARM: dict[tuple[object, ...], Warm] = {}
WARM_LOCK = threading.Lock()


def warm_key(job: BatchJob) -> tuple[object, ...]:
    """:data:`WARM`'s key for a job: its model, ``--set`` values, estimator and gates."""
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


def _warm(job: BatchJob) -> Warm:
    """The loaded model, prepared estimator, its input files and gates, once per process.

    Kept for the batch's model, ``--set`` values and estimator (one batch at a time: a new
    key replaces the old one), so a worker loads and compiles nothing after its first log.
    The estimator is warmed up here once, its machine code loaded or, on the model's first
    run, compiled, the installed reporter told
    (:func:`~hybridlog.jobs.estimator_calls.warm_up_told`: the console script says so on a
    terminal, above its bar), also in the batch's own
    process, whose rest :func:`~hybridlog.jobs.batch_plan.plan` made, when it runs the logs itself.
    """
    key = warm_key(job)
    with WARM_LOCK:
        warm = WARM.get(key)
        if warm is None:
            # hashed before it is read and again once read (with the files its options
            # name): a report never records a model it was not made from
            _check_model_unchanged(job)
            model, overrides = parse_sets(job.sets, job.model_ref)
            (prepared,) = prepare_estimators(
                model,
                [job.estimator],
                overrides,
                smooth=job.smooth,
                mode_sequence=job.mode_sequence,
            )
            _check_unchanged(job, input_files(prepared))
            gates = gates_for(model, [prepared], job.fail_under, job.fail_over)
            values = run_values(model, prepared, overrides.parameter_texts)
            given = given_values(overrides.parameter_texts, prepared)
            inputs = estimator_inputs(prepared, model)
            check_read_unchanged(job, prepared)
            warm = Warm(model, prepared, inputs, gates, values, given)
            WARM.clear()
            WARM[key] = warm
        if not warm.warmed_up.is_set():
            warm.warmed_up.set()
            # on rows of zeros: what it raises, the run raises again if the log makes it so
            with contextlib.suppress(Exception):
                warm_up_told(warm.prepared, warm.model)
        return warm


def _check_model_unchanged(job: BatchJob) -> None:
    """Refuse a model file whose content is not the one the batch hashed when it started.

    Called before the worker reads it and again once read (with the ``--set`` values, it is
    read twice): an edit saved between the hash and the read (an editor writing the file
    while a worker starts) was loaded under the hash of the content before it.

    Raises
    ------
    ModelError
        Naming the model file.
    """
    if model_hash(job.model_ref) != job.model_sha256:
        raise ModelError(
            f"{job.model_ref}: the model file changed since the batch started, so "
            "this log was not analysed with the model the batch checked and records; "
            "run the batch again"
        )


def check_read_unchanged(job: BatchJob, prepared: Prepared) -> None:
    """Refuse a model file or input file edited between the batch's hash and its read.

    Called once the model and the files its estimator's options name were read (by a
    worker, or by :func:`~hybridlog.jobs.batch_plan.plan` for the logs its own process
    analyses): an edit saved after the hash and before the read (an editor writing the
    model while the batch starts) was loaded under the hash of the content before it.

    Raises
    ------
    ModelError, OptionError
        Naming the file.
    """
    _check_model_unchanged(job)
    _check_unchanged(job, input_files(prepared))


def input_files(prepared: Prepared) -> list[tuple[str, str, str]]:
    """The files the estimator's options name: ``(option, what it is, path)`` each."""
    return [
        (name, what, value)
        for name, (what, _) in FILE_OPTIONS.items()
        if (value := getattr(prepared.options, name, None))
    ]


def _check_unchanged(job: BatchJob, files: Sequence[tuple[str, str, str]]) -> None:
    """Refuse input files and ``--msg-dir`` folders whose content changed since the batch started.

    The batch hashed them for its reports' provenance
    (:func:`~hybridlog.jobs.batch_plan._settings`) before any worker reads them; one edited
    since would be read by the workers that start, or the logs read, after the edit, their
    reports recording the content checked before.  Called before they are read (a report
    never records a content it was not made from).

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


def _intact(folder: Path, table_format: str) -> bool:
    """Whether ``folder`` still holds every file hybridlog wrote there, each unchanged.

    A report folder missing its timeline, or whose report.json was edited since (a VAF
    raised by hand), is not a report of this run whatever its provenance says: reused, its
    numbers would reach the summaries and the gates.  A folder whose marker lists no files
    (hidden files left out of a CI artifact) cannot be checked file by file: it is taken
    while it holds the files every report has (report.json, report.md and both tables in
    ``table_format``); one that lost any was "skipped" with its timeline gone.
    """
    written = recorded_files(folder)
    if written is None:
        every = (
            "report.json",
            "report.md",
            f"timeline.{table_format}",
            f"estimates.{table_format}",
        )
        return all((folder / name).is_file() for name in every)
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
    if not _intact(folder, job.table_format):
        return None  # redone: replaced if only a file is gone, refused if one was edited
    # checked without loading the model, so that resuming a finished batch costs no start-up
    gates = parse_gates(job.fail_under, job.fail_over) if job.plots == "failed" else []
    if _wants_plots(job, gates, report) and not (folder / "plots").is_dir():
        return None
    # written by this very run: the log's task run again (on Dask) is the log analysed now
    status = "done" if job.run and run == job.run else "skipped"
    return LogOutcome(log, str(folder), status, report, None)


def _analyze_checked(job: BatchJob, log: str, folder: str) -> LogOutcome:
    path = Path(folder)
    # creatable (a path the system takes, not under a file nor in another log's report), and
    # a folder hybridlog did not write is never replaced, with or without --force
    check_path_length(path, folder=True)  # first: a longer path fails every system call
    check_apart_from_reports(path)
    check_dir_target(path, force=True, replacing=False)
    # The log's bytes are hashed before they are read, and what stat says of it is the same
    # before the hash and after the read (:func:`_check_log_unchanged`), so a report never
    # records a content it was not made from.  Checked as its reader checks it first, so that
    # a log missing or a link to nothing fails with analyze's reason, not the hash's
    # (``cannot read it: No such file or directory``).
    log_format(log)
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
    if read.time == "header" and not header_time_applies(log):  # a table: header_time_note
        read = dataclasses.replace(read, time="log")
    signals = read_log(log, warm.model, read, reading)
    _check_log_unchanged(log, stamp)
    if job.read.msg_dirs:  # and after: an edit saved while the log was read
        _check_unchanged(job, [])
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
        error = error_line(str(err))
        outcome = LogOutcome(log, folder, "failed", None, error + missing_pattern_hint(log))
    except Exception as err:  # a reader or estimator bug must not stop the other logs
        why = error_line(f"{type(err).__name__}: {err}")
        outcome = LogOutcome(log, folder, "failed", None, why)
    return dataclasses.replace(outcome, seconds=time.perf_counter() - start)
