"""Run ``hybridlog analyze`` in this process with a clock on each stage (for ``make bench``).

    python -m benchmarks.analyze_stages STAGES.json -- analyze LOG --model M --out DIR ...

The arguments after ``--`` are the command line of ``hybridlog``; the command runs through
``hybridlog.cli.main`` exactly as the console script does, with the job's stage functions
wrapped by timers.  ``STAGES.json`` gets, in seconds since the epoch (``time.time()``, so
the parent can place them against its own clock): ``started`` (this module's first line)
and ``finished`` (when the command has ended: written by an atexit handler, which the
console script's ending runs before ``os._exit``); the
wall time of each stage in seconds (``stages``); and the resident high-water mark
(``VmHWM``, MiB) when each stage last ended (``peak_mib``): the stage where it jumps made
the peak.  A function that calls another timed one (a stage
inside a stage) is charged only for its own time.  Stages that ran in another thread than
the main one (``analyze`` reads the log in a thread while numba sets up, and draws the plots
in a thread beside the metrics and tables: :mod:`hybridlog.background`) are listed in
``beside``: they overlap the main thread's stages, among which ``waiting for a thread`` is
the time the main thread waited for them; the main thread's stages add up to the command.
The estimator streams its result from the estimators' worker process (the next chunk
computed while the report takes this one): ``estimate (filter)`` is its compiled loop's
time, and ``waiting for the filter`` this process's wait for chunks.  Stages run in the
command's worker processes (numba's set-up and the loading of the compiled code in the
estimators' worker, matplotlib's import and the plots in the plots' worker:
:class:`hybridlog.background.Worker`) are timed there, into ``STAGES.json.worker``, and
listed in ``forked`` (their ``VmHWM`` is the worker's).
``benchmarks/analyze_e2e.py`` runs this child and the plain command and assembles the
breakdown.
"""

from __future__ import annotations

import time

STARTED = time.time()

import atexit  # noqa: E402
import functools  # noqa: E402
import importlib.abc  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import threading  # noqa: E402
from collections.abc import Callable  # noqa: E402
from typing import Any  # noqa: E402

_clock: dict[str, float] = {}
_stacks = threading.local()
_peak: dict[str, float] = {}
_beside: set[str] = set()
_forked: set[str] = set()


def _vmhwm_mib() -> float:
    """The process's resident high-water mark so far (``VmHWM``), in MiB; 0 if unknown."""
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024
    except OSError:
        pass
    return 0.0


def _timed(stage: str, function: Callable[..., Any]) -> Callable[..., Any]:
    """``function`` charging its wall time, less that of timed calls inside it, to ``stage``."""

    def wrapper(*args: Any, **kwargs: Any) -> Any:
        if not hasattr(_stacks, "stack"):
            _stacks.stack = []
        _stack: list[list[float]] = _stacks.stack
        if threading.current_thread() is not threading.main_thread():
            _beside.add(stage)
        _stack.append([0.0])
        start = time.perf_counter()
        try:
            return function(*args, **kwargs)
        finally:
            spent = time.perf_counter() - start
            inner = _stack.pop()[0]
            _clock[stage] = _clock.get(stage, 0.0) + spent - inner
            _peak[stage] = _vmhwm_mib()
            if _stack:
                _stack[-1][0] += spent

    return wrapper


def _worker_clocked(stage: str, function: Callable[..., Any]) -> Callable[..., Any]:
    """``function``, run in the process's worker (forked after these patches, so it has them),
    appending its wall time and the worker's ``VmHWM`` to the file ``_WORKER_CLOCK`` names:
    the worker's clock, merged into this process's at exit."""

    @functools.wraps(function)
    def clocked(*args: Any, **kwargs: Any) -> Any:
        start = time.perf_counter()
        try:
            return function(*args, **kwargs)
        finally:
            spent = time.perf_counter() - start
            with open(_WORKER_CLOCK[0], "a", encoding="utf-8") as clock:
                clock.write(json.dumps([stage, spent, _vmhwm_mib()]) + "\n")

    return clocked


def _merge_worker_clock() -> None:
    try:
        with open(_WORKER_CLOCK[0], encoding="utf-8") as clock:
            entries = [json.loads(line) for line in clock]
    except OSError:
        return
    for stage, spent, peak in entries:
        _clock[stage] = _clock.get(stage, 0.0) + spent
        _forked.add(stage)
        _peak[stage] = max(_peak.get(stage, 0.0), peak)


_WORKER_CLOCK = [""]
"""The file the worker's stages are clocked into (``STAGES.json.worker``)."""


def _estimates_clocked(estimates: Callable[..., Any]) -> Callable[..., Any]:
    """``jobs.analysis.estimates`` whose chunks are clocked: this process's wait for each
    chunk is ``waiting for the filter``; the filter's compiled loop itself (its chunks'
    ``runtime_s``, run in the estimators' worker beside the report's work) is
    ``estimate (filter)``."""

    @functools.wraps(estimates)
    def clocked(*args: Any, **kwargs: Any) -> Any:
        chunks = estimates(*args, **kwargs)

        def timed() -> Any:
            runtime = 0.0
            while True:
                start = time.perf_counter()
                try:
                    chunk = next(chunks)
                except StopIteration:
                    break
                finally:
                    _clock["waiting for the filter"] = _clock.get("waiting for the filter", 0.0) + (
                        time.perf_counter() - start
                    )
                    _peak["waiting for the filter"] = _vmhwm_mib()
                runtime = chunk.runtime_s
                yield chunk
            _clock["estimate (filter)"] = _clock.get("estimate (filter)", 0.0) + runtime
            _forked.add("estimate (filter)")

        return timed()

    return clocked


