r"""The one place where sympy expressions become Python source (compiled by numba).

:func:`model_source` writes a model's module.  For every mode ``q`` it defines four
functions with one shared calling convention (the mode index selects the branch, the result
is written into ``out``)::

    f(q, x, u, out)   # out[i]    = f_q,i(x, u)           next state   (paper 000, eq. (2))
    F(q, x, u, out)   # out[i, j] = ∂f_q,i/∂x_j            eq. (25)
    h(q, x, u, out)   # out[i]    = h_q,i(x, u)           output
    H(q, x, u, out)   # out[i, j] = ∂h_q,i/∂x_j            eq. (12)

A continuous-time model's module defines ``dx`` (:math:`\dot x`) and ``DX``
(:math:`\partial \dot x / \partial x`) in place of ``f`` and ``F``, with the same
convention, and ``jump(p, q, x, out)`` (the state after a switch from mode ``p`` to ``q``,
paper 004 eq. (3), the identity where the model has no map); a boolean-affine one also
``G(q, x, u, out)`` and ``D(q, x, u, out)`` of paper 003, eq. (1) (``q`` unused).

And, when the model has them, ``guard(x, u)`` (index of the first mode whose guard holds,
or -1) and ``input_<j>(t, k)`` (the ``[simulation.inputs]`` signals, NumPy-vectorised over
the time grid, as :func:`lambdify` evaluates them).  :func:`emit_mode_function`
writes one mode function inline, for the straight-line filter loops of
:mod:`hybridlog.estimators.unrolled`.

Derivatives come from :mod:`hybridlog.model.derivatives`; common subexpressions are shared
(``sympy.cse``), so the generated code is scalar straight-line code without small-array
loops; but a linear mode's Jacobians, constant matrices, are copied from module-level tables
(:func:`constant_jacobians`), which compile in a moment where a store per entry took minutes.
Nothing here is run when the compiled-code cache (:mod:`hybridlog.model.compiled`)
already holds a model's module.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import TYPE_CHECKING, Any, cast

import sympy
from sympy.printing.numpy import NumPyPrinter
from sympy.printing.precedence import precedence
from sympy.printing.pycode import PythonCodePrinter

from hybridlog.model.derivatives import boolean_affine_split, jacobian

if TYPE_CHECKING:
    from hybridlog.model.hybrid_model import HybridModel

FUNCTION_NAMES = ("f", "F", "h", "H")
"""The mode functions every discrete-time model module defines."""

CONTINUOUS_FUNCTION_NAMES = ("dx", "DX", "h", "H")
"""The mode functions every continuous-time model module defines (``dx`` in place of ``f``)."""


_NAN_GUARDED = (sympy.Max, sympy.Min, sympy.sign)
"""Functions printed so that a NaN argument gives NaN (:class:`_ModelPrinter`)."""

_OPPOSITE: Mapping[type, type] = {
    sympy.StrictGreaterThan: sympy.LessThan,
    sympy.GreaterThan: sympy.StrictLessThan,
    sympy.StrictLessThan: sympy.GreaterThan,
    sympy.LessThan: sympy.StrictGreaterThan,
}
"""The comparison that holds exactly when one does not, unless a side is NaN."""


_EXACT_INTEGERS = 2**53
"""The largest magnitude below which every whole number is a double (and a 64-bit integer)."""


class _ExactFloats:
    """A finite ``Float`` printed as the double it holds (``repr``), not at 15 digits.

    And a whole number or fraction beyond 2**53 as the double Python makes of it.

    sympy prints a 53-bit ``Float`` with 15 significant digits, which is not enough to
    name a double: a parameter written ``0.12345678901234568`` was compiled as
    ``0.123456789012346``, a constant sympy folded (``1/616`` of the three tanks'
    ``0.00162337662337662``) one or two units in the last place from its value, so the
    compiled model was not the model the report's ``parameters`` record.  ``repr`` gives
    the shortest text that reads back as the same double.
    """

    def _print_Float(self, expr: sympy.Float) -> str:
        value = float(expr)
        if not math.isfinite(value):
            return str(super()._print_Float(expr))  # type: ignore[misc]  # sympy's own
        return repr(value)

    def _print_Integer(self, expr: sympy.Integer) -> str:
        """A whole number beyond 2**53 as the double Python's arithmetic makes of it.

        numba types a literal as a 64-bit integer: ``100000000000000000000*x_0`` (a model's
        ``1e20`` written in digits) failed to compile with "Int value is too large".
        """
        if abs(expr.p) <= _EXACT_INTEGERS:
            return str(expr.p)
        return repr(float(expr.p))

    def _print_Rational(self, expr: sympy.Rational) -> str:
        """``p/q``, or the double nearest ``p/q`` when ``p`` or ``q`` is beyond 2**53.

        Python divides two integers exactly and rounds once; numba first turns each into a
        double (or fails to type one beyond 64 bits), which rounds up to three times.
        """
        if max(abs(expr.p), expr.q) <= _EXACT_INTEGERS:
            return f"{expr.p}/{expr.q}"
        return repr(expr.p / expr.q)


class _ExactPythonPrinter(_ExactFloats, PythonCodePrinter):  # type: ignore[misc]  # untyped
    """sympy's Python printer, each ``Float`` printed as the double it holds."""


