"""How a model's modes start and switch: initial probabilities, transitions, jump maps.

``[initial]`` ``mode`` or ``mode_probabilities`` (:func:`initial_modes`), ``[transitions]``
``stay`` or ``matrix`` (:func:`markov_transitions`: one row per mode, in the modes' order or
keyed by mode id, each summing to 1), and ``[jumps."a->b"]``, the states a switch resets
(:func:`jump_maps`, paper 004 eq. (3)).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from hybridlog.errors import ModelError, excerpt
from hybridlog.model.expressions import expression_text, parse_expression
from hybridlog.model.file_keys import TRANSITION_KEYS
from hybridlog.model.hybrid_model import Jump, markov_matrix
from hybridlog.model.mode_equations import Symbols
from hybridlog.model.toml_text import spelled
from hybridlog.model.values import (
    as_number,
    as_probability,
    as_table,
    as_vector,
    check_keys,
    key_path,
    required,
)
from hybridlog.signals import FloatArray


def jump_maps(value: Any, mode_ids: tuple[str, ...], symbols: Symbols) -> tuple[Jump, ...]:
    """``[jumps."a->b"]``: reset expressions per state (paper 004 eq. (3))."""
    table = as_table(value, "jumps")
    env = {**dict(zip(symbols.states, symbols.x, strict=True)), **symbols.parameters}
    seen: dict[tuple[str, str], str] = {}
    jumps = []
    for raw, spec in table.items():
        shown = json.dumps(raw) if len(raw) <= 130 and raw.isprintable() else excerpt(raw, 40)
        key = f"jumps.{shown}"
        source, arrow, target = (part.strip() for part in raw.partition("->"))
        if not arrow or not source or not target:
            raise ModelError(
                f"{key}: expected 'a->b' (a jump from mode a to mode b, or '*->b' from any mode)"
            )
        for end, wildcard_allowed in ((source, True), (target, False)):
            if end not in mode_ids and not (wildcard_allowed and end == "*"):
                raise ModelError(
                    f"{key}: unknown mode {excerpt(end, 40)} (modes: {', '.join(mode_ids)})"
                )
        if source == target:
            raise ModelError(f"{key}: a mode does not jump to itself")
        if (source, target) in seen:
            raise ModelError(f"{key}: the same switch as {seen[source, target]}")
        seen[source, target] = key
        resets = as_table(spec, key)
        if not resets:
            raise ModelError(f"{key}: no state is reset; list the states the switch resets")
        reset = list(symbols.x)
        for name, text in resets.items():
            if name not in symbols.states:
                raise ModelError(
                    f"{key_path(key, name)}: not a state (states: {', '.join(symbols.states)})"
                )
            reset[symbols.states.index(name)] = parse_expression(
                expression_text(text), env, key=key_path(key, name)
            )
        jumps.append(
            Jump(
                source=None if source == "*" else source,
                target=target,
                reset=tuple(reset),
                key=key,
            )
        )
    return tuple(jumps)


def initial_modes(initial: Mapping[str, Any], mode_ids: tuple[str, ...]) -> FloatArray:
    """The initial mode probabilities of ``[initial]``, in the order of ``mode_ids``.

    ``mode`` (that mode, with probability 1) or ``mode_probabilities`` (a list in the modes'
    order or a table keyed by mode id, summing to 1); uniform where neither is given.
    """
    n = len(mode_ids)
    if "mode" in initial and "mode_probabilities" in initial:
        raise ModelError("initial: give either mode or mode_probabilities, not both")
    if "mode" in initial:
        written = initial["mode"]
        if isinstance(written, bool) or not isinstance(written, str | int | float):
            raise ModelError(
                f"initial.mode: expected a mode id (a string such as {mode_ids[0]!r}), got "
                f"{spelled(written)}"
            )
        mode = str(written)
        if mode not in mode_ids:
            raise ModelError(
                f"initial.mode: unknown mode {excerpt(mode, 40)} (modes: {', '.join(mode_ids)})"
            )
        probabilities = np.zeros(n)
        probabilities[mode_ids.index(mode)] = 1.0
        return probabilities
    if "mode_probabilities" not in initial:
        return np.full(n, 1.0 / n)
    value = initial["mode_probabilities"]
    key = "initial.mode_probabilities"
    if isinstance(value, dict):
        unknown = set(value) - set(mode_ids)
        if unknown:
            raise ModelError(f"{key_path(key, sorted(unknown)[0])}: unknown mode")
        probabilities = np.array([as_number(value.get(m, 0.0), f"{key}.{m}") for m in mode_ids])
    else:
        probabilities = as_vector(value, n, key)
    if probabilities.min() < 0:
        worst = int(np.argmin(probabilities))
        raise ModelError(
            f"{key}: probabilities must be non-negative; mode {mode_ids[worst]!r} has "
            f"{probabilities[worst]:g}"
        )
    if not math.isclose(probabilities.sum(), 1.0, abs_tol=_SUM_TOLERANCE):
        raise ModelError(
            f"{key}: probabilities must sum to 1; they sum to {probabilities.sum():.10g}"
            + ("" if isinstance(value, dict) else f" (modes in order: {', '.join(mode_ids)})")
        )
    normalised: FloatArray = probabilities / probabilities.sum()
    return normalised


def markov_transitions(value: Any, mode_ids: tuple[str, ...]) -> FloatArray | None:
    """The Markov matrix of ``[transitions]`` (``stay`` or ``matrix``); ``None`` where absent."""
    if value is None:
        return None
    table = as_table(value, "transitions")
    check_keys(table, TRANSITION_KEYS, "transitions")
    n = len(mode_ids)
    if "matrix" in table and "stay" in table:
        raise ModelError("transitions: give either matrix or stay, not both")
    if "stay" in table:
        return markov_matrix(as_probability(table["stay"], "transitions.stay"), n)
    return _markov_rows(required(table, "matrix", "transitions"), mode_ids)


_SUM_TOLERANCE = 1e-9
"""How far from 1 a row of probabilities may sum (rounding of the written decimals)."""


def _markov_rows(value: Any, mode_ids: tuple[str, ...]) -> FloatArray:
    """``transitions.matrix``: one row per mode, non-negative, each summing to 1.

    Written as a list of rows in the order of the modes, or (as ``initial.mode_probabilities``
    may be) keyed by mode id: ``{1 = {1 = 0.9, 2 = 0.1}, 2 = [0.2, 0.8]}``, each mode's row
    given (a row keyed by mode id leaves the modes it does not name at 0).  The keyed form
    was refused as "expected a 2x2 matrix" while the initial probabilities took it.
    """
    key = "transitions.matrix"
    n = len(mode_ids)
    shape = (
        f"{key}: expected a {n}x{n} matrix (one row per mode) or a table of rows keyed by "
        f"mode id (modes: {', '.join(mode_ids)})"
    )
    if isinstance(value, dict):
        _check_mode_keys(value, mode_ids, key)
        missing = [m for m in mode_ids if m not in value]
        if missing:
            raise ModelError(
                f"{key_path(key, missing[0])}: the row of mode {missing[0]!r} is missing "
                "(one row per mode)"
            )
        rows = [(key_path(key, m), value[m]) for m in mode_ids]
    elif isinstance(value, list) and len(value) == n:
        rows = [(f"{key}[{i}]", row) for i, row in enumerate(value)]
    else:
        raise ModelError(shape)
    entries: list[list[float]] = []
    entry_keys: list[list[str]] = []
    for where, row in rows:
        if isinstance(row, dict):
            _check_mode_keys(row, mode_ids, where)
            entry_keys.append([key_path(where, m) for m in mode_ids])
            written = [row.get(m, 0.0) for m in mode_ids]
        elif isinstance(row, list) and len(row) == n:
            entry_keys.append([f"{where}[{j}]" for j in range(n)])
            written = row
        else:
            raise ModelError(
                f"{where}: expected a row of {n} probabilities (modes: "
                f"{', '.join(mode_ids)}), as a list or a table keyed by mode id"
            )
        entries.append([as_number(v, k) for v, k in zip(written, entry_keys[-1], strict=True)])
    matrix = np.array(entries)
    if matrix.min() < 0:
        # The row of the negative entry: a row [1.1, -0.1] sums to 1, so the row whose sum
        # is furthest from 1 was named instead (row 0 of [[0.9, 0.1], [1.1, -0.1]]).
        row, col = (int(i) for i in np.unravel_index(np.argmin(matrix), matrix.shape))
        raise ModelError(
            f"{entry_keys[row][col]}: a probability must be non-negative, got "
            f"{matrix[row, col]:g} (from mode {mode_ids[row]!r} to {mode_ids[col]!r})"
        )
    sums = matrix.sum(axis=1)
    bad = int(np.argmax(np.abs(sums - 1.0)))
    if not math.isclose(sums[bad], 1.0, rel_tol=0.0, abs_tol=_SUM_TOLERANCE):
        # As initial.mode_probabilities: allclose's default relative tolerance let rows
        # summing to 0.99999 through, a Markov chain that loses probability every step.
        raise ModelError(
            f"{rows[bad][0]}: each row must sum to 1; the row of mode {mode_ids[bad]!r} sums to "
            f"{sums[bad]:.10g}"
        )
    return matrix


def _check_mode_keys(table: Mapping[str, Any], mode_ids: tuple[str, ...], key: str) -> None:
    """Refuse a key of ``table`` that is not a mode id, naming it and the modes."""
    for name in table:
        if name not in mode_ids:
            raise ModelError(f"{key_path(key, name)}: unknown mode (modes: {', '.join(mode_ids)})")
