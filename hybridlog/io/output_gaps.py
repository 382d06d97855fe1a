"""Gaps in an output longer than ``max_gap``: which step is one, and the error that names it.

A step between two samples is a gap beyond ``max(max_gap, dt)`` (:func:`gap_threshold`); a
gap the grid is sure to refuse is found before the grid is made (:func:`gap_on_the_grid`),
and refused naming the output, where and how long (:func:`gap_error`), with a hint when the
series is sampled slower than ``max_gap`` allows (:func:`slower_than_max_gap`).
"""

from __future__ import annotations

import numpy as np

from hybridlog.errors import LogError
from hybridlog.io.source import Series, format_ns
from hybridlog.io.time_grid import clock_tolerance_ns, longer_than_max_gap
from hybridlog.signals import IntArray


def gap_on_the_grid(
    series: Series, span: tuple[int, int], dt_ns: int, max_gap_ns: int
) -> IntArray | None:
    """A time inside the first gap of ``series`` that the grid check is sure to refuse.

    :func:`~hybridlog.io.resampling.resample_series` finds every gap longer than ``max_gap``, but on
    the grid, whose size follows from the log's span: a log whose times are not seconds (nanoseconds
    from 0, 10^9 times too long) would have a grid of hundreds of GiB made before its first
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


def gap_error(
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
    hint = slower_than_max_gap(series, max_gap_ns, dt_ns) or (
        "; --max-gap SECONDS accepts longer gaps, --split-gaps analyses the longest piece "
        "between them"
    )
    return LogError(
        f"{source}: gap in {label} ({field_word} {series.name!r}): no {usable}sample {where}{hint}"
    )


def slower_than_max_gap(series: Series, max_gap_ns: int, dt_ns: int) -> str:
    """A hint when ``series`` is sampled slower than ``max_gap`` allows, else ``""``.

    Then (nearly) every step is a gap: ``max_gap`` is shorter than the log's sample time, or
    (asked when the series is slower than ``dt``) the model's ``dt`` is not the log's.
    """
    if series.time_ns.size < 2:
        return ""
    median = round(float(np.median(np.diff(series.time_ns))))
    if not longer_than_max_gap(median, gap_threshold(max_gap_ns, dt_ns), dt_ns):
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


def gap_threshold(max_gap_ns: int, dt_ns: int) -> int:
    """The step between two samples that is a gap: ``max(max_gap, dt)``.

    Samples ``dt`` apart leave no grid point without a sample within ``dt/2``, which is what
    the reading refuses as a gap: with ``--max-gap 0`` (or anything under ``dt``) an input
    sampled at ``dt`` is not held over ``max_gap``, and a linear interpolation is drawn
    between outputs sampled at ``dt``.  (``--split-gaps`` cuts where the grid refuses a gap,
    :func:`~hybridlog.io.log_pieces.split_at_refused_gaps`.)
    """
    return max(max_gap_ns, dt_ns)
