r"""Symbolic derivatives of a model's expressions: Jacobians and Lie derivatives.

Every derivative hybridlog compiles is taken here, with sympy, and made printable: the
derivatives of ``abs``, ``sign``, ``max`` and ``min`` are distributions
(``Heaviside``, ``DiracDelta``), replaced by the functions a compiled step can evaluate
(:func:`printable`).  At a kink each takes the mean of its one-sided slopes, a
subgradient: ``∂|x|/∂x = sign(0) = 0``, ``∂max(x, 2x)/∂x = 3/2`` at ``x = 0``.

A model expression is real-valued, but sympy cannot always prove that an argument is real
(``sqrt(x1)``, ``log(x1)`` of a real ``x1`` may be complex to it).  It then leaves the
derivative of ``sign(sqrt(x1))`` unevaluated (``Derivative(...)``, which no printer can
write) and differentiates ``abs(sqrt(x1) - 1)`` through ``re`` and ``im`` into an expression
that is 0/0 where the argument is 0.  So :func:`jacobian` differentiates ``abs`` and
``sign`` as the real functions they are in a model: ``d|g| = sign(g) dg``, ``d sign(g) = 0``.

The Lie derivative of an output map :math:`h` along a vector field :math:`f` is

.. math::

    L_f^0 h = h, \qquad L_f^{k} h = \frac{\partial L_f^{k-1} h}{\partial x}\, f ,

the building block of the drift-observability map
:math:`\Phi = [h, L_f h, \dots, L_f^{n-1} h]` of paper 004, eq. (20) (Germani, Manes, Pepe,
``papers/004_33eb1488165da6c7.txt``).
"""

from __future__ import annotations

from collections.abc import Sequence

import sympy


def _heaviside(arg: sympy.Expr, *_: sympy.Expr) -> sympy.Expr:
    """The step of sympy's ∂max, ∂min: 1 above zero, 0 below, 1/2 at zero.

    sympy writes ``∂max(a, b)/∂x`` as ``H(a - b)·a' + H(b - a)·b'``.  At a tie (``a = b``)
    the half gives the mean of the two slopes, a subgradient, as ``sign(0) = 0`` gives
    for ``abs``; 0 there (the choice before) gave neither: ``max(x, 2*x)`` had derivative
    0 at ``x = 0`` instead of one in [1, 2], and an EKF whose estimate sat at 0 never
    moved, whatever the outputs said.
    """
    return sympy.Piecewise((sympy.S.One, arg > 0), (sympy.S.Half, arg >= 0), (sympy.S.Zero, True))


def _dirac(*_: sympy.Expr) -> sympy.Expr:
    # ∂sign(x)/∂x away from 0: the point x = 0 itself has measure zero.
    return sympy.S.Zero


class _RealAbs(sympy.Function):  # type: ignore[misc]  # sympy is untyped
    """``abs(g)`` of a real-valued ``g``: its derivative is ``sign(g) * g'``."""

    def fdiff(self, argindex: int = 1) -> sympy.Expr:
        return _RealSign(self.args[0])


class _RealSign(sympy.Function):  # type: ignore[misc]  # sympy is untyped
    """``sign(g)`` of a real-valued ``g``: its derivative is 0 away from ``g = 0``."""

    def fdiff(self, argindex: int = 1) -> sympy.Expr:
        return sympy.S.Zero


def _derivative(expression: sympy.Expr, variable: sympy.Symbol) -> sympy.Expr:
    """``∂expression/∂variable`` with ``abs`` and ``sign`` of real arguments (module doc)."""
    real = expression.replace(sympy.Abs, _RealAbs).replace(sympy.sign, _RealSign)
    derivative = sympy.diff(real, variable)
    return derivative.replace(_RealAbs, sympy.Abs).replace(_RealSign, sympy.sign)


def printable(expression: sympy.Expr) -> sympy.Expr:
    """``expression`` with ``DiracDelta`` set to 0 and ``Heaviside`` as :func:`_heaviside`."""
    return expression.replace(sympy.DiracDelta, _dirac).replace(sympy.Heaviside, _heaviside)


def jacobian(
    expressions: Sequence[sympy.Expr], variables: Sequence[sympy.Symbol]
) -> list[list[sympy.Expr]]:
    """``J[i][j] = ∂expressions[i]/∂variables[j]`` (``F``, ``H`` of paper 000, eqs. (12), (25)).

    Examples
    --------
    >>> x, y = sympy.symbols("x y", real=True)
    >>> jacobian([x * y, abs(x)], [x, y])
    [[y, x], [sign(x), 0]]
    >>> jacobian([sign(sqrt(x)), abs(sqrt(x) - 1)], [x])
    [[0], [sign(sqrt(x) - 1)/(2*sqrt(x))]]
    """
    return [_affine_row(e, variables) or _derived_row(e, variables) for e in expressions]


def _derived_row(expression: sympy.Expr, variables: Sequence[sympy.Symbol]) -> list[sympy.Expr]:
    """``∂expression/∂v`` for each of ``variables``, differentiated by sympy."""
    return [printable(_derivative(expression, v)) for v in variables]


