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
- Non-finite values (NaN, +inf, -inf) are counted apart from the samples, because
  ``analyze`` refuses them in a mapped signal (unless ``--drop-nonfinite``).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from hybridlog.signals import IntArray

GAP_FACTOR = 1.5
"""A step longer than this multiple of the median step is a gap; timing is regular when every
step lies between the median step divided and multiplied by it."""
MAX_LISTED_GAPS = 1000
"""At most this many gaps are listed (all are counted)."""


def describe_steps(time_ns: IntArray, *, gaps: bool = True) -> dict[str, Any]:
    """Rate, median step, spread of the steps and gaps of increasing sample times.

    Parameters
    ----------
    time_ns:
        Sample times in integer nanoseconds, non-decreasing.
    gaps:
        Whether to find the gaps (``gap_count`` and ``gaps`` are left out without).

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
        step, and ``rate_hz`` also when the span is zero; times that repeat make the timing
        irregular, unless every time is the same (median step zero, nothing is a gap).
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
    median = float(np.median(forward)) if forward.size else 0.0
    shortest, longest = int(steps.min()), int(steps.max())
    if span > 0:
        info["rate_hz"] = (time_ns.size - 1) * 1e9 / span
    info["sample_time"] = median / 1e9
    info["min_step"] = shortest / 1e9
    info["max_step"] = longest / 1e9
    info["regular"] = median / GAP_FACTOR <= shortest and longest <= GAP_FACTOR * median
    info["repeated"] = int(steps.size - forward.size)
    if gaps and median > 0:
        starts = np.flatnonzero(steps > GAP_FACTOR * median)
        info["gap_count"] = int(starts.size)
        info["gaps"] = [
            {
                "start": int(time_ns[i]) / 1e9,
                "end": int(time_ns[i + 1]) / 1e9,
                "duration": int(steps[i]) / 1e9,
            }
            for i in starts[:MAX_LISTED_GAPS].tolist()
        ]
    return info


def count_nonfinite(values: npt.NDArray[np.floating[Any]]) -> int:
    """How many of ``values`` are NaN, +inf or -inf."""
    return int(values.size - np.count_nonzero(np.isfinite(values)))
