"""The batch planned: everything the logs share checked before the first log is read.

:func:`plan` checks the model, the estimator, its options and gates, and every output
against every input, refuses a batch folder holding reports of another estimator
(:func:`_check_same_run_kind`) and a JUnit file in a log's report folder
(:func:`_check_junit_apart`), makes the batch folder, and returns the
:class:`~hybridlog.jobs.batch_job.BatchJob` (the settings that change results hashed,
:func:`_settings`) with a task per log.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import os
import uuid
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from hybridlog.errors import OutputError, excerpt
from hybridlog.estimators import Prepared
from hybridlog.io import ReadOptions, SignalSpec, check_read_options
from hybridlog.jobs.batch_folders import prepare_root, report_kind
from hybridlog.jobs.batch_job import BatchJob
from hybridlog.jobs.batch_logs import natural_key
from hybridlog.jobs.batch_names import SUMMARY_NAMES, folder_names
from hybridlog.jobs.batch_others import report_folders
from hybridlog.jobs.batch_summaries import summaries_ours
from hybridlog.jobs.batch_task import (
    WARM,
    WARM_LOCK,
    Warm,
    check_read_unchanged,
    input_files,
    warm_key,
)
from hybridlog.jobs.estimation import estimator_inputs, input_paths
from hybridlog.jobs.gate_checks import gates_for
from hybridlog.jobs.origins import given_values, run_values
from hybridlog.jobs.overrides import Overrides, parse_sets, prepare_estimators
from hybridlog.jobs.provenance import content_hash, folder_stamp, model_hash
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.outputs import (
    PathLike,
    check_apart,
    check_dir_target,
    check_distinct,
    check_file_name,
    check_file_target,
    output_path,
)
from hybridlog.outputs.file_targets import check_followable, path_too_long
from hybridlog.report.gates import Gate
from hybridlog.report.junit import check_junit_target
from hybridlog.report.table_format import check_table_format

__all__ = ["plan"]


def _settings(
    prepared: Prepared, overrides: Overrides, read: ReadOptions, table_format: str
) -> str:
    """The settings that change a batch's results, as canonical JSON text."""
    files = {name: content_hash(path, what=what) for name, what, path in input_files(prepared)}
    reading: dict[str, Any] = dataclasses.asdict(read)
    # a symbol maps once, and the maps are read as one dict (``io.mapping.parse_maps``): the
    # same maps in another order, or with spaces around a symbol, redid every log
    reading["maps"] = sorted(_canonical_map(item) for item in read.maps)
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


def _canonical_map(item: str) -> str:
    """A ``--map SYMBOL=PATH`` value as it is read: the symbol stripped, the path as written."""
    symbol, sep, path = item.partition("=")
    return f"{symbol.strip()}{sep}{path}"


def plan(
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

    ``locks`` gets the batch folder's lock (:func:`prepare_root`), to hold until the
    summaries are written.

    ``check_inputs`` is called with the files and folders the batch reads once all is
    checked, before anything is written (the Dask workers' check); ``check_out`` with the
    batch folder once it is made: when it raises, what this run made of it is removed.
    """
    # the model, the estimator and every --set value are checked before any work; the model
    # is hashed before it is read (as each worker does, :func:`~hybridlog.jobs.batch_task._warm`):
    # a report never records a model it was not made from
    model_sha256 = model_hash(model_ref)
    model, overrides = parse_sets(sets, model_ref)
    (prepared,) = prepare_estimators(
        model, [estimator], overrides, smooth=smooth, mode_sequence=mode_sequence
    )
    gates = gates_for(model, [prepared], fail_under, fail_over)
    check_read_options(SignalSpec.of(model), read)  # --map's symbols: once, not with each log
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
    # read after their hashes (the logs this process analyses use them): checked again
    inputs_read = estimator_inputs(prepared, model)
    check_read_unchanged(job, prepared)
    # the folder itself first (not a file, not a link): its summaries are checked as in it
    check_dir_target(root, force=True, replacing=False)
    ours = summaries_ours(root)
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
    # a folder whose path is too long fails its log alone (batch_task): never looked at here
    usable = [folder for folder in folders if path_too_long(folder, folder=True) is None]
    if not force:
        _check_same_run_kind(root, usable, job)
    if check_inputs is not None:
        check_inputs(inputs)
    made = prepare_root(root, usable, contextlib.ExitStack() if locks is None else locks)
    if check_out is not None:
        try:
            check_out(root)
        except BaseException:  # refused (a Dask worker that does not see it), interrupted
            made.undo()
            raise
    with WARM_LOCK:  # this process has it all loaded already
        WARM.clear()
        values = run_values(model, prepared, overrides.parameter_texts)
        given = given_values(overrides.parameter_texts, prepared)
        WARM[warm_key(job)] = Warm(model, prepared, inputs_read, gates, values, given)
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


def _check_same_run_kind(root: Path, folders: Sequence[Path], job: BatchJob) -> None:
    """Refuse, before any log is read, a batch folder holding another estimator's reports.

    Each such log would fail (its folder is not replaced without ``--force``), and the
    summaries of that run, every such log failed, would replace the previous run's: the
    user's summaries lost for a run that wrote nothing.  The report folders of logs not in
    this run count too (:func:`~hybridlog.jobs.batch_others.report_folders`): a run over
    other logs would replace that batch's summaries with its own, of another estimator,
    beside that batch's reports.  Reports of the same estimator and model made with other
    options are redone as usual (:func:`~hybridlog.jobs.batch_task._reusable`).  Among the
    others only this batch folder's reports count: ``analyze``, ``compare`` and another batch
    may write a new folder inside a batch folder
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
        kind = report_kind(report, of_a_batch=of_a_batch)
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