def _affine_row(
    expression: sympy.Expr, variables: Sequence[sympy.Symbol]
) -> list[sympy.Expr] | None:
    """``∂expression/∂v`` of a sum of numbers times symbols, read off; else ``None``.

    The derivative of ``c0 + Σ c_k s_k`` (numbers ``c_k``, symbols ``s_k``) by ``v`` is the
    coefficient of ``v``, the very number :func:`_derived_row` gets, without sympy's
    ``diff`` (a mode written as matrices ``A``, ``C`` of 20 states spent 9 s of its first
    run there); any other term, a product of symbols or a function, returns ``None``.
    """
    coefficients = expression.as_coefficients_dict()
    if not all(term.is_Symbol or term is sympy.S.One for term in coefficients):
        return None
    return [coefficients.get(v, sympy.S.Zero) for v in variables]


def lie_derivative(
    h: Sequence[sympy.Expr],
    f: Sequence[sympy.Expr],
    states: Sequence[sympy.Symbol],
    order: int = 1,
) -> list[sympy.Expr]:
    r"""The ``order``-th Lie derivative :math:`L_f^{order} h` of the map ``h`` along ``f``.

    Parameters
    ----------
    h:
        The map, one expression per component (e.g. a mode's outputs).
    f:
        The vector field, one expression per state (``dx`` of a continuous-time mode).
    states:
        The state symbols, in the order of ``f``.
    order:
        How often to differentiate; 0 returns ``h``.

    Examples
    --------
    >>> x1, x2 = sympy.symbols("x1 x2", real=True)
    >>> lie_derivative([x1], [x2, -x1], [x1, x2], order=2)
    [-x1]
    """
    if len(f) != len(states):
        raise ValueError(f"the vector field has {len(f)} components for {len(states)} states")
    if order < 0:
        raise ValueError(f"order must be non-negative, not {order}")
    current = list(h)
    for _ in range(order):
        current = [
            sympy.Add(*(d * fi for d, fi in zip(row, f, strict=True)))
            for row in jacobian(current, states)
        ]
    return current


def boolean_affine_split(
    expressions: Sequence[sympy.Expr], booleans: Sequence[sympy.Symbol]
) -> tuple[list[sympy.Expr], list[list[sympy.Expr]]]:
    r"""``G`` and ``D`` of :math:`\dot x = G(x, u) + D(x, u)\,\delta` (paper 003, eq. (1)).

    ``G`` is ``expressions`` at :math:`\delta = 0`; column ``j`` of ``D`` is
    :math:`\partial\,\text{expressions} / \partial \delta_j`.

    Raises
    ------
    ValueError
        ``"<i>: ..."`` naming the first expression that is not affine in the booleans (a
        column of ``D`` that still depends on a boolean), so that ``G + D δ`` would not give
        the expressions back.

    Examples
    --------
    >>> x, d1, d2 = sympy.symbols("x d1 d2", real=True)
    >>> boolean_affine_split([1 - x * d1, d2 * x + d1], [d1, d2])
    ([1, 0], [[-x, 0], [1, x]])
    """
    zero = {d: sympy.S.Zero for d in booleans}
    G: list[sympy.Expr] = []
    D: list[list[sympy.Expr]] = []
    for i, expression in enumerate(expressions):
        problem = boolean_affine_problem(expression, booleans)
        if problem:
            raise ValueError(f"{i}: not affine in the booleans ({problem})")
        G.append(expression.xreplace(zero))
        D.append([sympy.diff(expression, d) for d in booleans])
    return G, D


def boolean_affine_problem(expression: sympy.Expr, booleans: Sequence[sympy.Symbol]) -> str:
    """Why ``expression`` is not ``G + Σ D_j δ_j`` with ``G``, ``D_j`` free of the booleans.

    ``""`` when it is.  The expression must be a polynomial of degree at most 1 in the
    booleans.  Asking only that each derivative ∂e/∂δ_j be free of the booleans let a
    boolean inside a ``Piecewise`` through (``Piecewise(c*sqrt(h), U > 0.5, 0)``, whose
    derivative is 0): ``G`` and ``D`` were then ``e`` at δ = 0 and 0, a valve that never
    opens, while the modes, substituted directly, had it open.

    >>> x, d1, d2 = sympy.symbols("x d1 d2", real=True)
    >>> boolean_affine_problem(x * d1 + sympy.sqrt(x), [d1, d2])
    ''
    >>> boolean_affine_problem(x * d1 * d2, [d1, d2])
    'd1*d2 is a product of booleans'
    """
    used = [d for d in booleans if expression.has(d)]
    if not used:
        return ""
    try:
        polynomial = sympy.Poly(expression, *used)
    except sympy.PolynomialError:
        inside = next(
            (
                node
                for node in sympy.preorder_traversal(expression)
                if isinstance(node, sympy.Function | sympy.Pow)
                and not (isinstance(node, sympy.Pow) and node.exp.is_Integer)
                and node.has(*used)
            ),
            None,
        )
        where = f" inside {_short(inside)}" if inside is not None else ""
        return f"a boolean appears{where}, not as a term times a boolean"
    for monomial in polynomial.monoms():
        if sum(monomial) > 1:
            term = sympy.Mul(*(d**p for d, p in zip(used, monomial, strict=True)))
            return f"{term} is {'a power' if max(monomial) > 1 else 'a product'} of booleans"
    return ""


def _short(node: sympy.Basic) -> str:
    text = str(node)
    return text if len(text) <= 60 else text[:57] + "..."
