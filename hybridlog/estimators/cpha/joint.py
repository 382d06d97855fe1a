r"""A ``[components]`` model as enumerated joint modes, for estimators with a mode list.

Every joint assignment of known modes (no ``unknown``) becomes one mode of an ordinary
discrete-time model: the union of the components' equations (paper 002 eq. (8)) solved as a
whole — the MIMO model of eq. (1), as eq. (3) is for the three-component example — with the
process noise of the modes defining the states and the sensor noise of the modes determining
the outputs.  The Markov matrix is the product of the components' transition probabilities
(unknown removed, the rest renormalised; rules with ``when`` do not apply, and
:func:`unapplied_rules_note` names them in the run's notes), the prior the
product of their initial probabilities.  ``imm`` runs on it, so ``compare`` can put it beside
``unknown-mode``.  The number of joint modes grows as the product of the components' mode
counts; above
:data:`~hybridlog.estimators.capabilities.MAX_JOINT_MODES` the model is refused.
"""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
import sympy

from hybridlog.errors import ModelError
from hybridlog.estimators.capabilities import MAX_JOINT_MODES
from hybridlog.estimators.cpha.structure import Assignment
from hybridlog.estimators.result import TimelineColumn
from hybridlog.model.component_structure import (
    ComponentNames,
    causal_graph,
    solve_explicitly,
    undetermined_message,
    undetermined_use,
)
from hybridlog.model.components import UNKNOWN, Component
from hybridlog.model.components import joint_label as joint_mode_label
from hybridlog.model.expressions import previous_symbol
from hybridlog.model.hybrid_model import HybridModel, Mode
from hybridlog.signals import IntArray

__all__ = ["component_mode_columns", "joint_label", "joint_mode_model", "unapplied_rules_note"]


def joint_label(assignment: Assignment) -> str:
    """``m11|m21|m31``: a joint assignment's id (:func:`hybridlog.model.components.joint_label`)."""
    return joint_mode_label(assignment)


def _known(probabilities: dict[str, float]) -> dict[str, float]:
    kept = {m: p for m, p in probabilities.items() if m != UNKNOWN and p > 0.0}
    total = sum(kept.values())
    return {m: p / total for m, p in kept.items()} if total > 0.0 else {}


def _mode(model: HybridModel, assignment: Assignment) -> Mode:
    """The MIMO model (eq. (1)) of one joint assignment of known modes."""
    names = ComponentNames(model.states, model.inputs, model.outputs, model.variables)
    owned = [
        (e, c, m) for c, m in zip(model.components, assignment, strict=True) for e in c.equations(m)
    ]
    equations = [e for e, _, _ in owned]
    label = joint_label(assignment)
    _, determined_by, unmatched = causal_graph(names, equations)
    undetermined = undetermined_use(names, equations, determined_by)
    if undetermined is not None:
        raise model.error(undetermined[0], undetermined_message(undetermined[1], label))
    missing = [v for v in (*model.states, *model.outputs) if v not in determined_by]
    if unmatched or missing:
        what = f"equations {', '.join(unmatched)} determine nothing" if unmatched else ""
        what = what or f"nothing determines {', '.join(missing)}"
        raise model.error("components", f"joint mode {label}: {what}")
    algebraic = {v: equations[r] for v, r in determined_by.items() if v not in model.states}
    try:
        solved = solve_explicitly(list(algebraic.values()), list(algebraic), label)
    except ModelError as err:
        raise ModelError(f"{model.origin or model.name}: {err}") from None
    shift = {
        previous_symbol(str(s)): e.xreplace({c: previous_symbol(str(c)) for c in e.free_symbols})
        for s, e in solved.items()
    }
    plain = {previous_symbol(n): sympy.Symbol(n, real=True) for n in (*names.states, *names.inputs)}
    f = tuple(
        sympy.sympify(equations[determined_by[s]].rhs.xreplace(shift)).xreplace(plain)
        for s in model.states
    )
    h = tuple(sympy.sympify(solved[sympy.Symbol(o, real=True)]) for o in model.outputs)
    owner = {id(e): (c, m) for e, c, m in owned}

    def noise(variable: str, measured: bool) -> float:
        component, mode = owner[id(equations[determined_by[variable]])]
        spec = component.mode(mode)
        table = spec.measurement_noise if measured else spec.process_noise
        return float(table[variable])

    return Mode(
        id=label,
        process_noise=np.diag([noise(s, False) for s in model.states]),
        measurement_noise=np.diag([noise(o, True) for o in model.outputs]),
        f=f,
        h=h,
        process_noise_key="components",
        measurement_noise_key="components",
    )


