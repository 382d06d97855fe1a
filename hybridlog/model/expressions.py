"""Expressions in model files, parsed without ``eval`` into sympy.

A model file comes from anyone, so its expressions are never evaluated as Python.  They are
parsed with :mod:`ast` and only a small grammar is accepted: numbers, the model's symbols and
parameters, ``+ - * / **``, unary minus, comparisons, and calls of whitelisted functions.
Everything else (attribute access, subscripts, lambdas, comprehensions, strings, keyword
arguments, unknown names or functions) is refused with an error naming the model key.

Only the equations of a ``[components]`` model also accept the time index of paper 002,
``name[k]`` and ``name[k-1]`` (``previous=`` of :func:`parse_expression`).

Every expression must be real: one that sympy finds complex-valued (``sqrt(-1)``,
``log(-2)``, ``(-8)**(1/3)``, ``sqrt(-x**2 - 1)``) is refused, since compiled code would
either fail or silently drop the imaginary part; so is a complex constant anywhere in one,
named where it is made (``sqrt(-1)`` of ``sqrt(-1)**2*x``, :meth:`_Converter.real`).
``sqrt(x)`` of a real ``x`` is accepted: whether it is real depends on the data.
"""

from __future__ import annotations

import ast
import keyword
import math
import re
import sys
import unicodedata
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import sympy

from hybridlog.errors import ModelError, excerpt
from hybridlog.model.toml_text import (
    PLAIN_KEY_LIMIT,
    digits_beyond,
    held_digits,
    key_path,
    unheld_number,
)

_CONDITIONS = (
    sympy.core.relational.Relational,
    sympy.logic.boolalg.BooleanFunction,
    sympy.logic.boolalg.BooleanAtom,
)


def _piecewise(*args: sympy.Expr) -> sympy.Expr:
    """``Piecewise(value, condition, value, condition, ..., otherwise)`` with flat arguments."""
    if len(args) < 3 or len(args) % 2 == 0:
        raise ValueError(
            "Piecewise takes value, condition pairs and a final default value, "
            f"got {len(args)} arguments"
        )
    pairs = [(args[i], args[i + 1]) for i in range(0, len(args) - 1, 2)]
    for position, (_, condition) in enumerate(pairs, start=1):
        if not isinstance(condition, _CONDITIONS):  # a Symbol is a sympy Boolean too
            raise ValueError(
                f"Piecewise: condition {position} ({excerpt(condition, 40)}) is a value, not "
                "a comparison such as x1 > 0"
            )
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

_ARITY: Mapping[str, tuple[int, int | None]] = {
    "atan2": (2, 2),
    "min": (1, None),
    "max": (1, None),
    "Piecewise": (3, None),
}
"""How many arguments each function takes, ``(at least, at most)``; the others take one.
sympy's own functions take more (``sqrt(x, evaluate)``, ``log(x, base)``) with other
meanings, so the count is checked before they are called."""

CONSTANTS: Mapping[str, sympy.Expr] = {"pi": sympy.pi, "e": sympy.E}

RESERVED_NAMES = frozenset({*FUNCTIONS, *CONSTANTS, "t", "k"})
"""Names the grammar gives a meaning of its own: the functions, the constants, the time
``t`` and the step ``k`` of simulation inputs (and of component equations' ``x[k-1]``)."""

MAX_LENGTH = 20_000
"""Longest expression accepted, in characters."""
MAX_DEPTH = 100
"""Deepest nesting of operations accepted (a chain ``a + b + c ...`` counts once)."""
MAX_EXPONENT = 64
"""Largest magnitude of a numeric exponent of an expression: ``x**1000`` is no model's."""
MAX_POWER_BITS = 4096
"""Largest binary exponent of a number's power (``10**300`` has 997): double precision ends
at 1024, and ``2**10**9`` would make sympy compute forever."""


def symbol_name_problem(name: str) -> str | None:
    """Why ``name`` cannot be a model symbol (a state, input, parameter ...), or ``None``.

    A symbol must be a Python identifier that is not a keyword (``lambda``) and not a name
    the grammar already uses (``sqrt``, ``pi``, ``t``): either would make every expression
    that uses it fail to parse or mean something else.  It must also be in Unicode NFKC
    form: the parser reads ``ﬁ`` (a ligature) as ``fi``, so with states ``fi`` and ``ﬁ``
    an expression naming ``ﬁ`` would silently mean ``fi``.  And it is at most
    :data:`~hybridlog.model.toml_text.PLAIN_KEY_LIMIT` (64) characters long, as a mode id is.
    """
    if not name.isidentifier():
        return "is not a valid symbol name (letters, digits and _, not starting with a digit)"
    if len(name) > PLAIN_KEY_LIMIT:  # echoed whole in messages and table columns
        return f"is longer than {PLAIN_KEY_LIMIT} characters, as a symbol name may be"
    normal = unicodedata.normalize("NFKC", name)
    if normal != name:
        # Python's parser reads every name in NFKC form (PEP 3131), so an expression could
        # only ever name ``normal``: another symbol of that name, or an unknown one.
        return (
            f"is read as {excerpt(normal, 40)} in expressions (Unicode NFKC form); "
            f"write {excerpt(normal, 40)}"
        )
    if keyword.iskeyword(name):
        return "is a Python keyword and cannot be a symbol name"
    if name in ("t", "k"):
        return (
            "is the time (t) or step (k) of simulation inputs and component equations and "
            "cannot be a symbol name"
        )
    if name in RESERVED_NAMES:
        return "is a function or constant of the expression grammar and cannot be a symbol name"
    return None


