r"""Concurrent probabilistic hybrid automata: the ``[components.*]`` of a model file.

Paper 002 (Hofbaur & Williams, Definitions 1–3) describes a plant as components that run
concurrently, each a probabilistic hybrid automaton with its own modes.  A mode is a set of
equations over named variables — difference equations such as ``x1[k] = 0.5*u1[k-1]`` and
algebraic ones such as ``y1 = x1`` (eq. (2)) — and the plant's model for a joint mode is the
union of its components' equations (eq. (8)), solved by the estimator.  Every component also
has an implicit ``unknown`` mode that imposes no equation at all (§3).

This module holds the data only (immutable, typed); :mod:`hybridlog.model.loader` builds it
from the file and the ``unknown-mode`` estimator does the structural analysis.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Literal

import sympy

UNKNOWN = "unknown"
"""Id of every component's implicit unknown mode (no equations, paper 002 §3)."""

JOINT_SEPARATOR = "|"
"""What joins the components' mode ids into a joint mode's id (a component's mode id may not
hold it, :mod:`hybridlog.model.log_fields`)."""


def joint_label(modes: Iterable[str]) -> str:
    """``m11|m21|unknown``: a joint mode as every command names it, its components' mode ids.

    In the model's order of components; the joint-mode model ``imm`` runs on, its
    ``unknown-mode`` assignments, the refusals of :func:`hybridlog.model.component_structure.
    check_joint_modes`, of the estimators' structural analysis and of ``simulate``'s joint
    modes (where an unmodelled behaviour stands for a component's mode, the component is
    ``unknown``, as the simulated log's true mode says, and ``simulate`` names the
    behaviour beside the label) all write it so.
    """
    return JOINT_SEPARATOR.join(modes)


EquationKind = Literal["difference", "algebraic"]

COMMAND_TOLERANCE = 1e-6
"""Relative distance within which a logged command value is the ``when`` value it is near.

A 32-bit field holds ``0.1`` as ``0.10000000149``: compared exactly, ``when = {cmd = 0.1}``
would never hold on such a log, silently.  Relative to ``max(1, |value|)``; two ``when``
values of one command this close are refused by the loader (one logged value would be both).
"""


@dataclass(frozen=True)
class Equation:
    r"""One equation of a component mode.

    A *difference* equation ``x[k] = g(v[k-1], ...)`` gives a state at step k from variables
    at step k−1 (paper 002 eq. (1)); an *algebraic* equation ``lhs = rhs`` relates variables
    at the same step and carries no causality (the estimator's bipartite matching decides
    which variable it determines).  Variables at step k are the plain symbols of their names
    (``x1``); at step k−1 they are the symbols of
    :func:`hybridlog.model.expressions.previous_symbol` (``x1[k-1]``).  Parameters are
    substituted.

    Attributes
    ----------
    key:
        The model-file key, ``components.<c>.modes.<m>.equations[i]``.
    text:
        The equation as written.
    kind:
        ``"difference"`` or ``"algebraic"``.
    lhs, rhs:
        Both sides as sympy expressions; ``lhs`` of a difference equation is the state's
        symbol at step k.
    state:
        The state a difference equation defines; empty for an algebraic one.
    variables:
        Names of the variables used at step k.
    previous:
        Names of the variables used at step k−1.
    """

    key: str
    text: str
    kind: EquationKind
    lhs: sympy.Expr
    rhs: sympy.Expr
    state: str = ""
    variables: frozenset[str] = frozenset()
    previous: frozenset[str] = frozenset()

    @property
    def residual(self) -> sympy.Expr:
        """``lhs − rhs``, zero when the equation holds."""
        return self.lhs - self.rhs


@dataclass(frozen=True)
class ComponentMode:
    """One mode of a component: its equations and its noise.

    Attributes
    ----------
    id:
        The mode id as written (``partly_open``).
    equations:
        The mode's equations, in the file's order.
    process_noise:
        Variance of the additive disturbance of each state this mode's difference equations
        define (paper 002, ``N_x``).
    measurement_noise:
        Variance of the sensor noise of each measured output this mode's algebraic
        equations use (paper 002, ``N_y``, ``R = diag(r_i)``), while the mode is active.
    key:
        The model-file key, ``components.<c>.modes.<m>``.
    """

    id: str
    equations: tuple[Equation, ...]
    process_noise: dict[str, float] = field(default_factory=dict)
    measurement_noise: dict[str, float] = field(default_factory=dict)
    key: str = ""


