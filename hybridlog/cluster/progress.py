"""Where long work (clustering, first-use compilation) says how long it takes and how far it is.

The ``O(N²)`` exact potentials of a long log in many dimensions take minutes
(:mod:`hybridlog.cluster.subtractive`); a model's first run compiles its filters' machine
code, up to a minute (:func:`hybridlog.jobs.analysis.warm_up` holds :attr:`WorkReporter.wait`
around it).  The library prints nothing; a command that wants a note and a progress bar
installs a :class:`WorkReporter` around the call with :func:`reporting` (``hybridlog
cluster`` does: the note and the bar go to stderr, the bar only on a terminal, neither with
``--quiet``), and the clustering code asks :func:`current_reporter`.
Without one, the work is silent.  ``unknown-mode``'s hybrid estimation with a large ``beam``
reports itself the same way (:mod:`hybridlog.estimators.cpha.long_run`).
"""

from __future__ import annotations

import contextlib
import contextvars
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager
from dataclasses import dataclass

__all__ = [
    "LONG_WORK_S",
    "WorkReporter",
    "current_reporter",
    "duration_text",
    "reporting",
    "silent_wait",
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


@contextlib.contextmanager
def reporting(reporter: WorkReporter | None) -> Iterator[None]:
    """Install ``reporter`` for the clustering work done inside the ``with`` block."""
    token = _REPORTER.set(reporter)
    try:
        yield
    finally:
        _REPORTER.reset(token)