def previous_symbol(name: str) -> sympy.Symbol:
    """The symbol of variable ``name`` at step k−1 (written ``name[k-1]``), printed so."""
    return sympy.Symbol(f"{name}[k-1]", real=True)


def _unquoted(text: object, limit: int) -> str:
    """:func:`excerpt` without the quotes, for text inside a message of our own."""
    return excerpt(text, limit)[1:-1]


def _number_text(value: sympy.Expr, limit: int = 40) -> str:
    """:func:`excerpt` of a constant, one too long for Python's text as its first digits.

    A fraction past ``sys.get_int_max_str_digits`` (4,300 digits) is shown ``1.000e+5000``.

    ``x*10**1000*10**1000*10**1000*10**1000*10**1000`` folds to a number of 5,001 digits,
    whose text Python refuses: the overflow check, naming it, failed with a ValueError
    ("Exceeds the limit (4300 digits) for integer string conversion").
    """
    if _beyond_text(value):
        return excerpt(value.evalf(4), limit)
    return excerpt(value, limit)


def _beyond_text(value: sympy.Expr) -> bool:
    """Whether ``value`` is a fraction with more digits than Python writes as text."""
    most = sys.get_int_max_str_digits()
    if not isinstance(value, sympy.Rational) or not most:
        return False
    size = max(abs(int(value.p)).bit_length(), int(value.q).bit_length())
    return size * math.log10(2) >= most - 1


def _long_constant(expression: sympy.Expr) -> str:
    """A fraction of ``expression`` that no code can write (:func:`_beyond_text`), or ``""``.

    ``x*(1+10**-20)**60*(1+10**-20)**60*(1+10**-20)**60*(1+10**-20)**60`` (about
    ``1.000000000000000002*x``) folds to a fraction of 4,800 digits: every check passed it,
    and the model's compilation failed with an "unexpected ValueError in compiled.py".
    """
    return next(
        (_number_text(node) for node in expression.atoms(sympy.Rational) if _beyond_text(node)),
        "",
    )


_NOT_FINITE = (sympy.zoo, sympy.nan, sympy.oo, -sympy.oo)


def _magnitude(value: sympy.Expr) -> float | None:
    """``|value|`` of a real constant (``10``, ``pi``, ``sqrt(2)``), ``None`` of anything else."""
    if not value.is_number:
        return None
    try:
        return abs(float(value))
    except TypeError:  # a complex constant
        return None


def _exact_bits(value: sympy.Expr) -> int:
    """The most bits of a numerator or denominator written in ``value`` (0 without one).

    sympy computes a power of an exact number digit by digit, and of a root of one too
    (``sqrt(1 + 10**-20)**100000`` is ``(1 + 10**-20)**50000``), so these bound its cost.
    """
    return max(
        (
            max(abs(int(atom.p)).bit_length(), int(atom.q).bit_length()) - 1
            for atom in value.atoms(sympy.Rational)
            if atom.p != 0
        ),
        default=0,
    )


def _power(base: sympy.Expr, exponent: sympy.Expr) -> sympy.Expr:
    """``base**exponent``, an exponent past :data:`MAX_EXPONENT` only of a constant.

    A constant such as ``10**300`` (1e300) or ``pi**100`` is a number like another, which
    the checks of overflow and underflow then judge; its exponent is bounded by the bits of
    the result, so that ``2**10**9`` is not computed.  The bits of the exact numbers of the
    base count as written, their numerators' and denominators': ``(1 + 10**-20)**100000``
    or ``(10**-400)**100000``, whose float is 1 or 0, made sympy compute a fraction of
    millions of digits (minutes).  An exponent is a constant too: ``x**(100*pi)`` is
    ``x**314.159...``, past the bound as ``x**400`` is.

    An exponent within the bound is bounded by the same digits, powers of powers being
    computed as they come: ``(((1+10**-20)**60)**60)**60``, each exponent 60, ran for
    minutes (a fraction of 14 million bits), ``(x*(1+10**-20)**60)**60`` as long.
    """
    times = _magnitude(exponent)
    if times is None or base.has(*_NOT_FINITE) or exponent.has(*_NOT_FINITE):
        return base**exponent  # a complex exponent or an infinity: said by the checks after
    if times <= MAX_EXPONENT:
        # sympy multiplies out the exact numbers of a power, a product or a number; it
        # leaves a sum (1 + sqrt(2))**60 or a function's value as written
        folded = 0 if isinstance(base, sympy.Add | sympy.Function) else _exact_bits(base)
        if times * folded <= MAX_POWER_BITS:
            return base**exponent
        if not base.is_number:
            raise ValueError(
                f"({_number_text(base, 60)[1:-1]})**{_number_text(exponent, 30)[1:-1]} holds "
                f"an exact fraction of more than {MAX_POWER_BITS} bits, too long to compute; "
                "write its numbers as decimals"
            )
    magnitude = _magnitude(base)
    if magnitude is None or not (math.isfinite(magnitude) or base.is_finite):
        raise ValueError(
            f"the exponent {_number_text(exponent, 30)[1:-1]} is larger than {MAX_EXPONENT}"
        )
    if magnitude in (0.0, 1.0):
        bits = 0.0
    elif math.isfinite(magnitude):
        bits = times * abs(math.log2(magnitude))
    else:  # a number past a double's range: pi**1000, 2**3600
        bits = times * float(sympy.log(sympy.Abs(base), 2).evalf(15))
    if isinstance(base, sympy.Rational) and base.p != 0:  # exact: its float may be 0 or 1
        bits = times * abs(math.log2(abs(int(base.p))) - math.log2(int(base.q)))
    cost = times * _exact_bits(base)
    shown = _number_text(base, 60)[1:-1]
    if not (base.is_Integer and base.is_nonnegative):
        shown = f"({shown})"
    times_shown = _number_text(exponent, 30)[1:-1]
    if not exponent.is_Atom:
        times_shown = f"({times_shown})"
    power = f"{shown}**{times_shown}"
    if bits > MAX_POWER_BITS:
        raise ValueError(f"{power} is far beyond double precision")
    if cost > MAX_POWER_BITS:
        raise ValueError(
            f"{power} is an exact fraction of more than {MAX_POWER_BITS} bits, "
            "too long to compute; write its base as a decimal number"
        )
    return base**exponent