@dataclass(frozen=True)
class TransitionRule:
    """Transition probabilities out of one mode, optionally under given command values.

    Attributes
    ----------
    source:
        The mode left (a mode id, ``unknown``), or ``*`` for every known mode without a
        rule of its own.
    when:
        Command values under which the rule applies (``{"cmd_valve": 1.0}``); empty means
        always.
    targets:
        Probability of each target mode per step; they sum to at most 1 and the rest stays
        in the source mode.
    key:
        The model-file key, ``components.<c>.transitions[i]``.
    """

    source: str
    when: dict[str, float]
    targets: dict[str, float]
    key: str


@dataclass(frozen=True)
class Component:
    """One component automaton of a concurrent probabilistic hybrid automaton.

    Attributes
    ----------
    name:
        The component's name (``[components.<name>]``).
    modes:
        Its known modes, in the file's order; the unknown mode is implicit.
    unknown_probability:
        Prior probability per step that a known mode turns into the unknown mode (used
        unless the applying rule lists ``unknown`` itself).
    initial_mode_probabilities:
        ``Pr(x_d(0))`` over the known mode ids and ``unknown``; sums to 1.
    rules:
        Transition rules, in the file's order; see :meth:`transition_probabilities`.
    key:
        The model-file key, ``components.<name>``.
    """

    name: str
    modes: tuple[ComponentMode, ...]
    unknown_probability: float
    initial_mode_probabilities: dict[str, float]
    rules: tuple[TransitionRule, ...] = ()
    key: str = ""

    @property
    def mode_ids(self) -> tuple[str, ...]:
        """Known mode ids in the file's order (without ``unknown``)."""
        return tuple(m.id for m in self.modes)

    def mode(self, mode_id: str) -> ComponentMode:
        """The known mode ``mode_id``; raises ``KeyError`` for an unknown id."""
        for mode in self.modes:
            if mode.id == mode_id:
                return mode
        raise KeyError(mode_id)

    def equations(self, mode_id: str) -> tuple[Equation, ...]:
        """Equations of ``mode_id`` (none for ``unknown``: it constrains nothing)."""
        return () if mode_id == UNKNOWN else self.mode(mode_id).equations

    @property
    def states(self) -> tuple[str, ...]:
        """States defined by a difference equation in some mode, in order of appearance."""
        seen: dict[str, None] = {}
        for mode in self.modes:
            for equation in mode.equations:
                if equation.state:
                    seen[equation.state] = None
        return tuple(seen)

    def transition_probabilities(
        self, source: str, commands: Mapping[str, float] | None = None
    ) -> dict[str, float]:
        """``P_T(x_d(k) | x_d(k−1) = source, u_d(k−1) = commands)`` (paper 002, eq. (4)).

        The applying rule is the most specific one whose ``when`` matches the commands: a
        rule for ``source`` itself before a ``*`` rule, then the one with more conditions
        (two that tie with different targets are refused by the loader; else the first in
        the file, the same either way).  Without a rule the component stays.  Out of a known
        mode, unless the rule lists ``unknown``, the unknown mode gets
        :attr:`unknown_probability` and the rest is scaled by ``1 − unknown_probability``.
        A component leaves ``unknown`` only by a rule ``from = "unknown"``.

        Returns
        -------
        dict
            Target mode id → probability, summing to 1 (zero entries left out).
        """
        given = commands or {}
        best: TransitionRule | None = None
        best_rank = (-1, -1)
        for rule in self.rules:
            exact = rule.source == source
            if not exact and not (rule.source == "*" and source != UNKNOWN):
                continue
            if any(given.get(c) != v for c, v in rule.when.items()):
                continue
            rank = (int(exact), len(rule.when))
            if rank > best_rank:
                best, best_rank = rule, rank
        targets = dict(best.targets) if best is not None else {}
        rest = 1.0 - sum(targets.values())
        targets[source] = targets.get(source, 0.0) + rest
        if source != UNKNOWN and UNKNOWN not in targets and self.unknown_probability > 0.0:
            keep = 1.0 - self.unknown_probability
            targets = {m: p * keep for m, p in targets.items()}
            targets[UNKNOWN] = self.unknown_probability
        return {m: p for m, p in targets.items() if p > 0.0}
