"""The functions a generated backward pass defines beside its loop, which calls them per mode.

Their definition (:func:`helper`, :data:`HELPER_IMPORT`), parameters
(:func:`step_arguments`) and calls (:func:`call`), the module they make with the loop
(:func:`with_helpers`), the values of a step not taken (:func:`standing`), and next mode
``j``'s whole RTS step as one (:func:`step_function`).  Expectation correction's two stages
are :mod:`hybridlog.estimators.ec_source`'s.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

from hybridlog.estimators.branch_tuples import select
from hybridlog.estimators.rts_source import StepSource, rts_step_source
from hybridlog.estimators.unrolled import (
    Entry,
    Matrix,
    Program,
    Vector,
    matrix_names,
    term,
    upper,
    vector_names,
)
from hybridlog.model.hybrid_model import HybridModel


class Helper(NamedTuple):
    """A generated function the backward pass's loop calls for one next mode."""

    name: str
    source: str
    """``@jit``-decorated definition (:data:`HELPER_IMPORT` in scope)."""


HELPER_IMPORT = "import numpy as np\n\nfrom hybridlog.jit import jit"
"""The generated module's imports: the decorator its helper functions carry, and NumPy for
the array expectation correction's stages share (:data:`SCRATCH`)."""


def helper(name: str, parameters: Sequence[Entry], body: Program, returned: str) -> Helper:
    """``name(parameters…)`` with ``body``'s lines, returning ``returned``.

    The backward passes' per-mode steps are written as functions of their own, each compiled
    once per next mode, where the loop writes one call per pair: numba's passes over a
    function (SSA form, reaching definitions, liveness) grow with its blocks times its
    variables, and expectation correction's loop for three modes, written out whole,
    spent about 55 of its 70 s of compiling in them.
    """
    body.emit(f"return {returned}")
    listed = ", ".join(str(x) for x in parameters)
    return Helper(name, f"@jit\ndef {name}({listed}):\n{body.source()}\n")


class _Arguments(NamedTuple):
    """Parameter names of a step function (symmetric matrices by their upper triangle)."""

    x0: Vector
    P0: Matrix
    u: Vector
    xn: Vector
    Pn: Matrix
    rn: Vector


def step_arguments(model: HybridModel) -> _Arguments:
    """The parameter names of ``model``'s step functions."""
    n, n_u = model.n_states, model.n_inputs
    return _Arguments(
        vector_names("x0", n),
        matrix_names("p0", n, n, symmetric=True),
        vector_names("u", n_u),
        vector_names("xn", n),
        matrix_names("pn", n, n, symmetric=True),
        vector_names("rn", n),
    )


def standing(x: Vector, P: Matrix) -> list[Entry]:
    """A step's values where it is not taken: ``x``, ``P``'s upper triangle, a zero probe.

    The generated counterpart of :func:`forward_stands`.
    """
    return [*x, *upper(P), *([0.0] * len(x))]


def chosen(p: Program, step: StepSource, x0: Vector, P0: Matrix) -> str:
    """``((x, P upper, r) of the step where taken else the forward estimate, cause bit)``."""
    bundle = p.fresh("sq")
    select(p, step.taken, bundle, step.x + upper(step.P) + step.r, standing(x0, P0))
    cause = p.assign("cb", f"0 if {step.taken} else {step.cause}")
    return f"{bundle}, {cause}"


def step_function(model: HybridModel, j: int, Q: Matrix) -> Helper:
    """``rts_step_j(x0, P0, u, xn, Pn, rn)``: next mode ``j``'s RTS step (:func:`rts_step_source`).

    Returns ``(values, cause)``: the step's mean, covariance (upper triangle) and rounding
    probe where it was taken, else ``x0, P0`` and a zero probe; ``cause`` 0 where taken,
    else the bit of the check that refused it (:func:`note_fallbacks`).
    """
    a = step_arguments(model)
    body = Program(indent="    ")
    step = rts_step_source(body, model, j, a.x0, a.P0, a.u, Q, a.xn, a.Pn, a.rn)
    returned = chosen(body, step, a.x0, a.P0)
    parameters = [*a.x0, *upper(a.P0), *a.u, *a.xn, *upper(a.Pn), *a.rn]
    return helper(f"rts_step_{j}", parameters, body, returned)


def call(name: str, arguments: Sequence[Entry]) -> str:
    """Source of a call of a generated helper."""
    return f"{name}({', '.join(term(x) for x in arguments)})"


def with_helpers(helpers: Sequence[Helper], function: str) -> str:
    """The generated module's functions: the helpers, then the loop that calls them."""
    return "\n\n".join([HELPER_IMPORT, *(h.source for h in helpers), function])
