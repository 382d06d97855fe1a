"""Worker processes that fail only their own task when they die, and die with their parent.

:mod:`concurrent.futures` cannot tell which task killed a worker (a killed worker breaks the
whole pool and every pending task), and its workers outlive a parent killed with ``kill -9``
(they finish their task, then hang on the task queue).  Here each worker has its own pipe,
so the task it was busy with is known when it dies, and a daemon thread in each worker exits
the process as soon as the pool's process is gone.  The thread starts before the task
function's module is imported (the function is sent with the first task), so a worker exits
promptly even while it is still starting.

**Forkserver.**  Workers are forked from multiprocessing's forkserver: a fresh interpreter
(never a fork of the caller, who may have used polars' or BLAS's threads) started when the
pool is entered, or earlier by :func:`start_forkserver`, which imports :data:`WARMUP` once,
in parallel with the caller checking its inputs.  Each worker is a fork of that warm
process: numba's set-up and the imports are paid once per batch, not once per worker, and
a worker replacing a dead one starts warm in milliseconds.

A process may fork safely only with no thread but the one forking (a thread holding a lock
at fork time leaves it held forever in the child).  Measured with CPython 3.11, numpy 2.x
and polars 2.1 on two cores (``/proc/self/task``): numpy's OpenBLAS and scipy's (loaded by
numba's set-up) each start one pool thread at import; each library's ``pthread_atfork``
handler stops its pool before every fork (the forkserver has three threads before its first
fork, one right after it) and the pool restarts on first use, in the child too.  Importing
polars starts four threads with no such handler (jemalloc's two background threads,
``polars-ooc-cleaner``, ``polars-ooc-decay``), so the warm-up imports no polars
(:mod:`hybridlog.jobs.worker_warmup`) and each worker imports it after the fork (~0.08 s).
``tests/jobs/test_workers.py`` checks from a worker that the forkserver has one thread and
no polars.  A worker starts in the caller's current folder (multiprocessing sends it) and
with the caller's current environment (sent here: the forkserver keeps the one it started
with), polars' thread pool sized to the worker's share of the cores
(:func:`worker_environment`).

**Parent watch.**  A forked worker's parent is the forkserver, and the forkserver does not
exit when the pool's process dies while workers live: each worker inherits the write end of
the pipe whose end-of-file tells the forkserver that its clients are gone (measured: after
``kill -9`` of the caller, worker and forkserver stay until the worker exits).  So a worker
watches the pool's process itself, through a pipe whose only writer is that process: the
kernel closes it when the process ends, however it ends.  The workers then exit, the
forkserver sees its clients gone and exits, and so does multiprocessing's resource tracker.

:class:`WorkerPool` forks the workers on the first :meth:`WorkerPool.run` (a fork request
waits until the forkserver has finished its warm-up, which the caller should not wait for
while it has work of its own); a worker runs every task it is given in the same process, so
what a task function keeps between calls (a loaded model, compiled code) stays warm.
Leaving the pool with an exception kills the workers at once.  The forkserver serves every
pool of the calling process and lives until that process ends.
"""

from __future__ import annotations

import atexit
import contextlib
import multiprocessing
import multiprocessing.forkserver
import os
import signal
import sys
import threading
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from multiprocessing.connection import Connection, wait
from multiprocessing.context import ForkServerContext, ForkServerProcess
from typing import Any, TypeVar

__all__ = ["POLARS_THREADS", "WARMUP", "WorkerPool", "start_forkserver", "worker_environment"]

R = TypeVar("R")

QUEUED = 2
"""Tasks sent ahead to each worker: the next one is waiting when it finishes one."""

WARMUP = "hybridlog.jobs.worker_warmup"
"""The module the forkserver imports before it forks any worker (:func:`start_forkserver`)."""


def start_forkserver() -> None:
    """Start this process's forkserver, which imports :data:`WARMUP`, unless it runs already.

    Returns at once: the forkserver warms up while this process goes on.  A forkserver this
    process started earlier, for a pool or for other code, is reused as it is (with the
    modules it preloaded; workers forked from one without :data:`WARMUP` start cold).  It
    is stopped when this process ends (:func:`_stop_forkserver`).
    """
    multiprocessing.forkserver.set_forkserver_preload([WARMUP])
    multiprocessing.forkserver.ensure_running()
    atexit.unregister(_stop_forkserver)  # registered once, however often it is called
    atexit.register(_stop_forkserver)