class _ExactNumPyPrinter(_ExactFloats, NumPyPrinter):  # type: ignore[misc]  # untyped
    """sympy's NumPy printer, each ``Float`` printed as the double it holds."""


def lambdify(
    args: Sequence[sympy.Symbol], expressions: object, module: str, *, cse: bool = False
) -> Callable[..., Any]:
    """``sympy.lambdify(args, expressions, module)`` with each ``Float`` printed as its double.

    ``module`` is ``"numpy"`` or ``"math"``; the printer is made with the settings
    ``lambdify`` gives its own (a printer class passed to it would not be, and the
    modules its code calls, ``functools`` for ``max``, would not be imported).
    """
    printer = (_ExactNumPyPrinter if module == "numpy" else _ExactPythonPrinter)(
        {"fully_qualified_modules": False, "inline": True, "allow_unknown_functions": True}
    )
    function = sympy.lambdify(args, expressions, module, printer=printer, cse=cse)
    return cast(Callable[..., Any], function)


class _ModelPrinter(_ExactPythonPrinter):
    """sympy's Python printer with ``max``, ``min`` and ``sign`` that keep a NaN.

    A NaN in a mode function (``sqrt`` or ``log`` of a negative value) is how the
    simulation and the estimators find that a model left its domain, and they report it.
    Python's (and numba's) ``max(0, nan)`` is 0 while ``max(nan, 0)`` is NaN (which one
    depends on sympy's order of the arguments, not on the user's), sympy prints
    ``sign(x)`` as ``math.copysign(1, x)``, +1 or -1 for a NaN, and a ``Piecewise`` whose
    condition compares a NaN took its next branch: each turned a value outside the model's
    domain into a plausible number.  Here a NaN argument or condition gives NaN.

    The arguments are printed twice (the test and the value): :func:`assignments` binds
    each one that is not a name or a number to a temporary first, so none is computed twice.
    """

    def _guarded(self, value: str, arguments: Sequence[sympy.Expr]) -> str:
        printed = [self._print(argument) for argument in arguments]
        tests = [f"{a} == {a}" for a, e in zip(printed, arguments, strict=True) if not e.is_Number]
        if not tests:
            return f"({value.format(*printed)})"
        return f"({value.format(*printed)} if {' and '.join(tests)} else math.nan)"

    def _print_Pow(self, expr: sympy.Pow, rational: bool = False) -> str:
        """A negative whole power ``x**(-3)`` as ``1/x**3``.

        numba computes ``x**(-3)`` by repeated multiplication and raises ZeroDivisionError
        at ``x = 0`` (a crash "unexpected ZeroDivisionError"), where ``1/x**3`` is ``inf``
        as ``1/x`` is, which the runs then name as a pole.  sympy prints ``x**(-1)`` and
        a product's negative powers (``2*x**(-3)``) as divisions already.
        """
        exponent = expr.exp
        if exponent.is_Integer and exponent < -1:
            positive = sympy.Pow(expr.base, -exponent, evaluate=False)
            return f"1/{self.parenthesize(positive, precedence(expr))}"
        return str(super()._print_Pow(expr, rational=rational))

    def _print_Max(self, expr: sympy.Max) -> str:
        return self._guarded(f"max({', '.join(['{}'] * len(expr.args))})", expr.args)

    def _print_Min(self, expr: sympy.Min) -> str:
        return self._guarded(f"min({', '.join(['{}'] * len(expr.args))})", expr.args)

    def _print_sign(self, expr: sympy.sign) -> str:
        return self._guarded("(0.0 if {0} == 0 else math.copysign(1.0, {0}))", expr.args)

    def _print_Piecewise(self, expr: sympy.Piecewise) -> str:
        """Branches tested in order, NaN where a condition compares a NaN.

        Neither such a comparison nor its opposite holds: the value is NaN instead of the
        next branch's.
        """
        *pairs, last = expr.args
        if last.cond != sympy.true or not all(_comparisons(pair.cond) for pair in pairs):
            return str(super()._print_Piecewise(expr))
        printed = f"({self._print(last.expr)})"
        for pair in reversed(pairs):
            condition = pair.cond
            if type(condition) in _OPPOSITE:
                opposite = _OPPOSITE[type(condition)](condition.lhs, condition.rhs, evaluate=False)
                printed = (
                    f"(({self._print(pair.expr)}) if {self._print(condition)} "
                    f"else {printed} if {self._print(opposite)} else math.nan)"
                )
                continue
            # Two adjacent branches of one value are one branch to sympy, its condition
            # their Or ('Piecewise(1, x > 0, 1, sqrt(u) > 1, 0)'). A comparison of a NaN
            # is false, so where the condition holds it holds whatever a NaN compared
            # (x > 0 at x = 1); where it does not, a NaN compared leaves it undecided.
            decided = " and ".join(
                f"({self._print(c)} or "
                f"{self._print(_OPPOSITE[type(c)](c.lhs, c.rhs, evaluate=False))})"
                for c in sorted(_comparisons(condition), key=sympy.default_sort_key)
            )
            printed = (
                f"(({self._print(pair.expr)}) if {self._print(condition)} "
                f"else ({printed} if {decided} else math.nan))"
            )
        return printed