def _bound_product(terms: Sequence[sympy.Expr]) -> None:
    """Refuse a product whose exact numbers multiply to more digits than code can write.

    Such a product is refused after it is folded (:func:`_long_constant`), but sympy folds it
    fraction by fraction first: ``x*(1+10**-20)**60*...`` with 100 factors of 4,020 bits
    each took 2.1 s to be refused, with 300 factors 16 s.  Their bits add up to at least the
    product's (its exact numbers the coefficients of the terms: ``x*(1+10**-20)**60``'s
    ``(1+10**-20)**60``); refused past four times the digits (a few hundredths of a second
    to fold), so that a product just past them is named by the checks after folding, as
    ``x*10**1000*10**1000*10**1000*10**1000*10**1000``'s overflow.
    """
    most = sys.get_int_max_str_digits() or _INT_TEXT_DIGITS
    bits = sum(_exact_bits(term.as_coeff_Mul()[0]) for term in terms)
    if bits * math.log10(2) >= 4 * most:
        raise ValueError(
            f"its product of exact numbers folds to an exact fraction of more than {most:,} "
            "digits, which its compiled code cannot write; write its numbers as decimals "
            "(1.0000000001, not 1 + 10**-10)"
        )


_INT_TEXT_DIGITS = 4300
"""Python's default ``sys.get_int_max_str_digits()``, the bound where it sets none."""


_COMPARE: Mapping[type[ast.cmpop], Callable[[sympy.Expr, sympy.Expr], sympy.Expr]] = {
    ast.Lt: sympy.Lt,
    ast.LtE: sympy.Le,
    ast.Gt: sympy.Gt,
    ast.GtE: sympy.Ge,
}

_UNSUPPORTED_OPERATORS: Mapping[type[ast.operator], str] = {
    ast.Mod: "'%' (remainder)",
    ast.FloorDiv: "'//' (floor division)",
}
"""Arithmetic a model expression cannot write, as its reader would name it."""

_SUMS = (ast.Add, ast.Sub)
_PRODUCTS = (ast.Mult, ast.Div)


def _chain_group(op: ast.operator) -> type | None:
    if isinstance(op, _SUMS):
        return ast.Add
    if isinstance(op, _PRODUCTS):
        return ast.Mult
    return None


def _depth(root: ast.AST) -> int:
    """Nesting depth of ``root``; a left-leaning chain of ``+ -`` or ``* /`` counts once."""
    deepest = 0
    stack = [(root, 1)]
    while stack:
        node, depth = stack.pop()
        deepest = max(deepest, depth)
        group = _chain_group(node.op) if isinstance(node, ast.BinOp) else None
        for child in ast.iter_child_nodes(node):
            same_chain = (
                group is not None
                and isinstance(child, ast.BinOp)
                and child is getattr(node, "left", None)
                and _chain_group(child.op) is group
            )
            stack.append((child, depth if same_chain else depth + 1))
    return deepest


def expression_text(value: Any) -> Any:
    """A TOML value written as an expression: a number (``f = [0.5]``) as its decimal text.

    A boolean is no number here: ``f = [true]`` was read as the text ``True`` and refused
    as "the constant 'True'", a spelling the file never had; it is left as it is, for
    :func:`parse_expression` to refuse as it refuses every value that is not text.
    """
    return str(value) if isinstance(value, int | float) and not isinstance(value, bool) else value


def line_break_hint(text: str) -> str:
    r"""The hint for an expression that does not parse because of its line breaks, or ``""``.

    A TOML multi-line string keeps its line breaks, which end a Python expression outside
    parentheses: ``'a*x\n + u'`` was only "unexpected indent".  Said only where the text
    parses with its line breaks as spaces: ``'(x\n - 0.3'`` (``'(' was never closed``) or
    ``'x -\n * 0.3'`` were told to wrap what is wrapped, or a line break that is no cause.
    """
    if "\n" not in text.strip() and "\r" not in text.strip():
        return ""
    try:
        ast.parse(" ".join(text.splitlines()).strip(), mode="eval")
    except (SyntaxError, ValueError, RecursionError, MemoryError):
        return ""
    return (
        "; a line break ends an expression outside parentheses: wrap it in ( ), or end "
        "each line with \\ in a TOML multi-line string"
    )


