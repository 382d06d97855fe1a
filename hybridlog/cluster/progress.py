"""Where long clustering work says how long it will take and how far it is.

The ``O(N²)`` exact potentials of a long log in many dimensions take minutes
(:mod:`hybridlog.cluster.subtractive`).  The library prints nothing; a command that wants a
note and a progress bar installs a :class:`WorkReporter` around the call with
:func:`reporting` (``hybridlog cluster`` does: the note and the bar go to stderr, the bar only
on a terminal, neither with ``--quiet``), and the clustering code asks :func:`current_reporter`.
Without one, the work is silent.
"""

from __future__ import annotations

import contextlib
import contextvars
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager
from dataclasses import dataclass

__all__ = ["WorkReporter", "current_reporter", "reporting"]


@dataclass(frozen=True)
class WorkReporter:
    """How long work reports itself.

    Attributes
    ----------
    note:
        Called with one line saying what will take long and about how long, before the rest
        of the work.
    bar:
        Called with the total units of work and a label; the context it returns yields a
        function advancing the bar by the units just done.
    """

    note: Callable[[str], None]
    bar: Callable[[int, str], AbstractContextManager[Callable[[int], None]]]


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