def _comparisons(condition: sympy.Basic) -> set[sympy.Basic]:
    """The comparisons ``<, <=, >, >=`` a condition is made of; empty if it holds anything else.

    A comparison alone, or an ``And``, ``Or`` or ``Not`` of them (as sympy merges adjacent
    ``Piecewise`` branches of one value).
    """
    if isinstance(condition, tuple(_OPPOSITE)):
        return {condition}
    if not isinstance(condition, sympy.And | sympy.Or | sympy.Not):
        return set()
    parts = [_comparisons(argument) for argument in condition.args]
    return set().union(*parts) if all(parts) else set()


def _printer() -> PythonCodePrinter:
    """Python printer whose output numba compiles: ``math`` functions, ternaries for Piecewise."""
    return _ModelPrinter({"fully_qualified_modules": True, "standard": "python3"})


def unevaluated_functions(expression: sympy.Basic) -> list[str]:
    """The functions of ``expression`` the generated code cannot evaluate, sorted by name.

    A model's own expressions call only the grammar's functions, but sympy's solution of an
    equation may call others: ``w + exp(w) = x1`` solves to ``x1 - LambertW(exp(x1))``,
    which no printer here writes ("unexpected PrintMethodNotImplementedError" in
    ``simulate`` and ``imm``, "NameError: name 'LambertW' is not defined" in
    ``unknown-mode``), and a polynomial's root may be a ``CRootOf``, which prints as a name
    that the generated code does not define.  Those sympy's ``math`` printer knows
    (``asin``, ``asinh``, ...) are evaluated, as are the grammar's own.
    """
    printable = {*_printer().known_functions, "sign", "Piecewise"}
    called = {
        type(part).__name__
        for part in sympy.preorder_traversal(expression)
        if isinstance(part, sympy.Function | sympy.RootOf)
    }
    return sorted(called - printable)


def _hoisted(
    expression: sympy.Basic,
    temporaries: Iterator[sympy.Symbol],
    bound: list[tuple[sympy.Symbol, sympy.Basic]],
) -> sympy.Basic:
    """``expression`` with each argument of max, min and sign that is not an atom bound first.

    Appends ``(temporary, argument)`` to ``bound`` for each (innermost first), so the
    printed code computes the argument once although :class:`_ModelPrinter` names it twice.
    """
    if not expression.args:
        return expression
    arguments = [_hoisted(argument, temporaries, bound) for argument in expression.args]
    if isinstance(expression, _NAN_GUARDED):
        named = []
        for argument in arguments:
            if not argument.is_Atom:
                temporary = next(temporaries)
                bound.append((temporary, argument))
                argument = temporary
            named.append(argument)
        return expression.func(*named, evaluate=False)
    if arguments == list(expression.args):
        return expression
    return expression.func(*arguments)


