"""Expressions in model files, parsed without ``eval`` into sympy.

A model file comes from anyone, so its expressions are never evaluated as Python.  They are
parsed with :mod:`ast` and only a small grammar is accepted: numbers, the model's symbols and
parameters, ``+ - * / **``, unary minus, comparisons, and calls of whitelisted functions.
Everything else (attribute access, subscripts, lambdas, comprehensions, strings, keyword
arguments, unknown names or functions) is refused with an error naming the model key.
"""

from __future__ import annotations

import ast
import math
from collections.abc import Callable, Mapping

import sympy

from hybridlog.errors import ModelError


def _piecewise(*args: sympy.Expr) -> sympy.Expr:
    """``Piecewise(value, condition, value, condition, ..., otherwise)`` with flat arguments."""
    if len(args) < 3 or len(args) % 2 == 0:
        raise ValueError(
            "Piecewise takes value, condition pairs and a final default value, "
            f"got {len(args)} arguments"
        )
    pairs = [(args[i], args[i + 1]) for i in range(0, len(args) - 1, 2)]
    return sympy.Piecewise(*pairs, (args[-1], True))


FUNCTIONS: Mapping[str, Callable[..., sympy.Expr]] = {
    "sqrt": sympy.sqrt,
    "abs": sympy.Abs,
    "sign": sympy.sign,
    "exp": sympy.exp,
    "log": sympy.log,
    "sin": sympy.sin,
    "cos": sympy.cos,
    "tan": sympy.tan,
    "atan": sympy.atan,
    "atan2": sympy.atan2,
    "sinh": sympy.sinh,
    "cosh": sympy.cosh,
    "tanh": sympy.tanh,
    "min": sympy.Min,
    "max": sympy.Max,
    "Piecewise": _piecewise,
}
"""Functions a model expression may call.  ``Piecewise(a, c1, b, c2, ..., otherwise)``."""

CONSTANTS: Mapping[str, sympy.Expr] = {"pi": sympy.pi, "e": sympy.E}

MAX_LENGTH = 20_000
"""Longest expression accepted, in characters."""
MAX_EXPONENT = 64
"""Largest magnitude of a numeric exponent: ``2**10**9`` would make sympy compute forever."""


def _power(base: sympy.Expr, exponent: sympy.Expr) -> sympy.Expr:
    if exponent.is_Number and abs(exponent) > MAX_EXPONENT:
        raise ValueError(f"the exponent {exponent} is larger than {MAX_EXPONENT}")
    return base**exponent


_BINARY: Mapping[type[ast.operator], Callable[[sympy.Expr, sympy.Expr], sympy.Expr]] = {
    ast.Add: lambda a, b: a + b,
    ast.Sub: lambda a, b: a - b,
    ast.Mult: lambda a, b: a * b,
    ast.Div: lambda a, b: a / b,
    ast.Pow: _power,
}

_COMPARE: Mapping[type[ast.cmpop], Callable[[sympy.Expr, sympy.Expr], sympy.Expr]] = {
    ast.Lt: sympy.Lt,
    ast.LtE: sympy.Le,
    ast.Gt: sympy.Gt,
    ast.GtE: sympy.Ge,
}


