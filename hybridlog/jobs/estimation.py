"""What a run of prepared estimators over one log reads and needs, and the run itself.

The inputs no output may touch and the files estimator options name (:data:`FILE_OPTIONS`,
:func:`input_paths`, :func:`estimator_inputs`); the log read (:func:`read_log`; with numba
set up meanwhile, :func:`read_for_estimation`) and checked for every estimator's signals
(:func:`check_signals`) and for the memory their results need (:func:`check_memory`,
:func:`memory_reserved`); the estimators' worker warmed up (:func:`warm_up`) and their
chunks streamed from it (:func:`estimates`).  Shared by ``analyze``, ``compare``, ``batch``
and ``hybridlog cluster``.

Importing it loads no polars: the batch process of ``batch --jobs N`` (and of
``--scheduler``) imports this module for the files estimator options name but reads no log,
and polars' import costs 0.13-0.17 s of a core its workers need.  The readers
(:func:`hybridlog.io.load_signals`) are imported where a log is read
(``tests/jobs/test_batch_process.py``).
"""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import replace
from functools import partial
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

from hybridlog.background import ESTIMATES, Background, worker
from hybridlog.cluster.progress import current_reporter, current_wait
from hybridlog.errors import HybridlogError, LogError, OptionError, prefixed
from hybridlog.estimators import Prepared
from hybridlog.io import ReadOptions, SignalSpec
from hybridlog.jit import set_up
from hybridlog.jobs.centers import read_centers
from hybridlog.jobs.estimator_calls import reported, warm_up_told
from hybridlog.memory import check_fits, reserved
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.outputs import PathLike
from hybridlog.signals import AlignedSignals

if TYPE_CHECKING:
    from hybridlog.estimators.result import EstimationResult


FILE_OPTIONS: Mapping[str, tuple[str, Callable[[str], object]]] = MappingProxyType(
    {"centers": ("centres file", read_centers)}
)
"""Estimator options that name an input file: option → (what the file is, its reader).

The job reads the file (estimators read none) and passes the parsed content to the
estimator's run function as the keyword argument of the same name (:func:`estimator_inputs`);
no output may touch the file (:func:`input_paths`)."""


def input_paths(
    logs: Sequence[PathLike],
    model_ref: PathLike,
    prepared: Sequence[Prepared],
    read: ReadOptions,
) -> list[tuple[str, PathLike]]:
    """Every file and folder a run reads, named for error messages: no output may touch them.

    The logs, the model file (unless a built-in name), the files estimator options name
    (:data:`FILE_OPTIONS`: a centres file, from ``--set`` or the model file) and every
    ``--msg-dir``.
    """
    paths: list[tuple[str, PathLike]] = [("log", log) for log in logs]
    if os.path.isfile(model_ref):  # a folder named like a built-in is not the model
        paths.append(("model file", model_ref))
    for estimator in prepared:
        for name, (what, _) in FILE_OPTIONS.items():
            value = getattr(estimator.options, name, None)
            if value:
                paths.append((what, value))
    paths += [("--msg-dir folder", folder) for folder in read.msg_dirs]
    return paths


def estimator_inputs(prepared: Prepared, model: HybridModel) -> dict[str, Any]:
    """The files the estimator's options name (:data:`FILE_OPTIONS`), read, parsed and checked.

    The keyword arguments of :meth:`Prepared.run <hybridlog.estimators.Prepared.run>` (and
    ``stream``), checked against ``model`` and the options before any log is read
    (:meth:`Prepared.check_inputs <hybridlog.estimators.Prepared.check_inputs>`); errors
    name the file and the key at fault, and a file a model file names is named by its key
    (``m.toml: estimators.chiu.centers: ...``), a relative path there being relative to the
    model file's folder.
    """
    inputs: dict[str, Any] = {}
    for name, (_, read) in FILE_OPTIONS.items():
        value = getattr(prepared.options, name, None)
        if value:
            origin = prepared.origins.get(name, "")
            try:
                inputs[name] = read(value)
            except OptionError as err:
                if origin.startswith("--set"):
                    raise
                raise OptionError(f"{origin}: {err}") from err
    prepared.check_inputs(model, **inputs)
    return inputs


