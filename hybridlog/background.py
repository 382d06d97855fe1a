"""Work run beside the caller's own, its result or error collected.

:class:`Background` runs a function in a thread: for two stages of a command where one
spends its time in code that releases the GIL (polars' readers and writers, numpy's
reductions, LLVM loading numba's cached machine code, the filters' compiled loops) beside
code that holds it (numba's set-up, the report's Python): on two cores the two overlap.
Where both hold the GIL much of the time, or where what the work loads should stay out of
the command (numba's compiler, matplotlib), a :class:`Worker` runs functions in another
process instead: :func:`beside` sends a function to the process's worker of a role where
one was started (:func:`start_worker`) and runs it in a thread elsewhere, and
:meth:`Worker.stream` brings an iterator's items back as the worker makes them (the
estimators' chunks).

Workers are forked when the process is small and has one thread: the console script's
``analyze`` and ``compare`` start theirs (``ESTIMATES``, ``PLOTS``) before they import
polars, numba or matplotlib (``hybridlog.cli_process``), so a child inherits no thread that may
hold a lock and no large memory, and imports what its functions need itself.  Functions
(module-level, or named ``"module:name"``) and their arguments are sent pickled through a
pipe, NumPy arrays out of band, and the values or exceptions come back the same way.
Never in a library caller's process, a batch worker or a Dask worker, which run their
functions in threads.
"""

from __future__ import annotations

import atexit
import contextlib
import fcntl
import importlib
import io
import os
import pickle
import signal
import struct
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from typing import Any, Generic, TypeVar

__all__ = [
    "ESTIMATES",
    "PLOTS",
    "Background",
    "Task",
    "Worker",
    "beside",
    "forked",
    "start_worker",
    "worker",
]

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
            kind, value = self._owner.message(self._index)
            self._outcome = (kind == "value", value)
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
"""Lengths on the worker's pipes are unsigned 64-bit integers."""


def _write_message(stream: io.BufferedIOBase, message: object) -> None:
    """Write ``message`` pickled, its large buffers (NumPy arrays' data) out of band.

    The pickle (protocol 5) is written after the number and the lengths of its parts, then
    each out-of-band buffer straight from the memory it is in: an array of signals or
    estimates crosses the pipe without a pickled copy of it in either process.
    """
    buffers: list[pickle.PickleBuffer] = []
    payload = pickle.dumps(message, protocol=5, buffer_callback=buffers.append)
    views = [buffer.raw() for buffer in buffers]
    sizes = [len(payload), *(view.nbytes for view in views)]
    stream.write(struct.pack(f"<Q{len(sizes)}Q", len(sizes), *sizes))
    stream.write(payload)
    for view in views:
        stream.write(view)
    stream.flush()


def _read_message(stream: io.BufferedIOBase) -> tuple[bool, Any]:
    """``(True, message)`` written by :func:`_write_message`, or ``(False, None)`` at the end.

    Each out-of-band buffer is read into memory of its own, which the unpickled arrays
    then use as it is.
    """
    header = stream.read(_HEADER.size)
    if len(header) < _HEADER.size:
        return False, None
    (count,) = _HEADER.unpack(header)
    sizes = struct.unpack(f"<{count}Q", stream.read(_HEADER.size * count))
    parts = []
    for size in sizes:
        part = bytearray(size)
        if stream.readinto(part) != size:
            return False, None
        parts.append(part)
    return True, pickle.loads(parts[0], buffers=parts[1:])


_PARENT_ENDS: set[int] = set()
"""This process's ends of its workers' pipes: a worker forked later closes them, or a
worker would never see the end of another's requests (its copy would keep them open)."""

_ENDING_SIGNALS = (signal.SIGTERM, signal.SIGHUP)
"""Signals a worker dies of, whatever handler the process it was forked from had."""

_PIPE_BYTES = 1 << 20
"""Capacity asked of the pipes on Linux (``F_SETPIPE_SZ``; 64 KiB by default): a chunk of a
streamed result (about 7 MB) then crosses in a few writes, not a hundred."""

_PATIENCE_S = 10.0
"""How long :meth:`Worker.close` waits for a child to end once its pipes are closed."""

_DONE = ("value", "error", "end")
"""The kinds of message that end a request's messages (``item`` does not)."""


