"""Batch reprocessing: one estimator over many logs, each into its own report folder.

A failing log never stops the others: any exception while analysing a log, and a worker
process that dies, is recorded as that log's one-line error in the summary.

**Resume by content.**  Every report a batch writes records its provenance (report key
``batch``, :meth:`~hybridlog.jobs.batch_job.BatchJob.provenance`): the SHA-256 of the log's
bytes (of every file of a bag folder), of the model file (or built-in model text), the
settings that change results (estimator and its options, ``--set`` parameters, read options
with the content of every ``--msg-dir``, the centres file's content, the table format),
hybridlog's version and a hash of its source (:func:`~hybridlog.jit.package_fingerprint`:
an estimator fixed without a new version number gives new numbers, which a resumed batch
must not hide), and the versions of Python and of the libraries that compute the numbers
(:func:`~hybridlog.jobs.provenance.library_versions`).  A log is skipped
(its report reused) only when its folder's report records exactly the provenance of the run
about to be made and the folder holds every file hybridlog wrote there, unchanged
(:func:`~hybridlog.jobs.batch_task._intact`); otherwise it is redone.  ``force`` redoes
every log.  The log and the model file are hashed before they are read, and a log read with
a model file, centres file or ``--msg-dir`` whose content is no longer the one the batch
hashed (edited while it runs) fails (:func:`~hybridlog.jobs.batch_task._check_unchanged`);
the model and centres files are hashed again once read, by the batch process and by each
worker (:func:`~hybridlog.jobs.batch_task.check_read_unchanged`: an edit saved between the
hash and the read): a report never records a content it was not made from.

**Folder names** (:func:`~hybridlog.jobs.batch_names.folder_names`) are the log paths
relative to their common folder, suffix kept: ``d2/run.csv`` → ``<out>/d2/run.csv/``.  They
depend on each log's own path and on the common folder only, never on the order of the
arguments.

**Throughput.**  Workers stay warm: each process loads the model, prepares the estimator and
compiles its code once per batch (:func:`~hybridlog.jobs.batch_task._warm`) and reuses them
for every log it analyses; per-log plots are drawn only as ``plots`` asks (``none`` by
default, ``failed``: logs that miss a gate, ``all``).  ``jobs > 1`` analyses logs in worker
processes (:mod:`hybridlog.jobs.workers`), ``scheduler`` on a Dask cluster
(:mod:`hybridlog.jobs.dask_backend`); the results are the same.  Logs are processed and
summarised in natural order (``s1, s2, s10``).  The batch process of ``jobs > 1`` or of a
cluster imports neither polars nor numba (``tests/jobs/test_batch_process.py``): it checks,
hands out the logs and writes the summaries, whose CSV it writes with :mod:`csv`
(:func:`hybridlog.report.summary_tables.write_summary_csv`); the report's writer is imported
where a log is analysed.

**Where each part lives.**  This module runs the batch (:func:`run_batch`) and sizes its
pool of workers (:func:`pool_size`); the batch is planned, everything the logs share checked,
in :mod:`~hybridlog.jobs.batch_plan`, into a :class:`~hybridlog.jobs.batch_job.BatchJob`;
each log is the task :func:`~hybridlog.jobs.batch_task.analyze_log`, which returns a
:class:`~hybridlog.jobs.batch_outcomes.LogOutcome`; the batch folder is made and tidied by
:mod:`~hybridlog.jobs.batch_folders`, its report folders named by
:mod:`~hybridlog.jobs.batch_names`, and its summaries written by
:mod:`~hybridlog.jobs.batch_summaries`.
"""

from __future__ import annotations

import contextlib
import dataclasses
import gc
import os
import threading
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, Literal

from hybridlog.cluster.progress import current_wait
from hybridlog.environment import usable_cores
from hybridlog.errors import OptionError
from hybridlog.io import ReadOptions
from hybridlog.jobs import arguments
from hybridlog.jobs.batch_folders import (
    remove_empty_parents,
    remove_previous_report,
    remove_temporaries_left,
)
from hybridlog.jobs.batch_job import PLOT_CHOICES
from hybridlog.jobs.batch_junit import record_junit, withdraw_previous_junit
from hybridlog.jobs.batch_logs import FoundLogs, batch_logs, header_time_note, recover_note
from hybridlog.jobs.batch_others import other_folders, others_note
from hybridlog.jobs.batch_outcomes import BatchOutcome, LogOutcome, error_line
from hybridlog.jobs.batch_plan import plan
from hybridlog.jobs.batch_summaries import made_elsewhere_note, summarise, withdraw_summaries
from hybridlog.jobs.batch_task import analyze_log
from hybridlog.jobs.provenance import model_hash
from hybridlog.memory import available_memory, size_text
from hybridlog.outputs import PathLike, output_path

__all__ = ["run_batch"]


WORKER_BASELINE_BYTES = 150_000_000
"""What a local worker process holds before its first log: numpy, numba's compiler set up,
the filters, polars, the loaded model (70-150 MB measured; the larger figure is assumed)."""


