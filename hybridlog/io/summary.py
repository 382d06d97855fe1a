"""The statistics ``hybridlog inspect`` reports, computed once for every log format.

Tables (per column and for the time column) and message logs (per topic) describe their
timing with :func:`describe_steps` and their values with :func:`count_nonfinite`, so a rate,
a gap or a count of NaNs means the same whatever the format.

- The rate is the *mean* rate over the span, ``(n - 1) / (t_last - t_first)``: what the log
  holds.  The median step (``sample_time``) is reported beside it, as the nominal sample
  time; on a log whose steps vary (bursts, gaps) the two disagree and ``1 / sample_time``
  would overstate the rate, so the steps' range is given and the timing called irregular.
- A step longer than :data:`GAP_FACTOR` times the median step is a gap; timing is regular
  when every step lies within a factor :data:`GAP_FACTOR` of the median step.
- Non-finite values (NaN, +inf, -inf), and values out of range (``|value| >= 2^480``, what
  corrupt bytes decode to), are counted apart from the samples, because ``analyze``
  refuses them in a mapped signal (unless ``--drop-nonfinite``).
- Steps, spans and gap lengths are differences of times, and hold no more digits than the
  times do: seconds stored as float64 near a Unix time (1.7e9 s) are 238 ns apart, so the
  difference of two of them is off by as much, and a 100 Hz log's step read 0.00999999 s.
  Each is rounded to the power of ten of nanoseconds at or above that resolution
  (:func:`seconds_resolution_ns`, :func:`round_span`): 0.01 s, to the microsecond there.
  Integer nanoseconds (bags, MCAP, dates) are exact and kept whole.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

from hybridlog.io.source import seconds_of, usable_values
from hybridlog.signals import IntArray

GAP_FACTOR = 1.5
"""A step longer than this multiple of the median step is a gap; timing is regular when every
step lies between the median step divided and multiplied by it."""
MAX_LISTED_GAPS = 1000
"""At most this many gaps are listed (all are counted)."""


def seconds_resolution_ns(
    seconds: npt.NDArray[np.floating[Any]], kind: type[np.floating[Any]] = np.float64
) -> float:
    """How far apart, in nanoseconds, times stored as ``seconds`` can be told.

    The spacing of ``kind`` (the type the times were stored as) at the largest magnitude
    among them, at least 1 ns.

    Examples
    --------
    >>> round(seconds_resolution_ns(np.array([1.7e9])), 1)
    238.4
    >>> seconds_resolution_ns(np.array([0.0, 12.5]))
    1.0
    """
    if seconds.size == 0:
        return 1.0
    # from the least and greatest (no array of N magnitudes); NaN if any is NaN
    largest = float(np.max(np.abs([np.min(seconds), np.max(seconds)])))
    spacing = float(np.spacing(kind(largest)))
    return max(spacing * 1e9, 1.0) if math.isfinite(spacing) else 1.0


def round_span(ns: float, resolution_ns: float = 1.0) -> float:
    """A difference of two times (``ns`` nanoseconds) in seconds, to the digits it holds.

    Rounded to the smallest power of ten of nanoseconds at or above ``resolution_ns``, the
    resolution of the times it is the difference of: 9999990 ns read from float64 seconds
    near 1.7e9 s (resolution 238 ns) is 0.01 s, to the microsecond.

    Examples
    --------
    >>> round_span(9_999_990, 238.4)
    0.01
    >>> round_span(9_999_990)
    0.00999999
    """
    quantum = 10 ** max(math.ceil(math.log10(resolution_ns) - 1e-12), 0)
    return float(round(ns / quantum) * quantum / 1e9)


def describe_steps(
    time_ns: IntArray, *, gaps: bool = True, resolution_ns: float = 1.0
) -> dict[str, Any]:
    """Rate, median step, spread of the steps and gaps of increasing sample times.

    Parameters
    ----------
    time_ns:
        Sample times in integer nanoseconds, non-decreasing.
    gaps:
        Whether to find the gaps (``gap_count`` and ``gaps`` are left out without).
    resolution_ns:
        How far apart the times could be told where they were read from
        (:func:`seconds_resolution_ns`); steps, spans and gap lengths are rounded to it
        (:func:`round_span`).  1 for integer nanoseconds.

    Returns
    -------
    dict
        JSON-serialisable, times in seconds: ``rate_hz`` (mean rate over the span,
        ``(n - 1) / duration``), ``sample_time`` (median step; times that repeat are no
        step, so a message published twice hides no gap), ``min_step``, ``max_step``,
        ``regular`` (every step within a factor :data:`GAP_FACTOR` of the median),
        ``repeated`` (how many samples have the time of the one before, which ``analyze``
        refuses unless ``--sort``), and with ``gaps`` also ``gap_count`` and ``gaps``
        (``start, end, duration`` of every step longer than :data:`GAP_FACTOR` times the
        median, at most :data:`MAX_LISTED_GAPS` listed).
        Each is ``None`` (``0`` and ``[]`` for the gaps) when fewer than two samples give no
        step; ``rate_hz``, ``sample_time`` and ``regular`` also when every sample has the
        same time (no step forward: a sample time of 0 s was no sample time, and called
        regular); times that repeat make the timing irregular.
    """
    info: dict[str, Any] = {
        "rate_hz": None,
        "sample_time": None,
        "min_step": None,
        "max_step": None,
        "regular": None,
        "repeated": None,
    }
    if gaps:
        info.update(gap_count=0, gaps=[])
    if time_ns.size < 2:
        return info
    steps = np.diff(time_ns)
    span = int(time_ns[-1]) - int(time_ns[0])
    # times that repeat (a message published twice) are no step in time: with as many
    # repeats as steps, a median of zero would hide every gap
    forward = steps[steps > 0]
    shortest, longest = int(steps.min()), int(steps.max())
    seconds = round_span(span, resolution_ns)
    if seconds > 0:
        info["rate_hz"] = (time_ns.size - 1) / seconds
    info["min_step"] = round_span(shortest, resolution_ns)
    info["max_step"] = round_span(longest, resolution_ns)
    info["repeated"] = int(steps.size - forward.size)
    if not forward.size:  # every sample at one time: no step, so no sample time to judge by
        return info
    median = float(np.median(forward))
    info["sample_time"] = round_span(median, resolution_ns)
    info["regular"] = median / GAP_FACTOR <= shortest and longest <= GAP_FACTOR * median
    if gaps:
        starts = np.flatnonzero(steps > GAP_FACTOR * median)
        info["gap_count"] = int(starts.size)
        info["gaps"] = [
            {
                "start": seconds_of(time_ns[i]),
                "end": seconds_of(time_ns[i + 1]),
                "duration": round_span(int(steps[i]), resolution_ns),
            }
            for i in starts[:MAX_LISTED_GAPS].tolist()
        ]
    return info


def count_nonfinite(values: npt.NDArray[np.floating[Any]]) -> int:
    """How many of ``values`` are NaN, +inf, -inf or out of range (:func:`usable_values`)."""
    return int(values.size - np.count_nonzero(usable_values(values)))
