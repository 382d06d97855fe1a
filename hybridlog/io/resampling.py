"""A series' values at the grid's points (SPEC §5, :mod:`hybridlog.io.align`'s rules).

A series sampled on the grid is taken as it is (:func:`on_grid`, :func:`on_grid_values`);
else an input is held (:func:`hold_index`), or, recorded once per step on a jittering clock,
gives each point its own sample (:func:`jittered_index`); an output or true state takes the
nearest sample within ``dt/2`` or the line between the two around the point
(:func:`resample_series`), with the points it bridged across short gaps.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from hybridlog.io.options import Resample
from hybridlog.io.output_gaps import gap_threshold
from hybridlog.io.source import BLOCK, NS_PER_S, Series
from hybridlog.io.time_grid import clock_tolerance_ns, longer_than_max_gap, past_half_step
from hybridlog.signals import FloatArray, IntArray


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
    sample.  A gap (:func:`~hybridlog.io.output_gaps.gap_threshold`) says nothing of the
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
    long = longer_than_max_gap(step, gap_threshold(max_gap_ns, dt_ns), dt_ns)
    if not bool(long.any()):
        return
    before = np.searchsorted(time_ns, grid_ns, side="right") - 1  # the sample at or before
    inside = (before >= 0) & (before < step.size)
    inside[inside] = long[before[inside]]
    values[inside] = series.values[index[inside]]


def _taken_twice(index: IntArray, gap_mask: npt.NDArray[np.bool_]) -> IntArray:
    """Grid points within ``dt/2`` of a sample the point before took as its own too.

    A sample half a step between two grid points is within ``dt/2`` of both (the tie
    :func:`~hybridlog.io.time_grid.past_half_step` allows), and a point with no sample of its own
    beside it (a log sampled every ``1.5*dt``: samples at 0, 1.5, 3 s on a grid of 1 s) takes it a
    second time: one measurement counted as two, where a sample a microsecond further off was
    warned of as bridged.  The later of the two points is the one the log did not measure:
    bridged, as a point beyond half a step is (``unmeasured_outputs``).
    """
    if index.size < 2:
        return np.zeros(0, dtype=np.int64)
    within = ~gap_mask
    twice = (index[1:] == index[:-1]) & within[1:] & within[:-1]
    found: IntArray = np.flatnonzero(twice) + 1
    return found


Resampled = tuple[FloatArray, IntArray, IntArray]
"""What :func:`resample_series` gives of one output: values, points refused, points bridged."""
