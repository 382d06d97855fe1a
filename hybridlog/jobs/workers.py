"""Worker processes that fail only their own task when they die, and die with their parent.

:mod:`concurrent.futures` cannot tell which task killed a worker (a killed worker breaks the
whole pool and every pending task), and its workers outlive a parent killed with ``kill -9``
(they finish their task, then hang on the task queue).  Here each worker has its own pipe,
so the task it was busy with is known when it dies, and a daemon thread in each worker exits
the process as soon as its parent is gone.  The thread starts before the task function's
module is imported (the function is sent with the first task), so a worker exits promptly
even while it is still starting.

:class:`WorkerPool` starts the workers as soon as it is entered, so that they import what
they need (``preload``) while the caller still checks its inputs; a worker runs every task
it is given in the same process, so what a task function keeps between calls (a loaded
model, compiled code) stays warm.  Leaving the pool with an exception kills the workers at
once.
"""

from __future__ import annotations

import contextlib
import importlib
import multiprocessing
import os
import signal
import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from multiprocessing.connection import Connection, wait
from multiprocessing.context import SpawnContext, SpawnProcess
from typing import Any, TypeVar

__all__ = ["PARENT_POLL_S", "WorkerPool"]

R = TypeVar("R")

PARENT_POLL_S = 0.2
"""How often a worker checks that its parent still runs (seconds)."""

QUEUED = 2
"""Tasks sent ahead to each worker: the next one is waiting when it finishes one."""


def _watch_parent(parent: int) -> None:
    """Exit this process as soon as ``parent`` is gone (``kill -9`` runs no clean-up).

    The process has then been re-parented, so ``os.getppid()`` changed.  Its temporary
    outputs are left to the next run (:func:`hybridlog.outputs.remove_stale_temporaries`).
    """

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(PARENT_POLL_S)
        os._exit(1)

    threading.Thread(target=watch, name="hybridlog-parent-watch", daemon=True).start()


def _serve(connection: Connection, parent: int, preload: tuple[str, ...] = ()) -> None:
    """Worker process: run ``(function, arguments)`` tasks until told to stop (``None``).

    The modules named in ``preload`` are imported first, while the parent is busy too; an
    entry ``module:function`` also calls the function (without arguments).
    Told to stop, the worker flushes its standard streams and exits at once: its tasks wrote
    their files and sent their results, so the interpreter's tear-down (freeing every
    module of numpy, polars and numba one by one) would only make the parent wait.
    """
    _watch_parent(parent)
    for entry in preload:
        module, _, function = entry.partition(":")
        loaded = importlib.import_module(module)
        if function:
            getattr(loaded, function)()
    while True:
        try:
            task = connection.recv()
        except (EOFError, OSError):
            return
        if task is None:
            _exit_now()
        function, arguments = task
        result = function(*arguments)
        try:
            connection.send(result)
        except (OSError, ValueError):
            return


def _exit_now() -> None:
    """Exit the worker without the interpreter's tear-down, its output flushed."""
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    os._exit(0)


@dataclass
class _Worker:
    process: SpawnProcess
    connection: Connection
    tasks: deque[int] = field(default_factory=deque)
    """Tasks sent and not answered yet, in order: the first is the one running."""


def _start(context: SpawnContext, preload: tuple[str, ...] = ()) -> _Worker:
    ours, theirs = context.Pipe()
    process = context.Process(
        target=_serve, args=(theirs, os.getpid(), preload), name="hybridlog-worker", daemon=True
    )
    process.start()
    theirs.close()
    return _Worker(process, ours)


def _death(process: SpawnProcess) -> str:
    process.join(timeout=5)
    code = process.exitcode
    if code is not None and code < 0:
        try:
            return f"killed by signal {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit code {code}"


def _stop(worker: _Worker) -> None:
    with contextlib.suppress(OSError, ValueError):
        worker.connection.send(None)
    worker.process.join(timeout=5)
    if worker.process.is_alive():
        worker.process.kill()
        worker.process.join(timeout=5)
    worker.connection.close()


class WorkerPool:
    """``jobs`` worker processes, started when the pool is entered (see the module docstring).

    Parameters
    ----------
    jobs:
        Number of worker processes (``spawn`` start method: no state shared with the caller).
    preload:
        Modules each worker imports as soon as it starts (``module:function``: and calls).
    """

    def __init__(self, jobs: int, preload: Sequence[str] = ()) -> None:
        self.jobs = jobs
        self.preload = tuple(preload)
        self._context = multiprocessing.get_context("spawn")
        self._workers: list[_Worker] = []

    def __enter__(self) -> WorkerPool:
        self._workers = [_start(self._context, self.preload) for _ in range(self.jobs)]
        return self

    def __exit__(self, kind: object, error: object, trace: object) -> None:
        for worker in self._workers:  # all told first, so that they stop side by side
            if kind is not None:  # the caller failed: nothing the workers do is wanted
                worker.process.kill()
            with contextlib.suppress(OSError, ValueError):
                worker.connection.send(None)
        for worker in self._workers:
            _stop(worker)
        self._workers = []

    def run(
        self,
        function: Callable[..., R],
        tasks: Sequence[tuple[Any, ...]],
        *,
        died: Callable[[int, str], R],
        done: Callable[[R], None] | None = None,
    ) -> list[R]:
        """Run ``function(*task)`` for every task in the pool's workers.

        Parameters
        ----------
        function:
            A module-level function that returns a picklable result and does not raise
            (catch per task what may fail).  It is pickled by reference, so its module is
            imported in each worker.
        tasks:
            Picklable argument tuples.
        died:
            The result of task ``i`` whose worker died, from ``(i, reason)`` (e.g. ``"killed
            by signal SIGKILL"``).  The task is not retried: it may be what killed the
            worker.  A new worker takes the remaining tasks, including those queued
            behind it (:data:`QUEUED`), which had not started.
        done:
            Called with each result as it arrives (in completion order).

        Returns
        -------
        list
            One result per task, in the order of ``tasks``.
        """
        pending = deque(range(len(tasks)))
        results: dict[int, R] = {}
        workers = self._workers

        def finish(index: int, result: R) -> None:
            results[index] = result
            if done is not None:
                done(result)

        while pending or any(w.tasks for w in workers):
            while pending and len(workers) < self.jobs:
                workers.append(_start(self._context, self.preload))
            for worker in workers:
                # QUEUED tasks per worker, so that it never waits for this process between two
                while pending and len(worker.tasks) < QUEUED:
                    worker.tasks.append(pending.popleft())
                    # A worker that died is found below through its sentinel.
                    with contextlib.suppress(OSError, ValueError):
                        worker.connection.send((function, tasks[worker.tasks[-1]]))
            busy = [w for w in workers if w.tasks]
            ready = set(wait([w.connection for w in busy] + [w.process.sentinel for w in busy]))
            for worker in busy:
                if not {worker.connection, worker.process.sentinel} & ready:
                    continue
                try:
                    while worker.tasks and worker.connection.poll():
                        result: R = worker.connection.recv()
                        finish(worker.tasks.popleft(), result)
                    if worker.tasks and worker.process.sentinel in ready:
                        raise EOFError  # it ended with tasks unanswered
                except (EOFError, OSError):
                    # the task it was running killed it (or it was killed running it); the
                    # ones queued behind it never started and go to another worker
                    index = worker.tasks.popleft()
                    finish(index, died(index, _death(worker.process)))
                    pending.extendleft(reversed(worker.tasks))
                    worker.tasks.clear()
                    workers.remove(worker)
                    worker.connection.close()
        return [results[index] for index in range(len(tasks))]
