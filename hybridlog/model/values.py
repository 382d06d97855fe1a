"""Checked reading of TOML values for the model loader; every error names the key.

Each function takes the parsed TOML value and the full key it came from
(``modes.2.process_noise``) and returns a typed value or raises :class:`ModelError` whose
message starts with that key.  User text is quoted with :func:`hybridlog.errors.excerpt`,
so an error stays one short line whatever the file holds.
"""

from __future__ import annotations

import math
import re
import unicodedata
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np
import sympy

from hybridlog.errors import ModelError, excerpt
from hybridlog.model.expressions import expression_text, parse_expression, symbol_name_problem
from hybridlog.model.toml_text import PLAIN_KEY_LIMIT, spelled
from hybridlog.model.toml_text import key_path as key_path  # re-exported for the loaders
from hybridlog.signals import FloatArray

MAX_LABEL = PLAIN_KEY_LIMIT
"""Longest mode id or component name accepted (each is shown plain in a key path)."""
_LABEL_FORBIDDEN = (",", ":", "*", "->")


def check_keys(table: Mapping[str, Any], allowed: set[str], where: str) -> None:
    """Refuse any key of ``table`` not in ``allowed``, naming it and listing the allowed."""
    for key in table:
        if key not in allowed:
            raise ModelError(
                f"{key_path(where, key)}: unknown key (allowed: {', '.join(sorted(allowed))})"
            )


def required(table: Mapping[str, Any], key: str, where: str) -> Any:
    """``table[key]``, or an error naming the missing key.

    A top-level key missing from the top level but written in a table (``dt = 0.1`` below
    ``[parameters]``, where TOML puts every key after the header) is named where it is.
    """
    if key not in table:
        found = _nested_key(table, key) if not where else None
        hint = (
            f" (the file has {found}: a key written below a [table] header belongs to that "
            "table; move it above the first header)"
            if found
            else ""
        )
        raise ModelError(f"{key_path(where, key)}: required key is missing{hint}")
    return table[key]


def _nested_key(table: Mapping[str, Any], key: str) -> str | None:
    """The dotted path of ``key`` in a table of ``table`` or a table of one, or ``None``."""
    for name, value in table.items():
        if not isinstance(value, dict):
            continue
        if key in value:
            return key_path(name, key)
        for inner, spec in value.items():
            if isinstance(spec, dict) and key in spec:
                return key_path(key_path(name, inner), key)
    return None


def as_table(value: Any, key: str) -> dict[str, Any]:
    """A TOML table."""
    if not isinstance(value, dict):
        raise ModelError(f"{key}: expected a table, got {type(value).__name__}")
    return value


def as_string(value: Any, key: str) -> str:
    """A string."""
    if not isinstance(value, str):
        raise ModelError(f"{key}: expected a string, got {type(value).__name__}")
    return value


def as_name(value: Any, key: str) -> str:
    """A string that shows something: a model's ``name``, which every report and summary heads.

    ``name = ""`` was taken: report.md read "model: (empty code)", summary.md "# Batch:  · imm".
    """
    text = as_string(value, key)
    if not text.strip():
        raise ModelError(f"{key}: empty; give the model a name, or leave the key out ('unnamed')")
    return text


