"""A mode's equations as a model file writes them: expressions, matrices, guards.

:class:`Symbols` is what the equations of one model may refer to.  Here: the matrices
``A, B, C, D`` of a linear mode (:func:`mode_matrix`, entries of numbers and parameters), the
matrices of a mode whose expressions are affine (:func:`mode_linear_form`,
``Mode.linear_form``), the check that a boolean-affine model's equations are affine in the
booleans (paper 003 eq. (1)), and a mode's guard, one comparison of states and inputs.
"""

from __future__ import annotations

import ast
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy
from sympy.core.function import Application

from hybridlog.errors import ModelError, excerpt
from hybridlog.model.derivatives import boolean_affine_problem
from hybridlog.model.expressions import line_break_hint, parse_expression
from hybridlog.model.hybrid_model import LinearForm, Mode
from hybridlog.model.values import as_number, as_string, key_path
from hybridlog.signals import FloatArray


@dataclass(frozen=True)
class Symbols:
    """What the mode equations of one model may refer to."""

    states: tuple[str, ...]
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    x: tuple[sympy.Symbol, ...]
    u: tuple[sympy.Symbol, ...]
    parameters: dict[str, sympy.Expr]
    env: dict[str, sympy.Expr]
    continuous: bool

    @property
    def dynamics_key(self) -> str:
        """``dx`` in continuous time, ``f`` in discrete time."""
        return "dx" if self.continuous else "f"


def _affine_coefficients(expr: sympy.Expr, variables: list[sympy.Symbol]) -> list[float] | None:
    """``[∂e/∂v for v in variables] + [e(0)]`` when ``expr`` is affine, else ``None``.

    A function or a non-polynomial power of a variable rules affinity out at once (cheap,
    and it spares the derivatives of nonlinear expressions); what is left is a polynomial,
    affine when every first derivative is a constant (expanded if need be, so that
    ``(x + 1)**2 - x**2`` counts as affine).
    """
    if expr.free_symbols:
        for atom in expr.atoms(Application):
            if atom.free_symbols:
                return None
        for power in expr.atoms(sympy.Pow):
            if power.free_symbols and not (power.exp.is_Integer and power.exp > 0):
                return None
    row = []
    try:
        for variable in variables:
            slope = expr.diff(variable)
            if slope.free_symbols:
                slope = sympy.expand(slope)
                if slope.free_symbols:
                    return None
            row.append(float(slope))
        row.append(float(expr.xreplace(dict.fromkeys(variables, sympy.Integer(0)))))
    except TypeError:
        return None
    return row


def mode_linear_form(
    dynamics: tuple[sympy.Expr, ...],
    h: tuple[sympy.Expr, ...],
    symbols: Symbols,
    dynamics_key: str,
    h_key: str,
) -> tuple[LinearForm | None, str]:
    """The mode's matrices when every expression is affine; else ``None`` and the first key."""
    variables = [*symbols.x, *symbols.u]
    rows: list[list[float]] = []
    for key, expressions in ((dynamics_key, dynamics), (h_key, h)):
        for i, expr in enumerate(expressions):
            row = _affine_coefficients(expr, variables)
            if row is None:
                return None, f"{key}[{i}]"
            rows.append(row)
    n_x, n_u = len(symbols.x), len(symbols.u)
    table = np.array(rows, dtype=float).reshape(len(rows), n_x + n_u + 1)
    top, bottom = table[:n_x], table[n_x:]
    return (
        LinearForm(
            A=np.ascontiguousarray(top[:, :n_x]),
            B=np.ascontiguousarray(top[:, n_x : n_x + n_u]),
            C=np.ascontiguousarray(bottom[:, :n_x]),
            D=np.ascontiguousarray(bottom[:, n_x : n_x + n_u]),
            state_offset=np.ascontiguousarray(top[:, -1]),
            output_offset=np.ascontiguousarray(bottom[:, -1]),
        ),
        "",
    )


def check_boolean_affine(
    expressions: tuple[sympy.Expr, ...], key: str, deltas: tuple[sympy.Symbol, ...]
) -> None:
    """Each expression affine in the booleans, ``G + D·δ`` (paper 003 eq. (1))."""
    for i, expr in enumerate(expressions):
        problem = boolean_affine_problem(expr, deltas)
        if problem:
            raise ModelError(
                f"{key}[{i}]: not affine in the booleans ({problem}); write it as "
                "G(x, u) + D(x, u)·δ (a valve: c*sqrt(h)*U, not Piecewise(c*sqrt(h), U > 0.5, 0))"
            )


