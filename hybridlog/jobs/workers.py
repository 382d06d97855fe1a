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
kernel closes it when the process ends, however it ends.  The workers then stop (below),
the forkserver sees its clients gone and exits, and so does multiprocessing's resource
tracker.

**Stopping.**  A worker ends on ``SIGTERM`` or ``SIGHUP`` as the console script does: the
signal is raised in its task as an exception, so that the task's ``with`` blocks remove what
it was writing (a report's temporary folder, :mod:`hybridlog.outputs`), and the worker then
dies of that signal; further signals are ignored meanwhile.  ``SIGINT`` is blocked in it
from its fork on (the forkserver's warm-up blocks it, :data:`WARMUP`; ignoring it would not
last: importing polars installs polars' own handler, whose Ctrl-C aborts polars' running
queries): Ctrl-C reaches every process of the terminal's group, and the pool's process
decides.  A worker whose pool's process is gone sends its main thread ``SIGTERM`` (and exits
regardless if its task does not begin to unwind within :data:`STOP_GRACE_S`).  Leaving the
pool with an exception (Ctrl-C, the console script's ``SIGTERM``/``SIGHUP``, an error) sends
every worker ``SIGTERM``, kills those still running after :data:`STOP_GRACE_S` (a compiled
loop runs no signal handler until it returns), waits until each is gone (by process id: a
forkserver killed with its process group reports its children ended while they still run),
then calls the pool's ``clean_up`` with the workers' process ids, which removes what they
left (a worker killed mid-task, or one whose task's thread wrote into the folder it was
removing); further ``SIGINT``, ``SIGTERM`` and ``SIGHUP`` wait until then.

:class:`WorkerPool` forks the workers on the first :meth:`WorkerPool.run` (a fork request
waits until the forkserver has finished its warm-up, which the caller should not wait for
while it has work of its own); a worker runs every task it is given in the same process, so
what a task function keeps between calls (a loaded model, compiled code) stays warm.  The
forkserver serves every pool of the calling process and lives until that process ends.

**Waits.**  A task's work of unforeseeable length (a model's first run compiling its
machine code) is told to the pool's process, where a bar may be drawn that a worker's own
output would break: each worker has a :class:`~hybridlog.cluster.progress.WorkReporter`
installed whose ``wait`` sends its beginning and end through the worker's pipe, and
:meth:`WorkerPool.run` holds its own ``wait`` around it, once for the workers that do the
same work at the same time (:class:`_Waits`).
"""

from __future__ import annotations

import atexit
import contextlib
import gc
import multiprocessing
import multiprocessing.forkserver
import os
import signal
import sys
import tempfile
import threading
import time
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from contextlib import AbstractContextManager
from dataclasses import dataclass, field
from functools import partial
from multiprocessing.connection import Connection, wait
from multiprocessing.context import ForkServerContext, ForkServerProcess
from pathlib import Path
from typing import Any, TypeVar

from hybridlog.cluster.progress import WorkReporter, reporting, silent_wait
from hybridlog.environment import usable_cores
from hybridlog.errors import OptionError, excerpt
from hybridlog.memory import MemoryLedger

__all__ = [
    "POLARS_THREADS",
    "STOP_GRACE_S",
    "WARMUP",
    "WorkerPool",
    "start_forkserver",
    "worker_environment",
]

R = TypeVar("R")

QUEUED = 2
"""Tasks sent ahead to each worker: the next one is waiting when it finishes one."""

WARMUP = "hybridlog.jobs.worker_warmup"
"""The module the forkserver imports before it forks any worker (:func:`start_forkserver`)."""

STOP_GRACE_S = 2.0
"""How long a worker told to stop (``SIGTERM``) may take to remove what it was writing before
it is killed.  Its task unwinds as soon as it runs Python code again, not from inside a
compiled loop: a streaming estimator's chunk of 2^16 rows is milliseconds of one (a
batch of 300,000-sample logs stopped in 0.03-0.15 s), a whole-log one may take longer and
is then killed, its folder removed by the pool's ``clean_up``."""

