"""One function run in a thread beside the caller's own work, its result or error collected.

Used where two stages of a command spend their time in code that releases the GIL (polars'
readers and writers, numpy's reductions, LLVM loading numba's cached machine code) beside
code that holds it (matplotlib, numba's set-up): on two cores the two overlap.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Generic, TypeVar

__all__ = ["Background"]

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
