"""The model's grid ``t0 + k*dt`` in nanoseconds, and what counts as on it (SPEC §5).

Where the grid starts and ends (:func:`t0_and_last`, :func:`span_end`): at the latest first
sample, or on the clock the inputs and commands share (:func:`held_clock`, exact or
jittering); its points counted without rounding ``dt`` once (:func:`grid_between`).  And the
clock tolerance every reading of the grid shares (:func:`clock_tolerance_ns`): a sample that
close to a point is at it, a gap longer than ``max_gap`` or a distance beyond ``dt/2`` only
beyond it (:func:`longer_than_max_gap`, :func:`past_half_step`).  The rules are
:mod:`hybridlog.io.align`'s.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from fractions import Fraction
from typing import Any, NamedTuple

import numpy as np

from hybridlog.errors import LogError, OptionError
from hybridlog.io.source import NS_PER_S, LabelSeries, Series, format_ns
from hybridlog.signals import LONGEST_DT_S, SHORTEST_DT_S, IntArray


class SignalsApartError(LogError):
    """The signals a grid needs do not overlap in time.

    :func:`hybridlog.io.load.load_signals` says why where header stamps of clocks that
    disagree put them apart.
    """


def clock_tolerance_ns(dt_ns: int) -> int:
    """How far (ns) a sample may sit from a grid point and still count as at it."""
    return max(min(max(dt_ns // 1000, 1000), dt_ns // 4), 0)


def longer_than_max_gap(span_ns: Any, max_gap_ns: int, dt_ns: int) -> Any:
    """Whether a time span between two samples (ns; a number or an array) exceeds ``max_gap``.

    By more than :func:`clock_tolerance_ns`: both ends carry the rounding of the log's
    clock, so a gap of exactly ``max_gap`` measures up to a few hundred nanoseconds longer
    at Unix-epoch times, and would be refused or not depending on where in the log it lies.
    """
    return span_ns > max_gap_ns + clock_tolerance_ns(dt_ns)


def past_half_step(distance_ns: Any, dt_ns: int) -> Any:
    """Whether a distance (ns; a number or an array) from a grid point is more than ``dt/2``.

    By more than :func:`clock_tolerance_ns`, as a gap is longer than ``max_gap``: an output
    sampled half a step off the grid (ties, which go to the earlier sample) is at ``dt/2``
    of every grid point, and at Unix-epoch times the rounding of float seconds put a few
    hundred nanoseconds on either side.  The points it put beyond were warned of as bridged
    (0 to 23 of 29, and a grid one point shorter, by where in the epoch the log lay).
    """
    return 2 * distance_ns > dt_ns + 2 * clock_tolerance_ns(dt_ns)


def step_ns(dt: float) -> int:
    """``dt`` in whole nanoseconds, after checking it is a usable sample time.

    Raises
    ------
    OptionError
        When ``dt`` is not finite, or outside ``[SHORTEST_DT_S, LONGEST_DT_S]``.
    """
    if not (np.isfinite(dt) and SHORTEST_DT_S <= dt <= LONGEST_DT_S):
        raise OptionError(
            f"dt: the sample time must be between {SHORTEST_DT_S:g} s and {LONGEST_DT_S:g} s, "
            f"got {dt:g}"
        )
    return round(dt * NS_PER_S)


def span_end(dt_ns: int, t_last: int, bounded_by_ends: bool) -> int:
    """The last time (ns) a grid point may reach.

    ``t_last`` is the earliest last sample of the series bounding the end: half a step past
    it when outputs bound the end, else itself.
    """
    return t_last + (dt_ns // 2 + clock_tolerance_ns(dt_ns) if bounded_by_ends else 0)


def _from_tick(time_ns: IntArray, tick_ns: int, dt_ns: int) -> IntArray:
    """Each sample's signed offset (ns) from the nearest tick ``tick_ns + k*dt``."""
    half = dt_ns // 2
    offset: IntArray = time_ns - tick_ns  # one array, worked in place
    offset += half
    offset %= dt_ns
    offset -= half
    return offset


def on_whole_ns(held: Sequence[Series], dt: float) -> Sequence[Series]:
    """The held series whose clock can set the grid: all where ``dt`` is whole nanoseconds.

    Elsewhere a clock's ticks ``k*dt`` are not counted exactly, and none is given:
    :func:`_grid_start` then keeps the latest first sample.
    """
    return held if dt * NS_PER_S == step_ns(dt) else ()


class Clock(NamedTuple):
    """The clock the held signals share (:func:`held_clock`).

    ``tick``: one of its ticks (ns); ``reach``: how far (ns) a held sample may lie from
    its grid point and still be the point's own: the clock tolerance on an exact clock (the
    hold takes it), ``dt/4`` on a jittering one (:func:`~hybridlog.io.resampling.jittered_index`
    takes it).
    """

    tick: int
    reach: int