def read_log(
    log: str | Path,
    model: HybridModel,
    read: ReadOptions,
    notes: dict[str, Any] | None = None,
) -> AlignedSignals:
    """The log's signals for ``model`` on its grid; ``notes`` gets what reading did."""
    from hybridlog.io import load_signals  # polars: see the module's docstring

    return load_signals(log, SignalSpec.of(model), read, notes=notes)


def _memory_needs(
    log: str | Path, model: HybridModel, prepared: Sequence[Prepared], signals: AlignedSignals
) -> tuple[list[tuple[str, int]], str, str]:
    """What the estimators need of memory: ``(parts, what, remedy)`` for :func:`check_fits`.

    ``compare`` runs them one after the other, so the largest counts.
    """
    n = signals.n_samples

    def needs(estimator: Prepared) -> list[tuple[str, int]]:
        name = f" of {estimator.name}" if len(prepared) > 1 else ""
        return [(f"{what}{name}", size) for what, size in estimator.memory_needed(model, n)]

    parts = max(map(needs, prepared), key=lambda need: sum(size for _, size in need), default=[])
    offline = any(p.offline for p in prepared)
    remedy = "analyse a shorter log" + (
        ", or without --smooth and --mode-sequence" if offline else ""
    )
    beams: list[int] = sorted(
        {
            int(p.options.beam)
            for p in prepared
            if getattr(p.options, "mode_sequence", None) == "kbest" and hasattr(p.options, "beam")
        }
    )
    if beams:  # the k-best histories grow with the beam as with the log
        remedy += f", or a smaller beam (--set beam=N, now {', '.join(map(str, beams))})"
    names = ", ".join(p.name for p in prepared)
    return parts, f"{log}: {n:,} samples through {names}", remedy


def check_memory(
    log: str | Path, model: HybridModel, prepared: Sequence[Prepared], signals: AlignedSignals
) -> None:
    """Refuse, before any estimator allocates, a run whose results cannot fit in memory.

    The estimators' needs (:meth:`Prepared.memory_needed
    <hybridlog.estimators.Prepared.memory_needed>`; ``compare`` runs them one after the
    other, so the largest counts) against what the machine can still give
    (:func:`hybridlog.memory.check_fits`).

    Raises
    ------
    LogError
        One line naming the log, its samples, the estimators, the largest parts, the memory
        available and what to change.
    """
    parts, what, remedy = _memory_needs(log, model, prepared, signals)
    check_fits(parts, what=what, remedy=remedy, error=LogError)


def memory_reserved(
    log: str | Path, model: HybridModel, prepared: Sequence[Prepared], signals: AlignedSignals
) -> contextlib.AbstractContextManager[float]:
    """:func:`check_memory` for a ``with`` block that counts a pool's other workers too.

    In a worker of a local ``batch --jobs N`` the needs are held in the pool's ledger for the
    block, and a log that fits alone but not beside the logs the other workers run waits for
    them (:func:`hybridlog.memory.reserved`); on a Dask worker with a ``memory_limit``, the
    needs are checked against that limit and held beside the worker's other logs
    (:func:`hybridlog.jobs.dask_backend.worker_reserved`); elsewhere it is
    :func:`check_memory`.  The context gives the seconds waited.
    """
    from hybridlog.jobs.dask_backend import worker_memory, worker_reserved

    parts, what, remedy = _memory_needs(log, model, prepared, signals)
    on_dask = worker_memory()
    if on_dask is not None:
        return worker_reserved(parts, on_dask, what=what, remedy=remedy, error=LogError)
    return reserved(parts, what=what, remedy=remedy, error=LogError)


