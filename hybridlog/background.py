"""Work run beside the caller's own, its result or error collected.

:class:`Background` runs a function in a thread: for two stages of a command where one
spends its time in code that releases the GIL (polars' readers and writers, numpy's
reductions, LLVM loading numba's cached machine code, the filters' compiled loops) beside
code that holds it (numba's set-up, the report's Python): on two cores the two overlap.
Where both hold the GIL much of the time (matplotlib drawing beside the report's Python), a
thread only interleaves them; a :class:`Worker` runs functions in another process instead.
:func:`beside` sends a function to the process's worker where one was started
(:func:`start_worker`) and runs it in a thread elsewhere.

The worker is forked when the process is small and has one thread: the console script's
``analyze`` and ``compare`` start it before they import numpy, polars or numba
(``hybridlog.cli``), so the child inherits no thread that may hold a lock and no large
memory, and imports what its functions need itself (matplotlib: about 36 MiB the
analysing process then never holds).  It gets each function and its arguments pickled
through a pipe (a module-level function and small data, such as the reduced data of the
plots) and sends back the pickled value or exception.  Never in a library caller's
process, a batch worker or a Dask worker, which run their functions in threads.
"""

from __future__ import annotations

import atexit
import os
import pickle
import signal
import struct
import threading
from collections.abc import Callable
from typing import IO, Any, Generic, TypeVar

__all__ = ["Background", "Task", "Worker", "beside", "start_worker", "worker"]

R = TypeVar("R")


class Background(Generic[R]):
    """``function()`` running in a daemon thread from construction on.

    :meth:`result` waits and returns its value or raises what it raised, in the caller's
    thread; :meth:`wait` only waits (for clean-up paths that already have an error).
    """

    def __init__(self, function: Callable[[], R], name: str) -> None:
        self._function = function
        self._value: R | None = None
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        try:
            self._value = self._function()
        except BaseException as err:  # raised again by result(), in the caller's thread
            self._error = err

    def wait(self) -> None:
        """Wait for the function to return or raise."""
        self._thread.join()

    def result(self) -> R:
        """The function's value, once it returned; what it raised, raised here."""
        self._thread.join()
        if self._error is not None:
            raise self._error
        return self._value  # type: ignore[return-value]


class Task(Generic[R]):
    """A function sent to a :class:`Worker`.

    :meth:`result` and :meth:`wait` as for :class:`Background`.
    """

    def __init__(self, owner: Worker, index: int) -> None:
        self._owner = owner
        self._index = index
        self._outcome: tuple[bool, Any] | None = None

    def _collect(self) -> tuple[bool, Any]:
        if self._outcome is None:
            self._outcome = self._owner.outcome(self._index)
        return self._outcome

    def wait(self) -> None:
        """Wait for the worker to send this function's outcome."""
        self._collect()

    def result(self) -> R:
        """The function's value, once the worker sent it; what it raised, raised here."""
        ok, value = self._collect()
        if not ok:
            raise value
        result: R = value
        return result


_HEADER = struct.Struct("<Q")
"""Each message on the worker's pipes: its length, then that many bytes of pickle."""