def assignments(
    expressions: Sequence[sympy.Expr],
    targets: Sequence[str],
    names: Mapping[sympy.Symbol, sympy.Symbol],
    indent: str,
    temporaries: str = "c_",
) -> list[str]:
    """Lines assigning ``expressions`` to ``targets``, sharing common subexpressions.

    ``names`` renames the model's symbols to the generated code's scalar variables; the
    shared subexpressions are bound to ``<temporaries>0``, ``<temporaries>1`` ..., the
    arguments of max, min and sign (:func:`_hoisted`) to ``<temporaries>n0`` ...
    """
    printer = _printer()
    replacements, reduced = sympy.cse(
        list(expressions), symbols=sympy.numbered_symbols(temporaries), optimizations="basic"
    )
    guarded = sympy.numbered_symbols(f"{temporaries}n", real=True)
    lines: list[str] = []

    def assign(target: object, value: sympy.Basic) -> None:
        bound: list[tuple[sympy.Symbol, sympy.Basic]] = []
        value = _hoisted(sympy.sympify(value).xreplace(names), guarded, bound)
        lines.extend(f"{indent}{sym} = {printer.doprint(argument)}" for sym, argument in bound)
        lines.append(f"{indent}{target} = {printer.doprint(value)}")

    for sym, value in replacements:
        assign(sym, value)
    for target, value in zip(targets, reduced, strict=True):
        assign(target, value)
    return lines


def _slot_names(model: HybridModel) -> dict[sympy.Symbol, sympy.Symbol]:
    """The model's states and inputs renamed to ``x_<i>`` and ``u_<i>``."""
    xs, us = model.symbols()
    names = {x: sympy.Symbol(f"x_{i}") for i, x in enumerate(xs)}
    names.update({u: sympy.Symbol(f"u_{i}") for i, u in enumerate(us)})
    return names


def mode_expressions(model: HybridModel, mode_index: int, kind: str) -> list[sympy.Expr]:
    """``f``, ``h`` or the row-major Jacobian entries ``F``, ``H`` of one mode."""
    xs, _ = model.symbols()
    mode = model.modes[mode_index]
    if kind == "f":
        return list(mode.f)
    if kind == "dx":
        return list(mode.dx)
    if kind == "h":
        return list(mode.h)
    if kind == "F":
        return [entry for row in jacobian(mode.f, xs) for entry in row]
    if kind == "DX":
        return [entry for row in jacobian(mode.dx, xs) for entry in row]
    if kind == "H":
        return [entry for row in jacobian(mode.h, xs) for entry in row]
    raise ValueError(f"unknown mode function {kind!r}")


def _mode_functions(model: HybridModel) -> list[str]:
    names = _slot_names(model)
    n_x, n_y = model.n_states, model.n_outputs
    loads = [f"        x_{i} = x[{i}]" for i in range(n_x)]
    loads += [f"        u_{i} = u[{i}]" for i in range(model.n_inputs)]
    vector_targets = {
        "f": [f"out[{i}]" for i in range(n_x)],
        "h": [f"out[{i}]" for i in range(n_y)],
        "F": [f"out[{i}, {j}]" for i in range(n_x) for j in range(n_x)],
        "H": [f"out[{i}, {j}]" for i in range(n_y) for j in range(n_x)],
    }
    vector_targets["dx"], vector_targets["DX"] = vector_targets["f"], vector_targets["F"]
    lines: list[str] = []
    for name in CONTINUOUS_FUNCTION_NAMES if model.is_continuous else FUNCTION_NAMES:
        by_mode = [mode_expressions(model, index, name) for index in range(model.n_modes)]
        constant: dict[int, list[sympy.Expr]] = {}
        if name in JACOBIAN_NAMES:
            constant = {q: exprs for q, exprs in enumerate(by_mode) if _numbers(exprs)}
        tables, copy = constant_jacobians(name, constant, model.n_modes, n_x)
        lines = tables + lines + ["", "", f"def {name}(q, x, u, out):", *copy]
        keyword = "if"
        for index, mode in enumerate(model.modes):
            if index in constant:
                continue
            lines.append(f"    {keyword} q == {index}:  # mode {mode.id!r}")
            keyword = "elif"
            body = assignments(by_mode[index], vector_targets[name], names, " " * 8)
            used = "\n".join(body)
            lines += [line for line in loads if line.split(" = ")[0].strip() in used]
            lines += body
        lines.append("    return None")
    return lines