def joint_mode_model(model: HybridModel) -> HybridModel:
    """``model`` with its joint known modes enumerated (see the module docstring).

    Raises
    ------
    ModelError
        More than :data:`~hybridlog.estimators.capabilities.MAX_JOINT_MODES` joint modes, or
        a joint mode whose equations do not determine every state and output or cannot be
        solved explicitly (naming ``components`` and the joint mode).
    """
    components: tuple[Component, ...] = model.components
    count = math.prod(len(c.modes) for c in components)
    if count > MAX_JOINT_MODES:
        raise model.error(
            "components",
            f"{count} joint modes to enumerate (at most {MAX_JOINT_MODES}); use unknown-mode",
        )
    assignments = list(itertools.product(*(c.mode_ids for c in components)))
    modes = tuple(_mode(model, a) for a in assignments)
    tables = [{m: _known(c.transition_probabilities(m)) for m in c.mode_ids} for c in components]
    initial = [_known(c.initial_mode_probabilities) for c in components]
    n = len(assignments)
    transitions = np.zeros((n, n))
    prior = np.zeros(n)
    for i, source in enumerate(assignments):
        prior[i] = math.prod(p.get(m, 0.0) for p, m in zip(initial, source, strict=True))
        for j, target in enumerate(assignments):
            transitions[i, j] = math.prod(
                table[s].get(t, 0.0) for table, s, t in zip(tables, source, target, strict=True)
            )
    if prior.sum() <= 0.0:
        prior[:] = 1.0
    return dataclasses.replace(
        model,
        modes=modes,
        components=(),
        variables=(),
        commands=(),
        transitions=transitions,
        initial_mode_probabilities=prior / prior.sum(),
    )


def component_mode_columns(model: HybridModel, modes: IntArray) -> tuple[TimelineColumn, ...]:
    """Each component's mode of each sample, from indices of :func:`joint_mode_model`'s modes.

    The timeline columns ``mode.<component>`` that ``unknown-mode`` gives too, so that an
    estimator run on the joint modes is scored per component like it (labels: the
    component's known mode ids).
    """
    components: tuple[Component, ...] = model.components
    table = np.array(
        list(itertools.product(*(range(len(c.modes)) for c in components))), dtype=np.int64
    ).reshape(-1, len(components))
    return tuple(
        TimelineColumn(f"mode.{c.name}", np.ascontiguousarray(table[modes, j]), c.mode_ids)
        for j, c in enumerate(components)
    )


def unapplied_rules_note(model: HybridModel, estimator: str) -> str | None:
    """The note of a run on the joint modes naming the transition rules it did not apply.

    The joint modes' Markov matrix is fixed (:func:`joint_mode_model`), so the rules with
    ``when`` (commanded switches) are left out: ``imm`` on a commanded valve's log followed
    the valve only as far as the fault rules allowed, and nothing in its report said so.
    ``None`` when every rule applies.
    """
    skipped = [rule for c in model.components for rule in c.rules if rule.when]
    if not skipped:
        return None
    commands = list(dict.fromkeys(command for rule in skipped for command in rule.when))
    return (
        f"transition rules with 'when' not applied: {estimator} runs on the joint modes with "
        f"one fixed Markov matrix and reads no command ({', '.join(commands)}), so only the "
        f"rules without 'when' apply; left out: {', '.join(rule.key for rule in skipped)} "
        "(unknown-mode applies them by the logged commands)"
    )