def parse_expression(text: str, symbols: Mapping[str, sympy.Expr], *, key: str) -> sympy.Expr:
    """Parse one model expression into a sympy expression.

    Parameters
    ----------
    text:
        The expression as written in the model file, e.g. ``"x1 - k*sqrt(max(x1, 0))"``.
    symbols:
        Names the expression may use (states, inputs, parameters) and what they stand for.
    key:
        The model key holding the expression, used in every error message.

    Raises
    ------
    ModelError
        On a syntax error, a construct outside the grammar, or an unknown name or function.
    """
    if not isinstance(text, str):
        raise ModelError(f"{key}: expected an expression string, got {type(text).__name__}")
    if len(text) > MAX_LENGTH:
        raise ModelError(f"{key}: expression longer than {MAX_LENGTH} characters")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as err:
        raise ModelError(f"{key}: cannot parse {text!r}: {err.msg}") from err
    except (RecursionError, MemoryError) as err:
        raise ModelError(f"{key}: expression nested too deeply") from err
    try:
        expression = _Converter(symbols, key).visit(tree.body)
    except (TypeError, ValueError, ArithmeticError) as err:
        raise ModelError(f"{key}: {err}") from err
    except RecursionError as err:
        raise ModelError(f"{key}: expression nested too deeply") from err
    if not isinstance(expression, sympy.Expr):
        raise ModelError(f"{key}: {text!r} is a condition, not a value")
    if expression.has(sympy.zoo, sympy.nan, sympy.oo, -sympy.oo):
        raise ModelError(f"{key}: {text!r} is not finite (a division by zero?)")
    return expression


class _Converter:
    """Walks a restricted Python AST and builds the sympy expression."""

    def __init__(self, symbols: Mapping[str, sympy.Expr], key: str) -> None:
        self.symbols = symbols
        self.key = key

    def fail(self, what: str) -> ModelError:
        return ModelError(f"{self.key}: {what} is not allowed in a model expression")

    def visit(self, node: ast.expr) -> sympy.Expr:
        if isinstance(node, ast.Constant):
            return self.constant(node.value)
        if isinstance(node, ast.Name):
            return self.name(node.id)
        if isinstance(node, ast.BinOp):
            operator = _BINARY.get(type(node.op))
            if operator is None:
                raise self.fail(f"operator {type(node.op).__name__}")
            return operator(self.visit(node.left), self.visit(node.right))
        if isinstance(node, ast.UnaryOp):
            if isinstance(node.op, ast.USub):
                return -self.visit(node.operand)
            if isinstance(node.op, ast.UAdd):
                return self.visit(node.operand)
            raise self.fail(f"operator {type(node.op).__name__}")
        if isinstance(node, ast.Compare):
            return self.compare(node)
        if isinstance(node, ast.Call):
            return self.call(node)
        if isinstance(node, ast.Attribute):
            raise self.fail(f"attribute access '.{node.attr}'")
        raise self.fail(f"a {type(node).__name__} expression")

    def constant(self, value: object) -> sympy.Expr:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.fail(f"the constant {value!r}")
        if not math.isfinite(value):
            raise ModelError(f"{self.key}: non-finite number {value!r}")
        return sympy.Integer(value) if isinstance(value, int) else sympy.Float(value)

    def name(self, name: str) -> sympy.Expr:
        if name in self.symbols:
            return self.symbols[name]
        if name in CONSTANTS:
            return CONSTANTS[name]
        known = ", ".join(sorted(self.symbols)) or "none"
        raise ModelError(f"{self.key}: unknown symbol '{name}' (known: {known})")

    def compare(self, node: ast.Compare) -> sympy.Expr:
        if len(node.ops) != 1:
            raise self.fail("a chained comparison")
        operator = _COMPARE.get(type(node.ops[0]))
        if operator is None:
            raise self.fail(f"comparison {type(node.ops[0]).__name__}")
        return operator(self.visit(node.left), self.visit(node.comparators[0]))

    def call(self, node: ast.Call) -> sympy.Expr:
        if not isinstance(node.func, ast.Name):
            if isinstance(node.func, ast.Attribute):
                raise self.fail(f"attribute access '.{node.func.attr}'")
            raise self.fail("calling a computed function")
        function = FUNCTIONS.get(node.func.id)
        if function is None:
            allowed = ", ".join(sorted(FUNCTIONS))
            raise ModelError(f"{self.key}: unknown function '{node.func.id}' (allowed: {allowed})")
        if node.keywords:
            raise self.fail("a keyword argument")
        if any(isinstance(arg, ast.Starred) for arg in node.args):
            raise self.fail("argument unpacking")
        return function(*(self.visit(arg) for arg in node.args))
