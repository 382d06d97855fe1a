"""A model file's bytes → its TOML table, with errors that name the line or the key.

:mod:`tomllib` reads a number literal no double holds as some other number without a word:
``1e-400`` is ``0.0`` (a measurement noise of 1e-400 became a noiseless sensor, a command
value of a ``when`` rule became 0), ``1e-310`` keeps two of its digits, ``1e400`` is ``inf``,
and a 400-digit integer passed the reader and crashed the loader (``OverflowError``).  Here
each such literal is refused, naming its key.  Its errors say what they mean and where:
``Cannot overwrite a value (at end of document)``, tomllib's word for a key given twice in
the last line, is ``line 88: a key given twice, or a value and a table of one name: ...``;
a file that is not UTF-8 names the line of its first bad byte.

Every error here is a :class:`~hybridlog.errors.ModelError` without the file's name, which
the caller prefixes.  Nothing here imports sympy: the loaded-model cache reads the file's
bytes with :func:`decode_model_file` on its warm path.
"""

from __future__ import annotations

import re
import sys
import tomllib
import unicodedata
from typing import Any

from hybridlog.errors import ModelError, excerpt

__all__ = [
    "MAX_NESTING",
    "PLAIN_KEY_LIMIT",
    "decode_model_file",
    "key_path",
    "read_toml",
    "spelled",
]

MAX_NESTING = 32
"""Deepest nesting of tables and arrays read (a model file's deepest keys have 6 levels:
``components.<c>.modes.<m>.process_noise.<x>``)."""
PLAIN_KEY_LIMIT = 64
"""Longest key shown unquoted in a key path (the longest mode id or component name)."""

_SMALLEST = sys.float_info.min
"""The smallest normal double (2.2e-308): below it a double holds fewer significant digits."""
_LARGEST = sys.float_info.max
_POSITION = re.compile(r"\s*\(at (?:line (\d+), column \d+|end of document)\)$")
_HINTS = {
    "Cannot overwrite a value": "a key given twice, or given both a value and a table",
    "Cannot declare": "a table declared twice",
}
"""Plain words for tomllib's messages about keys given twice (by their start)."""


class _Unheld(float):
    """A float literal no double holds as written: the number tomllib made of it, and the text."""

    literal: str


def held_digits(value: float) -> str:
    """A double below the normal range with every digit it keeps (``9.9999999999999694e-311``).

    ``repr`` shows the shortest text that reads back as the double, ``1e-310``: as if the
    number written were held, where only 2 of its 17 digits are.
    """
    return repr(value) if value == 0 else format(value, ".17g")


def unheld_number(literal: str, value: float) -> str:
    """Why the double ``value`` read from the number ``literal`` is not that number, or ``""``.

    A literal with a nonzero digit below the smallest normal double (``1e-400`` is read as
    0, ``1e-310`` keeps two digits), or beyond the largest (``1e400`` is ``inf``, a
    400-digit integer no double at all).  ``inf`` and ``nan`` written as such are numbers
    the key reading them judges.
    """
    mantissa = literal.lower().lstrip("+-").split("e")[0]
    if mantissa in ("inf", "nan"):
        return ""
    if isinstance(value, int):
        return _beyond_doubles(value) if abs(value) > _LARGEST else ""
    if abs(value) == float("inf"):
        return f"{excerpt(literal, 40)} is beyond the largest double ({_LARGEST:.4g})"
    if any(c in "123456789" for c in mantissa) and abs(value) < _SMALLEST:
        return (
            f"{excerpt(literal, 40)} is smaller in magnitude than a double holds in full "
            f"({_SMALLEST:.4g}; it would be read as {held_digits(value)}); write 0 or a larger "
            "number"
        )
    return ""


def _beyond_doubles(value: int) -> str:
    """Why the integer ``value``, beyond the largest double, is refused."""
    try:
        digits = f"{len(str(abs(value))):,}"
    except ValueError:  # more digits than str() writes (sys.get_int_max_str_digits): 0x...
        digits = f"more than {sys.get_int_max_str_digits():,}"
    return digits_beyond(digits)


def digits_beyond(digits: str) -> str:
    """``a whole number of <digits> digits is beyond the largest double (...)``."""
    return f"a whole number of {digits} digits is beyond the largest double ({_LARGEST:.4g})"


def _long_integer(text: str, err: ValueError) -> str:
    """``line N: ...`` for the decimal literal of more digits than int() reads (4,300).

    tomllib raises a plain ValueError for it, with neither line nor key.
    """
    most = sys.get_int_max_str_digits()
    found = re.search(rf"(?<![\w.])\d(?:_?\d){{{most},}}(?![\w.])", text) if most else None
    if found is None:
        return f"invalid TOML: {excerpt(str(err), 120)}"
    digits = len(found.group().replace("_", "").lstrip("0"))
    line = text.count("\n", 0, found.start()) + 1
    return f"line {line}: {digits_beyond(f'{digits:,}')}"


def _parse_float(literal: str) -> float:
    """``float(literal)``, marked :class:`_Unheld` when the double is not the number written."""
    value = float(literal)
    if not unheld_number(literal, value):
        return value
    unheld = _Unheld(value)
    unheld.literal = literal
    return unheld


def spelled(value: object) -> str:
    """A TOML value as the model file spells it, for an error: ``true``, ``'slow'``, ``[1, 2]``.

    Python's ``repr`` wrote the file's ``true`` as ``True`` (``initial.mode: expected a mode
    id ..., got True``), a spelling the file never had; the estimators' options spell it so
    too (:func:`hybridlog.estimators.options.shown`).
    """
    if isinstance(value, bool):
        return "true" if value else "false"
    return excerpt(repr(value), 40)[1:-1]