def read_for_estimation(
    log: str | Path, model: HybridModel, read: ReadOptions, notes: dict[str, Any]
) -> AlignedSignals:
    """The log's signals, with numba set up meanwhile for the estimators.

    Where the process has a worker (the console script's ``analyze`` and ``compare``,
    :func:`hybridlog.background.start_worker`), the estimators run there and the worker set
    numba up from its start: the log is simply read.  Elsewhere the log is read in a thread
    while this one sets up numba (:func:`hybridlog.jit.set_up`): polars' readers release
    the GIL, numba's set-up holds it, and on two cores the pair costs the time of the
    longer.  ``notes`` gets what reading did.  polars, if that thread imported it first,
    leaves ``SIGINT`` to Python from then on (:mod:`hybridlog.polars_import`).
    """
    if worker(ESTIMATES) is not None:
        return read_log(log, model, read, notes)
    reading = Background(lambda: read_log(log, model, read, notes), "hybridlog-read")
    try:
        set_up()
    finally:
        reading.wait()
        if "hybridlog.polars_import" in sys.modules:  # first imported by the thread
            sys.modules["hybridlog.polars_import"].take_back_sigint()
    return reading.result()


def warm_up(prepared: Sequence[Prepared], model: HybridModel) -> None:
    """Send the estimators' warm-up to the estimators' worker, where there is one.

    :meth:`Prepared.warm_up <hybridlog.estimators.Prepared.warm_up>`: numba's cached
    machine code of the model's filters is loaded there while this process reads the log.
    On a model's first run with those options there is none: the warm-up compiles it (up to
    a minute, expectation correction's straight-line code), and the command's reporter, if
    any, is told (:func:`warm_up_told`: ``analyze`` and ``compare`` say so on a terminal
    once it outlasts a moment).
    """
    running = worker(ESTIMATES)
    if running is None:
        return
    wait = current_wait()
    for estimator in prepared:
        running.submit(partial(warm_up_told, estimator, wait=wait), model)


def estimates(
    prepared: Prepared,
    model: HybridModel,
    signals: AlignedSignals,
    inputs: Mapping[str, Any],
    *,
    last: bool = True,
) -> Iterator[EstimationResult]:
    """The estimator's result over the signals, as its chunks come (:meth:`Prepared.stream`).

    Computed in the process's worker where there is one (the model and the signals but the
    true states, which no estimator reads, are sent to it pickled, the arrays out of band;
    the chunks come back as they are made, the worker making the next while this process
    takes one), else here; sent when the first chunk is asked for (the report first sends
    the plots' worker its preparation).  So the process that writes the report never
    loads numba's compiler (its machine code and the loaded libraries, about 110 MiB, stay
    in the worker), and the estimator's loop never shares an interpreter with the report.
    ``last``: no estimator runs after this one, so the worker is let go with the last chunk
    (:meth:`~hybridlog.background.Worker.release`: its exit overlaps the drawing, not the
    command's end).
    """
    running = worker(ESTIMATES)
    if running is None:
        yield from prepared.stream(model, signals, **inputs)
        return
    sent = replace(signals, truth_states=None)  # what no estimator reads stays here
    stream: Callable[..., Iterator[EstimationResult]] = partial(prepared.stream, **inputs)
    reporter = current_reporter()
    if reporter is not None:  # the worker's long work (chiu's clustering) says how long
        stream = partial(reported, reporter, stream)
    try:
        yield from running.stream(stream, model, sent)
    finally:  # also after the run's error: compare reports a failed last estimator and goes on
        if last:
            running.release()


def check_signals(
    prepared: Sequence[Prepared], model: HybridModel, signals: AlignedSignals
) -> None:
    """Refuse the log for any of ``prepared`` that lacks a signal it needs, before any runs.

    :meth:`Prepared.check_signals <hybridlog.estimators.Prepared.check_signals>`: the
    switching signal, the commands the transition rules name.  Found as the estimator
    started, a log without the switching signal or a command of the last one named was
    refused after the others had run, their work lost.  Named as
    :func:`hybridlog.jobs.compare._watched` names a run's error when several are compared.
    """
    for estimator in prepared:
        try:
            estimator.check_signals(model, signals)
        except HybridlogError as err:
            if len(prepared) == 1:
                raise
            raise prefixed(err, f"--estimators {estimator.name}: ") from err