def held_clock(held: Sequence[Series], dt_ns: int) -> Clock | None:
    """The clock the held signals (inputs, commands) share, else ``None``.

    An exact clock: every sample within the clock tolerance of a tick ``t + k*dt``, ``t``
    their first one's first sample (dropped samples, or a multiple of ``dt``, allowed); the
    zero-order hold takes each tick's sample only at or after the tick.  Else a jittering
    one (:func:`_jittering_clock`), whose samples :func:`~hybridlog.io.resampling.jittered_index`
    gives their own grid points.  ``None`` for signals at times of their own (published when they
    change) or at another rate.
    """
    if not held:
        return None
    tick = int(held[0].time_ns[0])
    tolerance = clock_tolerance_ns(dt_ns)
    if any(int(np.abs(_from_tick(s.time_ns, tick, dt_ns)).max()) > tolerance for s in held):
        return _jittering_clock(held, dt_ns)
    return Clock(tick, tolerance)


def _jittering_clock(held: Sequence[Series], dt_ns: int) -> Clock | None:
    """The phase of held signals each recorded once per step around it, else ``None``.

    The phase is the median of their samples' offsets modulo ``dt`` (taken from the first
    sample, none more than ``dt/2`` from it once all are within ``dt/4`` of the phase: the
    circular median), or else the middle of their spread: a clock jittering uniformly by
    0.24 ``dt`` either way had its median 0.02 ``dt`` off the middle, samples beyond
    ``dt/4`` of it, and the hold took 105 of 500 a step late.  Each series must be sampled
    around it (:func:`_ticks_once`), every sample within ``dt/4`` of a tick, at most one at a
    tick, most one tick after the one before: what
    :func:`~hybridlog.io.resampling.jittered_index` takes as a jittering clock (a series
    every other step is not). Each topic of a log published once per step with its own
    jitter of 20 % of ``dt`` gave the grid the latest first message, 0.106 s after a tick
    with ``dt = 1 s``: input samples lay up to 0.306 s from their point, beyond ``dt/4``, and
    the hold took 57 of 300 a step late.
    """
    quarter = max(clock_tolerance_ns(dt_ns), dt_ns // 4)
    first = int(held[0].time_ns[0])
    offsets = np.concatenate([_from_tick(s.time_ns, first, dt_ns) for s in held])
    median = first + round(float(np.median(offsets)))
    # the middle of their spread: the phase nearest to the farthest sample, where the median
    # of samples jittering up to dt/4 either way lay off the middle and put some beyond dt/4
    middle = first + (int(offsets.min()) + int(offsets.max())) // 2
    for tick in dict.fromkeys((median, middle)):
        if all(_ticks_once(series, tick, dt_ns, quarter) for series in held):
            return Clock(tick, quarter)
    return None


def _ticks_once(series: Series, tick: int, dt_ns: int, quarter: int) -> bool:
    """Whether ``series`` has a sample within ``quarter`` of ticks ``tick + k*dt``, once each.

    At most one at a tick, most one tick after the one before, and sampled around them
    (:func:`sampled_around`): a series every other step is not.
    """
    offset = _from_tick(series.time_ns, tick, dt_ns)
    steps = np.diff((series.time_ns - offset - tick) // dt_ns)
    once = bool((steps > 0).all()) and 2 * int(np.count_nonzero(steps == 1)) > steps.size
    return once and int(np.abs(offset).max()) <= quarter and sampled_around(series, tick, dt_ns)


def sampled_around(series: Series | LabelSeries, tick_ns: int, dt_ns: int) -> bool:
    """Whether ``series`` is sampled around the ticks ``tick_ns + k*dt``.

    Its median distance from them is at most ``dt/8``: a clock jittering within ``dt/4``;
    samples at times of their own lie ``dt/4`` away, a clock half a step off ``dt/2``.
    """
    distance = np.abs(_from_tick(series.time_ns, tick_ns, dt_ns))
    return float(np.median(distance)) <= dt_ns / 8


def _grid_start(start_ns: int, starts: Sequence[Series], held: Sequence[Series], dt_ns: int) -> int:
    """``t0`` on the held signals' clock, else ``start_ns``, the latest first sample.

    ``start_ns`` when its grid already gives every held sample a point within the clock's
    reach (:func:`held_clock`): on an exact clock, when it is on it; on a jittering one,
    when :func:`~hybridlog.io.resampling.jittered_index` takes each sample (a latency, all late,
    keeps the hold's one-step delay, SPEC §5).  Else, when the others are sampled around the clock
    (:func:`sampled_around`), its first tick where every held series has a sample within its reach
    or before it (as the hold or :func:`~hybridlog.io.resampling.jittered_index` reads it) and every
    other one a sample within ``dt/2`` (as the nearest sample is taken); ``start_ns`` itself when
    that tick is within the clock tolerance of it, to the nanosecond.
    """
    clock = held_clock(held, dt_ns)
    if clock is None or (start_ns - clock.tick) % dt_ns == 0:
        # no clock, or the start is one of its ticks: every held sample's offset from the
        # start's grid is its offset from the clock's ticks, which held_clock found within
        # the clock's reach (a second pass over them took as long as held_clock's)
        return start_ns
    if all(int(np.abs(_from_tick(s.time_ns, start_ns, dt_ns)).max()) <= clock.reach for s in held):
        return start_ns  # the start is on the clock: no output's median is needed
    others = [s for s in starts if all(s is not h for h in held)]
    if not all(sampled_around(s, clock.tick, dt_ns) for s in others):
        return start_ns
    tolerance = clock_tolerance_ns(dt_ns)
    half = dt_ns // 2 + tolerance  # within dt/2: past_half_step
    earliest = max(
        int(s.time_ns[0]) - (half if any(s is o for o in others) else clock.reach) for s in starts
    )
    t0 = earliest + (clock.tick - earliest) % dt_ns
    return start_ns if abs(t0 - start_ns) <= tolerance else t0


def t0_and_last(
    starts: Sequence[Series],
    ends: Sequence[Series],
    source: str,
    dt_ns: int,
    held: Sequence[Series],
) -> tuple[int, int]:
    """``t0`` and the earliest last sample of the series that bound the grid's end (ns).

    ``t0`` is on the clock of the ``held`` series, if they have one (:func:`_grid_start`).
    """
    for series in (*starts, *ends):
        if series.time_ns.size == 0:
            raise LogError(f"{source}: {series.name!r} has no samples")
    if not starts:
        raise LogError(f"{source}: no input or output signal to align")
    first = max(starts, key=lambda s: int(s.time_ns[0]))
    t0 = int(first.time_ns[0])
    last = min(ends or starts, key=lambda s: int(s.time_ns[-1]))
    t_last = int(last.time_ns[-1])
    if t_last < t0:
        raise SignalsApartError(
            f"{source}: signals do not overlap in time ({first.name!r} starts at "
            f"t={format_ns(t0)} s, {last.name!r} ends at t={format_ns(t_last)} s)"
        )
    on_clock = _grid_start(t0, starts, held, dt_ns)
    return (on_clock if on_clock <= t_last else t0), t_last


def grid_between(dt: float, t0: int, t_last: int, bounded_by_ends: bool) -> IntArray:
    """The grid ``t0 + k*dt`` (ns), its first and last times known (:func:`t0_and_last`).

    ``t_last``: the earliest last sample of the series bounding the end, outputs when
    ``bounded_by_ends`` (:func:`_last_grid_index`).
    """
    step = dt * NS_PER_S
    n = _last_grid_index(dt, t_last - t0, bounded_by_ends) + 1
    # Built in place: one array, the same values as t0 + offsets.
    if step == round(step):  # whole nanoseconds: exact integer steps, and faster
        grid: IntArray = np.arange(n, dtype=np.int64)
        grid *= round(step)
    else:
        scaled = np.arange(n, dtype=np.float64)
        scaled *= step
        np.rint(scaled, out=scaled)
        grid = scaled.astype(np.int64)
        del scaled
    grid += t0
    return grid


def _last_grid_index(dt: float, span_ns: int, bounded_by_ends: bool) -> int:
    """The largest ``k`` whose time ``k*dt`` is within the log's span.

    ``span_ns`` runs from ``t0`` to the earliest last sample of the bounding series. Outputs may
    end half a step (:func:`past_half_step`) before the last grid point; inputs alone end it at
    their last sample, known to the nanosecond (half a nanosecond of rounding). A step of whole
    nanoseconds is counted exactly in integers. Otherwise the bound is exact with ``dt`` as the
    decimal it prints as, not rounded to nanoseconds (2 ns for 1.5e-9 s let a 12th grid point,
    at 16.5 ns, count as within half a step of the 11th sample, at 15 ns), and a trillionth of
    the span more absorbs a ``dt`` computed in floating point (``243 * 1e-10`` s prints as
    2.4300000000000002e-08), whose last sample, rounded down by half a nanosecond, lost its grid
    point.
    """
    step = dt * NS_PER_S
    if step == round(step):
        whole = round(step)
        half = whole // 2 + clock_tolerance_ns(whole)  # within dt/2: past_half_step
        return (span_ns + (half if bounded_by_ends else 0)) // whole
    exact = Fraction(str(float(dt))) * NS_PER_S
    tolerance = clock_tolerance_ns(round(step))
    reach = span_ns + (exact / 2 + tolerance if bounded_by_ends else Fraction(1, 2))
    return max(math.floor(reach * (1 + Fraction(1, 10**12)) / exact), 0)
