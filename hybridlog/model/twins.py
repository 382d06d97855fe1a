"""Modes no log can tell apart: the same equations, noise, guard and jump maps.

Two modes whose ``f`` (or ``dx``) and ``h``, after the parameters are substituted, are the
same functions, with the same process and measurement noise, produce the same log: no
estimator can separate them from the data.  Such a model is not wrong (two modes may
differ only in their rows of the Markov matrix, ``[transitions]``, which shape how long
``imm`` believes each lasts), so the loader does not refuse it; it records the groups
(:attr:`~hybridlog.model.hybrid_model.HybridModel.twin_modes`) and every report says what
follows (``report/build.py``).  Computed once, when the model file is parsed (sympy is
loaded then), and kept in the loaded-model cache, so a warm run compares nothing.
"""

from __future__ import annotations

from collections.abc import Hashable, Sequence

import numpy as np
import sympy

from hybridlog.model.components import Component, ComponentMode, Equation
from hybridlog.model.hybrid_model import Jump, LinearForm, Mode

__all__ = ["component_twin_modes", "twin_modes"]

_FORM = ("A", "B", "C", "D", "state_offset", "output_offset")


def _array_key(array: np.ndarray) -> tuple[tuple[int, ...], bytes]:
    """An array as a hashable key: its shape and float64 bytes, ``-0.0`` as ``0.0``."""
    values = np.ascontiguousarray(array, dtype=np.float64) + 0.0
    return values.shape, values.tobytes()


def _equations(mode: Mode) -> Hashable:
    """What the mode's equations are, comparable across modes.

    An affine mode by its matrices (so ``0.9*(x1 + u)`` and ``0.9*x1 + 0.9*u`` meet); a
    nonlinear one by its sympy expressions (sympy's canonical form: the order of terms and
    factors does not matter).
    """
    form: LinearForm | None = mode.linear_form
    if form is not None:
        return ("affine", tuple(_array_key(getattr(form, name)) for name in _FORM))
    return ("expressions", tuple(mode.dynamics), tuple(mode.h))


def twin_modes(modes: tuple[Mode, ...], jumps: tuple[Jump, ...]) -> tuple[tuple[str, ...], ...]:
    """Groups of two or more modes that give the same log, each in the file's order.

    Modes are twins when their equations (:func:`_equations`), process and measurement
    noise covariances and guards are equal and no jump map names either of them (a map
    from or into one mode only would set them apart at a switch; a ``"*->b"`` map into a
    third mode applies to both alike).

    Parameters
    ----------
    modes:
        The model's modes, in the file's order.
    jumps:
        The model's jump maps (``[jumps."a->b"]``).

    Returns
    -------
    tuple[tuple[str, ...], ...]
        The groups, ordered by their first mode; empty when every mode differs.

    """
    named = {jump.target for jump in jumps} | {j.source for j in jumps if j.source is not None}
    groups: dict[Hashable, list[str]] = {}
    for mode in modes:
        if mode.id in named:
            continue
        key = (
            _equations(mode),
            _array_key(mode.process_noise),
            _array_key(mode.measurement_noise),
            mode.guard,
        )
        groups.setdefault(key, []).append(mode.id)
    return tuple(tuple(ids) for ids in groups.values() if len(ids) > 1)


def _component_equation(equation: Equation) -> Hashable:
    """One component equation, comparable across modes (an algebraic one either way round)."""
    if equation.kind == "difference":
        return ("difference", equation.state, sympy.expand(equation.rhs))
    residual = sympy.expand(equation.residual)
    return ("algebraic", frozenset({residual, sympy.expand(-residual)}))


def _component_mode(mode: ComponentMode) -> Hashable:
    return (
        frozenset(_component_equation(e) for e in mode.equations),
        tuple(sorted(mode.process_noise.items())),
        tuple(sorted(mode.measurement_noise.items())),
    )


def component_twin_modes(
    components: Sequence[Component],
) -> tuple[tuple[str, tuple[str, ...]], ...]:
    """Per component, groups of two or more of its modes that give the same log.

    As :func:`twin_modes` for a ``[components]`` model: a component's modes are twins when
    their equations (in any order, the parameters substituted; ``y = x`` and ``x = y`` alike)
    and their process and measurement noise are equal.  Returns ``(component, mode ids)``
    pairs, the ids in the file's order; empty when every component's modes differ.
    """
    found = []
    for component in components:
        groups: dict[Hashable, list[str]] = {}
        for mode in component.modes:
            groups.setdefault(_component_mode(mode), []).append(mode.id)
        found += [(component.name, tuple(ids)) for ids in groups.values() if len(ids) > 1]
    return tuple(found)
