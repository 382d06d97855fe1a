"""Times of a log written in messages and reports: fixed point, to the digits they hold.

Every time hybridlog writes for people (an error naming where a run diverged, report.md's
span and switches, a note on held samples) goes through :func:`format_time`.  ``:g``'s six
significant digits wrote every time of a log stamped in Unix time as ``1.7e+09``: an error
"diverged at t = 1.7e+09 s" named no sample, and switches 100 s apart read alike.
"""

from __future__ import annotations

import math

__all__ = ["format_time"]


def format_time(seconds: float | None) -> str:
    """A time in fixed point, to the digits its float holds (at most the nanosecond).

    Near 1.7e9 s a float holds the microsecond (its spacing is 238 ns), so
    ``1700000101.01``; small times to the nanosecond, so ``0.2`` for 0.1999999999999993.
    ``None`` is ``n/a``.

    Examples
    --------
    >>> format_time(1700000101.01)
    '1700000101.01'
    >>> format_time(0.1999999999999993)
    '0.2'
    """
    if seconds is None:
        return "n/a"
    seconds = float(seconds)
    if not math.isfinite(seconds):
        return str(seconds)
    spacing = math.ulp(abs(seconds))
    decimals = 9 if spacing <= 1e-9 else max(0, math.floor(-math.log10(spacing)))
    text = f"{seconds:.{decimals}f}"
    text = text.rstrip("0").rstrip(".") if "." in text else text
    return "0" if text in ("-0", "") else text
