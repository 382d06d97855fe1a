"""Where long work (clustering, first-use compilation) says how long it takes and how far it is.

The ``O(N²)`` exact potentials of a long log in many dimensions take minutes
(:mod:`hybridlog.cluster.subtractive`); a model's first run compiles its filters' machine
code, up to a minute (:func:`hybridlog.jobs.estimation.warm_up` holds :attr:`WorkReporter.wait`
around it).  The library prints nothing; a command that wants a note and a progress bar
installs a :class:`WorkReporter` around the call with :func:`reporting` (``hybridlog
cluster`` does: the note and the bar go to stderr, the bar only on a terminal, neither with
``--quiet``), and the clustering code asks :func:`current_reporter`.
Without one, the work is silent.  Work whose length shows only once it runs times itself
with :class:`TimedWork`: ``unknown-mode``'s hybrid estimation with a large ``beam``
(:mod:`hybridlog.estimators.cpha.unknown_mode`), ``simulate`` writing a long log's messages
(:mod:`hybridlog.jobs.simulate`).
"""

from __future__ import annotations

import contextlib
import contextvars
import time
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager
from dataclasses import dataclass
from types import TracebackType

__all__ = [
    "CALIBRATION_S",
    "LONG_WORK_S",
    "TimedWork",
    "WorkReporter",
    "current_reporter",
    "current_wait",
    "duration_text",
    "reporting",
    "silent_wait",
    "simulating",
]

LONG_WORK_S = 10.0
"""Work expected to take longer than this (timed on its first steps) is announced with one
line and followed by a progress bar, where a :class:`WorkReporter` is installed."""


def duration_text(seconds: float) -> str:
    """``"40 s"``, ``"12 min"``, ``"1.5 h"``: an expected duration, as notes say it."""
    if seconds < 90.0:
        return f"{seconds:.0f} s"
    if seconds < 5400.0:
        return f"{seconds / 60.0:.0f} min"
    return f"{seconds / 3600.0:.1f} h"


def _silent_note(text: str) -> None:
    """A :attr:`WorkReporter.note` that says nothing (the default)."""


def _advance_nothing(done: int) -> None:
    """What :func:`_silent_bar`'s context yields: a bar that is not drawn."""


def _silent_bar(total: int, label: str) -> AbstractContextManager[Callable[[int], None]]:
    """A :attr:`WorkReporter.bar` that draws nothing (the default)."""
    return contextlib.nullcontext(_advance_nothing)


def silent_wait(what: str, why: str) -> AbstractContextManager[None]:
    """A :attr:`WorkReporter.wait` that says nothing (the default)."""
    return contextlib.nullcontext()


@dataclass(frozen=True)
class WorkReporter:
    """How long work reports itself; each member says nothing unless given.

    Made of module-level functions (the defaults are), a reporter is sent pickled to the
    process that does the work (``analyze``'s estimators' worker).

    Attributes
    ----------
    note:
        Called with one line saying what will take long and about how long, before the rest
        of the work.
    bar:
        Called with the total units of work and a label; the context it returns yields a
        function advancing the bar by the units just done.
    wait:
        Called with what is being done (``"imm: compiling machine code for model 'm'"``) and
        why it takes long, around work whose length cannot be foreseen (the machine code a
        model's first run compiles; a warm run loads it in a moment): the context it returns
        is held around that work.  It may say so only once the work has outlasted a moment,
        and then how long it took.
    """

    note: Callable[[str], None] = _silent_note
    bar: Callable[[int, str], AbstractContextManager[Callable[[int], None]]] = _silent_bar
    wait: Callable[[str, str], AbstractContextManager[None]] = silent_wait


_REPORTER: contextvars.ContextVar[WorkReporter | None] = contextvars.ContextVar(
    "hybridlog_cluster_reporter", default=None
)


def current_reporter() -> WorkReporter | None:
    """The reporter installed by :func:`reporting`, if any."""
    return _REPORTER.get()


def current_wait() -> Callable[[str, str], AbstractContextManager[None]]:
    """The installed reporter's :attr:`WorkReporter.wait`, or :func:`silent_wait` without one."""
    reporter = _REPORTER.get()
    return silent_wait if reporter is None else reporter.wait


@contextlib.contextmanager
def reporting(reporter: WorkReporter | None) -> Iterator[None]:
    """Install ``reporter`` for the clustering work done inside the ``with`` block."""
    token = _REPORTER.set(reporter)
    try:
        yield
    finally:
        _REPORTER.reset(token)


CALIBRATION_S = 1.0
"""Work time over which :class:`TimedWork` times the units before it expects the rest."""


class TimedWork:
    """Work of ``total`` units that times itself and, when long, says so and shows a bar.

    A context manager around the work, told how far it is with :meth:`reached`.  The first
    unit is not timed (it loads what the rest reuse), then the units of the next
    :data:`CALIBRATION_S` are, and the rate of their later half (the work per unit may grow
    at first: a beam filling) gives the rest's time.  When the work is then expected to
    take longer than :data:`LONG_WORK_S`, the installed reporter
    (:func:`current_reporter`) gets ``note(units left, seconds left)``'s line and a bar
    labelled ``label`` over the rest.  Without a reporter it does nothing.

    ``clock``: the work's own clock, in seconds (``unknown-mode``'s excludes the time its
    caches spend compiling).
    """

    def __init__(
        self,
        total: int,
        label: str,
        note: Callable[[int, float], str],
        clock: Callable[[], float] = time.perf_counter,
    ) -> None:
        self.total = total
        self.label = label
        self.note = note
        self.clock = clock
        self.reporter = current_reporter()
        self._stack = contextlib.ExitStack()
        self._advance: Callable[[int], None] | None = None
        self._shown = 0  # the units the bar shows
        self._first: tuple[int, float] | None = None  # (units, clock) after the first
        self._half: tuple[int, float] | None = None  # the same, half-way through timing
        self._decided = self.reporter is None or total < 2

    def __enter__(self) -> TimedWork:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        trace: TracebackType | None,
    ) -> None:
        self._stack.close()

    def reached(self, done: int) -> None:
        """``done`` units of the ``total`` are done, counted from the start."""
        if self._advance is not None:
            self._advance(done - self._shown)
            self._shown = done
            return
        if self._decided:
            return
        now = self.clock()
        if self._first is None:
            self._first = (done, now)
            return
        d0, t0 = self._first
        elapsed = now - t0
        if self._half is None and elapsed >= CALIBRATION_S / 2:
            self._half = (done, now)
        if elapsed < CALIBRATION_S and done < self.total:
            return
        self._decided = True
        d_h, t_h = self._half if self._half is not None and self._half[0] < done else (d0, t0)
        if done >= self.total or done <= d_h:
            return
        remaining = (now - t_h) / (done - d_h) * (self.total - done)
        if now - t0 + remaining <= LONG_WORK_S:
            return
        assert self.reporter is not None
        self.reporter.note(self.note(self.total - done, remaining))
        self._advance = self._stack.enter_context(self.reporter.bar(self.total, self.label))
        self._advance(done)
        self._shown = done


def simulating(rows: int, origin: str) -> TimedWork:
    """The progress of simulating ``rows`` log rows of the model file ``origin``.

    One line for every kind of simulation: the compiled loops' chunks
    (:mod:`hybridlog.simulate`) and a components model's Python steps
    (:mod:`hybridlog.simulate_components`).
    """
    return TimedWork(
        rows,
        "steps simulated",
        lambda left, seconds: (
            f"simulating {origin}: about {duration_text(seconds)} more on this machine "
            f"({left:,} of {rows:,} steps left)"
        ),
    )