def parse_expression(
    text: str,
    symbols: Mapping[str, sympy.Expr],
    *,
    key: str,
    previous: Mapping[str, sympy.Expr] | None = None,
) -> sympy.Expr:
    """Parse one model expression into a sympy expression.

    Parameters
    ----------
    text:
        The expression as written in the model file, e.g. ``"x1 - k*sqrt(max(x1, 0))"``.
    symbols:
        Names the expression may use (states, inputs, parameters) and what they stand for.
    key:
        The model key holding the expression, used in every error message.
    previous:
        Only for the equations of a components model: the variables that may carry a time
        index, and their symbols at step k−1.  ``name[k]`` then means ``symbols[name]`` and
        ``name[k-1]`` means ``previous[name]``.  Without it a subscript is an error.

    Raises
    ------
    ModelError
        On a syntax error, a construct outside the grammar, an unknown name or function,
        nesting deeper than :data:`MAX_DEPTH`, or a value that is not finite or not real.
    """
    if not isinstance(text, str):
        raise ModelError(f"{key}: expected an expression string, got {type(text).__name__}")
    if len(text) > MAX_LENGTH:
        raise ModelError(f"{key}: expression longer than {MAX_LENGTH} characters")
    if "#" in text:
        # Python's parser reads the rest of the line as a comment: '0.9*x # + u' was 0.9*x.
        raise ModelError(
            f"{key}: {excerpt(text)} holds '#', which would silently drop the rest of the "
            "expression; a TOML comment goes after the closing quote"
        )
    _refuse_unreadable_integer(text, key)
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as err:
        raise ModelError(
            f"{key}: cannot parse {excerpt(text)}: {err.msg}{line_break_hint(text)}"
        ) from err
    except ValueError as err:  # e.g. NUL bytes, on Python versions that raise it
        raise ModelError(f"{key}: cannot parse {excerpt(text)}: {_unquoted(err, 80)}") from err
    except (RecursionError, MemoryError) as err:
        raise ModelError(
            f"{key}: cannot parse {excerpt(text)}: too long or nested too deeply for the parser"
        ) from err
    if _depth(tree.body) > MAX_DEPTH:
        raise ModelError(f"{key}: expression nested more than {MAX_DEPTH} levels deep")
    converter = _Converter(symbols, key, previous, text.strip())
    try:
        expression = converter.visit(tree.body)
    except (TypeError, ValueError, ArithmeticError) as err:
        # a parameter's value may be the cause (E**E with E = 1000: an exponent past 64); of a
        # complex value, every parameter of the power or call that made it
        complex_value = isinstance(err, _ComplexValueError)
        root = err.node if isinstance(err, _ComplexValueError) else tree.body
        culprits = _parameters_used(root, symbols, converter, _no_problem, every=complex_value)
        # a complex value's message is bounded by its parts (their excerpts, the real root
        # written whole): cut at 200, a real root it suggested lost its start
        limit = _COMPLEX_MESSAGE_LIMIT if complex_value else 200
        raise ModelError(f"{key}: {_unquoted(err, limit)}{culprits}") from err
    except RecursionError as err:
        raise ModelError(f"{key}: expression too long or nested too deeply") from err
    if not isinstance(expression, sympy.Expr):
        raise ModelError(f"{key}: {excerpt(text)} is a condition, not a value")
    if _not_finite(expression):
        raise ModelError(
            f"{key}: {excerpt(text)} is not finite (a division by zero?"
            f"{_parameters_used(tree.body, symbols, converter, _not_finite)})"
        )
    overflow = _overflow(expression)
    if overflow:
        raise ModelError(
            f"{key}: {excerpt(text)} is not finite in double precision ({overflow} overflows"
            f"{_parameters_used(tree.body, symbols, converter, _overflow)})"
        )
    underflow = _underflow(expression)
    if underflow:
        raise ModelError(
            f"{key}: {excerpt(text)} holds a constant smaller in magnitude than a double holds "
            f"in full ({underflow}{_parameters_used(tree.body, symbols, converter, _underflow)}); "
            "write 0 or rescale"
        )
    reason = _complex_reason(expression)
    if reason:
        raise ModelError(
            f"{key}: {excerpt(text)} is complex-valued ({reason}); model expressions must be real"
        )
    long = _long_constant(expression)
    if long:
        raise ModelError(
            f"{key}: {excerpt(text)} folds to an exact fraction of more than "
            f"{sys.get_int_max_str_digits():,} digits ({long}), which its compiled code cannot "
            "write; write its numbers as decimals (1.0000000001, not 1 + 10**-10)"
        )
    return expression


def _not_finite(expression: sympy.Expr) -> str:
    """``not finite`` where the folded expression holds an infinity or NaN, else ``""``."""
    return "not finite" if expression.has(*_NOT_FINITE) else ""


def _no_problem(expression: sympy.Expr) -> str:
    """No problem with an expression that converts (for an error raised while converting)."""
    return ""