def mode_guard(
    value: Any, key: str, env: Mapping[str, sympy.Expr], variables: set[str]
) -> sympy.Basic:
    """A mode's guard: one comparison of states and inputs, e.g. ``"x3 <= 0"``."""
    text = as_string(value, key).strip()
    try:
        tree = ast.parse(text, mode="eval")
    except SyntaxError as err:
        raise ModelError(
            f"{key}: cannot parse {excerpt(text)}: {err.msg}{line_break_hint(text)}"
        ) from err
    except (RecursionError, MemoryError, ValueError) as err:
        raise ModelError(f"{key}: cannot parse {excerpt(text)}") from err
    if not isinstance(tree.body, ast.Compare):
        raise ModelError(f"{key}: expected a comparison such as 'x3 <= 0', got {excerpt(text)}")
    # The expression grammar returns values; a Piecewise carries the condition through it,
    # which the user did not write: an error quoting the whole expression quotes the guard
    wrapper = f"Piecewise(1, {text}, 0)"
    try:
        wrapped = parse_expression(wrapper, env, key=key)
    except ModelError as err:
        said = str(err).replace(excerpt(wrapper), excerpt(text))
        raise ModelError(said) from err
    if not isinstance(wrapped, sympy.Piecewise):  # sympy decided the comparison: 1 or 0
        always = "always holds" if wrapped == 1 else "never holds"
        raise ModelError(
            f"{key}: {excerpt(text)} {always}, whatever the states and inputs; a guard must "
            "depend on them"
        )
    condition: sympy.Basic = wrapped.args[0].cond
    if not {str(s) for s in condition.free_symbols} & variables:
        raise ModelError(f"{key}: {excerpt(text)} does not depend on the states or inputs")
    return condition


def check_guards(modes: tuple[Mode, ...]) -> None:
    """Either every mode has a guard (state-driven switching) or none has."""
    guarded = [m.id for m in modes if m.guard is not None]
    if guarded and len(guarded) != len(modes):
        missing = next(m.id for m in modes if m.guard is None)
        raise ModelError(
            f"{key_path('modes', missing)}.guard: missing; when one mode has a guard every mode "
            "needs one"
        )


def numeric_matrix(matrix: sympy.Matrix) -> FloatArray:
    """A matrix of :func:`mode_matrix` (numbers and parameters only) as floats."""
    rows, cols = matrix.shape
    return np.array([[float(matrix[i, j]) for j in range(cols)] for i in range(rows)]).reshape(
        rows, cols
    )


def mode_matrix(
    spec: Mapping[str, Any],
    name: str,
    shape: tuple[int, int],
    mode_id: str,
    symbols: Symbols,
    *,
    required: bool,
) -> sympy.Matrix:
    """Matrix ``name`` (``A``, ``B``, ``C`` or ``D``) of mode ``mode_id``, of ``shape``.

    A list of rows; a single row or column may be written as a flat list.  Zeros where the
    file does not give a matrix that is not ``required``.
    """
    key = f"{key_path('modes', mode_id)}.{name}"
    rows, cols = shape
    if name not in spec:
        if required:
            raise ModelError(f"{key}: matrix {name} of mode '{mode_id}' is missing")
        return sympy.zeros(rows, cols)
    value = spec[name]
    if rows == 1 and isinstance(value, list) and value and not isinstance(value[0], list):
        value = [value]
    if cols == 1 and isinstance(value, list) and value and not isinstance(value[0], list):
        value = [[v] for v in value]
    if not isinstance(value, list) or not all(isinstance(r, list) for r in value):
        raise ModelError(f"{key}: expected a matrix (a list of rows)")
    if len(value) != rows:
        raise ModelError(
            f"{key}: matrix {name} of mode '{mode_id}' has the wrong number of rows; "
            f"expected {rows} instead of {len(value)}"
        )
    for row in value:
        if len(row) != cols:
            raise ModelError(
                f"{key}: matrix {name} of mode '{mode_id}' has the wrong number of columns; "
                f"expected {cols} instead of {len(row)}"
            )
    entries = [
        [_entry(v, f"{key}[{i}][{j}]", symbols) for j, v in enumerate(r)]
        for i, r in enumerate(value)
    ]
    return sympy.Matrix(entries)


def _entry(value: Any, key: str, symbols: Symbols) -> sympy.Expr:
    """One matrix entry: a number or an expression of parameters (never states or inputs)."""
    if not isinstance(value, str):
        return sympy.Float(as_number(value, key))
    entry = parse_expression(value, symbols.env, key=key)
    if entry.free_symbols:
        names = ", ".join(sorted(str(s) for s in entry.free_symbols))
        raise ModelError(
            f"{key}: a matrix entry may use numbers and parameters only, not {names} "
            "(write a nonlinear mode with f/dx and h)"
        )
    return entry