def as_number(value: Any, key: str) -> float:
    """A finite number (integer or float, not a boolean)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ModelError(f"{key}: expected a number, got {spelled(value)}")
    if not math.isfinite(value):
        raise ModelError(f"{key}: non-finite number {value!r}")
    return float(value)


def as_positive(value: Any, key: str) -> float:
    """A finite number > 0."""
    number = as_number(value, key)
    if number <= 0:
        raise ModelError(f"{key}: must be positive, got {number!r}")
    return number


def as_probability(value: Any, key: str, *, below_one: bool = False) -> float:
    """A number in [0, 1], or in [0, 1) where ``below_one`` (the range the refusal names)."""
    number = as_number(value, key)
    if not 0.0 <= number <= 1.0 or (below_one and number == 1.0):
        interval = "[0, 1)" if below_one else "[0, 1]"
        raise ModelError(f"{key}: must be a probability in {interval}, got {number!r}")
    return number


def as_label(value: str, key: str, what: str) -> str:
    """A mode id or component name: printable, short, without ``, : * ->``.

    These labels become CSV column names (``p_<mode>``), ``--schedule`` items
    (``MODE:STEPS``) and jump keys (``"a->b"``), so the characters those use are refused,
    and so are leading or trailing spaces (invisible in every one of them).
    """
    if (
        not value
        or len(value) > MAX_LABEL
        or not value.isprintable()
        or value != value.strip()
        or any(bad in value for bad in _LABEL_FORBIDDEN)
    ):
        raise ModelError(
            f"{key}: {excerpt(value, 40)} is not a valid {what} (1 to {MAX_LABEL} printable "
            "characters, no leading or trailing space, no ',', ':', '*' or '->')"
        )
    return value


def check_distinct_labels(labels: Iterable[tuple[str, str]], what: str) -> None:
    """Refuse two labels (``(label, key)`` pairs) that are one text in two Unicode forms.

    ``é`` written as one character (NFC) and as ``e`` with a combining accent (NFD) are
    distinct TOML keys but look the same wherever hybridlog shows them: two modes ``é``
    gave report.md a dwell table and a confusion matrix with two rows of the same name,
    timeline.csv two ``p_é`` columns and modes.png two rows of the same label, with
    nothing to tell which was which.  Compared in NFC form; the error names the later key.
    """
    seen: dict[str, str] = {}
    for label, key in labels:
        normal = unicodedata.normalize("NFC", label)
        if normal in seen:
            raise ModelError(
                f"{key}: {excerpt(label, 40)} is the {what} {excerpt(seen[normal], 40)} "
                "written in another Unicode form (precomposed or combining characters): "
                "reports, tables and plots would show the two alike; give them ids that "
                "differ in what they show"
            )
        seen[normal] = label


_DECIMAL = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?", re.ASCII)
"""A number written in decimal or exponent notation, as a log's number cell is (ASCII digits:
no reader takes ``١.٥`` for a number, so such a mode id is a label like any other)."""


def as_mode_id(value: str, key: str) -> str:
    """A mode id (:func:`as_label`) that a log can hold: a number only as logs write it.

    A log's true mode may be a number (a Parquet or message field, a CSV column of numbers),
    which the readers write back as text the one way (a whole number without ``.0``, else
    Python's shortest form; :func:`hybridlog.io.message_paths.as_label`).  A mode id such as
    ``1.0``, ``1e3`` or ``2.50`` would never be found in such a log, and beside mode ``1``
    the true mode ``1.0`` of a CSV column of numbers was silently read as mode ``1``.
    """
    label = as_label(value, key, "mode id")
    if _DECIMAL.fullmatch(label) and any(c in label for c in ".eE"):
        number = float(label)
        if math.isfinite(number):
            written = str(int(number)) if number.is_integer() else repr(number)
            if written != label:
                raise ModelError(
                    f"{key}: {excerpt(label, 40)} is not a valid mode id: a log holding the "
                    f"mode as a number reads it as {excerpt(written, 40)} (whole numbers "
                    f"without '.0'); write {excerpt(written, 40)}"
                )
    return label


def as_names(value: Any, key: str, *, allow_empty: bool = False) -> tuple[str, ...]:
    """A list of unique symbol names (see :func:`symbol_name_problem`)."""
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise ModelError(f"{key}: expected a list of names")
    if not value and not allow_empty:
        raise ModelError(f"{key}: at least one name is required")
    for name in value:
        problem = symbol_name_problem(name)
        if problem:
            raise ModelError(f"{key}: {excerpt(name, 40)} {problem}")
    if len(set(value)) != len(value):
        twice = next(v for v in value if value.count(v) > 1)
        raise ModelError(f"{key}: names must be unique ('{twice}' is listed twice)")
    return tuple(value)


def check_disjoint(groups: Mapping[str, tuple[str, ...]]) -> None:
    """Every name in at most one group; the error names the later group's key."""
    seen: dict[str, str] = {}
    for group, names in groups.items():
        for name in names:
            if name in seen:
                raise ModelError(f"{group}: '{name}' is already one of the {seen[name]}")
            seen[name] = group


Names = tuple[str, tuple[str, ...]]
"""``(noun, names)`` of what a vector's entries are, for a table keyed by name:
``("state", ("x1", "x2"))``."""


def as_vector(value: Any, n: int, key: str, names: Names | None = None) -> FloatArray:
    """A list of exactly ``n`` finite numbers, or with ``names`` a table keyed by them.

    ``initial.state = {x1 = 15.0, x2 = 10.0}`` reads as ``[15.0, 10.0]`` in the model's
    order of the states (as ``initial.mode_probabilities`` and ``transitions.matrix`` take
    a table keyed by mode id).  Every name must be there: a state left out has no value
    hybridlog could vouch for.
    """
    if isinstance(value, dict) and names is not None:
        return np.array([as_number(v, k) for k, v in _keyed(value, key, names)])
    if not isinstance(value, list):
        keyed = f" or a table keyed by {names[0]}" if names is not None else ""
        raise ModelError(f"{key}: expected a list of {n} numbers{keyed}")
    if len(value) != n:
        raise ModelError(f"{key}: wrong length; expected {n} instead of {len(value)}")
    return np.array([as_number(v, f"{key}[{i}]") for i, v in enumerate(value)])


def _keyed(value: Mapping[str, Any], key: str, names: Names) -> list[tuple[str, Any]]:
    """``(key path, value)`` of each of ``names`` in ``value``, in the order of ``names``."""
    noun, known = names
    for name in value:
        if name not in known:
            raise ModelError(f"{key_path(key, name)}: unknown {noun} ({noun}s: {', '.join(known)})")
    missing = [name for name in known if name not in value]
    if missing:
        raise ModelError(
            f"{key}: no value for {noun} {excerpt(missing[0], 40)}; a table keyed by {noun} "
            f"gives every {noun} ({', '.join(known)})"
        )
    return [(key_path(key, name), value[name]) for name in known]


def as_covariance(value: Any, n: int, key: str, names: Names | None = None) -> FloatArray:
    """A covariance given as a scalar (times I), a diagonal list, or a full matrix.

    With ``names``, the diagonal may be a table keyed by them (``{y1 = 0.01, y2 = 0.04}``),
    as :func:`as_vector` reads one, and so may the full matrix, each row keyed by name and
    given as a list or a table keyed by name (``{y1 = {y1 = 0.01, y2 = 0.002}, y2 = [0.002,
    0.04]}``), every row and entry given.
    """
    if isinstance(value, dict) and names is not None:
        entries = _keyed(value, key, names)
        if any(isinstance(row, dict | list) for _, row in entries):
            matrix = np.array([as_vector(row, n, row_key, names) for row_key, row in entries])
        else:
            matrix = np.diag(as_vector(value, n, key, names))
    elif isinstance(value, int | float) and not isinstance(value, bool):
        matrix = np.eye(n) * as_number(value, key)
    elif isinstance(value, list) and value and all(isinstance(r, list) for r in value):
        if len(value) != n:
            rows = f"{len(value)} row" + ("" if len(value) == 1 else "s")
            raise ModelError(f"{key}: wrong shape; expected {n}x{n} instead of {rows}")
        for i, row in enumerate(value):
            if len(row) != n:
                raise ModelError(
                    f"{key}[{i}]: wrong length of a row of the {n}x{n} matrix; expected {n} "
                    f"instead of {len(row)}"
                )
        matrix = np.array(
            [
                [as_number(v, f"{key}[{i}][{j}]") for j, v in enumerate(r)]
                for i, r in enumerate(value)
            ]
        )
    elif isinstance(value, list):
        matrix = np.diag(as_vector(value, n, key))
    else:
        keyed = f" (either may be a table keyed by {names[0]})" if names is not None else ""
        raise ModelError(f"{key}: expected a number, a diagonal list or a matrix{keyed}")
    if not np.allclose(matrix, matrix.T, rtol=1e-12, atol=0.0):
        row, col = (int(k) for k in np.unravel_index(np.argmax(abs(matrix - matrix.T)), (n, n)))
        if isinstance(value, dict) and names is not None:  # as the file keys them: y1.y2
            entry = key_path(key_path("", names[1][row]), names[1][col])
            mirror = key_path(key_path("", names[1][col]), names[1][row])
        else:
            entry, mirror = f"[{row}][{col}]", f"[{col}][{row}]"
        raise ModelError(
            f"{key}: covariance must be symmetric; {entry} is {matrix[row, col]:g} but "
            f"{mirror} is {matrix[col, row]:g}"
        )
    smallest = float(np.linalg.eigvalsh(matrix).min()) if n else 0.0
    if smallest < -1e-12 * max(1.0, float(np.abs(matrix).max())):
        raise ModelError(
            f"{key}: covariance must be positive semi-definite (its smallest eigenvalue is "
            f"{smallest:.6g})"
        )
    return matrix


def as_expressions(
    value: Any, n: int, key: str, env: Mapping[str, sympy.Expr]
) -> tuple[sympy.Expr, ...]:
    """A list of ``n`` expression strings (a single string when ``n`` is 1)."""
    if isinstance(value, str):
        value = [value]
    if not isinstance(value, list):
        raise ModelError(f"{key}: expected a list of {n} expression strings")
    if len(value) != n:
        raise ModelError(
            f"{key}: wrong number of expressions; expected {n} instead of {len(value)}"
        )
    return tuple(
        parse_expression(expression_text(v), env, key=f"{key}[{i}]") for i, v in enumerate(value)
    )
