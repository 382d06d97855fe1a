"""What the alignment records of each signal for the report, beside its aligned values.

How often a bridged output was sampled (:func:`sampled_every`) and a held input, and
whether regularly (:func:`held_sampling`), the samples of a series
faster than the grid (:func:`faster_than_the_grid`) or that the hold never takes
(:func:`skipped_by_the_hold`), an input's longest hold over ``max_gap``
(:func:`longest_hold`), and the signal that starts the grid late or ends it early
(:func:`record_span_bounds`); durations in seconds to the digits the times hold
(:func:`seconds_between`).  :func:`hybridlog.io.align.align_signals` lists the notes.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from hybridlog.io.output_gaps import gap_threshold
from hybridlog.io.source import NS_PER_S, Series
from hybridlog.io.time_grid import longer_than_max_gap
from hybridlog.signals import IntArray
from hybridlog.times import round_duration


def sampled_every(time_ns: IntArray, grid_ns: IntArray, dt_ns: int) -> dict[str, float | None]:
    """How often a bridged output was sampled over the grid's span: why it was bridged.

    ``every``: the median step (s) between its samples from the grid's first point to its
    last (the whole series when fewer than two lie there); ``steps``: that step in steps of
    ``dt``, to two decimals.  A topic published at a third of the model's rate (``steps`` 3)
    is bridged at two points of three by design, one published at the model's rate
    (``steps`` 1) only where the log lacks samples: the report says which
    (:func:`~hybridlog.report.reading_notes.bridged_cause`), where it asked of both whether
    the model's dt is the log's.  Both ``None`` for a series of one sample, which has no
    step: an input recorded once (a latched set-point), held over the whole log; the median
    of no step was NaN, which ``analyze`` refused as numerical trouble.
    """
    steps = _steps_over(time_ns, grid_ns)
    if steps.size == 0:
        return {"every": None, "steps": None}
    step_ns = float(np.median(steps))
    ends = (float(grid_ns[0]) / NS_PER_S, float(grid_ns[-1]) / NS_PER_S)
    every = round_duration(step_ns / NS_PER_S, *ends)
    return {"every": every, "steps": round(step_ns / dt_ns, 2)}


REGULAR_TOLERANCE = 0.25
"""A step between two samples within this fraction of the median step is a regular one."""
REGULAR_SHARE = 0.9
"""A series is sampled regularly when at least this share of its steps are regular ..."""
REGULAR_STEPS = 10
"""... and it has at least this many steps: of fewer, a command published when it changes can
have steps alike by chance."""


def held_sampling(time_ns: IntArray, grid_ns: IntArray, dt_ns: int) -> dict[str, Any]:
    """How often a held signal (an input, a command) was sampled, and whether regularly.

    :func:`sampled_every`'s ``every`` and ``steps``, and ``regular``: whether at least
    :data:`REGULAR_SHARE` of its :data:`REGULAR_STEPS` or more steps (over the grid's span, as
    ``every``) lie within :data:`REGULAR_TOLERANCE` of their median, a robust test a few
    dropouts or a jittering clock do not fail and a command published when it changes, at
    irregular times, does.  An input published at 10 Hz to a model of ``dt = 0.01`` read "no
    sample in 100 stretches longer than max_gap ... as an input published only when it changes
    is": the report now says it is sampled every 0.1 s, 10 steps of dt
    (:func:`~hybridlog.report.reading_notes.log_reading_notes`), as it says of an output.
    """
    steps = _steps_over(time_ns, grid_ns)
    median = float(np.median(steps)) if steps.size else 0.0
    close = np.abs(steps - median) <= REGULAR_TOLERANCE * median
    regular = steps.size >= REGULAR_STEPS and median > 0 and close.mean() >= REGULAR_SHARE
    return {**sampled_every(time_ns, grid_ns, dt_ns), "regular": bool(regular)}


def _steps_over(time_ns: IntArray, grid_ns: IntArray) -> IntArray:
    """The steps between a series' samples from the grid's first point to its last.

    Those of the whole series when fewer than two samples lie there.
    """
    lo = int(np.searchsorted(time_ns, grid_ns[0], side="left"))
    hi = int(np.searchsorted(time_ns, grid_ns[-1], side="right"))
    inside = time_ns[lo:hi] if hi - lo >= 2 else time_ns
    return np.diff(inside)


def faster_than_the_grid(
    time_ns: IntArray, grid_ns: IntArray, dt_ns: int, kind: str
) -> dict[str, Any] | None:
    """``{kind, samples, points}`` of a series with more samples than the grid has points.

    The grid takes one sample per point (SPEC §5: the hold for an input, the nearest within
    half a step for an output; ``--resample linear`` two around it), so of a series sampled
    faster than ``dt`` at least ``samples - points`` of those within half a step of the
    grid's span are not used: a 10 Hz log analysed with a model of ``dt = 1 s`` uses 1 in 10,
    which said nothing.
    """
    half = dt_ns // 2
    first, last = np.searchsorted(time_ns, [grid_ns[0] - half, grid_ns[-1] + half], "right")
    samples = int(last - first)
    if samples <= grid_ns.size:
        return None
    return {"kind": kind, "samples": samples, "points": int(grid_ns.size)}


def skipped_by_the_hold(index: IntArray, kind: str) -> dict[str, Any] | None:
    """``{kind, samples, unused}`` of a held series some of whose samples no grid point takes.

    ``index``: the sample each grid point takes (nondecreasing, none before the first).  A
    series with no more samples than the grid has points (else :func:`faster_than_the_grid`
    says it) can still lose samples to the hold: two within one step, of which the point
    after them takes the later.  An input recorded once per step by a clock that jitters by
    more than ``dt/4`` (beyond :func:`~hybridlog.io.resampling.jittered_index`) loses a sample
    wherever a late one follows an early one, and the point before takes the sample before its own,
    a step late; a command published when it changes loses a change undone within a step.  Both
    were silent: the series had as many samples as the grid points.  ``samples``: the
    series' samples from the first point's to the last's; ``unused``: those no point takes.
    """
    if index.size == 0:
        return None
    samples = int(index[-1] - index[0]) + 1
    unused = samples - 1 - int(np.count_nonzero(np.diff(index)))
    if unused <= 0:
        return None
    return {"kind": kind, "samples": samples, "unused": unused}


def longest_hold(
    time_ns: IntArray, grid_ns: IntArray, dt_ns: int, max_gap_ns: int
) -> dict[str, float] | None:
    """The longest stretch of the grid over which the hold carries an input, if over ``max_gap``.

    Inputs are held (SPEC §5: a command published only when it changes is held so), across
    a gap between two samples or past the last one to the grid's end; a hold longer than
    ``max_gap`` is recorded, ``{start, end, seconds, holds}`` (seconds; ``holds``: how many
    such holds there are, the longest named), for the report to say, not refused: an input
    sampled every ``10*dt`` read "no sample from t = 290 to 300 s", as if it had one gap.
    ``None`` when every hold is shorter.  ``time_ns``: the signal's sample times.
    """
    if grid_ns.size == 0 or time_ns.size == 0:
        return None
    first, last = int(grid_ns[0]), int(grid_ns[-1])
    starts, ends = time_ns[:-1], time_ns[1:]
    threshold = gap_threshold(max_gap_ns, dt_ns)  # a sample held for one step is no hold
    steps = ends - starts
    candidates: list[tuple[int, int, int]] = []
    if steps.size and longer_than_max_gap(int(steps.max()), threshold, dt_ns):  # else none is
        long = longer_than_max_gap(steps, threshold, dt_ns) & (ends > first) & (starts < last)
        pairs = zip(starts[long], ends[long], strict=True)
        candidates = [(int(b - a), int(a), int(b)) for a, b in pairs]
    if last > int(time_ns[-1]) and longer_than_max_gap(last - int(time_ns[-1]), threshold, dt_ns):
        candidates.append((last - int(time_ns[-1]), int(time_ns[-1]), last))
    if not candidates:
        return None
    _, start, end = max(candidates)  # the longest; of equal ones the latest
    return {
        "start": start / NS_PER_S,
        "end": end / NS_PER_S,
        "seconds": seconds_between(start, end),
        "holds": len(candidates),
    }


def seconds_between(start_ns: int, end_ns: int) -> float:
    """``end - start`` in seconds, to the digits the two times hold as float seconds.

    The times were float seconds (most logs), good at 1.7e9 s to 238 ns: a 0.51 s hold read
    0.509999762 in report.json (:func:`~hybridlog.times.round_duration`).
    """
    start, end = start_ns / NS_PER_S, end_ns / NS_PER_S
    return round_duration((end_ns - start_ns) / NS_PER_S, start, end)


def record_span_bounds(
    inputs: Mapping[str, Series],
    outputs: Mapping[str, Series],
    commands: Mapping[str, Series],
    field_word: str,
    dt_ns: int,
    max_gap_ns: int,
    notes: dict[str, Any],
) -> None:
    """Record the signal that starts the grid late or ends it early, by more than ``max_gap``.

    The grid runs from the latest first sample of the inputs and outputs to the earliest last
    sample of the outputs: one output ending at 10 s of a 100 s log leaves 90 s unanalysed,
    which the report's span alone does not say.  ``notes["span"]`` gets ``{"start"|"end":
    {signal, at, log, left_out}}`` (seconds; ``log`` is where the other signals begin or end).
    """
    named = [
        (f"{kind} {symbol!r} ({field_word} {series.name!r})", series)
        for kind, group in (("input", inputs), ("command", commands), ("output", outputs))
        for symbol, series in group.items()
    ]
    if not named:
        return
    held = len(inputs) + len(commands)
    bounding = named[held:] or named  # the outputs end the grid (the held signals, if none)
    first = min(int(series.time_ns[0]) for _, series in named)
    last = max(int(series.time_ns[-1]) for _, series in named)
    start_by, start = max(((n, int(s.time_ns[0])) for n, s in named), key=lambda p: p[1])
    end_by, end = min(((n, int(s.time_ns[-1])) for n, s in bounding), key=lambda p: p[1])
    span: dict[str, dict[str, Any]] = {}
    for side, by, at, log in (("start", start_by, start, first), ("end", end_by, end, last)):
        if longer_than_max_gap(abs(at - log), max_gap_ns, dt_ns):
            span[side] = {
                "signal": by,
                "at": at / NS_PER_S,
                "log": log / NS_PER_S,
                "left_out": seconds_between(min(at, log), max(at, log)),
            }
    if span:
        notes["span"] = span