class Worker:
    """A forked process that runs the functions sent to it, one after the other.

    :meth:`submit` pickles a module-level function and its arguments into the child's
    pipe and returns at once; the child runs them in the order sent and sends back each
    outcome: the pickled value, or the pickled exception (or, if that cannot be pickled, a
    ``RuntimeError`` naming it).  :meth:`stream` sends a function that returns an iterator:
    the child sends its items one at a time as it makes them, and the caller iterates over
    them as they come (the pipe holds about one: the child makes the next while the caller
    takes this one).  A child that ends without sending (killed) makes every outcome still
    owed a ``ChildProcessError`` naming how it ended.  :meth:`close` (also at exit) closes
    the pipe, on which the child ends, and waits for it; a caller that leaves a stream
    before its end stops the child (:meth:`stop`), which is then gone for later work.  The
    child ignores ``SIGINT`` (an interrupted command ends it by closing the pipe), dies of
    ``SIGTERM`` and ``SIGHUP`` at once and silently (the console script's handler, which
    raises them as an exception to unwind the command, would be inherited by the fork: sent
    to the whole process group, the exception ended the worker's task, or, raised inside a
    library's callback (numba's cache), was printed on the shared standard error with a
    traceback while the worker went on), and leaves with ``os._exit``: no clean-up of the
    parent's objects, no second flush of its buffered output.
    """

    def __init__(self, name: str) -> None:
        self._name = name
        requests_read, requests_write = os.pipe()
        replies_read, replies_write = os.pipe()
        for end in (requests_write, replies_write):
            with contextlib.suppress(AttributeError, OSError):
                fcntl.fcntl(end, fcntl.F_SETPIPE_SZ, _PIPE_BYTES)
        pid = os.fork()
        if pid == 0:  # the child: serve until the pipe closes, then leave
            os.close(requests_write)
            os.close(replies_read)
            for end in _PARENT_ENDS:  # another worker's: its child must see its pipe close
                os.close(end)
            try:
                signal.signal(signal.SIGINT, signal.SIG_IGN)
                for ending in _ENDING_SIGNALS:  # not the command's handler: die of it
                    signal.signal(ending, signal.SIG_DFL)
                _IN_WORKER[0] = True
                _serve(requests_read, replies_write)
            finally:
                os._exit(0)
        os.close(requests_read)
        os.close(replies_write)
        _PARENT_ENDS.update((requests_write, replies_read))
        self._pid = pid
        # the pipes live as long as the worker: closed by close(), not by a with block
        self._requests: io.BufferedWriter | None = open(requests_write, "wb")  # noqa: SIM115
        self._replies: io.BufferedReader = open(replies_read, "rb")  # noqa: SIM115
        self._lock = threading.Lock()
        self._sent = 0
        self._current = 0  # the request whose messages come next
        self._messages: dict[int, deque[tuple[str, Any]]] = {}
        self._ended: str | None = None

    @property
    def alive(self) -> bool:
        """Whether the child still takes work (not closed, stopped or found dead)."""
        return self._requests is not None and self._ended is None

    def submit(self, function: Callable[..., R] | str, *args: Any) -> Task[R]:
        """Send ``function(*args)`` to the child; its outcome comes with :meth:`Task.result`.

        ``function`` is picklable (module-level), or ``"module:name"`` to be imported only
        in the child.
        """
        return Task(self, self._send("call", function, args))

    def stream(self, function: Callable[..., Iterable[R]], *args: Any) -> Iterator[R]:
        """Send ``function(*args)``, an iterable, to the child; iterate over its items here.

        The child sends each item as it makes it; what the function raises is raised here
        after the items before it.  The function runs when the request's turn comes,
        whether or not the iterator returned is ever started.
        """
        index = self._send("stream", function, args)

        def items() -> Iterator[R]:
            finished = False
            try:
                while True:
                    kind, value = self.message(index)
                    if kind == "item":
                        yield value
                        continue
                    finished = True
                    if kind == "error":
                        raise value
                    return
            finally:
                if not finished:  # left before its end: the child is still making items
                    self.stop()

        return items()

    def _send(self, kind: str, function: Callable[..., Any] | str, args: tuple[Any, ...]) -> int:
        with self._lock:
            if self._requests is None:
                raise RuntimeError(f"{self._name}: the worker is closed")
            with contextlib.suppress(BrokenPipeError):
                # a child that has ended reads no more: the request's outcome is the error
                # naming how it ended (``_read_message``), as for every request it owed
                _write_message(self._requests, (kind, function, args))
            index = self._sent
            self._sent += 1
            self._messages[index] = deque()
        return index

    def message(self, index: int) -> tuple[str, Any]:
        """The next message of the request sent ``index``-th (0 first): ``(kind, value)``.

        ``value`` (the function's value), ``error`` (what it raised), ``item`` (one item of
        a stream) or ``end`` (a stream's end).  Messages of earlier requests read meanwhile
        are kept for them; a request's last message is given once.
        """
        with self._lock:
            queue = self._messages[index]
            while not queue:
                kind, value = self._read_message()
                self._messages[self._current].append((kind, value))
                if kind in _DONE:
                    self._current += 1
            kind, value = queue.popleft()
            if kind in _DONE:
                del self._messages[index]
            return kind, value

    def _read_message(self) -> tuple[str, Any]:
        if self._ended is None:
            try:
                read, message = _read_message(self._replies)
            except BaseException:
                # interrupted (Ctrl-C) inside a message: the pipe is no longer in step with
                # the child, which is ended; every outcome still owed is an error now
                self._kill("the process was stopped while its reply was read")
                raise
            if read:
                kind, value = message
                return kind, value
            _, status = os.waitpid(self._pid, 0)
            self._ended = _ended(status)
        return "error", ChildProcessError(f"{self._name}: {self._ended}")

    def _kill(self, why: str) -> None:
        """``SIGKILL`` the child and wait for it, unless it has ended already."""
        if self._ended is None:
            with contextlib.suppress(ProcessLookupError):
                os.kill(self._pid, signal.SIGKILL)
            os.waitpid(self._pid, 0)
            self._ended = why

    def stop(self) -> None:
        """End the child now (``SIGKILL``), whatever it is doing, and wait for it."""
        self._kill("the process was stopped")
        self.close()

    def release(self) -> None:
        """Close both pipes, on which the child ends, without waiting for it; idempotent.

        For a caller done with the worker well before its own end: the child's exit (the
        estimators' worker frees about 250 MiB) then overlaps the caller's remaining work,
        and :meth:`close` (at exit) only collects it.
        """
        with self._lock:
            requests, self._requests = self._requests, None
        if requests is None:
            return
        _PARENT_ENDS.difference_update((requests.fileno(), self._replies.fileno()))
        for pipe in (self._replies, requests):
            with contextlib.suppress(OSError):
                pipe.close()  # a stopped child's pipe may be broken

    def close(self) -> None:
        """Close both pipes and wait for the child to end; idempotent.

        The child ends when it reads the end of its requests, or when it writes a reply
        nobody will read (a broken pipe): a command that leaves in the middle of a stream
        (an error, Ctrl-C) leaves its worker no reply to finish.  One still working after
        :data:`_PATIENCE_S` seconds (a long computation between two writes) is killed.
        A child still owing outcomes nobody read (a command that failed while the worker
        still warmed up: numba's set-up, matplotlib's import) is stopped at once: nothing
        can ask for them after this, and the command's end would wait for work it drops
        (0.4-0.6 s after an error found in the log or the options).
        """
        with self._lock:
            owed = self._requests is not None and self._current < self._sent
        if owed:
            self._kill("the process was stopped: closed with work still owed")
        self.release()
        deadline = time.monotonic() + _PATIENCE_S
        while self._ended is None:
            pid, _ = os.waitpid(self._pid, os.WNOHANG)
            if pid:
                self._ended = "closed"
            elif time.monotonic() > deadline:
                self._kill("the process was stopped: it did not end when its pipes closed")
            else:
                time.sleep(0.005)