UNWIND_LIMIT_S = 30.0
"""How long a worker whose pool's process is gone lets its task's clean-up run, once begun."""

ENDING_SIGNALS = (signal.SIGTERM, signal.SIGHUP)
"""What ends a worker after its task's clean-up (:func:`_stop_on_signals`)."""

HELD_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
"""What waits while the pool's process stops its workers and cleans up (:func:`_held`)."""


def start_forkserver() -> None:
    """Start this process's forkserver, which imports :data:`WARMUP`, unless it runs already.

    Returns at once: the forkserver warms up while this process goes on.  A forkserver this
    process started earlier, for a pool or for other code, is reused as it is (with the
    modules it preloaded; workers forked from one without :data:`WARMUP` start cold).  It
    is stopped when this process ends (:func:`_stop_forkserver`).

    Raises
    ------
    OptionError
        When the forkserver cannot start: its socket goes in the temporary folder
        (``TMPDIR``), whose path may be too long for one (``AF_UNIX path too long``, a
        traceback before), or which may refuse it.
    """
    multiprocessing.forkserver.set_forkserver_preload([WARMUP])
    try:
        with _sigint_ignored():
            multiprocessing.forkserver.ensure_running()
    except OSError as err:
        raise OptionError(
            f"--jobs: cannot start the worker processes: {err.strerror or err} for their "
            f"socket in the temporary folder {excerpt(tempfile.gettempdir())} (TMPDIR); set "
            "TMPDIR to a shorter writable folder, or use --jobs 1"
        ) from err
    atexit.unregister(_stop_forkserver)  # registered once, however often it is called
    atexit.register(_stop_forkserver)


