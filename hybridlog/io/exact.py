"""Integers a ``float64`` cannot hold: refused where a log's number becomes a signal value.

Every signal value is a ``float64``, whose 53-bit significand holds every integer up to
2^53 (9,007,199,254,740,992) and beyond it only some: 2^53 + 1, an ``int64`` counter or a
``uint64`` id in a Parquet column or a ROS message, read as 2^53, its last digits lost
without a word.  A value whose ``float64`` is not the number the log holds is an error
naming where it is; a number beyond 2^53 that the ``float64`` holds exactly (2^60, 1e20) is
read as it is.  What counts as the log's number: an integer (Parquet integer columns, ROS
and Protobuf integer fields, JSON integers), a Parquet decimal, and a CSV cell written as a
whole number (digits, an optional sign); a number written with a decimal point or an
exponent is rounded to the nearest ``float64``, as every decimal fraction is.

Labels (true modes) are never numbers here: an integer mode id is read as its digits, so
ids beyond 2^53 stay distinct (:func:`hybridlog.io.table_labels._as_labels`,
:func:`hybridlog.io.message_paths.as_label`).
"""

from __future__ import annotations

import re
from decimal import Decimal
from typing import Any

import numpy as np

from hybridlog.signals import FloatArray

EXACT_LIMIT = 2**53
"""Integers of at most this magnitude are all held exactly by a ``float64``."""

WHOLE_NUMBER = r"^\s*[+-]?[0-9]+\s*$"
"""Text of a whole number: digits, an optional sign, blanks around (a CSV cell)."""

_WHOLE = re.compile(WHOLE_NUMBER)


def beyond_exact(values: FloatArray) -> np.ndarray[Any, np.dtype[np.bool_]]:
    """Which of ``values`` (already ``float64``) may stand for a number they do not hold.

    A ``float64`` of magnitude at least 2^53 (an integer beyond 2^53 rounds to 2^53 at
    least); NaN is not.
    """
    with np.errstate(invalid="ignore"):
        found: np.ndarray[Any, np.dtype[np.bool_]] = np.abs(values) >= EXACT_LIMIT
    return found


def any_beyond_exact(values: FloatArray) -> bool:
    """Whether any of ``values`` is :func:`beyond_exact`, or NaN.

    Their least and greatest values alone (no array of N magnitudes, nor of N answers):
    a NaN among them makes both NaN, and the answer ``True``, for :func:`beyond_exact` to
    look again.
    """
    return bool(values.size) and not (values.min() > -EXACT_LIMIT and values.max() < EXACT_LIMIT)


def inexact(value: object) -> str | None:
    """Why ``value`` (a decoded number, or a CSV cell's text) is not what its ``float64`` is.

    ``None`` when it is: a ``float``, a boolean, an integer or decimal the ``float64`` holds
    exactly, text that is not a whole number.  Else a reason such as ``9007199254740993 is
    an integer beyond 2^53, which a float64 cannot hold (it would read as
    9007199254740992)``.
    """
    number: int | Decimal
    if isinstance(value, (bool, np.bool_, float, np.floating)):
        return None
    if isinstance(value, (int, np.integer)):
        number = int(value)
    elif isinstance(value, Decimal):
        number = value
    elif isinstance(value, str) and _WHOLE.match(value):
        number = int(value)
    else:
        return None
    if -EXACT_LIMIT <= number <= EXACT_LIMIT:
        return None
    try:
        held = float(number)
    except OverflowError:
        return None  # beyond a float64's range: infinite, refused as such by the readers
    if Decimal(held) == Decimal(number):
        return None
    kind = "an integer" if number == int(number) else "a decimal"
    shown = number if isinstance(number, int) else format(number, "f")
    return (
        f"{shown} is {kind} beyond 2^53, which a float64 cannot hold (it would read as {int(held)})"
    )