JACOBIAN_NAMES = frozenset({"F", "DX", "H"})
"""The mode functions that are Jacobians: constant matrices in a linear mode."""


def _numbers(expressions: Sequence[sympy.Expr]) -> bool:
    return all(expression.is_Number for expression in expressions)


def constant_jacobians(
    name: str, constant: Mapping[int, Sequence[sympy.Expr]], n_modes: int, columns: int
) -> tuple[list[str], list[str]]:
    """Module-level tables of the modes' constant Jacobians, and the lines that copy one.

    ``constant`` maps a mode index to its Jacobian's entries (row-major, every one a
    number: a linear mode's ``F = A``, ``H = C``).  Returns the lines binding
    ``<name>_TABLE`` (one matrix per such mode) and ``<name>_SLOT`` (each mode's matrix in
    the table, -1 for the others), and the function's first lines, which copy the mode's
    matrix into ``out`` and return where it has one.  Written as one store per entry
    instead, a 20-state model of six modes took 45 s to compile ``F``'s 2,400 stores; the
    table is frozen into the machine code by numba and copied in a loop (about a second
    for 16 modes).  Each entry is printed as the stores printed it: the same doubles.
    """
    if not constant:
        return [], []
    printer = _printer()
    slots = [-1] * n_modes
    tables = ["", f"{name}_TABLE = numpy.array(["]
    for slot, (index, entries) in enumerate(constant.items()):
        slots[index] = slot
        tables.append("    [")
        for start in range(0, len(entries), columns):
            row = ", ".join(printer.doprint(entry) for entry in entries[start : start + columns])
            tables.append(f"        [{row}],")
        tables.append("    ],")
    tables += [
        "], dtype=numpy.float64)",
        f"{name}_SLOT = numpy.array({slots}, dtype=numpy.int64)",
    ]
    copy = [
        f"    slot = {name}_SLOT[q]",
        "    if slot >= 0:  # a linear mode: its constant Jacobian",
        "        for i in range(out.shape[0]):",
        "            for j in range(out.shape[1]):",
        f"                out[i, j] = {name}_TABLE[slot, i, j]",
        "        return None",
    ]
    return tables, copy


def _guard_function(model: HybridModel) -> list[str]:
    """``guard(x, u)``: the first mode whose guard holds, -1 where none does.

    A guard that compares a NaN (``sqrt(x) > 0.5`` at ``x < 0``, outside its domain) does
    not hold, as its comparison is false in the reals; where no guard holds, ``-2 - i``
    names the first such mode ``i``, so that the error says which guard left the sample
    without a mode (it said only that none held).  A side that is infinite (``1/x > 0`` at
    ``x = 0``, a pole, whose sign is that of the zero's; or past float64) decides nothing:
    ``-2 - n - i`` (``n`` modes) stops the run there, naming mode ``i``'s guard (it held or
    not by the sign of a zero).
    """
    names = _slot_names(model)
    printer = _printer()
    lines = ["", "", "def guard(x, u):"]
    lines += [f"    x_{i} = x[{i}]" for i in range(model.n_states)]
    lines += [f"    u_{i} = u[{i}]" for i in range(model.n_inputs)]
    lines.append("    undecided = -1")
    for index, mode in enumerate(model.modes):
        if mode.guard is None:
            continue
        condition = mode.guard
        if not isinstance(condition, sympy.core.relational.Relational):
            # never so from the loader (one comparison); printed as it is
            lines.append(f"    if {printer.doprint(condition.xreplace(names))}:  # {mode.id!r}")
            lines.append(f"        return {index}")
            continue
        lhs, rhs = f"g{index}_l", f"g{index}_r"
        lines += assignments(
            [condition.lhs, condition.rhs], [lhs, rhs], names, "    ", temporaries=f"g{index}_"
        )
        test = condition.func(sympy.Symbol(lhs), sympy.Symbol(rhs), evaluate=False)
        lines.append(f"    if {lhs} != {lhs} or {rhs} != {rhs}:  # mode {mode.id!r}: NaN")
        lines.append("        if undecided < 0:")
        lines.append(f"            undecided = {index}")
        lines.append(f"    elif math.isinf({lhs}) or math.isinf({rhs}):  # a pole, or past float64")
        lines.append(f"        return {-2 - len(model.modes) - index}")
        lines.append(f"    elif {printer.doprint(test)}:  # mode {mode.id!r}")
        lines.append(f"        return {index}")
    lines.append("    return -1 if undecided < 0 else -2 - undecided")
    return lines


