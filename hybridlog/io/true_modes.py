"""The true mode on the grid: held, or a sampled one's silences left without a true mode.

A true mode recorded only at its switches (:func:`records_switches`) is held however long it
is silent; one that repeats its label is sampled, and the grid points of a stretch without a
sample get :data:`~hybridlog.signals.NO_TRUE_MODE` (:func:`_blank_gaps`), as do those before
a true mode that starts late (:func:`hold_modes`; where it starts, :func:`truth_start`).  The
rules are :mod:`hybridlog.io.align`'s (SPEC §5).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from hybridlog.errors import LogError
from hybridlog.io.alignment_notes import seconds_between
from hybridlog.io.resampling import hold_index, jittered_index, nearest_index, on_grid
from hybridlog.io.source import NS_PER_S, LabelSeries
from hybridlog.io.time_grid import longer_than_max_gap, past_half_step, sampled_around
from hybridlog.signals import NO_TRUE_MODE, IntArray, covered_from


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


def hold_modes(
    what: str,
    field_word: str,
    series: LabelSeries,
    grid: IntArray,
    steps: tuple[int, int],
    jitter: dict[str, Any] | None = None,
    label: str = "mode",
) -> tuple[IntArray, dict[str, Any] | None]:
    """The true mode (code) at each grid point, held like an input (:func:`.jittered_index`).

    A sampled one around the grid's points (:func:`~hybridlog.io.time_grid.sampled_around`) takes
    the nearest sample, as the outputs logged in its rows are read
    (:func:`~hybridlog.io.resampling.nearest_index`).  ``steps``: ``dt`` and the clock tolerance
    (ns).  A jittered series' :class:`~hybridlog.io.resampling.Jittered` goes into ``jitter`` under
    ``the true <label>``.  Returns the codes and the stretches of a sampled true mode left without
    one (:func:`_blank_gaps`), or ``None``.
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
    elif sampled and sampled_around(series, int(grid[0]), dt_ns):
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
    :func:`~hybridlog.io.time_grid.longer_than_max_gap`), or from the last sample to the grid's end,
    may hide a switch, however short: its grid points more than ``dt/2`` from both samples get
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
        "seconds": seconds_between(begin, end),
        "gaps": int(stretches.size),
        "points": int(np.count_nonzero(blank)),
        "of": int(grid.size),
    }


def truth_start(series: LabelSeries, codes: IntArray, grid: IntArray) -> dict[str, Any] | None:
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