def pool_size(jobs: int, logs: int, *, auto: bool = False) -> tuple[int, list[str]]:
    """The worker processes for ``--jobs jobs`` over ``logs`` logs, and a note per cap applied.

    Never more workers than logs, nor more than the memory available holds at
    :data:`WORKER_BASELINE_BYTES` each (``--jobs 500`` started 500 processes, which the
    kernel then killed or the machine swapped): each worker's logs need memory on top.
    ``auto``: ``jobs`` is ``--jobs auto``'s count of cores, which the notes name as such;
    fewer logs than cores is no note then (the user asked for no number of workers).  More
    workers than the cores this process may use (:func:`usable_cores`) are started as asked,
    with a note: ``--jobs 64`` on 2 cores took 35 s where ``--jobs 2`` took 5 s, each worker
    setting up its own compiler and imports while the logs wait for the cores, and held
    about 7 GB, without a word.
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
    cores = usable_cores()
    if size > cores:
        notes.append(
            f"--jobs {asked}: {size} worker processes on {cores} core{'s' if cores > 1 else ''}: "
            "each sets up its own compiler and imports (about "
            f"{WORKER_BASELINE_BYTES / 1e6:.0f} MB) and the logs share the cores, so more "
            "workers than cores make a batch slower, not faster (--jobs auto: one per core)"
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
    jobs: int | Literal["auto"] | None = None,
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
    worker processes (default 1; ``"auto"``: one per core this process may use,
    :func:`~hybridlog.environment.usable_cores`) analyse the logs, or the Dask cluster whose
    scheduler is at ``scheduler``.  ``junit`` names a JUnit XML file to write
    (:func:`hybridlog.report.junit.write_junit`).  ``smooth`` and ``mode_sequence`` are
    ``--smooth`` and ``--mode-sequence``
    (:func:`hybridlog.jobs.overrides.smoothing_overrides`); as estimator options they are part
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
    # Any --jobs given is refused with a scheduler, 1 too: "--jobs 1" read as one log at a time
    # on the cluster, which ran as many at once as its workers have threads (None: not given)
    given = jobs is not None
    auto = jobs == "auto"
    jobs = usable_cores() if auto else 1 if jobs is None else arguments.integer(jobs, "jobs")
    if jobs < 1:
        raise OptionError("--jobs: must be at least 1")
    if given and scheduler is not None:  # ignored, as if it held the cluster back
        raise OptionError(
            f"--jobs {'auto' if auto else jobs}: has no effect with --scheduler (the Dask "
            "workers' threads set how many logs run at once); leave it out"
        )
    if plots not in PLOT_CHOICES:
        raise OptionError(f"--plots: expected one of {', '.join(PLOT_CHOICES)}, got {plots!r}")
    found = logs if isinstance(logs, FoundLogs) else batch_logs(logs)
    paths, searched = found.paths, found.searched
    if not paths:  # the command line requires LOGS; run_batch([]) wrote "0 logs: all analysed"
        raise OptionError("logs (LOGS): no log given; name at least one log, bag or folder of logs")
    notes: list[str] = list(found.notes)
    if read is not None and read.recover:  # refused when it applies to no log
        recovered = recover_note(paths)
        notes += [] if recovered is None else [recovered]
    if read is not None and read.time == "header":  # so too: the tables keep their time column
        stamped = header_time_note(paths)
        notes += [] if stamped is None else [stamped]
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
            clean_up=lambda workers: remove_temporaries_left(staging, workers),
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

    # the batch folder's lock (:func:`~hybridlog.jobs.batch_folders.prepare_root`): held until
    # the summaries are written
    with contextlib.ExitStack() as locks:
        with resource:
            job, model, gates, tasks = plan(
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
            withdraw_summaries(output_path(out_dir), junit)
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
                            tasks[i][1], tasks[i][2], "failed", None, error_line(why)
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
            remove_previous_report(job, outcome)
            remove_empty_parents(root, outcome)
        others = other_folders(root, [Path(o.folder) for o in outcomes])
        summary = summarise(root, model, job, gates, outcomes, junit, others)
        record_junit(root, junit)  # withdrawn by the next run that does not write it
        notes += made_elsewhere_note(outcomes)
        if others:
            notes.append(others_note(others))
        return dataclasses.replace(summary, notes=notes)


def _prepare_summary_plot(n_rows: int) -> None:
    """Import matplotlib and make the summary plot's figure ahead, without garbage collection.

    Done while this process waits for the forkserver's warm-up (the other core's), which
    it should not outlast: a thread still importing when the workers start takes their
    core.  Its objects live as long as the process; the collector walked them as they grew
    (131 passes, 0.04-0.09 s of the thread's 0.35-0.40 s of CPU; without them 0.34-0.35 s;
    two runs each).  The collector is off in the whole process meanwhile: its main thread
    only waits for the workers' results.
    """
    enabled = gc.isenabled()
    gc.disable()
    try:
        from hybridlog.report.summary_plot import prepare_summary_figure

        prepare_summary_figure(n_rows)
    finally:
        if enabled:
            gc.enable()
