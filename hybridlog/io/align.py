"""Alignment of sample series onto the model's grid ``t0 + k*dt`` (SPEC §5).

Format-independent: works on :class:`~hybridlog.io.source.Series` in integer nanoseconds.

- The grid starts at ``t0``, the first instant where every input and output has a value (the
  latest first sample among them), and ends at the last grid point where every output still
  has a sample within half a step.  When the inputs and commands share one clock (every
  sample within the clock tolerance of a tick, :func:`held_clock`) and every output is
  sampled around its ticks (median distance at most ``dt/8``), the grid is on that clock:
  ``t0`` is its first tick where every held signal has a sample at or before it and every
  output one within half a step.  The latest first sample could be a jittered output
  message that came early (56 ms of 1 s): the grid then sat just before the ticks, and the
  held inputs and true mode came out one step behind the outputs.  A log on one clock keeps
  ``t0`` to the nanosecond; outputs on a clock of their own (half a step off) keep theirs.
  Held signals each recorded once per step around a common phase (a jittering clock, every
  sample within ``dt/4`` of it) put ``t0`` on that phase, the first tick where every held
  signal has a sample within ``dt/4`` and every output one within half a step, unless the
  latest first sample's grid already gives every held sample a point within ``dt/4``: topics
  each jittering by 20 % of ``dt`` started the grid at the latest first message, 0.106 s
  after a tick, and the hold took 57 of 300 input samples a step late (below).
  ``t_k = t0 + round(k * dt)`` in nanoseconds, so ``dt`` is not rounded once and the error
  multiplied by ``k``.
- Inputs: zero-order hold, the last sample at or before ``t_k``; but a series recorded once
  per step on a jittering clock (every sample within ``dt/4`` of a grid point of its own,
  more than half the points with one, some late, some not) takes each point's own sample,
  where the hold would delay about half of them by a step at random (:func:`jittered_index`,
  ``notes["jitter"]``); a point whose sample was dropped holds the one before, counted
  (``notes["jitter_held"]``).  The true mode likewise, but a sampled one's point whose sample
  was dropped has none (below).  Samples no grid point takes
  (another followed within the step) are counted, ``notes["skipped"]``.  Commands (of a
  ``[components]`` model) are held as inputs are.
- Outputs: the nearest sample, if it is within ``dt/2`` (``resample="nearest"``; ties go to
  the earlier sample), or linear interpolation between the samples around ``t_k``
  (``resample="linear"``).  A grid point without a sample within ``dt/2`` is a gap; a gap
  between two samples more than ``max_gap`` apart is an error, shorter gaps are bridged by the
  same rule (nearest or linear) from the samples around them; no line is drawn across a
  longer one (:func:`_nearest_beside_gaps`): the points within ``dt/2`` of its ends take
  those samples, as the points past a series' last sample take the last.  A sample half a
  step between two grid points is within ``dt/2`` of both; when both take it (no other sample
  beside it: a log sampled every ``1.5*dt``), the later point is bridged, for the log
  measured once (:func:`_taken_twice`).
- True mode: zero-order hold; grid points before its first sample take that sample if it is
  within ``dt/2``, and have no true mode (``NO_TRUE_MODE``, not scored) if not: a true mode
  that starts late is scored over the samples from its first on, as a true state that starts
  late is (``notes["truth_starts"]``).  A true mode recorded only at its switches (no sample
  repeats the label of the one before, :func:`records_switches`) is held however long it
  is silent: its silence says the mode did not change (``notes["truth_held"]``).  One that
  repeats its label is *sampled*: its silence says nothing, and a stretch without a sample
  longer than ``dt`` (a gap of any length, bridged or not: the hold of an output's short gap
  is not the truth's; or past its last sample, to the grid's end) may hide a switch; its
  grid points more than ``dt/2`` from every sample have no true mode (those within ``dt/2``
  of the sample after take it, the nearer one, as before the first), are not scored, and
  are recorded (``notes["truth_gaps"]``, :func:`_blank_gaps`), as a true state's bridged
  points are left out of its RMSE.  A jittered true mode's dropped samples likewise.  A
  sampled true mode around the grid's points (median distance at most ``dt/8``,
  :func:`_around`, as the grid's start reads the outputs) gives each point its nearest
  sample, as the outputs and true states are read: logged in their rows 10 ms after the
  inputs' ticks (the grid on the ticks), the hold took each point the row before's mode,
  a step behind the outputs and states of its own row.
- True states: like outputs, but NaN instead of an error where no sample is usable.
- The signal that starts the grid more than ``max_gap`` after the log's first input or output
  sample, or ends it that long before the last one, is recorded (``notes["span"]``): the
  report's span alone would not say that part of the log was left out.
- ``split_gaps``: instead of refusing a log with an output gap longer than ``max_gap``, cut it
  at every such gap and align the longest piece (the earliest of equally long ones): at the
  gaps the piece's grid refuses, and only there (:func:`_split_at_refused_gaps`); a sample
  alone between two gaps is a piece of its own.  Each output keeps its samples inside the
  piece and the one beside it on either side that no cut separates (:func:`_piece_of`):
  the piece's grid reads them as the whole log's would.  The
  estimators need one continuous grid, and a filter carried across a gap would start the next
  piece from a stale state; analysing each piece separately would need one report per piece.
  The pieces and the one analysed are recorded (``notes["segments"]``,
  ``notes["analysed_segment"]``, ``notes["analysed"]``) and end up in ``report.json``: the
  first :data:`~hybridlog.io.summary.MAX_LISTED_GAPS` pieces and gaps in time order, as
  ``inspect`` lists gaps, each list with its count and whether it was cut
  (``segment_count``, ``segments_truncated``, ``gap_count``, ``gaps_truncated``): a log cut
  into 20,000 pieces had them all listed, 2 MB of report.json, in every report of a batch.

A sample up to ``dt/1000`` (at least 1 µs, at most ``dt/4``) away from a grid point counts as
*at* it: float seconds at Unix-epoch magnitudes carry ~0.2 µs of rounding, and a log sampled
at ``dt`` must come out unchanged.  For the same reason a gap is longer than ``max_gap`` only
when it exceeds it by more than that tolerance (:func:`longer_than_max_gap`): a gap of exactly
``5*dt`` is accepted whether the log's clock starts at 0 or at 1.7e9 s.  And a sample is
more than ``dt/2`` from a grid point only beyond that tolerance (:func:`past_half_step`): an
output sampled half a step off the grid is within ``dt/2`` of every point wherever it lies.
With that, a log already on the grid is reproduced bit for bit: every value is one of the
log's samples, never recomputed.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from fractions import Fraction
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt

from hybridlog.errors import LogError, OptionError
from hybridlog.io.options import Resample, check_max_gap, check_resample
from hybridlog.io.source import BLOCK, NS_PER_S, LabelSeries, Series, format_ns, ns_to_seconds
from hybridlog.io.summary import MAX_LISTED_GAPS
from hybridlog.signals import (
    LONGEST_DT_S,
    NO_TRUE_MODE,
    SHORTEST_DT_S,
    AlignedSignals,
    ComponentTruth,
    FloatArray,
    IntArray,
    covered_from,
)
from hybridlog.times import round_duration

DEFAULT_MAX_GAP_STEPS = 5


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


def grid_span(
    dt_ns: int,
    starts: Sequence[Series],
    ends: Sequence[Series],
    *,
    held: Sequence[Series] = (),
    source: str = "log",
) -> tuple[int, int]:
    """First and last time (ns) the grid of :func:`make_grid` may reach: ``t0`` and ``t_end``.

    Raises
    ------
    LogError
        When the series do not overlap or one of them is empty.
    """
    t0, t_last = _first_and_last(starts, ends, source, dt_ns, held)
    return t0, _span_end(dt_ns, t_last, bool(ends))


def _span_end(dt_ns: int, t_last: int, bounded_by_ends: bool) -> int:
    """The last time (ns) a grid point may reach (:func:`grid_span`).

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
    hold takes it), ``dt/4`` on a jittering one (:func:`jittered_index` takes it).
    """

    tick: int
    reach: int


def held_clock(held: Sequence[Series], dt_ns: int) -> Clock | None:
    """The clock the held signals (inputs, commands) share, else ``None``.

    An exact clock: every sample within the clock tolerance of a tick ``t + k*dt``, ``t``
    their first one's first sample (dropped samples, or a multiple of ``dt``, allowed); the
    zero-order hold takes each tick's sample only at or after the tick.  Else a jittering
    one (:func:`_jittering_clock`), whose samples :func:`jittered_index` gives their own
    grid points.  ``None`` for signals at times of their own (published when they change)
    or at another rate.
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
    circular median).  Each series must be sampled around it (:func:`_around`), every sample
    within ``dt/4`` of a tick, at most one at a tick, most one tick after the one before: what
    :func:`jittered_index` takes as a jittering clock (a series every other step is not).
    Each topic of a log published once per step with its own jitter of 20 % of ``dt`` gave
    the grid the latest first message, 0.106 s after a tick with ``dt = 1 s``: input samples
    lay up to 0.306 s from their point, beyond ``dt/4``, and the hold took 57 of 300 a step
    late.
    """
    quarter = max(clock_tolerance_ns(dt_ns), dt_ns // 4)
    first = int(held[0].time_ns[0])
    offsets = np.concatenate([_from_tick(s.time_ns, first, dt_ns) for s in held])
    tick = first + round(float(np.median(offsets)))
    for series in held:
        offset = _from_tick(series.time_ns, tick, dt_ns)
        steps = np.diff((series.time_ns - offset - tick) // dt_ns)
        once = bool((steps > 0).all()) and 2 * int(np.count_nonzero(steps == 1)) > steps.size
        if not (once and int(np.abs(offset).max()) <= quarter and _around(series, tick, dt_ns)):
            return None
    return Clock(tick, quarter)


def _around(series: Series | LabelSeries, tick_ns: int, dt_ns: int) -> bool:
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
    when :func:`jittered_index` takes each sample (a latency, all late, keeps the hold's
    one-step delay, SPEC §5).  Else, when the others are sampled around the clock
    (:func:`_around`), its first tick where every held series has a sample within its reach
    or before it (as the hold or :func:`jittered_index` reads it) and every other one a
    sample within ``dt/2`` (as the nearest sample is taken); ``start_ns`` itself when that
    tick is within the clock tolerance of it, to the nanosecond.
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
    if not all(_around(s, clock.tick, dt_ns) for s in others):
        return start_ns
    tolerance = clock_tolerance_ns(dt_ns)
    half = dt_ns // 2 + tolerance  # within dt/2: past_half_step
    earliest = max(
        int(s.time_ns[0]) - (half if any(s is o for o in others) else clock.reach) for s in starts
    )
    t0 = earliest + (clock.tick - earliest) % dt_ns
    return start_ns if abs(t0 - start_ns) <= tolerance else t0


def _first_and_last(
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


def make_grid(
    dt: float,
    starts: Sequence[Series],
    ends: Sequence[Series],
    *,
    held: Sequence[Series] = (),
    source: str = "log",
) -> IntArray:
    """The grid ``t0 + k*dt`` in nanoseconds.

    Parameters
    ----------
    dt:
        Sample time in seconds.
    starts:
        Series that must all have begun at ``t0`` (inputs and outputs).
    ends:
        Series that bound the end (outputs; the inputs when there are no outputs): the last
        grid point is at most ``dt/2`` after the earliest last sample among them.
    held:
        The series among ``starts`` that are held (inputs, commands): ``t0`` is on their
        clock, if they have one and ``dt`` is whole nanoseconds (:func:`_grid_start`).
    source:
        The log's path, for messages.

    Raises
    ------
    LogError
        When the series do not overlap or one of them is empty.
    """
    dt_ns = step_ns(dt)
    t0, t_last = _first_and_last(starts, ends, source, dt_ns, on_whole_ns(held, dt))
    return grid_between(dt, t0, t_last, bool(ends))


def grid_between(dt: float, t0: int, t_last: int, bounded_by_ends: bool) -> IntArray:
    """The grid ``t0 + k*dt`` (ns) of :func:`make_grid`, its first and last times known.

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