class Worker:
    """A forked process that runs the functions sent to it, one after the other.

    :meth:`submit` pickles a module-level function and its arguments into the child's
    pipe and returns at once; the child runs them in the order sent and sends back each
    outcome: the pickled value, or the pickled exception (or, if that cannot be pickled, a
    ``RuntimeError`` naming it).  A child that ends without sending (killed) makes every
    outcome still owed a ``ChildProcessError`` naming how it ended.  :meth:`close` (also at
    exit) closes the pipe, on which the child ends, and waits for it; the child ignores
    ``SIGINT`` (an interrupted command ends it by closing the pipe) and leaves with
    ``os._exit``: no clean-up of the parent's objects, no second flush of its buffered
    output.
    """

    def __init__(self, name: str) -> None:
        self._name = name
        requests_read, requests_write = os.pipe()
        replies_read, replies_write = os.pipe()
        pid = os.fork()
        if pid == 0:  # the child: serve until the pipe closes, then leave
            os.close(requests_write)
            os.close(replies_read)
            try:
                signal.signal(signal.SIGINT, signal.SIG_IGN)
                _serve(requests_read, replies_write)
            finally:
                os._exit(0)
        os.close(requests_read)
        os.close(replies_write)
        self._pid = pid
        self._requests: IO[bytes] | None = os.fdopen(requests_write, "wb")
        self._replies = os.fdopen(replies_read, "rb")
        self._lock = threading.Lock()
        self._sent = 0
        self._received = 0
        self._outcomes: dict[int, tuple[bool, Any]] = {}
        self._ended: str | None = None

    def submit(self, function: Callable[..., R], *args: Any) -> Task[R]:
        """Send ``function(*args)`` to the child; its outcome comes with :meth:`Task.result`."""
        payload = pickle.dumps((function, args), protocol=pickle.HIGHEST_PROTOCOL)
        with self._lock:
            if self._requests is None:
                raise RuntimeError(f"{self._name}: the worker is closed")
            self._requests.write(_HEADER.pack(len(payload)) + payload)
            self._requests.flush()
            index = self._sent
            self._sent += 1
        return Task(self, index)

    def outcome(self, index: int) -> tuple[bool, Any]:
        """``(ok, value or exception)`` of the function sent ``index``-th (0 first).

        Given once per function (its :class:`Task` keeps it).
        """
        with self._lock:
            while index not in self._outcomes:
                self._outcomes[self._received] = self._read_reply()
                self._received += 1
            return self._outcomes.pop(index)

    def _read_reply(self) -> tuple[bool, Any]:
        if self._ended is None:
            header = self._replies.read(_HEADER.size)
            if len(header) == _HEADER.size:
                data = self._replies.read(_HEADER.unpack(header)[0])
                outcome: tuple[bool, Any] = pickle.loads(data)
                return outcome
            _, status = os.waitpid(self._pid, 0)
            self._ended = _ended(status)
        return False, ChildProcessError(f"{self._name}: {self._ended}")

    def close(self) -> None:
        """Close the pipe (the child ends) and wait for the child; idempotent."""
        with self._lock:
            requests, self._requests = self._requests, None
        if requests is None:
            return
        requests.close()
        if self._ended is None:
            os.waitpid(self._pid, 0)
            self._ended = "closed"
        self._replies.close()


def _serve(requests: int, replies: int) -> None:
    """The child's loop: read a function and its arguments, run it, send its outcome."""
    with os.fdopen(requests, "rb") as incoming, os.fdopen(replies, "wb") as outgoing:
        while True:
            header = incoming.read(_HEADER.size)
            if len(header) < _HEADER.size:
                return
            data = incoming.read(_HEADER.unpack(header)[0])
            payload = _outcome(data)
            outgoing.write(_HEADER.pack(len(payload)) + payload)
            outgoing.flush()


def _outcome(data: bytes) -> bytes:
    """Run the pickled ``(function, args)`` and pickle its outcome (in the child)."""
    try:
        function, args = pickle.loads(data)
        return pickle.dumps((True, function(*args)), protocol=pickle.HIGHEST_PROTOCOL)
    except BaseException as err:  # raised again by Task.result, in the caller
        try:
            return pickle.dumps((False, err), protocol=pickle.HIGHEST_PROTOCOL)
        except Exception:
            return pickle.dumps((False, RuntimeError(f"{type(err).__name__}: {err}")))


def _ended(status: int) -> str:
    if os.WIFSIGNALED(status):
        number = os.WTERMSIG(status)
        try:
            return f"the process was killed by signal {signal.Signals(number).name}"
        except ValueError:
            return f"the process was killed by signal {number}"
    return f"the process ended with exit code {os.waitstatus_to_exitcode(status)} and no result"


_WORKER: dict[str, Worker] = {}
"""The process's worker, once :func:`start_worker` made it."""


def start_worker() -> None:
    """Fork this process's :class:`Worker` now; it is closed at exit.

    Only in a one-command process, while it is still small and has one thread (the console
    script's ``analyze`` and ``compare``).
    """
    if "worker" not in _WORKER and hasattr(os, "fork"):
        _WORKER["worker"] = Worker("hybridlog-worker")
        atexit.register(_WORKER["worker"].close)


def worker() -> Worker | None:
    """The process's worker, or ``None`` where none was started."""
    return _WORKER.get("worker")


def beside(function: Callable[..., R], *args: Any, name: str) -> Background[R] | Task[R]:
    """``function(*args)`` run beside the caller.

    In the process's worker where there is one (``function`` then a module-level function,
    it and ``args`` picklable), else in a thread.
    """
    running = worker()
    if running is not None:
        return running.submit(function, *args)
    return Background(lambda: function(*args), name)