def read_toml(text: str) -> dict[str, Any]:
    """The TOML table of ``text`` (a byte-order mark at the start is skipped).

    Raises
    ------
    ModelError
        Invalid TOML (naming the line, and the line's text), or a number no double holds
        (naming the key).
    """
    try:
        data = tomllib.loads(text.removeprefix("\ufeff"), parse_float=_parse_float)
    except tomllib.TOMLDecodeError as err:
        raise ModelError(_decode_error(text, err)) from err
    except ValueError as err:  # an integer literal of more digits than int() reads
        raise ModelError(_long_integer(text, err)) from err
    except RecursionError as err:  # arrays or inline tables nested thousands deep
        raise ModelError(
            f"invalid TOML: arrays or tables nested too deeply (a model file nests at most "
            f"{MAX_NESTING} levels)"
        ) from err
    _check_values(data)
    return data


def decode_model_file(data: bytes) -> str:
    """The text of a model file's bytes, which must be UTF-8.

    Raises
    ------
    ModelError
        Naming the line of the first byte that is not UTF-8 (or the UTF-16 byte-order mark a
        Windows editor writes).
    """
    if data.startswith((b"\xff\xfe", b"\xfe\xff")):
        raise ModelError(
            "not UTF-8: the file is UTF-16 (it starts with a UTF-16 byte-order mark); "
            "save it as UTF-8"
        )
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as err:
        line = data.count(b"\n", 0, err.start) + 1
        raise ModelError(
            f"line {line}: not UTF-8 (byte 0x{data[err.start]:02x}); save the file as UTF-8"
        ) from err


def key_path(where: str, key: str) -> str:
    """``where.key``, with ``key`` quoted (and cut) unless it is a plain short name."""
    plain = bool(key) and (key.isidentifier() or key.replace("_", "").replace("-", "").isalnum())
    shown = key if plain and len(key) <= PLAIN_KEY_LIMIT else excerpt(key, 40)
    return f"{where}.{shown}" if where else shown


def _decode_error(text: str, err: tomllib.TOMLDecodeError) -> str:
    """``line N: invalid TOML: what (hint): the line's text`` for a tomllib error."""
    message = str(err)
    found = _POSITION.search(message)
    if found is None:
        return f"invalid TOML: {message}"
    what = message[: found.start()]
    lines = text.removeprefix("\ufeff").split("\n")  # tomllib counts "\n" alone
    if found.group(1) is not None:
        number = int(found.group(1))
    else:  # at the end of the document: the last line that holds something
        number = max((i + 1 for i, line in enumerate(lines) if line.strip()), default=1)
    hint = next((h for start, h in _HINTS.items() if what.startswith(start)), "")
    # only TOML's own blanks are trimmed: str.strip() also took away the no-break space or
    # lone carriage return the parser refused, quoting 'time = "discrete"' as invalid
    line = lines[number - 1].removesuffix("\r") if 0 < number <= len(lines) else ""
    shown = line.strip(" \t")
    unquoted = re.sub(r'"[^"]*"|\'[^\']*\'', "", line)  # a string may hold any blank
    blank = next((c for c in unquoted if c.isspace() and c not in " \t"), None)
    if blank is not None:
        hint = ", ".join(filter(None, [hint, _foreign_blank(blank)]))
    return (
        f"line {number}: invalid TOML: {what}"
        + (f" ({hint})" if hint else "")
        + (f": {excerpt(shown, 60)}" if shown else "")
    )


_CONTROL_BLANKS = {"\r": "carriage return", "\x0b": "vertical tab", "\x0c": "form feed"}


def _foreign_blank(character: str) -> str:
    """``U+00A0 NO-BREAK SPACE, which TOML does not read as a space``."""
    name = _CONTROL_BLANKS.get(character) or unicodedata.name(character, "control").lower()
    return f"U+{ord(character):04X} ({name}), which TOML does not read as a space or line end"


_Trail = tuple[str, "_Trail"] | None
"""A value's key path, innermost part first (built as the walk descends: no copies)."""


def _check_values(data: dict[str, Any]) -> None:
    """Refuse a number no double holds, or nesting deeper than :data:`MAX_NESTING`.

    The walk keeps a stack, not Python's: a dotted key of 5,000 parts (which tomllib reads)
    overflowed a recursive walk, and the loader's ``repr`` of such a value in its errors.
    """
    stack: list[tuple[Any, _Trail, int]] = [(data, None, 0)]
    while stack:
        value, trail, depth = stack.pop()
        if depth > MAX_NESTING:
            raise ModelError(
                f"{_where(trail)}: nested more than {MAX_NESTING} levels deep (no model key is)"
            )
        if isinstance(value, dict):
            stack.extend(
                (item, ("." + str(name), trail), depth + 1) for name, item in value.items()
            )
        elif isinstance(value, list):
            stack.extend((item, (f"[{i}]", trail), depth + 1) for i, item in enumerate(value))
        elif isinstance(value, _Unheld):
            raise ModelError(f"{_where(trail)}: {unheld_number(value.literal, float(value))}")
        elif isinstance(value, int) and not isinstance(value, bool) and abs(value) > _LARGEST:
            raise ModelError(f"{_where(trail)}: {_beyond_doubles(value)}")


def _where(trail: _Trail) -> str:
    """The key path of ``trail`` as the loader writes keys (``noise.process[0][1]``)."""
    parts: list[str] = []
    while trail is not None:
        parts.append(trail[0])
        trail = trail[1]
    where = ""
    for part in reversed(parts):
        where = key_path(where, part[1:]) if part.startswith(".") else where + part
    return where
