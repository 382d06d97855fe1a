"""One function run beside the caller's own work, its result or error collected.

:class:`Background` runs it in a thread: for two stages of a command where one spends its
time in code that releases the GIL (polars' readers and writers, numpy's reductions, LLVM
loading numba's cached machine code) beside code that holds it (numba's set-up): on two
cores the two overlap.  Where both hold the GIL much of the time (matplotlib drawing beside
the metrics' and tables' Python), a thread only interleaves them; :class:`Forked` runs the
function in a forked child instead, which sees the caller's memory as it was (copy on
write: the arrays are not copied) and runs on the other core.  :func:`beside` picks the
child where the process has allowed it (:func:`allow_fork`) and the thread elsewhere.

Forking a process that has threads is safe only if the child touches nothing another
thread may have held locked at the fork.  So the child is allowed only in a process that
runs one command and ends (the console script's ``analyze`` and ``compare``,
``hybridlog.cli``), whose other threads then are polars' allocator and spill threads and
OpenBLAS's, none of which the child calls (glibc's ``malloc``, jemalloc and OpenBLAS reset
their locks in the child through their fork handlers), and only for drawing plots (numpy
and matplotlib, imported before the fork); never in a library caller's process, a batch
worker or a Dask worker, whose threads are not known.
"""

from __future__ import annotations

import os
import pickle
import signal
import threading
from collections.abc import Callable
from typing import Any, Generic, TypeVar

__all__ = ["Background", "Forked", "allow_fork", "beside"]

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


_POLICY = {"fork": False}
"""Whether :func:`beside` may fork (:func:`allow_fork`)."""


def allow_fork() -> None:
    """Let :func:`beside` run functions in a forked child (one-command processes only)."""
    _POLICY["fork"] = hasattr(os, "fork")


class Forked(Generic[R]):
    """``function()`` running in a forked child process from construction on.

    The child sends back, through a pipe, the pickled value or the pickled exception (or, if
    that cannot be pickled, a ``RuntimeError`` naming it) and leaves with ``os._exit``: no
    clean-up of the caller's objects, no second flush of the caller's buffered output.
    :meth:`result` and :meth:`wait` as for :class:`Background`; a child that ends without
    sending (killed) is a ``ChildProcessError`` naming how it ended.
    """

    def __init__(self, function: Callable[[], R], name: str) -> None:
        self._name = name
        readable, writable = os.pipe()
        pid = os.fork()
        if pid == 0:  # the child: run, send, leave
            os.close(readable)
            try:
                _send(writable, function)
            finally:
                os._exit(0)
        os.close(writable)
        self._pid = pid
        self._readable = readable
        self._outcome: tuple[bool, Any] | None = None

    def _collect(self) -> tuple[bool, Any]:
        if self._outcome is None:
            with os.fdopen(self._readable, "rb") as pipe:
                data = pipe.read()
            _, status = os.waitpid(self._pid, 0)
            if data:
                self._outcome = pickle.loads(data)
            else:
                self._outcome = (False, ChildProcessError(f"{self._name}: {_ended(status)}"))
        return self._outcome

    def wait(self) -> None:
        """Wait for the child to send its outcome and end."""
        self._collect()

    def result(self) -> R:
        """The function's value, once the child sent it; what it raised, raised here."""
        ok, value = self._collect()
        if not ok:
            raise value
        result: R = value
        return result


def _send(writable: int, function: Callable[[], Any]) -> None:
    """Run ``function`` and write its pickled outcome to ``writable`` (in the child)."""
    try:
        payload = pickle.dumps((True, function()))
    except BaseException as err:  # raised again by Forked.result, in the caller
        try:
            payload = pickle.dumps((False, err))
        except Exception:
            payload = pickle.dumps((False, RuntimeError(f"{type(err).__name__}: {err}")))
    with os.fdopen(writable, "wb") as pipe:
        pipe.write(payload)


def _ended(status: int) -> str:
    if os.WIFSIGNALED(status):
        number = os.WTERMSIG(status)
        try:
            return f"the process was killed by signal {signal.Signals(number).name}"
        except ValueError:
            return f"the process was killed by signal {number}"
    return f"the process ended with exit code {os.waitstatus_to_exitcode(status)} and no result"


def beside(function: Callable[[], R], name: str) -> Background[R] | Forked[R]:
    """``function()`` run beside the caller: in a forked child where allowed, else a thread."""
    if _POLICY["fork"]:
        return Forked(function, name)
    return Background(function, name)
