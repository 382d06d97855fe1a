"""How long work reports itself on stderr: progress bars, notes and waits.

Only on a terminal that can draw them and without ``--quiet`` (:func:`_bars_shown`):
a batch's bar of logs with its rate and time left (:func:`batch_progress`, from a
:class:`BatchClock` that leaves out the waits for a model's first compile), the bar of
long clustering, and the lines said while a model's first run compiles (:func:`_work_wait`),
given to the jobs as a :class:`~hybridlog.cluster.progress.WorkReporter`
(:func:`work_reporter`, :func:`batch_reporter`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import click

from hybridlog.cli_lines import for_terminal
from hybridlog.cli_options import is_quiet
from hybridlog.fitted_lines import fitted

if TYPE_CHECKING:
    from hybridlog.cluster.progress import WorkReporter


def _bars_shown(quiet: bool) -> bool:
    """Whether progress bars are drawn: on a terminal that can draw them, without ``--quiet``.

    Not where stderr is no terminal (a file, a pipe, a CI log) nor on a terminal that says it
    is ``TERM=dumb`` (Emacs' shell, an editor's output pane): click's bar hides the cursor
    with an escape sequence (``ESC[?25l``) and redraws the line with carriage returns, which
    such a terminal prints as they are, a line of ``^[[?25l`` fragments per update.
    """
    return not quiet and sys.stderr.isatty() and os.environ.get("TERM") != "dumb"


@contextlib.contextmanager
def _progress(
    ctx: click.Context,
    total: int,
    label: str,
    show: Callable[[Any], str] | None = None,
) -> Iterator[Callable[[object], None] | None]:
    """A progress bar on stderr, only on a terminal and without ``--quiet``.

    Without click's ETA: ``show`` says the time left where it can be told.
    """
    if not _bars_shown(is_quiet(ctx)):
        yield None
        return
    bar: Any
    with click.progressbar(
        length=total,
        label=label,
        file=fitted(sys.stderr),
        width=0,  # the bar takes what the line leaves of the terminal (fitted_lines.py)
        show_eta=False,
        show_pos=True,
        item_show_func=None if show is None else lambda item: show(item),
    ) as bar:
        yield lambda item: bar.update(1, item)


@contextlib.contextmanager
def batch_progress(
    ctx: click.Context, total: int, clock: BatchClock
) -> Iterator[Callable[[Any], None] | None]:
    """A progress bar of a batch on stderr: done / failed / skipped, rate and time left.

    Both from ``clock``'s working time, without the waits for a model's first compile: click's
    own ETA, from the bar's start, counted those 10-20 s into every log (54 s left for three
    logs that then took a second); with workers compiling side by side, the time after the
    first of them finishes a log is work, at that worker's rate.  The time left assumes the
    logs left are analysed, not skipped, at the rate of those analysed so far; there is none
    before the first is.
    """
    from hybridlog.cluster.progress import duration_text

    counts = {"done": 0, "failed": 0, "skipped": 0}

    def show(_: object) -> str:
        finished = sum(counts.values())
        analysed = counts["done"] + counts["failed"]
        working = max(clock.working(), 1e-9)
        text = (
            f"done {counts['done']} · failed {counts['failed']} · skipped {counts['skipped']}"
            f" · {finished / working * 60:,.0f} logs/min"
        )
        if analysed and finished < total:
            left = max((total - finished) * working / analysed, 1.0)  # not "0 s left"
            text += f" · {duration_text(left)} left"
        return text

    with _progress(ctx, total, "logs", show) as bar:
        if bar is None:
            yield None
            return

        def advance(outcome: Any) -> None:
            clock.work()
            counts[outcome.status] = counts.get(outcome.status, 0) + 1
            bar(outcome)

        yield advance


@dataclass
class BatchClock:
    """A batch's working time: since it started, less the time its work waited for compiling.

    A wait is one its reporter holds (:func:`_clocked_wait`) while a model's first run
    compiles, once for workers compiling side by side.  It counts as waiting until it ends or
    a log finishes during it (from then on a worker is analysing logs, which is work).
    """

    started: float = dataclasses.field(default_factory=time.monotonic)
    waited: float = 0.0
    waiting_since: float | None = None

    def working(self) -> float:
        """Seconds since the start, less those waited (so far, for a wait going on)."""
        now = time.monotonic()
        waiting = 0.0 if self.waiting_since is None else now - self.waiting_since
        return now - self.started - self.waited - waiting

    def wait(self) -> None:
        """A wait for compiling begins."""
        self.waiting_since = time.monotonic()

    def work(self) -> None:
        """A wait ends, or a log finished: the time waited so far is counted out."""
        if self.waiting_since is not None:
            self.waited += time.monotonic() - self.waiting_since
            self.waiting_since = None


@contextlib.contextmanager
def _clocked_wait(clock: BatchClock, shown: bool, what: str, why: str) -> Iterator[None]:
    """:func:`_work_wait` over the bar, its time counted out of ``clock``'s working time."""
    clock.wait()
    try:
        with _work_wait(shown, what, why, over_bar=True):
            yield
    finally:
        clock.work()


def _work_note(quiet: bool, text: str) -> None:
    """A note on stderr that long work is coming and how long it will take (not ``--quiet``).

    Prefixed as every other note (``hybridlog: note: ``): the exact potentials' "about 58
    min" stood bare among them.
    """
    if not quiet:
        click.echo(for_terminal(f"hybridlog: note: {text}"), err=True)


@contextlib.contextmanager
def _work_progress(quiet: bool, total: int, label: str) -> Iterator[Callable[[int], None]]:
    """A progress bar on stderr of ``total`` units of work, advanced by the units done.

    Only on a terminal and without ``--quiet``.
    """
    if not _bars_shown(quiet):
        yield lambda done: None
        return
    bar: Any
    lines = fitted(sys.stderr)
    with click.progressbar(length=total, label=label, file=lines, show_eta=True, width=0) as bar:
        yield bar.update


WAIT_SHOWN_S = 2.0
"""Work of unforeseeable length (:func:`_work_wait`) is announced once it has taken this long:
a model's warm run loads its cached machine code in about half a second."""


@contextlib.contextmanager
def _work_wait(shown: bool, what: str, why: str, *, over_bar: bool = False) -> Iterator[None]:
    """Say ``what`` and ``why`` once the work inside has taken :data:`WAIT_SHOWN_S`, then how long.

    Only where ``shown`` (:func:`_bars_shown`: a terminal, no ``--quiet``), as the bars: the
    lines tell someone watching why nothing happens for a while (a model's first run
    compiling its machine code); a CI log has the compile time in report.md's Runtime.
    ``over_bar``: a progress bar may be drawn on the current line, which each line clears
    first.
    """
    if not shown:
        yield
        return
    import threading

    from hybridlog.cluster.progress import duration_text

    start = time.perf_counter()
    said = threading.Event()
    # the cursor to the line's start, the line erased (kept: shown only on a terminal)
    clear = "\r\x1b[K" if over_bar else ""

    def say() -> None:
        said.set()
        click.echo(clear + for_terminal(f"{what} ({why})..."), err=True, color=over_bar)

    timer = threading.Timer(WAIT_SHOWN_S, say)
    timer.daemon = True
    timer.start()
    try:
        yield
    finally:  # a failed work's error is the command's to say, no "done" before it
        timer.cancel()
        timer.join()
    if said.is_set():
        took = duration_text(time.perf_counter() - start)
        click.echo(clear + for_terminal(f"{what}: done in {took}"), err=True, color=over_bar)


def work_reporter(ctx: click.Context) -> WorkReporter:
    """How long work reports itself on stderr (:mod:`hybridlog.cluster.progress`).

    The exact clustering potentials: a note with the expected time first, then a bar.  A
    model's first run compiling its machine code: :func:`_work_wait`.  Made of module-level
    functions, so that it is sent pickled to the estimators' worker of ``analyze`` and
    ``compare``, where ``chiu`` clusters and the filters compile (it writes on the same
    stderr).
    """
    from functools import partial

    from hybridlog.cluster.progress import WorkReporter

    quiet = is_quiet(ctx)
    return WorkReporter(
        note=partial(_work_note, quiet),
        bar=partial(_work_progress, quiet),
        wait=partial(_work_wait, _bars_shown(quiet)),
    )


def batch_reporter(ctx: click.Context, clock: BatchClock) -> WorkReporter:
    """A batch's reporter: a model's first compiling said as :func:`_work_wait`, over the bar.

    The lines clear the bar's line first (its next update draws it again below them); the
    time they wait is left out of ``clock``'s working time, the bar's rate and time left.
    Long clustering inside a log says nothing (the logs' bar is the batch's progress).
    """
    from functools import partial

    from hybridlog.cluster.progress import WorkReporter

    quiet = is_quiet(ctx)
    return WorkReporter(wait=partial(_clocked_wait, clock, _bars_shown(quiet)))