def _loads(model: HybridModel, used: str, indent: str = "    ") -> list[str]:
    """``x_<i> = x[i]`` and ``u_<i> = u[i]`` for the slots ``used`` (the body's text) reads."""
    loads = [f"{indent}x_{i} = x[{i}]" for i in range(model.n_states)]
    loads += [f"{indent}u_{i} = u[{i}]" for i in range(model.n_inputs)]
    return [line for line in loads if line.split(" = ")[0].strip() in used]


def _boolean_affine_functions(model: HybridModel) -> list[str]:
    """``G(q, x, u, out)`` and ``D(q, x, u, out)`` of paper 003, eq. (1) (``q`` is unused).

    The mode argument keeps the calling convention (and numba signature) of ``dx`` and
    ``DX``, so a kernel takes them as the same first-class function types.
    """
    affine = model.boolean_affine
    assert affine is not None
    try:
        G, D = boolean_affine_split(affine.dynamics, affine.symbols())
    except ValueError as err:  # the loader checks this too; the code must not rely on it
        index, _, message = str(err).partition(": ")
        raise model.error(f"{affine.key}.dx[{index}]", message) from err
    names = _slot_names(model)
    n_x, n_b = model.n_states, len(affine.booleans)
    lines: list[str] = []
    for name, exprs, targets in (
        ("G", list(G), [f"out[{i}]" for i in range(n_x)]),
        (
            "D",
            [e for row in D for e in row],
            [f"out[{i}, {j}]" for i in range(n_x) for j in range(n_b)],
        ),
    ):
        body = assignments(exprs, targets, names, "    ")
        lines += ["", "", f"def {name}(q, x, u, out):", *_loads(model, "\n".join(body)), *body]
        lines.append("    return None")
    return lines


def _jump_function(model: HybridModel) -> list[str]:
    """``jump(p, q, x, out)``: ``out = R(p, q, x)``, the state after a switch from ``p`` to ``q``.

    Paper 004, eq. (3); the identity where the model has no map for the pair (and for
    ``p == q``).  ``out`` must not be ``x``.
    """
    names = _slot_names(model)
    xs, _ = model.symbols()
    lines = ["", "", "def jump(p, q, x, out):"]
    keyword = "if"
    pairs = range(model.n_modes) if model.has_jumps else range(0)
    for source in pairs:
        for target in range(model.n_modes):
            reset = model.reset_map(source, target)
            if reset is None:
                continue
            lines.append(f"    {keyword} p == {source} and q == {target}:")
            keyword = "elif"
            targets = [f"out[{i}]" for i in range(model.n_states)]
            body = assignments(list(reset), targets, names, " " * 8)
            lines += _loads(model, "\n".join(body), " " * 8)
            lines += body
            lines.append("        return None")
    lines += [f"    out[{i}] = x[{i}]" for i in range(len(xs))]
    lines.append("    return None")
    return lines


def _input_functions(model: HybridModel) -> list[str]:
    """``input_<j>(t, k)`` of the ``[simulation.inputs]``, after the modules their code calls.

    Every module the printer used is imported: ``max`` prints as
    ``functools.reduce(numpy.maximum, ...)``, and ``functools`` was imported nowhere.
    """
    # The NumPy printer of sympy.lambdify(modules="numpy"): the same calls, exact constants.
    printer = _ExactNumPyPrinter({"fully_qualified_modules": True, "inline": True})
    lines: list[str] = []
    for index, name in enumerate(model.inputs):
        if name in model.simulation_inputs:
            expression = printer.doprint(model.simulation_inputs[name])
            lines += ["", "", f"def input_{index}(t, k):  # {name}", f"    return {expression}"]
    imports = [f"import {module}" for module in sorted(printer.module_imports)]
    return ["", *imports, *lines] if lines else []