def on_grid(time_ns: IntArray, grid_ns: IntArray, tolerance_ns: int) -> int:
    """Where a series sampled exactly on the grid starts, else -1.

    Returns ``i0`` when ``time_ns[i0 : i0 + len(grid_ns)]`` is within ``tolerance_ns`` of the
    grid point by point -- the common case of a log recorded at the model's rate, for which
    every grid point's sample is known without searching.
    """
    n = grid_ns.size
    if n == 0:
        return -1
    start = int(np.searchsorted(time_ns, grid_ns[0] - tolerance_ns, side="left"))
    if start + n > time_ns.size:
        return -1
    for lo in range(0, n, BLOCK):  # a block's offsets at a time, not N of them
        offset = time_ns[start + lo : start + min(lo + BLOCK, n)] - grid_ns[lo : lo + BLOCK]
        if int(offset.max()) > tolerance_ns or int(offset.min()) < -tolerance_ns:
            return -1
    return start


def on_grid_values(series: Series, grid_ns: IntArray, tolerance_ns: int) -> FloatArray | None:
    """The series' values at the grid points when it is sampled on the grid, else ``None``.

    A view of ``series.values`` (no copy, no index array): on the grid, the zero-order hold,
    the nearest sample and the linear interpolation all take the sample at each grid point
    (the one within ``tolerance_ns``), and no grid point is in a gap.
    """
    start = on_grid(series.time_ns, grid_ns, tolerance_ns)
    if start < 0:
        return None
    values: FloatArray = series.values[start : start + grid_ns.size]
    return values


def hold_index(time_ns: IntArray, grid_ns: IntArray, tolerance_ns: int) -> IntArray:
    """Index of the last sample at or before each grid point (-1 where there is none)."""
    start = on_grid(time_ns, grid_ns, tolerance_ns)
    if start >= 0:
        return np.arange(start, start + grid_ns.size, dtype=np.int64)
    index: IntArray = np.searchsorted(time_ns, grid_ns + tolerance_ns, side="right") - 1
    return index


class Jittered(NamedTuple):
    """A series recorded once per step on a jittering clock, taken on the grid.

    ``taken``: the index of the sample each grid point takes (its own, else the hold's);
    ``jitter``: the largest distance (s) of a sample from its grid point; ``held``: the grid
    points without a sample of their own, which hold the one before.
    """

    taken: IntArray
    jitter: float
    held: int