def _parameters_used(
    root: ast.expr,
    symbols: Mapping[str, sympy.Expr],
    converter: _Converter,
    problem: Callable[[sympy.Expr], str],
    *,
    every: bool = True,
) -> str:
    """``"; with parameters.A = 1e+308"``: the parameters behind ``problem``, with their values.

    A parameter is a number by the time the expression is folded, so an overflow of
    ``A*x*10`` with ``A = 1e308`` showed only ``1e+309``, at the expression, and the
    parameter (the value to fix, perhaps set by ``--set``) was not named.  Named are the
    parameters the expression uses whose value set to 1 makes ``problem`` go; when no single
    one does (``A*B``, both 1e200), every parameter the expression uses, unless not
    ``every`` (an error while converting, which a parameter seldom causes: ``x/Z`` with
    ``Z = 0`` and ``E**E`` with ``E = 1000`` are named, an unknown function is not blamed
    on the parameters beside it).
    """
    used = sorted(
        {
            node.id
            for node in ast.walk(root)
            if isinstance(node, ast.Name) and isinstance(symbols.get(node.id), sympy.Number)
        }
    )
    culprits = [name for name in used if not _still(root, symbols, name, converter, problem)]
    names = culprits or (used if every else [])
    if not names:
        return ""
    shown = ", ".join(
        f"{key_path('parameters', name)} = {float(symbols[name]):.10g}" for name in names[:3]
    )
    more = f" and {len(names) - 3} more" if len(names) > 3 else ""
    return f"; with {shown}{more}"


def _still(
    root: ast.expr,
    symbols: Mapping[str, sympy.Expr],
    name: str,
    converter: _Converter,
    problem: Callable[[sympy.Expr], str],
) -> bool:
    """Whether ``problem`` remains with parameter ``name`` set to 1."""
    other = _Converter(
        {**symbols, name: sympy.Integer(1)}, converter.key, converter.previous, converter.source
    )
    try:
        expression = other.visit(root)
    except (ModelError, TypeError, ValueError, ArithmeticError, RecursionError):
        return True
    return not isinstance(expression, sympy.Expr) or bool(problem(expression))


_SMALLEST_NORMAL = sys.float_info.min
"""The smallest normal double (2.2e-308): below it a double holds fewer significant digits."""


def _constants(expression: sympy.Expr) -> list[sympy.Expr]:
    """The numbers of ``expression`` and its functions and powers of numbers, in one order."""
    constants = expression.atoms(sympy.Number) | {
        node for node in expression.atoms(sympy.Function, sympy.Pow) if node.is_number
    }
    return sorted(constants, key=sympy.default_sort_key)


def _overflow(expression: sympy.Expr) -> str:
    """A constant of ``expression`` beyond float64 (``1e200*1e200``, ``exp(1000)``), or ``""``.

    sympy's numbers have no limit, so such a constant passes its own checks and becomes
    ``inf`` in the compiled code.
    """
    for node in _constants(expression):
        try:
            value = float(node)
        except OverflowError:
            return _number_text(node)
        except TypeError:  # complex: said by _complex_reason
            continue
        if not math.isfinite(value):
            return _number_text(node)
    return ""


def _underflow(expression: sympy.Expr) -> str:
    """A constant of ``expression`` that is not 0 but below the smallest normal double, or ``""``.

    sympy's numbers have no lower limit either: ``1e-200*1e-200`` (or a parameter ``a =
    1e-200`` in ``a*a*x``) folds to ``1.0e-400``, which the compiled code holds as ``0.0``,
    the term gone without a word, as a literal ``1e-400`` is refused where it is written.
    """
    for node in _constants(expression):
        try:
            value = float(node)
        except (OverflowError, TypeError):  # said by _overflow and _complex_reason
            continue
        if abs(value) < _SMALLEST_NORMAL and node.is_zero is False:
            shown = node.evalf(4) if node.is_Float else node  # 1.000e-400; exp(-1000)
            held = held_digits(value)
            return f"{_number_text(shown)} is below {_SMALLEST_NORMAL:.4g} and would be {held}"
    return ""


def _complex_reason(expression: sympy.Expr) -> str:
    """Why sympy finds ``expression`` complex-valued, or ``""`` when it does not.

    Among the grammar's functions only the imaginary unit itself, powers (roots of negative
    numbers) and logarithms (of negative numbers) leave the reals from real arguments, so
    only those are asked; asking every node costs several times more.
    """
    if expression.has(sympy.I):
        return f"it evaluates to {excerpt(expression, 40)}"
    for atom in sorted(expression.atoms(sympy.Pow, sympy.log), key=sympy.default_sort_key):
        if atom.is_extended_real is False:
            return f"{excerpt(atom, 40)} is not real"
        if isinstance(atom, sympy.Pow) and _negative_base_variable_power(atom):
            return (
                f"{excerpt(atom, 40)} is real only where its exponent is a whole number, and "
                "its derivative is complex"
            )
    return ""


def _negative_base_variable_power(power: sympy.Pow) -> bool:
    """``(-1)**x``, ``(-pi)**x``: a negative constant to a power of a variable other than ``k``.

    Real only at whole exponents (NaN in compiled code elsewhere), and its derivative
    ``(-1)**x*I*pi`` is complex: numba failed to compile the model's Jacobian ("No
    implementation of function setitem ... complex128").  ``(-1)**k`` of simulation inputs
    is real: the step ``k`` is a whole number (a name no model symbol may take).
    """
    base, exponent = power.base, power.exp
    return bool(
        not base.free_symbols  # a number, or one written with constants: (-pi)**x
        and base.is_extended_negative
        and any(str(symbol) != "k" for symbol in exponent.free_symbols)
    )