def _stop_forkserver() -> None:
    """Kill this process's forkserver: an atexit handler of :func:`start_forkserver`.

    The forkserver holds this process's standard output and error, and it reads no request,
    not even the end of its clients, before its warm-up has ended.  Left alone, it would keep
    a caller that reads the command's output through a pipe waiting for that warm-up after
    a command that ended before it: a rejected option, a missing model, a batch of one log
    (``batch LOGS --model nonexistent --jobs 2 | cat`` took 1.04 s, against 0.44 s with
    the output not piped).  Every pool has been left by then, so no worker is running.
    multiprocessing has no public way to stop it: its process id is read from the
    module's server object.
    """
    server = getattr(multiprocessing.forkserver, "_forkserver", None)
    pid = getattr(server, "_forkserver_pid", None)
    if isinstance(pid, int):
        with contextlib.suppress(OSError):
            os.kill(pid, signal.SIGKILL)


def _watch_parent(lifeline: Connection) -> None:
    """Exit this process as soon as the pool's process is gone (``kill -9`` runs no clean-up).

    ``lifeline`` is the reading end of a pipe nothing is ever written to; its one writer is
    the pool's process, so reading it ends (end of file) when that process has ended.  Its
    temporary outputs are left to the next run
    (:func:`hybridlog.outputs.remove_stale_temporaries`).
    """

    def watch() -> None:
        with contextlib.suppress(EOFError, OSError):
            lifeline.recv_bytes()
        os._exit(1)

    threading.Thread(target=watch, name="hybridlog-parent-watch", daemon=True).start()


def _serve(connection: Connection, lifeline: Connection, environment: dict[str, str]) -> None:
    """Worker process: run ``(function, arguments)`` tasks until told to stop (``None``).

    ``environment`` is the pool's process's when it started this worker.  Told to stop, the
    worker flushes its standard streams and exits at once: its tasks wrote their files and
    sent their results, so the interpreter's tear-down (freeing every module of numpy,
    polars and numba one by one) would only make the parent wait.
    """
    _watch_parent(lifeline)
    if os.environ != environment:
        os.environ.clear()
        os.environ.update(environment)
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
    process: ForkServerProcess
    connection: Connection
    tasks: deque[int] = field(default_factory=deque)
    """Tasks sent and not answered yet, in order: the first is the one running."""


POLARS_THREADS = "POLARS_MAX_THREADS"
"""Read by polars when it is imported: the size of its thread pool."""


def worker_environment(jobs: int) -> dict[str, str]:
    """The caller's current environment for a worker of a pool of ``jobs``.

    Each worker imports polars itself, whose thread pool would otherwise have a thread per
    core in every worker: with ``jobs`` workers busy, the threads that reading and writing
    their tables start outnumber the cores.  A worker's pool gets its share of the cores this
    process may run on instead (at least one), unless the caller set :data:`POLARS_THREADS`.
    On two cores, 200 logs of 300 samples, ``--jobs 2``, eight interleaved runs each: best
    2.98 → 2.78 s, median 3.29 → 3.24 s, within the noise of this machine (an earlier round
    of six found no effect); small logs keep polars' threads mostly idle, larger ones do not.
    """
    environment = dict(os.environ)
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    environment.setdefault(POLARS_THREADS, str(max(1, (cores or 1) // jobs)))
    return environment


def _start(context: ForkServerContext, lifeline: Connection, jobs: int) -> _Worker:
    ours, theirs = context.Pipe()
    process = context.Process(
        target=_serve,
        args=(theirs, lifeline, worker_environment(jobs)),
        name="hybridlog-worker",
        daemon=True,
    )
    process.start()
    theirs.close()
    return _Worker(process, ours)


def _death(process: ForkServerProcess) -> str:
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
    """``jobs`` worker processes forked from a warm forkserver (see the module docstring).

    Parameters
    ----------
    jobs:
        Number of worker processes.
    """

    def __init__(self, jobs: int) -> None:
        self.jobs = jobs
        self._context = multiprocessing.get_context("forkserver")
        self._workers: list[_Worker] = []
        # only this process holds the writing end: the workers' reading ends close with it
        self._lifeline, self._lifeline_writer = self._context.Pipe(duplex=False)

    def __enter__(self) -> WorkerPool:
        start_forkserver()
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
        self._lifeline_writer.close()
        self._lifeline.close()

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
                workers.append(_start(self._context, self._lifeline, self.jobs))
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