def jittered_index(
    time_ns: IntArray, grid_ns: IntArray, tolerance_ns: int, dt_ns: int
) -> Jittered | None:
    """The samples a series recorded once per step on a jittering clock gives the grid, else None.

    A series whose samples each lie within ``dt/4`` of a grid point of their own (at most one
    per point), covering more than half the grid's points, some after their point by more
    than ``tolerance_ns`` and some not, was recorded at the model's rate by a clock that
    jitters.  The zero-order hold would take each grid point's own sample where it came early
    and the one before where it came late: a random one-step delay on about half the samples,
    which no estimate could tell from the plant.  Such a series gives each grid point its own
    sample (``notes["jitter"]``, said in the report); a point whose sample the log dropped
    holds the one before, as the hold would (``Jittered.held``, ``notes["jitter_held"]``): one
    dropped sample no longer sends the whole series back to the hold's random delays.  A
    series whose samples all come late (a constant latency) keeps the hold's consistent
    one-step delay, as SPEC §5 says; one on the grid within ``tolerance_ns`` never gets here;
    one published only when it changes, at its own times, is held.  The first grid point's
    sample is not counted among the late or on-time ones: the grid may start at it.
    """
    n = grid_ns.size
    quarter = max(tolerance_ns, dt_ns // 4)
    if n == 0 or time_ns.size == 0:
        return None
    start = on_grid(time_ns, grid_ns, quarter)
    if start >= 0:  # no sample dropped: checked a block at a time, no search
        return _jittered_on_grid(time_ns, grid_ns, tolerance_ns, start)
    lo = int(np.searchsorted(time_ns, grid_ns[0] - quarter, side="left"))
    hi = int(np.searchsorted(time_ns, grid_ns[-1] + quarter, side="right"))
    if not n < 2 * (hi - lo) <= 2 * n:  # not once per step: slower, at its own times, or faster
        return None
    inner = time_ns[lo:hi]
    right = np.minimum(np.searchsorted(grid_ns, inner, side="left"), n - 1)
    left = np.maximum(right - 1, 0)
    owner = np.where(np.abs(inner - grid_ns[left]) < np.abs(grid_ns[right] - inner), left, right)
    offset = inner - grid_ns[owner]
    if int(np.abs(offset).max()) > quarter or bool((np.diff(owner) <= 0).any()):
        return None  # a sample between grid points, or two at one point
    counted = offset[owner > 0]  # the grid may start at the first sample
    if not (bool((counted > tolerance_ns).any()) and bool((counted <= tolerance_ns).any())):
        return None
    index = hold_index(time_ns, grid_ns, tolerance_ns)
    index[owner] = np.arange(lo, hi, dtype=np.int64)
    return Jittered(index, int(np.abs(offset).max()) / NS_PER_S, int(n - inner.size))


def _jittered_on_grid(
    time_ns: IntArray, grid_ns: IntArray, tolerance_ns: int, start: int
) -> Jittered | None:
    """:func:`jittered_index` of a series with one sample within ``dt/4`` of every grid point."""
    late = on_time = False
    worst = 0
    n = grid_ns.size
    for lo in range(0, n, BLOCK):
        offset = time_ns[start + lo : start + min(lo + BLOCK, n)] - grid_ns[lo : lo + BLOCK]
        worst = max(worst, int(np.abs(offset).max()))
        counted = offset[1:] if lo == 0 else offset  # the grid may start at the first sample
        late = late or bool((counted > tolerance_ns).any())
        on_time = on_time or bool((counted <= tolerance_ns).any())
    if not (late and on_time):
        return None
    return Jittered(np.arange(start, start + n, dtype=np.int64), worst / NS_PER_S, 0)


def nearest_index(
    time_ns: IntArray, grid_ns: IntArray, tolerance_ns: int
) -> tuple[IntArray, IntArray]:
    """Index of and distance to the nearest sample of every grid point.

    The later sample wins only when it is closer by more than ``tolerance_ns``, so exact
    ties (and ties blurred by timestamp rounding) go to the earlier sample.
    """
    start = on_grid(time_ns, grid_ns, tolerance_ns)
    if start >= 0:
        index_on: IntArray = np.arange(start, start + grid_ns.size, dtype=np.int64)
        distance_on: IntArray = np.abs(time_ns[start : start + grid_ns.size] - grid_ns)
        return index_on, distance_on
    n = time_ns.size
    right = np.searchsorted(time_ns, grid_ns, side="left")
    left = right - 1
    right_c = np.minimum(right, n - 1)
    left_c = np.maximum(left, 0)
    far = np.iinfo(np.int64).max
    d_left = np.where(left >= 0, grid_ns - time_ns[left_c], far)
    d_right = np.where(right < n, time_ns[right_c] - grid_ns, far)
    use_right = (d_right < d_left) & (d_left - d_right > tolerance_ns)
    index: IntArray = np.where(use_right, right_c, left_c)
    distance: IntArray = np.where(use_right, d_right, d_left)
    return index, distance


def interpolate(series: Series, grid_ns: IntArray, tolerance_ns: int) -> FloatArray:
    """Linear interpolation of ``series`` at the grid points.

    Grid points within ``tolerance_ns`` of a sample take that sample's value exactly;
    points outside the series' span take the nearest end value.
    """
    time_ns, values = series.time_ns, series.values
    n = time_ns.size
    nearest, distance = nearest_index(time_ns, grid_ns, tolerance_ns)
    if n == 1:
        return values[nearest]
    lo = np.clip(np.searchsorted(time_ns, grid_ns, side="right") - 1, 0, n - 2)
    hi = lo + 1
    weight = (grid_ns - time_ns[lo]).astype(np.float64) / (time_ns[hi] - time_ns[lo])
    linear = values[lo] + weight * (values[hi] - values[lo])
    snap = (distance <= tolerance_ns) | (grid_ns <= time_ns[0]) | (grid_ns >= time_ns[-1])
    result: FloatArray = np.where(snap, values[nearest], linear)
    return result


def resample_series(
    series: Series,
    grid_ns: IntArray,
    dt_ns: int,
    max_gap_ns: int,
    method: Resample,
) -> tuple[FloatArray, IntArray, IntArray]:
    """Values of ``series`` on the grid, with the gaps it was bridged across or not.

    Returns
    -------
    values:
        Nearest (or interpolated) values; gaps up to ``max_gap`` bridged.  For a series
        sampled on the grid, a read-only view of ``series.values``.
    too_long:
        Indices of grid points with no sample within ``dt/2`` whose surrounding samples are
        more than ``max_gap`` apart, or that lie outside the series' span.
    bridged:
        Indices of the grid points without a sample within ``dt/2`` that took a value from
        the samples around them (``nearest``: a sample the grid uses twice), and of those
        whose only sample within ``dt/2`` the point before took (:func:`_taken_twice`):
        values the log did not measure there.
    """
    tolerance = clock_tolerance_ns(dt_ns)
    on = on_grid_values(series, grid_ns, tolerance)
    if on is not None:  # the common case: one view, no index, distance or gap arrays
        return on, np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    index, distance = nearest_index(series.time_ns, grid_ns, tolerance)
    if method == "linear":
        values = interpolate(series, grid_ns, tolerance)
        _nearest_beside_gaps(values, series, grid_ns, index, max_gap_ns, dt_ns)
    else:
        values = series.values[index]
    gap_mask = past_half_step(distance, dt_ns)
    in_gap = np.flatnonzero(gap_mask)
    reused = _taken_twice(index, gap_mask)
    if in_gap.size == 0:
        return values, in_gap, reused
    time_ns = series.time_ns
    lo = np.searchsorted(time_ns, grid_ns[in_gap], side="right") - 1
    hi = lo + 1
    outside = (lo < 0) | (hi >= time_ns.size)
    span = time_ns[np.clip(hi, 0, time_ns.size - 1)] - time_ns[np.clip(lo, 0, time_ns.size - 1)]
    beyond = outside | longer_than_max_gap(span, max_gap_ns, dt_ns)
    bridged: IntArray = np.union1d(in_gap[~beyond], reused)
    return values, in_gap[beyond], bridged


def _nearest_beside_gaps(
    values: FloatArray,
    series: Series,
    grid_ns: IntArray,
    index: IntArray,
    max_gap_ns: int,
    dt_ns: int,
) -> None:
    """Give the grid points inside a gap longer than ``max_gap`` their nearest sample.

    ``values``: the linear interpolation, changed in place; ``index``: each point's nearest
    sample.  A gap (:func:`_gap_threshold`) says nothing of the
    signal inside it, as nothing is said past the last sample, where the interpolation takes
    the end value: a line drawn to the sample across the gap is a guess.  A point within
    ``dt/2`` of the sample before such a gap read a value part of the way to the sample
    after it (the points farther from both are an error); with ``--split-gaps`` an output
    cut at the gap took its last sample there, and a true state of the same field, read
    whole, the line across the gap.
    """
    time_ns = series.time_ns
    if time_ns.size < 2:
        return
    step = np.diff(time_ns)
    long = longer_than_max_gap(step, _gap_threshold(max_gap_ns, dt_ns), dt_ns)
    if not bool(long.any()):
        return
    before = np.searchsorted(time_ns, grid_ns, side="right") - 1  # the sample at or before
    inside = (before >= 0) & (before < step.size)
    inside[inside] = long[before[inside]]
    values[inside] = series.values[index[inside]]


def sampled_every(time_ns: IntArray, grid_ns: IntArray, dt_ns: int) -> dict[str, float]:
    """How often a bridged output was sampled over the grid's span: why it was bridged.

    ``every``: the median step (s) between its samples from the grid's first point to its
    last (the whole series when fewer than two lie there; a bridged output has two at
    least); ``steps``: that step in steps of ``dt``, to two decimals.  A topic published at
    a third of the model's rate (``steps`` 3) is bridged at two points of three by design,
    one published at the model's rate (``steps`` 1) only where the log lacks samples: the
    report says which (:func:`~hybridlog.report.reading_notes.bridged_cause`), where it asked of
    both whether the model's dt is the log's.
    """
    lo = int(np.searchsorted(time_ns, grid_ns[0], side="left"))
    hi = int(np.searchsorted(time_ns, grid_ns[-1], side="right"))
    inside = time_ns[lo:hi] if hi - lo >= 2 else time_ns
    step_ns = float(np.median(np.diff(inside)))
    ends = (float(grid_ns[0]) / NS_PER_S, float(grid_ns[-1]) / NS_PER_S)
    every = round_duration(step_ns / NS_PER_S, *ends)
    return {"every": every, "steps": round(step_ns / dt_ns, 2)}


def _taken_twice(index: IntArray, gap_mask: npt.NDArray[np.bool_]) -> IntArray:
    """Grid points within ``dt/2`` of a sample the point before took as its own too.

    A sample half a step between two grid points is within ``dt/2`` of both (the tie
    :func:`past_half_step` allows), and a point with no sample of its own beside it (a log
    sampled every ``1.5*dt``: samples at 0, 1.5, 3 s on a grid of 1 s) takes it a second
    time: one measurement counted as two, where a sample a microsecond further off was
    warned of as bridged.  The later of the two points is the one the log did not measure:
    bridged, as a point beyond half a step is (``unmeasured_outputs``).
    """
    if index.size < 2:
        return np.zeros(0, dtype=np.int64)
    within = ~gap_mask
    twice = (index[1:] == index[:-1]) & within[1:] & within[:-1]
    found: IntArray = np.flatnonzero(twice) + 1
    return found


def _faster_than_the_grid(
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


def _skipped_by_the_hold(index: IntArray, kind: str) -> dict[str, Any] | None:
    """``{kind, samples, unused}`` of a held series some of whose samples no grid point takes.

    ``index``: the sample each grid point takes (nondecreasing, none before the first).  A
    series with no more samples than the grid has points (else :func:`_faster_than_the_grid`
    says it) can still lose samples to the hold: two within one step, of which the point
    after them takes the later.  An input recorded once per step by a clock that jitters by
    more than ``dt/4`` (beyond :func:`jittered_index`) loses a sample wherever a late one
    follows an early one, and the point before takes the sample before its own, a step
    late; a command published when it changes loses a change undone within a step.  Both
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


def _longest_hold(
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
    threshold = _gap_threshold(max_gap_ns, dt_ns)  # a sample held for one step is no hold
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
        "seconds": _seconds(start, end),
        "holds": len(candidates),
    }


def _seconds(start_ns: int, end_ns: int) -> float:
    """``end - start`` in seconds, to the digits the two times hold as float seconds.

    The times were float seconds (most logs), good at 1.7e9 s to 238 ns: a 0.51 s hold read
    0.509999762 in report.json (:func:`~hybridlog.times.round_duration`).
    """
    start, end = start_ns / NS_PER_S, end_ns / NS_PER_S
    return round_duration((end_ns - start_ns) / NS_PER_S, start, end)


def _gap_on_the_grid(
    series: Series, span: tuple[int, int], dt_ns: int, max_gap_ns: int
) -> IntArray | None:
    """A time inside the first gap of ``series`` that the grid check is sure to refuse.

    :func:`resample_series` finds every gap longer than ``max_gap``, but on the grid, whose
    size follows from the log's span: a log whose times are not seconds (nanoseconds from
    0, 10^9 times too long) would have a grid of hundreds of GiB made before its first
    gap was seen.  Between consecutive samples more than ``max(max_gap, 2 dt)`` apart, a
    stretch longer than ``dt`` of the grid's span ``(t0, t_end)`` lies more than ``dt/2``
    from both, so it holds a grid point that check refuses (with the same message); a
    shorter gap is left to it.  ``None`` when there is no such gap.
    """
    time_ns = series.time_ns
    if time_ns.size < 2:
        return None
    half = dt_ns // 2 + clock_tolerance_ns(dt_ns) + 1  # past_half_step from a sample
    steps = np.diff(time_ns)
    candidates = np.flatnonzero(longer_than_max_gap(steps, max(max_gap_ns, 2 * dt_ns), dt_ns))
    if candidates.size == 0:
        return None
    t0, t_end = span
    lo = np.maximum(time_ns[candidates] + half, t0)
    hi = np.minimum(time_ns[candidates + 1] - half, t_end)
    inside = np.flatnonzero(hi - lo > dt_ns + 1)  # a grid step is dt rounded to 1 ns
    if inside.size == 0:
        return None
    k = int(inside[0])
    return np.array([(int(lo[k]) + int(hi[k])) // 2], dtype=np.int64)


def _gap_error(
    source: str,
    label: str,
    field_word: str,
    series: Series,
    grid_ns: IntArray,
    point: int,
    max_gap_ns: int,
    dt_ns: int,
    *,
    dropped: IntArray | None = None,
) -> LogError:
    """The error of an output gap longer than ``max_gap`` around ``grid_ns[point]``.

    ``dropped``: the times of the series' samples ``--drop-nonfinite`` dropped: a gap it
    made says so, for the log has samples there ("no sample from t=0.4 s to t=1.5 s" sent
    the user to a log with a NaN every 0.1 s in between).
    """
    time_ns = series.time_ns
    hi = int(np.searchsorted(time_ns, grid_ns[point], side="right"))
    lo = hi - 1
    if lo < 0 or hi >= time_ns.size:
        where = f"near t={format_ns(int(grid_ns[point]))} s"
        start, end = (int(time_ns[-1]), None) if lo >= 0 else (None, int(time_ns[0]))
    else:
        start, end = int(time_ns[lo]), int(time_ns[hi])
        where = (
            f"from t={format_ns(start)} s to t={format_ns(end)} s "
            f"({format_ns(end - start)} s > max_gap {format_ns(max_gap_ns)} s)"
        )
    usable = ""
    if dropped is not None and dropped.size:
        after = dropped > start if start is not None else np.ones(dropped.size, dtype=bool)
        before = dropped < end if end is not None else np.ones(dropped.size, dtype=bool)
        inside = int(np.count_nonzero(after & before))
        if inside:
            usable = "usable "
            where += (
                f"; --drop-nonfinite dropped the {inside} NaN, infinite or out-of-range "
                f"{'sample' if inside == 1 else 'samples'} it has there"
            )
    hint = _slower_than_max_gap(series, max_gap_ns, dt_ns) or (
        "; --max-gap SECONDS accepts longer gaps, --split-gaps analyses the longest piece "
        "between them"
    )
    return LogError(
        f"{source}: gap in {label} ({field_word} {series.name!r}): no {usable}sample {where}{hint}"
    )


def _slower_than_max_gap(series: Series, max_gap_ns: int, dt_ns: int) -> str:
    """A hint when ``series`` is sampled slower than ``max_gap`` allows, else ``""``.

    Then (nearly) every step is a gap: ``max_gap`` is shorter than the log's sample time, or
    (asked when the series is slower than ``dt``) the model's ``dt`` is not the log's.
    """
    if series.time_ns.size < 2:
        return ""
    median = round(float(np.median(np.diff(series.time_ns))))
    if not longer_than_max_gap(median, _gap_threshold(max_gap_ns, dt_ns), dt_ns):
        return ""
    hint = (
        f"; it is sampled every {format_ns(median)} s (its median step), slower than max_gap "
        f"{format_ns(max_gap_ns)} s allows"
    )
    if median > dt_ns + clock_tolerance_ns(dt_ns):
        hint += f": is the model's dt ({format_ns(dt_ns)} s) the log's?"
    if median >= 500 * dt_ns:  # 1000 dt for a log in milliseconds, 10^9 dt in nanoseconds
        hint += " Or are its times not in seconds (milliseconds, nanoseconds)?"
    return hint


def _gap_threshold(max_gap_ns: int, dt_ns: int) -> int:
    """The step between two samples that is a gap: ``max(max_gap, dt)``.

    Samples ``dt`` apart leave no grid point without a sample within ``dt/2``, which is what
    the reading refuses as a gap: with ``--max-gap 0`` (or anything under ``dt``) an input
    sampled at ``dt`` is not held over ``max_gap``, and a linear interpolation is drawn
    between outputs sampled at ``dt``.  (``--split-gaps`` cuts where the grid refuses a gap,
    :func:`_split_at_refused_gaps`.)
    """
    return max(max_gap_ns, dt_ns)


Resampled = tuple[FloatArray, IntArray, IntArray]
"""What :func:`resample_series` gives of one output: values, points refused, points bridged."""


def _output_grid(
    source: str,
    dt: float,
    signals: tuple[Mapping[str, Series], Mapping[str, Series], Mapping[str, Series]],
    field_word: str,
    max_gap_ns: int,
    dropped: Mapping[str, IntArray],
) -> IntArray:
    """The grid of the inputs, commands and outputs ``signals`` (:func:`make_grid`).

    A gap of an output that the grid is sure to refuse is refused before the grid is made
    (:func:`_gap_on_the_grid`): times not in seconds would ask for GiBs.
    """
    inputs, commands, outputs = signals
    dt_ns = step_ns(dt)
    output_list = list(outputs.values())
    held_signals = [*inputs.values(), *commands.values()]
    starts, ends = [*held_signals, *output_list], output_list or held_signals
    # make_grid's first and last times, found once (the held signals' clock is a pass over
    # their samples): the span of grid_span, then the grid
    t0, t_last = _first_and_last(starts, ends, source, dt_ns, on_whole_ns(held_signals, dt))
    span = t0, _span_end(dt_ns, t_last, bool(ends))
    for symbol, series in outputs.items():
        gap = _gap_on_the_grid(series, span, dt_ns, max_gap_ns)
        if gap is not None:
            raise _gap_error(
                source,
                f"output {symbol!r}",
                field_word,
                series,
                gap,
                0,
                max_gap_ns,
                dt_ns,
                dropped=dropped.get(symbol),
            )
    return grid_between(dt, t0, t_last, bool(ends))


def _split_at_refused_gaps(
    named: tuple[str, str],
    held: Mapping[str, Series],
    outputs: Mapping[str, Series],
    steps: tuple[int, int],
    notes: dict[str, Any],
    build: tuple[
        Callable[[str, Mapping[str, Series]], IntArray],
        Callable[[Mapping[str, Series], IntArray], list[Resampled]],
    ],
) -> tuple[dict[str, Series], str, IntArray, list[Resampled]]:
    """``--split-gaps``: the longest piece whose grid refuses no gap, with that grid.

    ``named``: the log's path and what it calls a series; ``steps``: ``dt`` and ``max_gap``
    (ns); ``build``: the grid of a piece's outputs (named by the piece) and the outputs
    resampled onto it.  A step between two samples that is longer than ``max_gap`` but
    shorter than about ``2*dt`` leaves a grid point more than ``dt/2`` from both, which the
    reading refuses, or not, by where the grid lies: cut at every step longer than
    ``max(max_gap, dt)``, a log on a clock jittering by 20 % of ``dt`` read whole with
    ``--max-gap`` equal to ``dt`` came in 105 pieces with ``--split-gaps``, which analysed
    5 of its 301 samples.  So the log is cut at the gaps refused wherever the grid lies
    (:func:`_longest_piece`), then at those the piece's own grid refuses, until it refuses
    none: ``--split-gaps`` cuts where the reading alone would refuse the log, and only there.
    Returns the piece's outputs, its description (empty when nothing was cut), its grid and
    its outputs resampled.
    """
    source, field_word = named
    grid_of, resampled = build
    refused: frozenset[tuple[int, int]] = frozenset()
    while True:
        cut, piece = _longest_piece(source, field_word, held, outputs, steps, notes, refused)
        grid = grid_of(f"{source} ({piece})" if piece else source, cut)
        on_grid_outputs = resampled(cut, grid)
        more = set(refused)
        for series, (_, too_long, _) in zip(cut.values(), on_grid_outputs, strict=True):
            hi = np.searchsorted(series.time_ns, grid[too_long], side="right")
            inside = (hi >= 1) & (hi < series.time_ns.size)  # points outside: refused later
            for k in hi[inside].tolist():
                more.add((int(series.time_ns[k - 1]), int(series.time_ns[k])))
        if len(more) == len(refused):
            return cut, piece, grid, on_grid_outputs
        refused = frozenset(more)


def _gap_anywhere(steps: IntArray, max_gap_ns: int, dt_ns: int) -> npt.NDArray[np.bool_]:
    """Which steps between two samples (ns) the reading refuses wherever the grid lies.

    Longer than ``max_gap`` (:func:`longer_than_max_gap`), and long enough that the
    stretch more than ``dt/2`` from both samples (:func:`past_half_step`) is longer than a
    grid step: it holds a grid point, as :func:`_gap_on_the_grid` reasons.  A shorter step
    is refused or not by the phase of the grid (:func:`_split_at_refused_gaps`).
    """
    half = dt_ns // 2 + clock_tolerance_ns(dt_ns) + 1
    anywhere: npt.NDArray[np.bool_] = longer_than_max_gap(steps, max_gap_ns, dt_ns) & (
        steps - 2 * half > dt_ns + 1
    )
    return anywhere


def check_alignment_options(
    dt: float, resample: str, max_gap: float | None
) -> tuple[int, Resample, int]:
    """Validate the alignment options before any log is read.

    Returns
    -------
    tuple
        ``dt`` in nanoseconds, the resampling method, and ``max_gap`` in nanoseconds.

    Raises
    ------
    OptionError
        For an unusable ``dt``, an unknown ``resample`` or a negative ``max_gap``.
    """
    dt_ns = step_ns(dt)
    method = check_resample(resample)
    check_max_gap(max_gap)
    if max_gap is None:
        return dt_ns, method, DEFAULT_MAX_GAP_STEPS * dt_ns
    return dt_ns, method, round(max_gap * NS_PER_S)


def align_signals(
    *,
    source: str,
    dt: float,
    inputs: Mapping[str, Series],
    outputs: Mapping[str, Series],
    commands: Mapping[str, Series] | None = None,
    truth_mode: LabelSeries | None = None,
    truth_components: Mapping[str, LabelSeries] | None = None,
    states: Sequence[str] = (),
    truth_states: Mapping[str, Series] | None = None,
    resample: str = "nearest",
    max_gap: float | None = None,
    split_gaps: bool = False,
    notes: dict[str, Any] | None = None,
    field_word: str = "column",
    dropped: Mapping[str, IntArray] | None = None,
) -> AlignedSignals:
    """Put mapped series onto the grid ``t0 + k*dt`` (rules in the module docstring).

    Parameters
    ----------
    source:
        The log's path, stored in the result and used in messages.
    dt:
        The model's sample time in seconds.
    inputs, outputs:
        ``{symbol: series}`` in the model's order.
    commands:
        ``{command: series}`` of a ``[components]`` model's commands, held onto the grid
        as inputs are (and, like them, bounding its start), into
        ``AlignedSignals.commands``; named as commands in messages and notes (``held``
        entries of commands carry ``"kind": "command"``).
    truth_mode:
        True-mode samples whose ``codes`` are indices into the model's mode ids
        (:func:`~hybridlog.io.source.labels_to_codes`), or ``None``.
    truth_components:
        ``{component: true-mode samples}`` whose ``codes`` index the component's mode ids,
        held onto the grid like ``truth_mode``.
    states:
        The model's state names (order of ``truth_states`` columns).
    truth_states:
        ``{state: series}`` for the states the log has.
    resample:
        ``"nearest"`` or ``"linear"`` (outputs and true states).
    max_gap:
        Longest tolerated time in seconds between two output samples around a gap;
        default ``5*dt``.
    split_gaps:
        Align the longest piece between longer gaps instead of refusing the log.
    notes:
        Filled with the signals that start the grid late or end it early by more than
        ``max_gap`` (``span``), the pieces (``segments``) and the one analysed when
        ``split_gaps`` cut the log, and per output the grid points bridged across short
        gaps (``bridged``: ``{symbol: {points, of}}``), per true state the same
        (``truth_bridged``), per input and output sampled faster than the grid its
        samples on the grid's span and the grid's points (``faster``: ``{symbol: {kind,
        samples, points}}``), per input its longest hold over ``max_gap`` (``held``:
        ``{symbol: {start, end, seconds}}``), and the same for the true mode and each
        component's (``truth_held``: ``{"mode" | "mode.<component>": {start, end, seconds}}``),
        and for a true mode that starts more than half a step after the first sample time
        where it starts and how many samples it covers (``truth_starts``: ``{"mode" |
        "mode.<component>": {at, samples, of}}``).  ``truth_held`` is of a true mode recorded
        only at its switches (:func:`records_switches`); a sampled one's stretches without a
        sample (longer than ``dt``, whatever ``max_gap``) leave their grid points more than
        ``dt/2`` from every sample without a true mode, recorded as ``truth_gaps``:
        ``{"mode" | "mode.<component>": {start, end, seconds, gaps, points, of}}`` (the
        longest stretch, how many there are, the grid points left without a true mode, all
        grid points).
    field_word:
        What the log calls a series in messages: ``"column"`` (tables) or ``"field"``
        (message paths; :attr:`~hybridlog.io.source.SourceInfo.field_word`).
    dropped:
        ``{output: times (ns)}`` of the samples ``--drop-nonfinite`` dropped, for the error
        of a gap they made.

    Returns
    -------
    AlignedSignals

    Raises
    ------
    OptionError
        For an unknown ``resample``, a negative ``max_gap`` or an unusable ``dt``.
    LogError
        For an input or output without samples, an output gap longer than ``max_gap``
        (naming the time span), or signals that do not overlap.
    """
    dt_ns, method, max_gap_ns = check_alignment_options(dt, resample, max_gap)
    tolerance = clock_tolerance_ns(dt_ns)
    commands = commands or {}
    for kind, signals in (("input", inputs), ("output", outputs), ("command", commands)):
        for symbol, series in signals.items():
            if series.time_ns.size == 0:
                raise LogError(
                    f"{source}: {kind} {symbol!r} ({field_word} {series.name!r}) has no samples"
                )
    if notes is not None:
        _record_span_bounds(inputs, outputs, commands, field_word, dt_ns, max_gap_ns, notes)
    piece = ""
    held_series = {**inputs, **commands}

    def grid_of(named: str, cut: Mapping[str, Series]) -> IntArray:
        return _output_grid(
            named, dt, (inputs, commands, cut), field_word, max_gap_ns, dropped or {}
        )

    def resampled(cut: Mapping[str, Series], grid: IntArray) -> list[Resampled]:
        return [resample_series(s, grid, dt_ns, max_gap_ns, method) for s in cut.values()]

    if split_gaps and outputs:
        outputs, piece, grid, on_grid_outputs = _split_at_refused_gaps(
            (source, field_word),
            held_series,
            outputs,
            (dt_ns, max_gap_ns),
            notes if notes is not None else {},
            (grid_of, resampled),
        )
        if piece:  # every message from here on is about that piece
            source = f"{source} ({piece})"
    else:
        grid = grid_of(source, outputs)
        on_grid_outputs = resampled(outputs, grid)
    n = grid.size

    u = _held_onto(grid, inputs, "input", dt_ns, max_gap_ns, notes)
    held_commands = _held_onto(grid, commands, "command", dt_ns, max_gap_ns, notes)

    y = np.empty((n, len(outputs)), dtype=np.float64)
    unmeasured: npt.NDArray[np.bool_] | None = None
    for j, (symbol, series) in enumerate(outputs.items()):
        values, too_long, bridged = on_grid_outputs[j]
        if too_long.size:
            raise _gap_error(
                source,
                f"output {symbol!r}",
                field_word,
                series,
                grid,
                int(too_long[0]),
                max_gap_ns,
                dt_ns,
                dropped=(dropped or {}).get(symbol),
            )
        if bridged.size:
            if unmeasured is None:
                unmeasured = np.zeros((n, len(outputs)), dtype=np.bool_)
            unmeasured[bridged, j] = True
            if notes is not None:
                notes.setdefault("bridged", {})[symbol] = {
                    "points": int(bridged.size),
                    "of": n,
                    **sampled_every(series.time_ns, grid, dt_ns),
                }
        faster = _faster_than_the_grid(series.time_ns, grid, dt_ns, "output")
        if faster is not None and notes is not None:
            notes.setdefault("faster", {})[symbol] = faster
        y[:, j] = values

    jittered: dict[str, Any] = {}
    labelled = {"mode": truth_mode} if truth_mode is not None else {}
    labelled |= {f"mode.{name}": series for name, series in (truth_components or {}).items()}
    codes_of: dict[str, IntArray] = {}
    for label, label_series in labelled.items():
        codes, gaps = _hold_modes(
            f"{source}: truth.{label}",
            field_word,
            label_series,
            grid,
            (dt_ns, tolerance),
            jittered,
            label,
        )
        codes_of[label] = codes
        if notes is None:
            continue
        if gaps is not None:
            notes.setdefault("truth_gaps", {})[label] = gaps
        held = (  # a record of the switches: held however long, and the metrics score the hold
            _longest_hold(label_series.time_ns, grid, dt_ns, max_gap_ns)
            if records_switches(label_series.codes)
            else None
        )
        if held is not None:
            notes.setdefault("truth_held", {})[label] = held
        late = _truth_start(label_series, codes, grid)
        if late is not None:
            notes.setdefault("truth_starts", {})[label] = late
    modes = codes_of.get("mode")
    components = {
        name: ComponentTruth(series.categories, codes_of[f"mode.{name}"])
        for name, series in (truth_components or {}).items()
    }
    for signal, found in jittered.items():
        _note_jitter(notes, signal, found, n)

    x_true: FloatArray | None = None
    if truth_states:
        x_true = np.full((n, len(states)), np.nan)
        for j, state in enumerate(states):
            truth_series = truth_states.get(state)
            if truth_series is None or truth_series.time_ns.size == 0:
                continue
            values, too_long, bridged = resample_series(
                truth_series, grid, dt_ns, max_gap_ns, method
            )
            if bridged.size and notes is not None:
                notes.setdefault("truth_bridged", {})[state] = {
                    "points": int(bridged.size),
                    "of": n,
                }
            x_true[:, j] = values
            x_true[too_long, j] = np.nan
            x_true[bridged, j] = np.nan  # not the truth there: no state error is scored

    return AlignedSignals(
        source=source,
        time=ns_to_seconds(grid),
        input_names=tuple(inputs),
        output_names=tuple(outputs),
        inputs=u,
        outputs=y,
        truth_modes=modes,
        state_names=tuple(states),
        truth_states=x_true,
        truth_components=components,
        command_names=tuple(commands or {}),
        commands=held_commands if commands else None,
        unmeasured_outputs=unmeasured,
        piece=piece,
    )


def _held_onto(
    grid: IntArray,
    signals: Mapping[str, Series],
    kind: str,
    dt_ns: int,
    max_gap_ns: int,
    notes: dict[str, Any] | None,
) -> FloatArray:
    """Inputs (or commands: ``kind``) on the grid by the hold, ``(N, len(signals))``.

    Each column is the series' sample at each grid point (on the grid), its own sample
    (a jittering clock, :func:`jittered_index`), or the last at or before it.  Recorded in
    ``notes`` under the signal's own kind: a command is held as an input is, but the model
    has no input of its name, and a note of "input cmd" sent the user looking for one.
    """
    tolerance = clock_tolerance_ns(dt_ns)
    n = grid.size
    held = np.empty((n, len(signals)), dtype=np.float64)
    for j, (symbol, series) in enumerate(signals.items()):
        on = on_grid_values(series, grid, tolerance)
        index: IntArray | None = None
        if on is None:
            found = jittered_index(series.time_ns, grid, tolerance, dt_ns)
            if found is not None:
                _note_jitter(notes, f"{kind} {symbol}", found, n)
            index = (
                found.taken if found is not None else _hold_from_first(series.time_ns, grid, dt_ns)
            )
            on = series.values[index]
        held[:, j] = on
        if notes is None:
            continue
        faster = _faster_than_the_grid(series.time_ns, grid, dt_ns, kind)
        if faster is not None:
            notes.setdefault("faster", {})[symbol] = faster
        elif index is not None:
            skipped = _skipped_by_the_hold(index, kind)
            if skipped is not None:
                notes.setdefault("skipped", {})[symbol] = {**skipped, "points": n}
        hold = _longest_hold(series.time_ns, grid, dt_ns, max_gap_ns)
        if hold is not None:
            notes.setdefault("held", {})[symbol] = (
                hold if kind == "input" else {**hold, "kind": kind}
            )
    return held


def _hold_from_first(time_ns: IntArray, grid_ns: IntArray, dt_ns: int) -> IntArray:
    """:func:`hold_index` of a held series, whose first sample the points before it take.

    Only a grid on a jittering clock (:func:`_grid_start`) starts before a held series'
    first sample, by at most ``dt/4``; :func:`jittered_index` gives that point its sample,
    but a series it does not take (half its samples dropped over a short grid) was held
    from index -1: the series' last sample, 299 at the first point of a log from 0 to 299.
    """
    index = hold_index(time_ns, grid_ns, clock_tolerance_ns(dt_ns))
    np.maximum(index, 0, out=index)
    return index


def _record_span_bounds(
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
                "left_out": _seconds(min(at, log), max(at, log)),
            }
    if span:
        notes["span"] = span


def records_switches(codes: IntArray) -> bool:
    """Whether a true mode's samples record only its switches: none repeats the label before.

    Such a record (a mode published when it changes) says by its silence that the mode did
    not change: held from one sample to the next, however far apart, it is the mode.  A true
    mode that repeats its label is sampled, as a logger writes it at its rate: its silence
    says nothing, and a stretch without a sample may hide switches, there and back.  A record
    of switches with one repeated sample is read as sampled: a stretch without a sample is
    then a gap, left unscored and said, never held as a guess.
    """
    return bool(np.all(codes[1:] != codes[:-1]))


def _hold_modes(
    what: str,
    field_word: str,
    series: LabelSeries,
    grid: IntArray,
    steps: tuple[int, int],
    jitter: dict[str, Any] | None = None,
    label: str = "mode",
) -> tuple[IntArray, dict[str, Any] | None]:
    """The true mode (code) at each grid point, held like an input (:func:`jittered_index`).

    A sampled one around the grid's points (:func:`_around`) takes the nearest sample, as
    the outputs logged in its rows are read (:func:`nearest_index`).  ``steps``: ``dt`` and
    the clock tolerance (ns).  A jittered series' :class:`Jittered` goes into ``jitter``
    under ``the true <label>``.  Returns the codes and the stretches of a sampled true mode
    left without one (:func:`_blank_gaps`), or ``None``.
    """
    dt_ns, tolerance = steps
    if series.time_ns.size == 0:
        raise LogError(f"{what} ({field_word} {series.name!r}) has no samples")
    start = on_grid(series.time_ns, grid, tolerance)
    if start >= 0:  # the codes at the grid points, without an index array; no gap
        on: IntArray = series.codes[start : start + grid.size].astype(np.int64, copy=False)
        return on, None
    found = jittered_index(series.time_ns, grid, tolerance, dt_ns)
    sampled = not records_switches(series.codes)
    if found is not None:
        index = found.taken
    elif sampled and _around(series, int(grid[0]), dt_ns):
        index, _ = nearest_index(series.time_ns, grid, tolerance)  # as the outputs are read
        index[series.time_ns[index] > grid + dt_ns // 2 + tolerance] = -1  # before the first
    else:
        index = hold_index(series.time_ns, grid, tolerance)
    before = index < 0
    modes: IntArray = series.codes[np.maximum(index, 0)].astype(np.int64)
    # a grid point within half a step of the first sample takes it, as the nearest sample;
    # before that there is no truth to hold: those samples are not scored
    first = int(series.time_ns[0])
    modes[before & past_half_step(first - grid, dt_ns)] = NO_TRUE_MODE
    gaps = _blank_gaps(series, grid, dt_ns, modes) if sampled else None
    if found is not None and jitter is not None:
        if gaps is not None:  # the points whose sample was dropped hold none: no true mode
            taken = series.time_ns[np.maximum(found.taken, 0)]
            still = (modes != NO_TRUE_MODE) & past_half_step(np.abs(taken - grid), dt_ns)
            found = found._replace(held=int(np.count_nonzero(still)))
        jitter[f"the true {label}"] = found
    return modes, gaps


def _blank_gaps(
    series: LabelSeries, grid: IntArray, dt_ns: int, modes: IntArray
) -> dict[str, Any] | None:
    """Leave a sampled true mode's silences without a true mode, in ``modes``.

    A stretch between two samples longer than ``dt`` (by more than the clock tolerance,
    :func:`longer_than_max_gap`), or from the last sample to the grid's end, may hide a
    switch, however short: its grid points more than ``dt/2`` from both samples get
    :data:`NO_TRUE_MODE`; those within ``dt/2`` of the later sample take it (the nearest
    sample, as before the first); those within ``dt/2`` of the earlier keep theirs.  Not
    ``max_gap``: a gap the outputs are bridged across is bridged with their own samples,
    and the true mode held over it was a guess scored as a measurement (a switch inside it
    placed at the gap's end, and the samples before it scored against the old mode).
    Returns ``{start, end, seconds, gaps, points, of}`` (the longest stretch that left a
    point without a true mode, in seconds; how many did; the points; all grid points), or
    ``None`` when no point was left without one.
    """
    times = series.time_ns
    if grid.size == 0:
        return None
    last = int(grid[-1])
    after = np.append(times[1:], max(last, int(times[-1])))  # where each sample's stretch ends
    long = longer_than_max_gap(after - times, dt_ns, dt_ns)
    # past the last sample no later one is within dt/2: a point beyond half a step has none
    long[-1] = bool(past_half_step(after[-1] - times[-1], dt_ns))
    if not bool(long.any()):
        return None
    sample = np.searchsorted(times, grid, side="right") - 1  # the sample at or before each point
    points = np.flatnonzero((sample >= 0) & long[np.maximum(sample, 0)])
    k = sample[points]
    has_next = k + 1 < times.size
    following = times[np.minimum(k + 1, times.size - 1)]
    far = past_half_step(grid[points] - times[k], dt_ns)
    near_next = has_next & ~past_half_step(following - grid[points], dt_ns)
    modes[points[far & near_next]] = series.codes[k[far & near_next] + 1]
    blank = far & ~near_next
    modes[points[blank]] = NO_TRUE_MODE
    stretches = np.unique(k[blank])
    if stretches.size == 0:
        return None
    ends = after[stretches]
    longest = int(np.argmax(ends - times[stretches]))  # of equal ones the first
    begin, end = int(times[stretches[longest]]), int(ends[longest])
    return {
        "start": begin / NS_PER_S,
        "end": end / NS_PER_S,
        "seconds": _seconds(begin, end),
        "gaps": int(stretches.size),
        "points": int(np.count_nonzero(blank)),
        "of": int(grid.size),
    }


def _note_jitter(notes: dict[str, Any] | None, signal: str, found: Jittered, n: int) -> None:
    """Record a jittered series: its jitter (s), and the grid points it held, if any."""
    if notes is None:
        return
    notes.setdefault("jitter", {})[signal] = found.jitter
    if found.held:
        notes.setdefault("jitter_held", {})[signal] = {"points": found.held, "of": n}


def _truth_start(series: LabelSeries, codes: IntArray, grid: IntArray) -> dict[str, Any] | None:
    """Where a true mode that starts late starts: ``{at, samples, of}``, else ``None``.

    ``at``: its first sample's time (s); ``samples``: the samples it covers, from the first
    it is held at; ``of``: all samples.
    """
    start = covered_from(codes)
    if start == 0:
        return None
    return {
        "at": int(series.time_ns[0]) / NS_PER_S,
        "samples": int(grid.size - start),
        "of": int(grid.size),
    }


def _piece(start_ns: int, end_ns: int) -> dict[str, float]:
    """A piece of a log cut by ``--split-gaps``, as report.json lists it."""
    return {
        "start": start_ns / NS_PER_S,
        "end": end_ns / NS_PER_S,
        "duration": _seconds(start_ns, end_ns),
    }


def _listed(key: str, noun: str, items: list[dict[str, float]]) -> dict[str, Any]:
    """``items`` under ``key``, the first :data:`MAX_LISTED_GAPS` of them, counted and flagged.

    ``{key: [...], f"{noun}_count": n, f"{key}_truncated": bool}``: a reader of report.json
    knows from the flag, never from a guess, that the list is not whole.
    """
    return {
        key: items[:MAX_LISTED_GAPS],
        f"{noun}_count": len(items),
        f"{key}_truncated": len(items) > MAX_LISTED_GAPS,
    }


def _longest_piece(
    source: str,
    field_word: str,
    inputs: Mapping[str, Series],
    outputs: Mapping[str, Series],
    steps: tuple[int, int],
    notes: dict[str, Any],
    refused: frozenset[tuple[int, int]] = frozenset(),
) -> tuple[dict[str, Series], str]:
    """The outputs (none empty) cut to the longest stretch without a gap longer than ``max_gap``.

    ``steps``: ``dt`` and ``max_gap`` (ns).  The log is cut at every step between two
    samples of an output that the reading refuses wherever its grid lies
    (:func:`_gap_anywhere`), and at the steps in ``refused`` (``(start, end)`` times, ns),
    which the grid of a piece cut before refused (:func:`_split_at_refused_gaps`).  A
    sample alone between two gaps is a piece of its own, wherever it lies.  With it, the
    piece kept when the log was cut, for messages (``--split-gaps piece 2 of 3, t = 20 … 23
    s, the longest``; its number counts the pieces in time order from 1, as report.json's
    ``reading.segments`` lists them); empty when no gap cut it.
    """
    dt_ns, max_gap_ns = steps
    for symbol, series in outputs.items():
        # every step a gap: no piece longer than one sample (counted, not judged from the
        # median step: a log mostly sampled slowly can still hold a piece sampled at dt)
        diffs = np.diff(series.time_ns)
        if diffs.size and bool(np.all(_gap_anywhere(diffs, max_gap_ns, dt_ns))):
            hint = _slower_than_max_gap(series, max_gap_ns, dt_ns)
            raise LogError(
                f"{source}: --split-gaps: output {symbol!r} ({field_word} {series.name!r}) "
                f"leaves no piece of more than one sample{hint}"
            )
    start = max(int(s.time_ns[0]) for s in (*inputs.values(), *outputs.values()))
    end = min(int(s.time_ns[-1]) for s in outputs.values())
    if start > end:  # nothing to cut: the grid refuses it, naming the signals
        return dict(outputs), ""
    found: set[tuple[int, int]] = set(refused)
    for series in outputs.values():
        diffs = np.diff(series.time_ns)
        for i in np.flatnonzero(_gap_anywhere(diffs, max_gap_ns, dt_ns)).tolist():
            found.add((int(series.time_ns[i]), int(series.time_ns[i + 1])))
    if not found:
        return dict(outputs), ""
    gaps = sorted(found)
    pieces: list[tuple[int, int]] = []
    cursor = start
    for gap_start, gap_end in gaps:
        if gap_start >= cursor:  # a sample between two gaps (gap_start == cursor) too
            pieces.append((cursor, min(gap_start, end)))
        cursor = max(cursor, gap_end)
    if cursor <= end:
        pieces.append((cursor, end))
    pieces = [(a, b) for a, b in pieces if a <= b]
    if not pieces:
        raise _no_piece(source, field_word, outputs, (start, end), gaps)
    best = max(range(len(pieces)), key=lambda i: (pieces[i][1] - pieces[i][0], -i))
    lo, hi = pieces[best]
    notes.update(_listed("segments", "segment", [_piece(a, b) for a, b in pieces]))
    notes["analysed_segment"] = best
    notes["analysed"] = _piece(lo, hi)
    gap_list = [{"start": a / NS_PER_S, "end": b / NS_PER_S} for a, b in gaps]
    notes.update(_listed("gaps", "gap", gap_list))
    cut = {symbol: _piece_of(series, (lo, hi), found) for symbol, series in outputs.items()}
    longest = "the only one" if len(pieces) == 1 else "the longest"
    piece = (
        f"--split-gaps piece {best + 1:,} of {len(pieces):,}, t = {format_ns(lo)} … "
        f"{format_ns(hi)} s, {longest}"
    )
    return cut, piece


def _piece_of(series: Series, piece: tuple[int, int], cuts: set[tuple[int, int]]) -> Series:
    """The samples of an output that a piece ``(lo, hi)`` (ns) of the log reads.

    Those inside it, and the one on either side of it unless a cut (``cuts``, ``(start,
    end)`` of two samples, ns) lies between: the piece's grid takes the nearest sample, or
    bridges a short gap, as the log read whole would.  Cut to the piece alone, a point at
    its start took another output's sample a step away where one lay 2 ms before the
    start, and the grid started a whole step late (the piece said ``t = 22.41 …``, the grid
    23.17 s), and an output with no sample inside a short piece had "no samples".  A
    longer gap between such a sample and the piece is refused on the piece's grid, and cut
    (:func:`_split_at_refused_gaps`).
    """
    time_ns = series.time_ns
    lo, hi = piece
    first = int(np.searchsorted(time_ns, lo, side="left"))
    stop = int(np.searchsorted(time_ns, hi, side="right"))
    if first > 0 and (int(time_ns[first - 1]), int(time_ns[first])) not in cuts:
        first -= 1
    if stop < time_ns.size and (int(time_ns[stop - 1]), int(time_ns[stop])) not in cuts:
        stop += 1
    return Series(series.name, time_ns[first:stop], series.values[first:stop])


def _no_piece(
    source: str,
    field_word: str,
    outputs: Mapping[str, Series],
    overlap: tuple[int, int],
    gaps: Sequence[tuple[int, int]],
) -> LogError:
    """The error of ``--split-gaps`` when the signals overlap only inside output gaps.

    ``overlap``: the latest first sample and the earliest last one (ns); ``gaps``: the cuts,
    ``(start, end)`` in time order.  Names the first gap over the overlap and its output:
    "no stretch of the outputs is free of gaps" named neither, nor when.
    """
    start, end = overlap
    first = next(g for g in gaps if g[1] > start)
    owner = next(
        (
            f"output {symbol!r} ({field_word} {series.name!r})"
            for symbol, series in outputs.items()
            if bool(np.any((series.time_ns[:-1] == first[0]) & (series.time_ns[1:] == first[1])))
        ),
        "an output",
    )
    return LogError(
        f"{source}: --split-gaps: no piece: the signals overlap from t={format_ns(start)} s to "
        f"t={format_ns(end)} s, where {owner} has no sample from t={format_ns(first[0])} s "
        f"to t={format_ns(first[1])} s, a gap longer than max_gap"
    )