_INTEGER_LITERAL = re.compile(r"(?<![\w.])[0-9]+(?![\w.])")
"""A whole number as Python's parser reads one: digits not part of a name or a decimal."""


def _refuse_unreadable_integer(text: str, key: str) -> None:
    """Refuse a whole number of more digits than Python reads (4,300), as a 400-digit one is.

    Python's parser raised a SyntaxError naming ``sys.set_int_max_str_digits()``, advice
    for a program, where a 401-digit number was "beyond the largest double".
    """
    most = sys.get_int_max_str_digits()
    for literal in _INTEGER_LITERAL.finditer(text):
        if most and len(literal.group()) > most:
            raise ModelError(f"{key}: {digits_beyond(f'{len(literal.group()):,}')}")


_PLAIN_NUMBER = re.compile(r"(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?", re.ASCII)
"""A number literal as a model expression may write it (its sign is an operator)."""


_LINE = re.compile(r"[^\r\n]*(?:\r\n|\r|\n)|[^\r\n]+$")
"""A line of source with its end, as Python's parser counts lines (``\r\n``, ``\r``, ``\n``)."""


class _Converter:
    """Walks a restricted Python AST and builds the sympy expression."""

    def __init__(
        self,
        symbols: Mapping[str, sympy.Expr],
        key: str,
        previous: Mapping[str, sympy.Expr] | None,
        source: str,
    ) -> None:
        self.symbols = symbols
        self.key = key
        self.previous = previous
        self.source = source
        self._lines: list[bytes] | None = None

    def segment(self, node: ast.expr) -> str | None:
        """The text of ``node`` in the source, as :func:`ast.get_source_segment` gives it.

        That function splits the whole source into lines at every call: once per number
        literal, the check of a 20,000-character expression of 9,900 numbers took 35 s.  The
        lines are split and encoded once here (a node's columns count UTF-8 bytes).
        """
        end = node.end_lineno
        if end is None or node.end_col_offset is None or end != node.lineno:
            return ast.get_source_segment(self.source, node)
        if self._lines is None:
            self._lines = [line.encode() for line in _LINE.findall(self.source)]
        return self._lines[end - 1][node.col_offset : node.end_col_offset].decode()

    def fail(self, what: str) -> ModelError:
        return ModelError(f"{self.key}: {what} is not allowed in a model expression")

    def visit(self, node: ast.expr) -> sympy.Expr:
        if isinstance(node, ast.Constant):
            self.check_written(node)
            return self.constant(node.value)
        if isinstance(node, ast.Name):
            return self.name(node.id)
        if isinstance(node, ast.BinOp):
            return self.binary(node)
        if isinstance(node, ast.UnaryOp):
            if isinstance(node.op, ast.USub):
                return -self.value(node.operand)
            if isinstance(node.op, ast.UAdd):
                return self.value(node.operand)
            if isinstance(node.op, ast.Not):
                raise ModelError(
                    f"{self.key}: 'not' is not in the grammar of model expressions; write the "
                    "opposite comparison (x <= 0 for not x > 0)"
                )
            raise self.fail(f"operator {type(node.op).__name__}")
        if isinstance(node, ast.Compare):
            return self.compare(node)
        if isinstance(node, ast.Call):
            return self.call(node)
        if isinstance(node, ast.Attribute):
            raise self.fail(f"attribute access '.{node.attr}'")
        if isinstance(node, ast.IfExp):
            raise ModelError(
                f"{self.key}: 'a if condition else b' is not in the grammar of model "
                "expressions; write Piecewise(a, condition, b)"
            )
        if isinstance(node, ast.BoolOp):
            both = isinstance(node.op, ast.And)
            instead = (
                "Piecewise(Piecewise(a, x > 0, b), u > 0, b) for a where x > 0 and u > 0"
                if both
                else "Piecewise(a, x > 0, a, u > 0, b) for a where x > 0 or u > 0"
            )
            raise ModelError(
                f"{self.key}: '{'and' if both else 'or'}' is not in the grammar of model "
                f"expressions (a condition is one comparison); write {instead}"
            )
        if isinstance(node, ast.Subscript) and self.previous is not None:
            return self.indexed(node)
        raise self.fail(f"a {type(node).__name__} expression")

    def value(self, node: ast.expr) -> sympy.Expr:
        """``node`` as an operand of arithmetic or a function: a value, never a condition.

        sympy refuses ``(x > 0)*x`` in its own words ("Relational cannot be used in Mul");
        the error says what to write instead.
        """
        result = self.visit(node)
        if isinstance(result, _CONDITIONS):
            raise ModelError(
                f"{self.key}: the comparison {excerpt(ast.unparse(node), 40)} is a condition, "
                "not a number; write Piecewise(value, condition, otherwise)"
            )
        return result

    def binary(self, node: ast.BinOp) -> sympy.Expr:
        """``+ - * / **``; a chain ``a + b - c ...`` is built in one step, without recursion."""
        group = _chain_group(node.op)
        if group is None:
            if isinstance(node.op, ast.Pow):
                base, exponent = self.value(node.left), self.value(node.right)
                hint = self._real_root(node, base, exponent)
                return self.real(node, _power(base, exponent), hint)
            if isinstance(node.op, ast.BitXor):
                raise ModelError(
                    f"{self.key}: '^' is not a power in a model expression (Python reads it "
                    "as a bitwise xor); write '**', as in x**2"
                )
            spelled = _UNSUPPORTED_OPERATORS.get(type(node.op))
            if spelled is not None:
                raise ModelError(
                    f"{self.key}: {spelled} is not in the grammar of model expressions "
                    "(+ - * / ** and the listed functions)"
                )
            raise self.fail(f"operator {type(node.op).__name__}")
        links: list[tuple[ast.operator, ast.expr]] = []
        left: ast.expr = node
        while isinstance(left, ast.BinOp) and _chain_group(left.op) is group:
            links.append((left.op, left.right))
            left = left.left
        terms = [self.value(left)]
        for op, right in reversed(links):
            value = self.value(right)
            if isinstance(op, ast.Sub):
                value = -value
            elif isinstance(op, ast.Div):
                value = 1 / value
            terms.append(value)
        if group is ast.Add:
            return sympy.Add(*terms)
        _bound_product(terms)
        return sympy.Mul(*terms)

    def check_written(self, node: ast.Constant) -> None:
        """Refuse a number not written in plain decimal, or that no double holds.

        Python's literals also read ``1_0`` as 10, ``0x10`` as 16, ``0o7`` and ``0b1``, which a
        model file's reader would take for other numbers (or typos) than the parser does;
        and ``1e-400`` as 0 (:func:`~hybridlog.model.toml_text.unheld_number`).
        """
        written = self.segment(node)
        if (
            isinstance(node.value, int | float)
            and not isinstance(node.value, bool)
            and written is not None
            and _PLAIN_NUMBER.fullmatch(written) is None
        ):
            raise ModelError(
                f"{self.key}: the number {excerpt(written, 40)} is not written in plain decimal "
                "digits (no '_', no 0x/0o/0b prefix)"
            )
        if isinstance(node.value, int | float) and not isinstance(node.value, bool) and written:
            unheld = unheld_number(written, node.value)
            if unheld:
                raise ModelError(f"{self.key}: {unheld}")

    def constant(self, value: object) -> sympy.Expr:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.fail(f"the constant {excerpt(value, 40)}")
        if not math.isfinite(value):
            raise ModelError(f"{self.key}: non-finite number {value!r}")
        return sympy.Integer(value) if isinstance(value, int) else sympy.Float(value)

    def name(self, name: str) -> sympy.Expr:
        if name in self.symbols:
            return self.symbols[name]
        if name in CONSTANTS:
            return CONSTANTS[name]
        known = ", ".join(sorted(self.symbols)) or "none"
        raise ModelError(
            f"{self.key}: unknown symbol {excerpt(name, 40)} (known: {_unquoted(known, 200)})"
        )

    def indexed(self, node: ast.Subscript) -> sympy.Expr:
        """``name[k]`` (step k) or ``name[k-1]`` (step k−1) of a components equation."""
        assert self.previous is not None
        if not isinstance(node.value, ast.Name):
            raise self.fail("indexing anything but a variable name")
        name = node.value.id
        index = node.slice
        if name not in self.previous:
            if name in self.symbols:
                raise ModelError(
                    f"{self.key}: {excerpt(name, 40)} is a parameter and has no time index"
                )
            return self.name(name)  # raises: unknown symbol
        if isinstance(index, ast.Name) and index.id == "k":
            return self.symbols[name]
        if (
            isinstance(index, ast.BinOp)
            and isinstance(index.op, ast.Sub)
            and isinstance(index.left, ast.Name)
            and index.left.id == "k"
            and isinstance(index.right, ast.Constant)
            and self.segment(index.right) == "1"
        ):
            return self.previous[name]
        raise ModelError(
            f"{self.key}: the time index of '{name}' must be [k] or [k-1], "
            f"got [{_unquoted(ast.unparse(index), 20)}]"
        )

    def compare(self, node: ast.Compare) -> sympy.Expr:
        if len(node.ops) != 1:
            raise self.fail("a chained comparison")
        operator = _COMPARE.get(type(node.ops[0]))
        if isinstance(node.ops[0], ast.Eq | ast.NotEq):
            raise ModelError(
                f"{self.key}: '{'==' if isinstance(node.ops[0], ast.Eq) else '!='}' is not a "
                "comparison of model expressions (computed numbers are seldom exactly equal); "
                "write <, <=, > or >="
            )
        if operator is None:
            raise self.fail(f"comparison {type(node.ops[0]).__name__}")
        left, right = self.value(node.left), self.value(node.comparators[0])
        return operator(*self.finite(node, (left, right)))

    def finite(self, node: ast.expr, operands: Sequence[Any]) -> Sequence[Any]:
        """``operands`` of the comparison or call ``node``, refused where one is beyond float64.

        sympy decides a comparison of constants (``x > exp(exp(exp(100)))``, and inside
        ``min``, ``max``, ``atan2``, ``exp(-...)``) by evaluating them to ever more digits: it
        ran for minutes, the checks of :func:`parse_expression` never reached.

        Raises
        ------
        ValueError
            Naming ``node`` and the constant that overflows.
        """
        overflow = next((found for value in operands if (found := _overflow(value))), "")
        if overflow:
            written = self.segment(node) or ast.unparse(node)
            raise ValueError(
                f"{excerpt(written, 40)} is not finite in double precision ({overflow} overflows)"
            )
        return operands

    def call(self, node: ast.Call) -> sympy.Expr:
        if not isinstance(node.func, ast.Name):
            if isinstance(node.func, ast.Attribute):
                raise self.fail(f"attribute access '.{node.func.attr}'")
            raise self.fail("calling a computed function")
        function = FUNCTIONS.get(node.func.id)
        if function is None:
            allowed = ", ".join(sorted(FUNCTIONS))
            raise ModelError(
                f"{self.key}: unknown function {excerpt(node.func.id, 40)} (allowed: {allowed})"
            )
        if node.keywords:
            raise self.fail("a keyword argument")
        if node.func.id == "Piecewise" and any(isinstance(a, ast.Tuple) for a in node.args):
            raise ModelError(
                f"{self.key}: Piecewise takes flat arguments, Piecewise(value, condition, "
                "value, condition, ..., otherwise), not sympy's (value, condition) pairs"
            )
        if any(isinstance(arg, ast.Starred) for arg in node.args):
            raise self.fail("argument unpacking")
        name, given = node.func.id, len(node.args)
        least, most = _ARITY.get(name, (1, 1))
        if given < least or (most is not None and given > most):
            wanted = (
                f"exactly {least}" if least == most else f"at least {least}"
            ) + f" argument{'s' if least > 1 else ''}"
            raise ModelError(f"{self.key}: {name} takes {wanted} ({given} given)")
        if name == "Piecewise":  # conditions at the odd positions, values elsewhere
            return function(
                *self.finite(
                    node,
                    [
                        self.visit(arg)
                        if position % 2 == 1 and position < given - 1
                        else self.value(arg)
                        for position, arg in enumerate(node.args)
                    ],
                )
            )
        arguments = self.finite(node, [self.value(arg) for arg in node.args])
        return self.real(node, function(*arguments))

    def _real_root(self, node: ast.BinOp, base: sympy.Expr, exponent: sympy.Expr) -> str:
        """How to write the real root ``node`` meant, where it is a negative number's odd root.

        sympy's ``(-8)**(1/3)`` is the principal root, ``1 + 1.732i``, as Python's and
        NumPy's are; a user who meant the real one, -2, is told how to write it:
        ``sign(b)*abs(b)**(p/q)`` for an odd numerator ``p``, ``abs(b)**(p/q)`` for an even
        one (an empty text for any other power).
        """
        if not (
            base.is_number
            and base.is_extended_negative
            and isinstance(exponent, sympy.Rational)
            and not exponent.is_Integer
            and exponent.q % 2 == 1
        ):
            return ""
        written = self.segment(node.left) or ast.unparse(node.left)
        power = f"abs({written})**({self.segment(node.right) or ast.unparse(node.right)})"
        real = power if exponent.p % 2 == 0 else f"sign({written})*{power}"
        if len(real) <= _REAL_ROOT_LIMIT and real.isprintable():
            return f"; for its real root write '{real}'"
        # cut, it was no longer what to write: 'for i…(coefficient_tank1)*abs(...' lost sign
        root = f"abs(b)**({exponent})" if exponent.p % 2 == 0 else f"sign(b)*abs(b)**({exponent})"
        return f"; for its real root write {excerpt(root, 60)}, b its base"

    def real(self, node: ast.expr, value: sympy.Expr, hint: str = "") -> sympy.Expr:
        """``value``, the power or function ``node``, refused where it is a complex constant.

        Only powers and functions leave the reals from real constants (``sqrt(-1)``,
        ``(-1)**(1/2)``, ``log(-1)``), so they are asked as they are built, before anything
        folds the constant away or works on it: ``sqrt(-1)**100`` was refused as "the
        exponent 100 is larger than 64" (the size of ``I`` unknown), ``sqrt(-1)**2*x`` and
        ``log(-1)*0 + x`` were accepted.  An infinity or NaN is left to the checks of
        :func:`parse_expression`, which say so.

        ``hint`` is added to the refusal (:meth:`_real_root`).

        Raises
        ------
        ValueError
            Naming the power or call and the value (:func:`parse_expression` adds the key,
            and a parameter behind it).
        """
        if (
            isinstance(value, sympy.Expr)
            and value.is_number
            and not value.has(*_NOT_FINITE)
            and (value.has(sympy.I) or value.is_extended_real is False)
        ):
            written = self.segment(node) or ast.unparse(node)
            raise _ComplexValueError(
                f"{excerpt(written, 40)} is complex-valued ({_unquoted(value, 40)}, not a real "
                f"number); model expressions must be real{hint}",
                node,
            )
        return value


_REAL_ROOT_LIMIT = 80
"""Longest real root :meth:`_Converter._real_root` writes out (a longer one in terms of ``b``)."""


_COMPLEX_MESSAGE_LIMIT = 300
"""Longest :class:`_ComplexValueError` message kept whole (its parts hold at most 265)."""


class _ComplexValueError(ValueError):
    """:meth:`_Converter.real`'s refusal, with the power or call ``node`` that made it.

    The parameters that power or call uses are named (``sqrt(p - 3)`` with ``p = 2``): setting
    one to 1 (how :func:`_parameters_used` finds the culprit of an overflow) does not make
    ``p - 3`` positive, so ``p`` went unnamed.
    """

    def __init__(self, message: str, node: ast.expr) -> None:
        super().__init__(message)
        self.node = node