def _patch(module: Any, name: str, stage: str) -> None:
    setattr(module, name, _timed(stage, getattr(module, name)))


def _patch_analysis(analysis: Any) -> None:
    _patch(analysis, "parse_sets", "model (load, sympy)")
    _patch(analysis, "prepare_estimators", "estimator options")
    analysis.estimates = _estimates_clocked(analysis.estimates)


def _patch_estimation(estimation: Any) -> None:
    _patch(estimation, "read_log", "read log")
    # its ``set_up`` is jit's, bound after jit's own wrapper (a worker's clock) was put on it
    set_up = estimation.set_up
    estimation.set_up = _timed("numba set-up", getattr(set_up, "__wrapped__", set_up))


def _patch_jit(jit: Any) -> None:
    jit.set_up = _worker_clocked("numba set-up", jit.set_up)


def _patch_background(background: Any) -> None:
    background.Background.wait = _timed("waiting for a thread", background.Background.wait)
    background.Background.result = _timed("waiting for a thread", background.Background.result)
    background.Task.wait = _timed("waiting for the worker", background.Task.wait)
    background.Task.result = _timed("waiting for the worker", background.Task.result)


def _patch_common(common: Any) -> None:
    common.compile_generated = _worker_clocked("compile (numba cache)", common.compile_generated)
    common.compile_model = _worker_clocked("compile (numba cache)", common.compile_model)


def _patch_build(build: Any) -> None:
    _patch(build.ReportBuilder, "add", "metrics")
    _patch(build.ReportBuilder, "report", "metrics")


def _patch_writer(writer: Any) -> None:
    _patch(writer._RunTables, "add", "tables")
    _patch(writer._RunTables, "close", "tables")
    _patch(writer, "render_markdown", "report.json + report.md")


def _patch_plot_reducer(plot_reducer: Any) -> None:
    _patch(plot_reducer.PlotReducer, "add", "plot reductions")
    _patch(plot_reducer.PlotReducer, "finish", "plot reductions")


def _patch_document(document: Any) -> None:
    document.Report.to_json = _timed("report.json + report.md", document.Report.to_json)


def _patch_plot_figures(plot_figures: Any) -> None:
    plot_figures.prepare_plotting = _worker_clocked(
        "import matplotlib", plot_figures.prepare_plotting
    )


def _patch_plots(plots: Any) -> None:
    plots.draw_into = _worker_clocked("plots", plots.draw_into)


PATCHES: dict[str, Callable[[Any], None]] = {
    "hybridlog.background": _patch_background,
    "hybridlog.jit": _patch_jit,
    "hybridlog.estimators.common": _patch_common,
    "hybridlog.report.build": _patch_build,
    "hybridlog.report.plot_reducer": _patch_plot_reducer,
    "hybridlog.report.plot_figures": _patch_plot_figures,
    "hybridlog.report.plots": _patch_plots,
    "hybridlog.report.document": _patch_document,
    "hybridlog.report.writer": _patch_writer,
    "hybridlog.jobs.analysis": _patch_analysis,
    "hybridlog.jobs.estimation": _patch_estimation,
}
"""Each timed module's stages, wrapped when the command first imports it (:class:`_OnImport`)."""


class _OnImport(importlib.abc.MetaPathFinder):
    """Wraps a module's stages (:data:`PATCHES`) as soon as it is imported, wherever it is.

    Importing them all before the command loaded numba, the readers and the report in this
    process, which the command itself imports later or only in its workers: charged to
    ``imports``, they made it 0.66 s where the command's own imports take about 0.1 s, and
    the workers started with numba loaded.  Forked workers inherit the finder.
    """

    def find_spec(self, name: str, path: Any, target: Any = None) -> Any:
        patch = PATCHES.get(name)
        if patch is None:
            return None
        for finder in sys.meta_path:
            if finder is self or not hasattr(finder, "find_spec"):
                continue
            spec = finder.find_spec(name, path, target)
            if spec is not None:
                break
        else:
            return None
        execute = spec.loader.exec_module

        def exec_module(module: Any) -> None:
            execute(module)
            patch(module)

        spec.loader.exec_module = exec_module
        return spec


def main() -> None:
    """Install the stages' timers, run the command, write the clock."""
    out, sep, *argv = sys.argv[1:]
    if sep != "--":
        raise SystemExit(__doc__)
    _WORKER_CLOCK[0] = f"{out}.worker"
    sys.meta_path.insert(0, _OnImport())
    start = time.perf_counter()
    import hybridlog.cli as cli

    _clock["imports"] = time.perf_counter() - start
    _peak["imports"] = _vmhwm_mib()
    command = time.perf_counter()

    def write_clock() -> None:
        # run by the console script's ending (atexit handlers, then os._exit: the command
        # never returns to this caller)
        _clock["command"] = time.perf_counter() - command
        _merge_worker_clock()
        with open(out, "w", encoding="utf-8") as stream:
            json.dump(
                {
                    "started": STARTED,
                    "finished": time.time(),
                    "stages": _clock,
                    "peak_mib": _peak,
                    "beside": sorted(_beside),
                    "forked": sorted(_forked),
                },
                stream,
            )

    atexit.register(write_clock)
    sys.argv = ["hybridlog", *argv]
    cli.main()  # as the console script calls it: this process runs the one command and ends


if __name__ == "__main__":
    main()