def _send_outcome(stream: io.BufferedIOBase, kind: str, value: Any) -> None:
    """Write the message ``(kind, value)``; an error that cannot be pickled goes as one line.

    An item or value that cannot be pickled raises here (the caller sends that as the error).
    """
    try:
        _write_message(stream, (kind, value))
    except Exception:
        if kind != "error":
            raise
        _write_message(stream, (kind, RuntimeError(f"{type(value).__name__}: {value}")))


def _serve(requests: int, replies: int) -> None:
    """The child's loop: read a request, run it, send its messages."""
    with open(requests, "rb") as incoming, open(replies, "wb") as outgoing:

        def send(kind: str, value: Any) -> None:
            _send_outcome(outgoing, kind, value)

        while True:
            read, request = _read_message(incoming)
            if not read:
                return
            try:
                kind, function, args = request
                if isinstance(function, str):  # "module:name", imported here
                    module, _, name = function.partition(":")
                    function = getattr(importlib.import_module(module), name)
                if kind == "stream":
                    for item in function(*args):
                        send("item", item)
                    send("end", None)
                else:
                    send("value", function(*args))
            except BaseException as err:  # raised again in the caller
                send("error", err)


def _ended(status: int) -> str:
    if os.WIFSIGNALED(status):
        number = os.WTERMSIG(status)
        try:
            return f"the process was killed by signal {signal.Signals(number).name}"
        except ValueError:
            return f"the process was killed by signal {number}"
    return f"the process ended with exit code {os.waitstatus_to_exitcode(status)} and no result"