@contextlib.contextmanager
def _sigint_ignored() -> Iterator[None]:
    """``SIGINT`` ignored in this process meanwhile (its main thread), so that what it starts is.

    The forkserver's interpreter inherits the ignored ``SIGINT`` through its ``exec`` and
    installs no ``KeyboardInterrupt`` for it: a Ctrl-C in its first 0.1 s, before its warm-up
    blocks the signal (:data:`WARMUP`), printed its traceback, under the command's own line.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    before = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, before)


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
    """Stop this process as soon as the pool's process is gone (``kill -9`` runs no clean-up).

    ``lifeline`` is the reading end of a pipe nothing is ever written to; its one writer is
    the pool's process, so reading it ends (end of file) when that process has ended.  The
    worker then stops as on ``SIGTERM`` (its task's temporary outputs removed), sent to its
    main thread itself (a signal to the process may be taken by this thread, leaving the
    main one asleep in a call); it exits at once if its task has not begun to unwind after
    :data:`STOP_GRACE_S` (a compiled loop), and after :data:`UNWIND_LIMIT_S` if it has not
    ended by then.  What it leaves is for the next run
    (:func:`hybridlog.outputs.remove_stale_temporaries`).
    """

    def watch() -> None:
        with contextlib.suppress(EOFError, OSError):
            lifeline.recv_bytes()
        main = threading.main_thread().ident
        if main is None:
            os.kill(os.getpid(), signal.SIGTERM)
        else:
            signal.pthread_kill(main, signal.SIGTERM)
        deadline = time.monotonic() + STOP_GRACE_S
        while not _STOPPED_BY and time.monotonic() < deadline:
            time.sleep(0.01)
        if _STOPPED_BY:  # unwinding: its clean-up ends the process
            time.sleep(UNWIND_LIMIT_S)
        os._exit(1)

    threading.Thread(target=watch, name="hybridlog-parent-watch", daemon=True).start()


class _Stopped(BaseException):
    """A worker told to stop by a signal: raised in its task, so that the task unwinds.

    Not an :class:`Exception`: a task catches what may fail, never this.
    """


_STOPPED_BY: list[int] = []
"""The signal that stopped this worker, once one has (:func:`_raise_stopped`)."""


def _raise_stopped(signum: int, frame: object) -> None:
    """Raise :class:`_Stopped` in the task, silencing the worker for its clean-up.

    Raised inside a library's own check for signals, the exception may come out of the task
    as another: polars takes any exception there for Ctrl-C, aborts its running queries
    (a table's streaming sink in its writer's thread panics, printing a message) and raises
    ``KeyboardInterrupt``.  So the worker's standard error goes to ``/dev/null`` (nothing it
    says while it is stopped is the user's concern) and whatever leaves the task ends the
    worker as stopped (:func:`_serve`).
    """
    for held in (signal.SIGINT, *ENDING_SIGNALS):  # the clean-up must not be cut short
        signal.signal(held, signal.SIG_IGN)
    _STOPPED_BY.append(signum)
    with contextlib.suppress(OSError):
        sink = os.open(os.devnull, os.O_WRONLY)
        os.dup2(sink, 2)
        os.close(sink)
    raise _Stopped(signum)


def _stop_on_signals() -> None:
    """``SIGTERM``/``SIGHUP`` raise :class:`_Stopped` in this worker; ``SIGINT`` never arrives.

    ``SIGINT`` is blocked, as by the forkserver's warm-up (:data:`WARMUP`), for a forkserver
    started without it: ignoring it would not last, since importing polars installs polars'
    own handler.  Every thread the worker starts keeps the mask.
    """
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    for ending in ENDING_SIGNALS:
        signal.signal(ending, _raise_stopped)


def _serve(
    connection: Connection,
    lifeline: Connection,
    environment: dict[str, str],
    ledger: MemoryLedger,
    slot: int,
) -> None:
    """Worker process: run ``(function, arguments)`` tasks until told to stop (``None``).

    ``environment`` is the pool's process's when it started this worker; ``ledger`` and
    ``slot`` where its tasks reserve memory (:func:`hybridlog.memory.reserved`), counting the
    other workers'.  Told to stop, the
    worker flushes its standard streams and exits at once: its tasks wrote their files and
    sent their results, so the interpreter's tear-down (freeing every module of numpy,
    polars and numba one by one) would only make the parent wait.  Stopped by a signal
    (:func:`_stop_on_signals`), it dies of that signal once its task has unwound, whatever
    exception the unwinding ends with.
    """
    try:
        _stop_on_signals()
        _watch_parent(lifeline)
        ledger.install(slot)
        if os.environ != environment:
            os.environ.clear()
            os.environ.update(environment)
        _serve_tasks(connection)
    except BaseException:
        if _STOPPED_BY:  # _Stopped, or what a library made of it (_raise_stopped)
            _exit_now(_STOPPED_BY[0])
        raise


def _serve_tasks(connection: Connection) -> None:
    """The worker's loop: each task run, its waits told to the pool (:class:`_Waiting`).

    The first task runs without the cyclic garbage collector (:func:`_uncollected`).
    """
    with reporting(WorkReporter(wait=partial(_told_to_pool, connection))):
        first = True
        while True:
            try:
                task = connection.recv()
            except (EOFError, OSError):
                return
            if task is None:
                _exit_now()
            function, arguments = task
            with _uncollected() if first else contextlib.nullcontext():
                result = function(*arguments)
            first = False
            try:
                connection.send(result)
            except (OSError, ValueError):
                return


@contextlib.contextmanager
def _uncollected() -> Iterator[None]:
    """No cyclic garbage collection meanwhile: a worker's first task, bounded (one log).

    It imports what its function needs beyond the forkserver's warm-up (polars, the
    readers, the report's writer: objects that live as long as the worker), which the
    collector walked as they grew, freeing next to nothing; every worker does it before its
    first result.  A 300-sample log's first task took 0.160-0.165 s of CPU without it (two
    runs), 0.176-0.207 s with it (0.009-0.010 s in the collector; four runs), on a machine
    shared with other work.  The collector runs again from the second task on.
    """
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


@dataclass(frozen=True)
class _Waiting:
    """A worker's message: its task's work ``what`` (for ``why``) has begun, or ended.

    ``ended``: ``None`` when it begins, then ``"done"``, or ``"failed"`` (by an exception,
    which its task's result says).
    """

    what: str
    why: str
    ended: str | None = None


@contextlib.contextmanager
def _told_to_pool(connection: Connection, what: str, why: str) -> Iterator[None]:
    """A worker's :attr:`WorkReporter.wait`: the pool is told when ``what`` begins and ends."""
    _tell(connection, _Waiting(what, why))
    try:
        yield
    except BaseException:
        _tell(connection, _Waiting(what, why, "failed"))
        raise
    _tell(connection, _Waiting(what, why, "done"))


def _tell(connection: Connection, waiting: _Waiting) -> None:
    with contextlib.suppress(OSError, ValueError):  # the pool's process gone: nobody to tell
        connection.send(waiting)


def _exit_now(signum: int | None = None) -> None:
    """Exit the worker without the interpreter's tear-down, its output flushed.

    With ``signum``, die of that signal (how the pool's process tells a worker stopped
    from one that failed: ``killed by signal SIGTERM``).
    """
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    if signum is not None:
        signal.signal(signum, signal.SIG_DFL)
        os.kill(os.getpid(), signum)
    os._exit(0 if signum is None else 128 + signum)


@dataclass
class _Worker:
    process: ForkServerProcess
    connection: Connection
    slot: int
    """Its slot in the pool's :class:`~hybridlog.memory.MemoryLedger`."""
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
    environment.setdefault(POLARS_THREADS, str(max(1, usable_cores() // jobs)))
    return environment


def _start(
    context: ForkServerContext, lifeline: Connection, jobs: int, ledger: MemoryLedger, slot: int
) -> _Worker:
    ours, theirs = context.Pipe()
    process = context.Process(
        target=_serve,
        args=(theirs, lifeline, worker_environment(jobs), ledger, slot),
        name="hybridlog-worker",
        daemon=True,
    )
    process.start()
    theirs.close()
    return _Worker(process, ours, slot)


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


def _running(pid: int) -> bool:
    """Whether process ``pid`` runs (a zombie has ended: only its parent's bookkeeping is left)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    try:
        stat = (Path("/proc") / str(pid) / "stat").read_text()
    except FileNotFoundError:
        return False
    except OSError:
        return True  # no /proc (not Linux): the signal test above is all there is
    return stat.rsplit(")", 1)[-1].split()[:1] != ["Z"]


def _signal(pids: Sequence[int], signum: signal.Signals) -> None:
    for pid in pids:
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.kill(pid, signum)


def _running_after(pids: Sequence[int], seconds: float) -> list[int]:
    """Wait until every process of ``pids`` has ended, at most ``seconds``; those still running."""
    deadline = time.monotonic() + seconds
    while (left := [pid for pid in pids if _running(pid)]) and time.monotonic() < deadline:
        time.sleep(0.01)
    return left


def _end(workers: Sequence[_Worker]) -> None:
    """Stop ``workers`` mid-task: ``SIGTERM``, then ``SIGKILL`` after :data:`STOP_GRACE_S`.

    Returns once each has ended.  Watched by process id, not through multiprocessing: its
    exit codes come from the forkserver, which a signal to the whole process group (a CI
    runner's) kills too, and a process whose forkserver is gone counts as ended (exit code
    255) while it still runs.
    """
    pids = [w.process.pid for w in workers if w.process.pid is not None]
    _signal(pids, signal.SIGTERM)
    left = _running_after(pids, STOP_GRACE_S)
    _signal(left, signal.SIGKILL)
    _running_after(left, 5.0)
    for worker in workers:
        worker.process.join(timeout=1)
        worker.connection.close()


@contextlib.contextmanager
def _held(*, raised_after: bool) -> Iterator[None]:
    """``SIGINT``, ``SIGTERM`` and ``SIGHUP`` wait while the pool's process stops its workers.

    A second Ctrl-C (or a ``SIGTERM`` after it) would otherwise cut short the wait for the
    workers and the removal of what they left.  A signal that came meanwhile is raised again
    afterwards if ``raised_after`` (the pool was left normally), else dropped: the pool is
    being left with an exception already, the first signal's.  Only the main thread can
    handle signals; elsewhere nothing is held.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    came: list[int] = []
    previous: dict[signal.Signals, Any] = {}
    for held in HELD_SIGNALS:
        if signal.getsignal(held) is not None:  # None: set outside Python, left alone
            previous[held] = signal.signal(held, lambda signum, frame: came.append(signum))
    try:
        yield
    finally:
        for held, handler in previous.items():
            signal.signal(held, handler)
    if came and raised_after:
        signal.raise_signal(came[0])


class _UnansweredError(Exception):
    """How a wait ends in the pool's process whose work no worker said done: it failed."""


@dataclass
class _Held:
    """A work's wait held in the pool's process (:class:`_Waits`)."""

    context: AbstractContextManager[None]
    slots: set[int] = field(default_factory=set)
    """The workers doing the work (their ledger slots)."""
    done: bool = False
    """Whether a worker said it done."""


class _Waits:
    """The pool's side of its workers' waits (:class:`_Waiting`).

    ``wait``'s context for a work is held from the first worker's beginning of it to the
    last one's end (workers starting side by side in a cold cache compile the same code:
    it is said once).  A worker whose task ends (answered, or the worker died) in the
    middle of its waits no longer does them.  The context ends as done where a worker said
    the work done, else as failed: its error, or the worker's death, is the task's result
    to say.
    """

    def __init__(self, wait: Callable[[str, str], AbstractContextManager[None]]) -> None:
        self._wait = wait
        self._held: dict[str, _Held] = {}

    def told(self, slot: int, waiting: _Waiting) -> None:
        """Worker ``slot`` says ``waiting``."""
        held = self._held.get(waiting.what)
        if waiting.ended is None:
            if held is None:
                held = self._held[waiting.what] = _Held(self._wait(waiting.what, waiting.why))
                held.context.__enter__()
            held.slots.add(slot)
        elif held is not None and slot in held.slots:
            held.done = held.done or waiting.ended == "done"
            self._leave(waiting.what, slot)

    def task_ended(self, slot: int) -> None:
        """Worker ``slot``'s task ended: the waits it had begun and not ended stop here."""
        for what, held in list(self._held.items()):
            if slot in held.slots:
                self._leave(what, slot)

    def close(self) -> None:
        """End every wait still held, as failed (the pool's run was left)."""
        for what, held in list(self._held.items()):
            del self._held[what]
            held.context.__exit__(_UnansweredError, _UnansweredError(what), None)

    def _leave(self, what: str, slot: int) -> None:
        held = self._held[what]
        held.slots.discard(slot)
        if held.slots:
            return
        del self._held[what]
        if held.done:
            held.context.__exit__(None, None, None)
        else:
            held.context.__exit__(_UnansweredError, _UnansweredError(what), None)


class WorkerPool:
    """``jobs`` worker processes forked from a warm forkserver (see the module docstring).

    Parameters
    ----------
    jobs:
        Number of worker processes.  Their tasks reserve memory in the pool's
        :attr:`ledger` (:func:`hybridlog.memory.reserved`), so that the logs the workers run
        at once are checked together against the memory available.
    clean_up:
        Called when the pool is left, once every worker has ended, with the process ids of
        all the workers it started and ``SIGINT``, ``SIGTERM`` and ``SIGHUP`` held
        (:func:`_held`): removes what a worker stopped mid-task left (its temporary outputs).
    """

    def __init__(
        self, jobs: int, *, clean_up: Callable[[Sequence[int]], None] | None = None
    ) -> None:
        self.jobs = jobs
        self._clean_up = clean_up
        self._context = multiprocessing.get_context("forkserver")
        self._workers: list[_Worker] = []
        self._leaving: list[_Worker] = []
        # told to stop by run (nothing left for them), not joined yet
        self._started: list[int] = []
        # only this process holds the writing end: the workers' reading ends close with it
        self._lifeline, self._lifeline_writer = self._context.Pipe(duplex=False)
        # each log's memory is checked beside what the other workers' logs hold
        self.ledger = MemoryLedger(jobs)

    def __enter__(self) -> WorkerPool:
        start_forkserver()
        return self

    def __exit__(self, kind: object, error: object, trace: object) -> None:
        with _held(raised_after=kind is None):
            if kind is not None:  # the caller failed: nothing the workers do is wanted
                _end(self._workers)
            else:
                for worker in self._workers:  # all told first, so that they stop side by side
                    with contextlib.suppress(OSError, ValueError):
                        worker.connection.send(None)
            # those let go had no task and were told to stop: joined, never signalled by
            # process id (they may have ended long ago, and their ids been given to others)
            for worker in self._leaving + ([] if kind is not None else self._workers):
                _stop(worker)
            self._workers = []
            self._leaving = []
            self._lifeline_writer.close()
            self._lifeline.close()
            self.ledger.close()
            if self._clean_up is not None:
                self._clean_up(self._started)

    def run(
        self,
        function: Callable[..., R],
        tasks: Sequence[tuple[Any, ...]],
        *,
        died: Callable[[int, str], R],
        done: Callable[[R], None] | None = None,
        wait: Callable[[str, str], AbstractContextManager[None]] = silent_wait,
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
        wait:
            Held around the work of unforeseeable length that the tasks tell
            (:attr:`WorkReporter.wait <hybridlog.cluster.progress.WorkReporter.wait>`):
            once for the workers doing the same at the same time (:class:`_Waits`).

        Returns
        -------
        list
            One result per task, in the order of ``tasks``.
        """
        waits = _Waits(wait)
        try:
            return self._run(function, tasks, died, done, waits)
        finally:
            waits.close()

    def _run(
        self,
        function: Callable[..., R],
        tasks: Sequence[tuple[Any, ...]],
        died: Callable[[int, str], R],
        done: Callable[[R], None] | None,
        waits: _Waits,
    ) -> list[R]:
        pending = deque(range(len(tasks)))
        results: dict[int, R] = {}
        workers = self._workers

        def finish(worker: _Worker, result: R) -> None:
            waits.task_ended(worker.slot)
            results[worker.tasks.popleft()] = result
            if done is not None:
                done(result)

        while pending or any(w.tasks for w in workers):
            while pending and len(workers) < self.jobs:
                slot = min(set(range(self.jobs)) - {w.slot for w in workers})
                workers.append(_start(self._context, self._lifeline, self.jobs, self.ledger, slot))
                if workers[-1].process.pid is not None:  # set once started
                    self._started.append(workers[-1].process.pid)
            # QUEUED tasks per worker, so that it never waits for this process between two;
            # dealt one round at a time: filled one worker after the other, the first took
            # both logs of a two-log batch and the second none
            for depth in range(1, QUEUED + 1):
                for worker in workers:
                    if pending and len(worker.tasks) < depth:
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
                        message: R | _Waiting = worker.connection.recv()
                        if isinstance(message, _Waiting):
                            waits.told(worker.slot, message)
                        else:
                            finish(worker, message)
                    if worker.tasks and worker.process.sentinel in ready:
                        raise EOFError  # it ended with tasks unanswered
                    if not worker.tasks and not pending:
                        self._let_go(worker)
                except (EOFError, OSError):
                    # the task it was running killed it (or it was killed running it); the
                    # ones queued behind it never started and go to another worker
                    finish(worker, died(worker.tasks[0], _death(worker.process)))
                    self.ledger.release(worker.slot)  # what it held died with it
                    pending.extendleft(reversed(worker.tasks))
                    worker.tasks.clear()
                    workers.remove(worker)
                    worker.connection.close()
        return [results[index] for index in range(len(tasks))]

    def _let_go(self, worker: _Worker) -> None:
        """Tell ``worker``, whose tasks are all answered and none left to give, to stop now.

        It ends (the kernel freeing its memory, the forkserver reaping it) while the other
        workers run their last tasks, not after them, when the pool is left: on two cores a
        worker's end took 0.016-0.030 s of the batch's end (four runs, beside other work).
        A task given after this (a worker that died left tasks, or another :meth:`run`)
        goes to a new worker.
        """
        with contextlib.suppress(OSError, ValueError):  # a dead one is joined all the same
            worker.connection.send(None)
        self._workers.remove(worker)
        self._leaving.append(worker)