def model_source(model: HybridModel) -> str:
    """Python source (without decorators) of the model's functions, see the module doc."""
    lines = [
        f'"""Generated by hybridlog for model {model.name!r}: mode functions."""',
        "",
        "import math",
        "",
        "import numpy",
    ]
    lines += _mode_functions(model)
    if model.state_driven:
        lines += _guard_function(model)
    if model.is_continuous:
        lines += _jump_function(model)
        if model.has_booleans:
            lines += _boolean_affine_functions(model)
    lines += _input_functions(model)
    return "\n".join(lines) + "\n"


def emit_mode_function(
    model: HybridModel,
    mode_index: int,
    kind: str,
    states: Sequence[str],
    inputs: Sequence[str],
    prefix: str,
    indent: str,
) -> tuple[list[str], list[float | str]]:
    """Straight-line lines computing one mode function at named scalar states and inputs.

    Returns the lines and one entry per value: a float where the expression is a number
    (Jacobian entries that are structurally constant cost nothing), else a variable name.
    """
    xs, us = model.symbols()
    names: dict[sympy.Symbol, sympy.Symbol] = {
        **{x: sympy.Symbol(s) for x, s in zip(xs, states, strict=True)},
        **{u: sympy.Symbol(s) for u, s in zip(us, inputs, strict=True)},
    }
    entries: list[float | str] = []
    pending: list[sympy.Expr] = []
    targets: list[str] = []
    for index, expression in enumerate(mode_expressions(model, mode_index, kind)):
        if expression.is_Number:
            entries.append(float(expression))
        else:
            target = f"{prefix}{index}"
            entries.append(target)
            pending.append(expression)
            targets.append(target)
    if not pending:
        return [], entries
    return assignments(pending, targets, names, indent, temporaries=f"{prefix}c"), entries


def switched_function(
    model: HybridModel,
    name: str,
    expressions: Sequence[Sequence[sympy.Expr]],
    targets: Sequence[str],
) -> list[str]:
    """Lines of ``def <name>(q, x, u, out)``: ``targets = expressions[q]`` for mode index ``q``.

    The calling convention of the model functions (:func:`model_source`) for expressions an
    estimator derives itself (paper 004's drift-observability Jacobian ``Q``, a mode's
    ``dx``): one branch per mode, states and inputs read into scalars only where used.
    """
    names = _slot_names(model)
    loads = [f"        x_{i} = x[{i}]" for i in range(model.n_states)]
    loads += [f"        u_{i} = u[{i}]" for i in range(model.n_inputs)]
    lines = ["", "", f"def {name}(q, x, u, out):"]
    for index, mode in enumerate(model.modes):
        keyword = "if" if index == 0 else "elif"
        lines.append(f"    {keyword} q == {index}:  # mode {mode.id!r}")
        body = assignments(expressions[index], targets, names, " " * 8)
        used = "\n".join(body)
        lines += [line for line in loads if line.split(" = ")[0].strip() in used]
        lines += body
    lines.append("    return None")
    return lines


def jump_function(model: HybridModel, name: str = "reset") -> list[str]:
    """Lines of ``def <name>(a, b, x, out) -> int``: the jump map ``R`` (paper 004, eq. (3)).

    ``out`` receives the state after a switch from mode index ``a`` to ``b``
    (:meth:`~hybridlog.model.hybrid_model.HybridModel.reset_map`); the function returns 1
    when a map was applied and 0 when the state is continuous across the switch (``out = x``).
    """
    names = _slot_names(model)
    n_x = model.n_states
    targets = [f"out[{i}]" for i in range(n_x)]
    lines = ["", "", f"def {name}(a, b, x, out):"]
    lines += [f"    x_{i} = x[{i}]" for i in range(n_x)]
    first = True
    for a in range(model.n_modes):
        for b in range(model.n_modes):
            reset = model.reset_map(a, b)
            if reset is None:
                continue
            keyword = "if" if first else "elif"
            first = False
            source, target = model.modes[a].id, model.modes[b].id
            lines.append(f"    {keyword} a == {a} and b == {b}:  # {source!r} -> {target!r}")
            lines += assignments(list(reset), targets, names, " " * 8)
            lines.append("        return 1")
    lines += [f"    out[{i}] = x_{i}" for i in range(n_x)]
    lines.append("    return 0")
    return lines