_IN_WORKER = [False]
"""Whether this process is a :class:`Worker`'s child (set there, right after the fork)."""


def forked(function: Callable[[], R]) -> Callable[[], R]:
    """Start ``function()`` in a child forked from this worker process; return its waiter.

    Only in a :class:`Worker`'s process while it has one thread (the plots' worker, which
    draws one figure in such a child while it draws the others: the command has little left
    to do by then, so the other core is free): the child sends the value, or what it raised,
    pickled (:func:`_write_message`) and ends with ``os._exit``; the waiter returns the value
    or raises the error, or a ``ChildProcessError`` naming how the child ended if it ended
    without sending.  Anywhere else ``function`` runs at once, and the waiter returns its
    value or raises what it raised.  A child whose worker is killed meanwhile (the command
    interrupted while it draws) finishes its function, finds nobody to read its outcome and
    ends: a fraction of a second, as long as one figure takes.
    """
    if not (_IN_WORKER[0] and threading.active_count() == 1 and hasattr(os, "fork")):
        outcome: list[Any] = []
        try:
            outcome.append(function())
        except Exception as err:  # raised again by the waiter
            error = err

            def failed() -> R:
                raise error

            return failed
        value: R = outcome[0]
        return lambda: value
    read_end, write_end = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: run, send, leave (nothing of the worker's is flushed or run)
        try:
            os.close(read_end)
            with open(write_end, "wb") as outgoing:
                try:
                    result = function()
                except BaseException as err:
                    _send_outcome(outgoing, "error", err)
                else:
                    _send_outcome(outgoing, "value", result)
        finally:
            os._exit(0)
    os.close(write_end)

    def wait() -> R:
        with open(read_end, "rb") as incoming:
            read, message = _read_message(incoming)
        _, status = os.waitpid(pid, 0)
        if not read:
            raise ChildProcessError(f"a forked child: {_ended(status)}")
        kind, value = message
        if kind == "error":
            raise value
        returned: R = value
        return returned

    return wait


ESTIMATES = "estimates"
"""The worker that runs the estimators (numba set up there, never in the command)."""
PLOTS = "plots"
"""The worker that draws the plots (matplotlib imported there, never in the command)."""

_WORKERS: dict[str, Worker] = {}
"""The process's workers by role, once :func:`start_worker` made them."""


def start_worker(role: str, *warm_up: str) -> None:
    """Fork this process's worker for ``role`` now; it is closed at exit.

    Only in a one-command process, while it is still small and has one thread (the console
    script's ``analyze`` and ``compare``).  ``warm_up``: functions, as ``"module:name"``
    (imported in the worker, not here), the worker runs first while this process goes on
    (numba's set-up, matplotlib's import); their outcomes are not waited for (an error
    there shows again in the work that needs what failed).
    """
    if role not in _WORKERS and hasattr(os, "fork"):
        started = Worker(f"hybridlog-{role}")
        _WORKERS[role] = started
        atexit.register(started.close)
        for function in warm_up:
            started.submit(function)


def worker(role: str) -> Worker | None:
    """The process's worker for ``role``, or ``None`` where none was started or it is gone."""
    running = _WORKERS.get(role)
    return running if running is not None and running.alive else None


def beside(
    function: Callable[..., R], *args: Any, name: str, role: str = PLOTS
) -> Background[R] | Task[R]:
    """``function(*args)`` run beside the caller.

    In the process's worker for ``role`` where there is one (``function`` then a
    module-level function, it and ``args`` picklable), else in a thread.
    """
    running = worker(role)
    if running is not None:
        return running.submit(function, *args)
    return Background(lambda: function(*args), name)
