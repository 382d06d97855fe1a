"""Which expression of a model turned a finite point into NaN or infinity: a run's divergence named.

A compiled loop (``simulate``'s kernels, ``switching-observer``'s generated loop) that
diverges leaves only its non-finite output: "the simulation diverged: h1 = nan", "the
estimate is not finite", naming neither the mode nor the expression.  The caller runs the
failing interval again in plain Python with the model's functions wrapped by a
:class:`Watch`, which keeps the first evaluation whose point is finite and whose value is
not; :func:`escape_error` names its model-file key (``modes.<id>.dx[i]``, ``modes.<id>.h[i]``,
``jumps."a->b"``), its expression and the point, and tells leaving the expression's domain
(NaN: ``log`` of a negative level) from overflowing float64 (infinite: ``exp`` of a state
running away).  Pure NumPy: the wrapped functions are whatever the caller passes, compiled
or not.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from hybridlog.errors import ModelError, excerpt
from hybridlog.model.compiled import ModelFunction
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.signals import FloatArray

if TYPE_CHECKING:
    import sympy

__all__ = ["Escape", "Watch", "escape_error", "point", "replayed"]

Reset = Callable[[int, int, FloatArray, FloatArray], object]
"""A jump map ``(source, target, x, out)``; the generated observer's returns whether it jumped."""

MAX_SHOWN = 8
"""Values of a point named in a message at most (the rest ``…``)."""


@dataclass(frozen=True)
class Escape:
    """One evaluation at a finite point whose value is not finite.

    Attributes
    ----------
    function:
        ``"dx"``, ``"f"``, ``"h"`` or ``"reset"`` (a jump map).
    mode:
        The mode index (for ``reset``: the mode before the switch).
    target:
        For ``reset``: the mode index after the switch; else -1.
    x, u:
        The point (``u`` empty for ``reset``).
    out:
        The value, some entry of it not finite.
    """

    function: str
    mode: int
    target: int
    x: FloatArray
    u: FloatArray
    out: FloatArray


class Watch:
    """Wrap model functions so that the first evaluation leaving the finite numbers is kept."""

    def __init__(self) -> None:
        self.found: Escape | None = None

    def _keep(self, escape: Escape) -> None:
        if (
            self.found is None
            and np.isfinite(escape.x).all()
            and np.isfinite(escape.u).all()
            and not np.isfinite(escape.out).all()
        ):
            self.found = escape

    def vector(self, name: str, function: ModelFunction) -> ModelFunction:
        """``function`` (``dx`` or ``h``: ``(q, x, u, out)``), watched under ``name``."""

        def watched(q: int, x: FloatArray, u: FloatArray, out: FloatArray) -> None:
            function(q, x, u, out)
            self._keep(Escape(name, int(q), -1, x.copy(), u.copy(), out.copy()))

        return watched

    def jump(self, function: Reset) -> Reset:
        """The jump map ``(source, target, x, out)``, watched as ``"reset"``."""

        def watched(source: int, target: int, x: FloatArray, out: FloatArray) -> object:
            value = function(source, target, x, out)
            empty = np.zeros(0)
            self._keep(Escape("reset", int(source), int(target), x.copy(), empty, out.copy()))
            return value

        return watched


def point(model: HybridModel, x: FloatArray, u: FloatArray) -> str:
    """``h1 = 0.5, u = 1``: the states' and inputs' values, at most :data:`MAX_SHOWN`."""
    values = [
        f"{name} = {number:.6g}"
        for name, number in (
            *zip(model.states, x.tolist(), strict=True),
            *zip(model.inputs, u.tolist(), strict=False),
        )
    ]
    return ", ".join(values[:MAX_SHOWN]) + (", …" if len(values) > MAX_SHOWN else "")


def _expression_key(model: HybridModel, function: str, mode: int, index: int) -> str:
    mode_id = model.modes[mode].id
    if model.has_booleans:
        return f"dynamics.{function}[{index}] of mode '{mode_id}'"
    return f"modes.{mode_id}.{function}[{index}]"


def escape_error(
    model: HybridModel,
    escape: Escape,
    where: str,
    consequence: str,
    noun: str = "state",
) -> ModelError:
    """The error naming ``escape``'s key, expression, point and kind.

    Parameters
    ----------
    where:
        When, after the point (``a step of the interval from t = 0.2 s to 0.3 s``).
    consequence:
        What the run did, closing the message (``the simulation diverged; nothing was
        written``).
    noun:
        What the point is (``state``, ``estimate``).
    """
    column = int(np.argmin(np.isfinite(escape.out)))
    value = float(escape.out[column])
    if escape.function == "reset":
        found = model.jump_between(escape.mode, escape.target)
        key = found.key if found is not None else "jumps"
        return model.error(
            key,
            f"the jump map gives {model.states[column]} = {value:g} at the switch from "
            f"'{model.modes[escape.mode].id}' to '{model.modes[escape.target].id}' {where}, "
            f"from {point(model, escape.x, escape.u)}: {consequence}",
        )
    mode = model.modes[escape.mode]
    expressions = {"dx": mode.dx, "f": mode.f}.get(escape.function, mode.h)
    if np.isnan(value):
        why = f"the {noun} left the domain of {escape.function} there"
    elif _at_pole(model, expressions[column], escape):
        why = f"a pole of {escape.function}: a division by 0 or a log of 0 there"
    else:
        why = f"more than float64 holds: the {noun} ran away"
    return model.error(
        _expression_key(model, escape.function, escape.mode, column),
        f"{excerpt(str(expressions[column]))} is {value:g} at "
        f"{point(model, escape.x, escape.u)}, {where} ({why}): {consequence}",
    )


def _at_pole(model: HybridModel, expression: sympy.Expr, escape: Escape) -> bool:
    """True when ``expression`` is infinite at ``escape``'s point itself, not just beyond float64.

    ``1/x`` or ``log(x)`` at ``x = 0`` is infinite in exact arithmetic too (a pole: the
    state reached it, it did not run away), where ``exp(10*x)`` at ``x = 148`` is a finite
    number float64 cannot hold.  sympy evaluates at the point with unbounded exponents.
    """
    import sympy  # only on this error's path: a warm run imports no sympy

    xs, us = model.symbols()
    values = {
        **dict(zip(xs, escape.x.tolist(), strict=True)),
        **dict(zip(us, escape.u.tolist(), strict=False)),
    }
    try:
        exact = expression.xreplace({s: sympy.Float(v) for s, v in values.items()})
        return bool(exact.has(sympy.zoo, sympy.oo, -sympy.oo) or exact.is_finite is False)
    except (TypeError, ValueError, ArithmeticError, RecursionError):
        return False


Replay = Callable[[Watch], None]
"""Runs the failing stretch again with the functions the :class:`Watch` wraps."""


def replayed(replay: Replay) -> Escape | None:
    """The first escape of ``replay`` (floating-point warnings silenced), or ``None``."""
    watch = Watch()
    with np.errstate(all="ignore"):
        replay(watch)
    return watch.found
