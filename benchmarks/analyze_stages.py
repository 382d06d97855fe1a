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
A stage run in a forked child (the plots, where the console script allows it) is timed in
the child and its clock sent back with its value; it is listed in ``forked`` (its ``VmHWM``
is the child's).
``benchmarks/analyze_e2e.py`` runs this child and the plain command and assembles the
breakdown.
"""

from __future__ import annotations

import time

STARTED = time.time()

import atexit  # noqa: E402
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


def _child_clocked(beside: Callable[..., Any]) -> Callable[..., Any]:
    """``hybridlog.background.beside`` whose function, run in a forked child, brings back
    the clock its stages' timers kept there; it is added to this process's once."""

    def clocked(function: Callable[[], Any], name: str) -> Any:
        def run() -> Any:
            _clock.clear()
            return function(), dict(_clock), dict(_peak)

        task = beside(run, name)
        result = task.result
        merged = False

        def unpack() -> Any:
            nonlocal merged
            value, clock, peak = result()
            if not merged:
                merged = True
                for stage, seconds in clock.items():
                    _clock[stage] = _clock.get(stage, 0.0) + seconds
                    _forked.add(stage)
                    _peak[stage] = peak[stage]
            return value

        task.result = task.wait = unpack
        return task

    return clocked


def _patch(module: Any, name: str, stage: str) -> None:
    setattr(module, name, _timed(stage, getattr(module, name)))


def main() -> None:
    """Import, wrap the stages, run the command, write the clock."""
    out, sep, *argv = sys.argv[1:]
    if sep != "--":
        raise SystemExit(__doc__)
    start = time.perf_counter()
    import hybridlog.cli as cli
    import hybridlog.estimators.common as common
    import hybridlog.jobs.analysis as analysis
    import hybridlog.report.writer as writer
    from hybridlog.background import Background, Forked
    from hybridlog.estimators.registry import Prepared
    from hybridlog.report.document import Report

    _clock["imports"] = time.perf_counter() - start
    _peak["imports"] = _vmhwm_mib()
    _patch(analysis, "parse_sets", "model (load, sympy)")
    _patch(analysis, "prepare_estimators", "estimator options")
    _patch(analysis, "read_log", "read log")
    _patch(analysis, "set_up", "numba set-up")
    _patch(analysis, "import_plotting", "import matplotlib")
    Background.wait = _timed("waiting for a thread", Background.wait)  # type: ignore[method-assign]
    Background.result = _timed("waiting for a thread", Background.result)  # type: ignore[method-assign]
    Forked.wait = _timed("waiting for a thread", Forked.wait)  # type: ignore[method-assign]
    Forked.result = _timed("waiting for a thread", Forked.result)  # type: ignore[method-assign]
    writer.beside = _child_clocked(writer.beside)
    _patch(Prepared, "run", "estimate (filter)")
    _patch(common, "compile_generated", "compile (sympy source, numba cache)")
    _patch(common, "compile_model", "compile (sympy source, numba cache)")
    for name, stage in (
        ("build_report", "metrics"),
        ("render_markdown", "report.json + report.md"),
        ("timeline_table", "tables"),
        ("estimates_table", "tables"),
        ("write_table", "tables"),
        ("write_plots", "plots"),
    ):
        _patch(writer, name, stage)
    Report.to_json = _timed("report.json + report.md", Report.to_json)  # type: ignore[method-assign]
    command = time.perf_counter()

    def write_clock() -> None:
        # run by the console script's ending (atexit handlers, then os._exit: the command
        # never returns to this caller)
        _clock["command"] = time.perf_counter() - command
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
