"""A long ``unknown-mode`` run says about how long it will take (:mod:`hybridlog.cluster.progress`).

The tracker's work per step grows with ``beam`` and ``candidates``: ``--set beam=10000`` on a
400-sample log of one component took 59 s with nothing printed, where chiu's exact
potentials and cluster labelling say how long they will take.  :class:`LongRun` times the
steps after the first (compilation excluded, the caches' own clock) for
:data:`CALIBRATION_S`, and when the whole run is then expected to take more than
:data:`~hybridlog.cluster.progress.LONG_WORK_S`, gives the installed
:class:`~hybridlog.cluster.progress.WorkReporter` one line (steps, beam, expected time) and
a bar over the remaining steps.  Without a reporter (the library, ``batch``) it does nothing.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable
from types import TracebackType

from hybridlog.cluster import progress
from hybridlog.cluster.progress import current_reporter

__all__ = ["CALIBRATION_S", "LongRun"]

CALIBRATION_S = 1.0
"""Work time (compilation excluded) over which the steps are timed before the estimate."""


class LongRun:
    """Times a run's steps and announces it when long; a context manager around the loop.

    Parameters
    ----------
    steps:
        The steps of the run (``N - 1``: step 0 only starts the hypotheses).
    what:
        What runs, for the note (``"unknown-mode over 400 samples, beam 10,000"``).
    compiling:
        The seconds spent compiling so far (structure and filter caches), excluded.
    """

    def __init__(self, steps: int, what: str, compiling: Callable[[], float]) -> None:
        self.steps = steps
        self.what = what
        self.compiling = compiling
        self.reporter = current_reporter()
        self._stack = contextlib.ExitStack()
        self._advance: Callable[[int], None] | None = None
        self._first: tuple[int, float] | None = None  # (step, work time) after step 1
        self._half: tuple[int, float] | None = None  # the same, half-way through timing
        self._decided = self.reporter is None or steps < 2

    def __enter__(self) -> LongRun:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        trace: TracebackType | None,
    ) -> None:
        self._stack.close()

    def _work(self) -> float:
        return time.perf_counter() - self.compiling()

    def done(self, k: int) -> None:
        """Step ``k`` (1 … ``steps``) is done."""
        if self._advance is not None:
            self._advance(1)
            return
        if self._decided:
            return
        now = self._work()
        if self._first is None:  # the first step loads what the rest reuse: not timed
            self._first = (k, now)
            return
        k0, t0 = self._first
        elapsed = now - t0
        if self._half is None and elapsed >= CALIBRATION_S / 2:
            self._half = (k, now)
        if elapsed < CALIBRATION_S and k < self.steps:
            return
        self._decided = True
        # the rate of the later half: the beam fills over the first steps, each then costs more
        k_h, t_h = self._half if self._half is not None and self._half[0] < k else (k0, t0)
        per_step = (now - t_h) / (k - k_h)
        remaining = per_step * (self.steps - k)
        if k >= self.steps or now - t0 + remaining <= progress.LONG_WORK_S:
            return
        assert self.reporter is not None
        self.reporter.note(
            f"{self.what}: about {progress.duration_text(remaining)} more on this machine "
            f"({self.steps - k:,} of {self.steps:,} steps left, timed on the steps after the "
            "first, compilation excluded; a smaller beam or candidates takes less)"
        )
        advance = self._stack.enter_context(self.reporter.bar(self.steps, "unknown-mode steps"))
        advance(k)
        self._advance = advance
