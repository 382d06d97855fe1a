"""How much of a log the mode metrics of a report cover, in words for the summaries.

A true mode that starts after the first sample time is scored from its first sample on
(``modes.samples``, ``reading.truth_starts``), and a sampled one is not scored where it has
no sample within ``dt/2`` (``reading.truth_gaps``, a gap of any length), where it may have
switched unseen.  report.md says so; the summaries of ``batch`` (summary.csv's
``mode_samples``, summary.md, JUnit) and a missed gate's message say it with
:func:`mode_coverage`, so that a log's 100 % over its last third does not read as a whole
log's 100 % beside the others.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from hybridlog.times import format_duration, format_time

if TYPE_CHECKING:
    from hybridlog.report.document import Report

__all__ = ["component_coverage", "mode_coverage", "samples_coverage"]


def _number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _starts(reading: Mapping[str, Any] | None, only: str | None = None) -> list[str]:
    """What the true modes that leave samples without one say, a phrase each.

    ``the true mode.fr2 starts at t = 30000 s`` per true mode that starts late, ``the true
    mode has no sample from t = 10 to 20 s`` per one with gaps (``reading.truth_gaps``).
    ``only``: that true mode's alone (``"mode.fr2"``).
    """
    said = []
    for key in ("truth_starts", "truth_gaps"):
        entries = (reading or {}).get(key)
        if not isinstance(entries, dict):
            continue
        for label, entry in entries.items():
            if only not in (None, label) or not isinstance(entry, dict):
                continue
            if key == "truth_starts":
                if _number(entry.get("at")):
                    said.append(f"the true {label} starts at t = {format_time(entry['at'])} s")
            elif all(_number(entry.get(k)) for k in ("start", "end", "gaps", "points")):
                said.append(f"the true {label} has no sample {_gaps(entry)}")
    return said


def _gaps(entry: Mapping[str, Any]) -> str:
    """``from t = 10 to 20 s`` or ``in 3 stretches (120 samples), the longest from … s``."""
    start, end = entry["start"], entry["end"]
    span = f"from t = {format_time(start)} to {format_time(end)} s"
    count = int(entry["gaps"])
    if count == 1:
        return span
    seconds = entry.get("seconds")
    length = format_duration(seconds, start, end) if _number(seconds) else None
    points = int(entry["points"])
    longest = f"the longest {span}" + (f" ({length} s)" if length else "")
    return f"in {count:,} stretches ({points:,} samples), {longest}"


def samples_coverage(
    scored: int | None,
    samples: int,
    reading: Mapping[str, Any] | None,
    *,
    only: str | None = None,
) -> str | None:
    """``1,001 of 1,501 samples (the true mode.fr2 starts at t = 30000 s)``, or ``None``.

    The words of :func:`mode_coverage` for a mode accuracy over ``scored`` of ``samples``
    samples, where ``reading`` is what reading the log recorded (``truth_starts``,
    ``truth_gaps``); ``only`` names the one true mode whose start and gaps to give
    (``"mode.fr2"``; ``None``: every one).
    ``None`` when ``scored`` is ``None`` or every sample.  ``hybridlog cluster`` says its
    decision rule's accuracy over part of a log with it.
    """
    if scored is None or scored >= samples:
        return None
    where = "; ".join(_starts(reading, only))
    return f"{scored:,} of {samples:,} samples" + (f" ({where})" if where else "")


def mode_coverage(report: Report) -> str | None:
    """``1,001 of 1,501 samples (the true mode.fr2 starts at t = 30000 s)``, or ``None``.

    ``None`` when the mode metrics (``mode_accuracy``: for a ``[components]`` model the
    joint one) score every sample, or without a true mode.
    """
    return samples_coverage(report.modes.samples, report.samples, report.reading)


def component_coverage(report: Report, component: str) -> str | None:
    """As :func:`mode_coverage` for one component's own metrics (``mode_accuracy.<c>``)."""
    modes = report.modes.components.get(component)
    scored = None if modes is None else modes.samples
    return samples_coverage(scored, report.samples, report.reading, only=f"mode.{component}")
