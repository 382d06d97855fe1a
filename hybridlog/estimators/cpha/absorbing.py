r"""Components whose ``unknown`` mode no transition leaves (paper 002 §3).

A component leaves ``unknown`` only by a rule ``from = "unknown"``
(:meth:`~hybridlog.model.components.Component.transition_probabilities`); without one, a
trajectory that enters it stays there.  Staying costs nothing (``P_T = 1``) while its
dropped filters score the upper bound ``P_O = 1`` and a well-fitting known mode pays about
``e^{-1/2}`` per output per step, so that trajectory outscores the well-fitting one after a
few dozen steps and the estimate sits in ``unknown`` to the end of the log: on a 400-sample
log of one well-modelled component, on 312 samples, without a word on why.

The estimator, not the loader, says so: a model file is also read by ``imm`` (its joint
modes), ``simulate`` and ``--set unknown_mode=false``, where the unknown mode is never
entered.  :func:`absorbing_notes` gives a note per component whose unknown mode the run can
enter and not leave, and a ``WARNING`` instead where the reported estimate sits there on at
least :data:`ABSORBING_SHARE` of the samples.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from hybridlog.model.components import UNKNOWN, Component
from hybridlog.signals import FloatArray
from hybridlog.times import format_time

__all__ = [
    "ABSORBING_SHARE",
    "LEAVING_ADVICE",
    "absorbing_components",
    "absorbing_notes",
    "unknown_stays",
]

ABSORBING_SHARE = 0.25
"""Share of the samples in an absorbing ``unknown`` past which the note is a ``WARNING``."""

LEAVING_ADVICE = (
    "leaving with probability above 1 - e^(-n/2) for the n outputs its unknown mode leaves "
    "unchecked: 0.39 for one, 0.63 for two, 0.78 for three"
)
"""How readily a rule ``from = "unknown"`` must leave: a well-fitting mode pays about 1/2 a
step per output it checks (``E[rᵀS⁻¹r]/2``), staying ``unknown`` ``-ln P(stay)``."""


def _enterable(component: Component) -> bool:
    """Whether a trajectory can be in the component's ``unknown`` mode at all."""
    return (
        component.unknown_probability > 0.0
        or component.initial_mode_probabilities.get(UNKNOWN, 0.0) > 0.0
        or any(rule.targets.get(UNKNOWN, 0.0) > 0.0 for rule in component.rules)
    )


def _command_rows(
    command_names: Sequence[str], commands: FloatArray | None
) -> list[dict[str, float]]:
    """The distinct commands of the steps that select a transition (rows 0 … N−2)."""
    if commands is None or len(commands) <= 1:
        return [{}]
    distinct = np.unique(commands[:-1], axis=0)
    return [dict(zip(command_names, row.tolist(), strict=True)) for row in distinct]


def unknown_stays(
    components: Sequence[Component],
    command_names: Sequence[str],
    commands: FloatArray | None,
) -> dict[str, float]:
    """Per component the run can put in ``unknown``: the most likely stay there in one step.

    The largest ``P(unknown → unknown)`` over the commands of this log's steps.
    """
    rows = _command_rows(command_names, commands)
    return {
        component.name: max(
            component.transition_probabilities(UNKNOWN, given).get(UNKNOWN, 0.0) for given in rows
        )
        for component in components
        if _enterable(component)
    }


def absorbing_components(
    components: Sequence[Component],
    command_names: Sequence[str],
    commands: FloatArray | None,
) -> dict[str, str]:
    """Per component whose ``unknown`` the run can enter but never leave: why it cannot.

    ``commands``: the values of ``command_names`` per sample (rows 0 … N−2 select the
    transitions, eq. (4)), ``None`` when no rule names one.  A component with ``from =
    "unknown"`` rules whose ``when`` held on no step cannot leave on this log either.
    """
    rows = _command_rows(command_names, commands)
    found: dict[str, str] = {}
    for component in components:
        if not _enterable(component):
            continue
        leaving = [
            rule
            for rule in component.rules
            if rule.source == UNKNOWN
            and any(p > 0.0 for m, p in rule.targets.items() if m != UNKNOWN)
        ]
        if not leaving:
            found[component.name] = 'no transition rule has from = "unknown"'
            continue
        if all(
            set(component.transition_probabilities(UNKNOWN, given)) == {UNKNOWN} for given in rows
        ):
            keys = ", ".join(rule.key for rule in leaving)
            found[component.name] = (
                f'the rules from "unknown" ({keys}) apply under commands no step of this log had'
            )
    return found


def absorbing_notes(
    components: Sequence[Component],
    absorbing: dict[str, str],
    assignments: Sequence[tuple[str, ...]],
    times: FloatArray,
) -> tuple[str, ...]:
    """A note per component of ``absorbing`` (:func:`absorbing_components`), in model order.

    A ``WARNING`` where the reported ``assignments`` have it ``unknown`` on at least
    :data:`ABSORBING_SHARE` of the samples, saying on how many and from when.
    """
    notes = []
    n = len(assignments)
    for c, component in enumerate(components):
        why = absorbing.get(component.name)
        if why is None:
            continue
        where = [k for k, a in enumerate(assignments) if a[c] == UNKNOWN]
        name = component.name
        advice = (
            f"a trajectory that enters it stays, and as its dropped filters score the upper "
            f"bound P_O = 1 (paper 002 §3) it outscores even a well-fitting mode after a few "
            f"dozen samples; add a [[components.{name}.transitions]] rule with from = "
            f'"unknown" ({LEAVING_ADVICE}) so that it can leave'
        )
        if n and len(where) >= ABSORBING_SHARE * n:
            notes.append(
                f"WARNING: component {name} is reported in its unknown mode on "
                f"{len(where):,} of {n:,} samples (first at t = {format_time(times[where[0]])} "
                f"s), and that unknown mode is absorbing: no rule leaves it ({why}); {advice}"
            )
        else:
            notes.append(
                f"component {name}: its unknown mode is absorbing, no rule leaves it ({why}); "
                f"{advice}"
            )
    return tuple(notes)
