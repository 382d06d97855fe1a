"""Times of a log written in messages and reports: fixed point, to the digits they hold.

Every time hybridlog writes for people (an error naming where a run diverged, report.md's
span and switches, a note on held samples) goes through :func:`format_time`.  ``:g``'s six
significant digits wrote every time of a log stamped in Unix time as ``1.7e+09``: an error
"diverged at t = 1.7e+09 s" named no sample, and switches 100 s apart read alike.

A duration that is the difference of two such times (how long an input was held, how much
of the log was left out) holds no more digits than they do: :func:`round_duration` for
report.json, :func:`format_duration` for people.  A 0.51 s hold between two float times near
1.7e9 s was 0.509999762 in report.json, and ``:g`` wrote a 123456.75 s span 123457.
"""

from __future__ import annotations

import math
from decimal import Decimal

__all__ = ["format_duration", "format_time", "round_duration"]


def _decimals(seconds: float, *times: float) -> int:
    """Decimals of a second the float of the largest of ``seconds`` and ``times`` holds (<= 9).

    ``seconds`` is finite; infinite and NaN ``times`` are left out.  One loop, no generator:
    a report writes a time this way per missed mode switch (10^4 of them in a 10^6-row log).
    """
    magnitude = abs(seconds)
    for time in times:
        if math.isfinite(time) and abs(time) > magnitude:
            magnitude = abs(time)
    spacing = math.ulp(magnitude)
    return 9 if spacing <= 1e-9 else max(0, math.floor(-math.log10(spacing)))


def _fixed(seconds: float, decimals: int) -> str:
    """``seconds`` to ``decimals`` places, without trailing zeros (``-0`` is ``0``)."""
    text = f"{seconds:.{decimals}f}"
    text = text.rstrip("0").rstrip(".") if "." in text else text
    return "0" if text in ("-0", "") else text


def format_time(seconds: float | None, *, below_ns: bool = False) -> str:
    """A time in fixed point, to the digits its float holds (at most the nanosecond).

    Near 1.7e9 s a float holds the microsecond (its spacing is 238 ns), so
    ``1700000101.01``; small times to the nanosecond, so ``0.2`` for 0.1999999999999993.
    ``None`` is ``n/a``.  ``below_ns``: a time said to lie between whole nanoseconds, in
    its float's shortest digits (``0.0000000175``, which the nanosecond wrote ``0.000000018``,
    the very nanosecond it was said to be off).

    Examples
    --------
    >>> format_time(1700000101.01)
    '1700000101.01'
    >>> format_time(0.1999999999999993)
    '0.2'
    >>> format_time(1.75e-08, below_ns=True)
    '0.0000000175'
    """
    if below_ns and seconds is not None and math.isfinite(seconds):
        exponent = Decimal(repr(seconds)).as_tuple().exponent  # an int: the time is finite
        return _fixed(seconds, max(0, -int(exponent)))
    return format_duration(seconds)


def round_duration(seconds: float, *times: float) -> float:
    """``seconds``, a difference of ``times``, rounded to the digits the largest time holds.

    Two float times near 1.7e9 s are 238 ns apart at best, so their difference is good to
    the microsecond: 0.509999762 is 0.51.  Small times hold the nanosecond (kept).

    Examples
    --------
    >>> round_duration(0.509999762, 1700000000.49, 1700000001.0)
    0.51
    >>> round_duration(0.509999762, 0.49, 1.0)
    0.509999762
    """
    seconds = float(seconds)
    if not math.isfinite(seconds):
        return seconds
    return round(seconds, _decimals(seconds, *times))


def format_duration(seconds: float | None, *times: float) -> str:
    """A duration for people: :func:`round_duration`'s digits in fixed point.

    ``:g`` wrote a 123456.75 s hold 123457 and one of 1.5e-05 s in exponent form; ``None``
    is ``n/a``.  Without ``times`` it is :func:`format_time`'s form: the digits ``seconds``
    itself holds.

    Examples
    --------
    >>> format_duration(123456.75, 1700000000.0)
    '123456.75'
    >>> format_duration(0.509999762, 1700000000.49, 1700000001.0)
    '0.51'
    """
    if seconds is None:
        return "n/a"
    seconds = float(seconds)
    if not math.isfinite(seconds):
        return str(seconds)
    return _fixed(seconds, _decimals(seconds, *times))
