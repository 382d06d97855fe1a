"""Numbers a user typed on the command line, read strictly.

Python's ``int()`` and ``float()`` are lenient: they accept underscores (``1_0`` is 10), any
Unicode decimal digits (``٣`` is 3), surrounding Unicode whitespace, and ``float()`` also
``inf``, ``infinity`` and ``nan``.  A typo read so runs a different analysis without a word,
so every number hybridlog reads from text the user typed (numeric options, ``--set``
values, gate bounds) goes through :func:`parse_int` or :func:`parse_float`, which accept
only:

* a whole number: ASCII digits with an optional sign (``42``, ``-3``, ``+7``);
* a number: the same with an optional decimal point and exponent (``0.5``, ``.5``, ``5.``,
  ``1e-3``, ``-2.5E+4``), finite.

ASCII whitespace around the text is ignored (``' 2'`` is 2); nothing else is: ``0x10``,
``1_000``, ``1,5``, non-ASCII digits and ``inf``/``nan`` are refused.  Numbers in model
files are typed by the TOML parser, but those written inside text (a ``[simulation]``
schedule, a scenario's command values and steps) come here too.

Comma-separated lists a user types (``--estimators``, ``output_lags``, ``cluster_modes``)
are split by :func:`comma_items`, which refuses an empty item (``a,,b``, ``a,``): a name or
number left out, which skipping would hide.
"""

from __future__ import annotations

import math
import re
import sys

_WHITESPACE = " \t\n\r\f\v"
"""The ASCII whitespace ignored around a number."""

_WHOLE = re.compile(r"[+-]?[0-9]+", re.ASCII)
_DECIMAL = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?", re.ASCII)


def parse_int(text: str) -> int:
    """``text`` as a whole number: ASCII digits with an optional sign.

    Raises
    ------
    ValueError
        ``expected a whole number`` for anything else (the caller names the option and
        the value).

    Examples
    --------
    >>> parse_int(" -12 ")
    -12
    >>> parse_int("1_0")
    Traceback (most recent call last):
    ...
    ValueError: expected a whole number
    """
    stripped = text.strip(_WHITESPACE)
    if _WHOLE.fullmatch(stripped) is None:
        raise ValueError("expected a whole number")
    try:
        return int(stripped)
    except ValueError:  # more digits than Python converts (sys.get_int_max_str_digits)
        raise ValueError("expected a whole number of fewer digits") from None


_SMALLEST_NORMAL = sys.float_info.min
"""The smallest normal double: a typed number below it (but 0) loses digits or becomes 0."""


def parse_float(text: str) -> float:
    """``text`` as a finite number: ASCII digits, sign, decimal point and exponent.

    Raises
    ------
    ValueError
        ``expected a finite number`` for anything else, ``inf``, ``nan`` and a value beyond
        the range of a float (``1e999``) included; a number other than 0 smaller in
        magnitude than a double holds in full (``1e-400``, read as 0; ``1e-310``, a few
        digits), as a model file's value is refused (``model/toml_text.py``).

    Examples
    --------
    >>> parse_float("1e-3")
    0.001
    >>> parse_float("infinity")
    Traceback (most recent call last):
    ...
    ValueError: expected a finite number
    """
    stripped = text.strip(_WHITESPACE)
    if _DECIMAL.fullmatch(stripped) is None:
        raise ValueError("expected a finite number")
    value = float(stripped)
    if not math.isfinite(value):
        raise ValueError("expected a finite number")
    mantissa = stripped.lower().partition("e")[0]
    if abs(value) < _SMALLEST_NORMAL and any(c in "123456789" for c in mantissa):
        raise ValueError(
            f"expected a number a double holds in full (0, or at least {_SMALLEST_NORMAL:.4g} "
            f"in magnitude; it would be read as {value!r})"
        )
    return value


def comma_items(text: str, what: str) -> tuple[str, ...]:
    """The items of a comma-separated list, stripped; no items for a blank ``text``.

    Raises
    ------
    ValueError
        An empty item: ``item 2 of '0,,1' is empty; separate the <what> with single commas``.
    """
    if not text.strip():
        return ()
    items = tuple(item.strip() for item in text.split(","))
    if "" in items:
        shown = text if len(text) <= 60 else text[:59] + "…"
        raise ValueError(
            f"item {items.index('') + 1} of {shown!r} is empty; separate the {what} with "
            "single commas"
        )
    return items
