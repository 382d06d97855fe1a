"""How a batch ended: each log's outcome, the whole batch's, and a log's error on one line.

:class:`LogOutcome` is what the task of a log returns
(:func:`~hybridlog.jobs.batch_task.analyze_log`), :class:`BatchOutcome` what
:func:`~hybridlog.jobs.batch.run_batch` returns; :func:`error_line` makes any error of a log
the one line the summaries show.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from hybridlog.errors import shortened
from hybridlog.report import Report
from hybridlog.report.summary_notes import warning_notes

__all__ = ["BatchOutcome", "LogOutcome", "error_line"]


_ERROR_LIMIT = 300


@dataclass(frozen=True)
class LogOutcome:
    """How one log of a batch ended: ``done``, ``skipped`` (already done) or ``failed``."""

    log: str
    folder: str
    status: str
    report: Report | None
    error: str | None
    memory_wait_s: float = 0.0
    """How long the log waited for memory the other workers' logs held (``--jobs N``)."""
    seconds: float = 0.0
    """The log's wall time in this run, from its task's start to its outcome (reading,
    estimating, writing its report, waiting for memory; a reused report's check alone):
    JUnit's ``time`` of its cases.  0 for a log whose worker died."""


@dataclass(frozen=True)
class BatchOutcome:
    """The whole batch: per-log outcomes, the summary table and the missed CI gates."""

    logs: list[LogOutcome]
    table: str
    gate_failures: list[str]
    notes: list[str] = dataclasses.field(default_factory=list)
    """What the user should know of how the batch ran (``--jobs`` capped, Dask's memory)."""

    @property
    def failed(self) -> int:
        """Number of logs that could not be analysed."""
        return sum(1 for log in self.logs if log.status == "failed")

    @property
    def warned(self) -> list[LogOutcome]:
        """The analysed logs whose report has a note that warns (:func:`warning_notes`).

        A log reused by a resumed batch counts by its report.json's notes.
        """
        return [log for log in self.logs if warning_notes(log.report)]

    @property
    def waited_for_memory(self) -> list[LogOutcome]:
        """The logs that waited for memory the other workers' logs held (``--jobs N``)."""
        return [log for log in self.logs if log.memory_wait_s > 0.0]


def error_line(text: str) -> str:
    """A log's error on one line of at most :data:`_ERROR_LIMIT` characters.

    A longer one is cut in the middle, not at the end: an error starts with the log's path
    (or the report folder's, as long) and ends with what is wrong, which must stay (between
    words where one is near, :func:`~hybridlog.errors.shortened`).  The end
    keeps two thirds of the room: the summaries name the log in a column of its own, and a
    reason of 150 characters behind a long path lost its first half when the end kept one.
    """
    return shortened(text, _ERROR_LIMIT, end_share=2 / 3)
