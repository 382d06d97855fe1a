r"""Which variable each equation of a joint mode determines, checked for every joint mode.

Paper 002 §3.1 orders the union of the components' equations at a joint mode (eq. (8)) by a
maximum bipartite matching of equations to the variables they determine
(``scipy.sparse.csgraph.maximum_bipartite_matching``): a difference equation
``x[k] = g(v[k-1])`` determines its state; an algebraic equation one of its outputs or
internal variables (inputs are given, states are set by their difference equations).
:func:`causal_graph` is that ordering, which the ``unknown-mode`` estimator's structural
analysis (:mod:`hybridlog.estimators.cpha.structure`) and ``imm``'s joint modes
(:mod:`hybridlog.estimators.cpha.joint`) build on.

At a joint mode of known modes only (no component ``unknown``) the model must be complete
(eq. (1): "only a fully specified mode allows us to deduce the mathematical model"): every
equation determines a variable, every output or internal variable an equation uses is
determined by one, and every output is (a mode whose sensor explains nothing is the unknown
mode's case; ``imm`` and ``simulate`` refused such a joint mode, ``unknown-mode`` left the
output unexplained).  :func:`check_joint_modes` checks this for every joint known mode when the
file is read, so that every estimator, ``simulate`` and ``models FILE`` read one model file
the same way: ``unknown-mode`` had checked a joint mode only when its tracker first visited
it, so one file passed on one log and was refused on another, while ``imm`` and
``models FILE`` refused it.

The check factors over groups of components: two components whose equations (in any mode)
share an output or internal variable are in one group, and the matching of a joint mode is
the union of its groups' matchings (disjoint parts of the bipartite graph), and whether every
equation and every variable used is matched does not depend on which maximum matching is
taken (it asks for a matching that covers both, whose existence is a property of the graph).
So a group's joint modes are enumerated, not the model's: six components with four modes
each in two groups of three are 2·64 checks, not 4096.  A group with more than
:data:`MAX_CHECKED_JOINT_MODES` joint modes is not enumerated: its joint
modes are checked as an estimator first reaches them, and :func:`check_joint_modes` returns
the note that says so.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import NoReturn

import numpy as np
import sympy

from hybridlog.errors import ModelError
from hybridlog.model.components import Component, Equation, joint_label

__all__ = [
    "MAX_CHECKED_JOINT_MODES",
    "CausalGraph",
    "ComponentNames",
    "causal_graph",
    "check_joint_modes",
    "solve_explicitly",
    "unchecked_note",
    "undetermined_message",
    "undetermined_use",
    "unmatched_message",
]

MAX_CHECKED_JOINT_MODES = 1 << 14
"""The most joint modes of one group of components :func:`check_joint_modes` enumerates
(:func:`_first_incomplete`: about 16 µs each for a group of 16 components, a quarter of a
second at most when the file is read; the 288 of ``bioplex_pgc`` take a few ms)."""


@dataclass(frozen=True)
class ComponentNames:
    """The names of a components model, by role."""

    states: tuple[str, ...]
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    variables: tuple[str, ...]


@dataclass(frozen=True)
class CausalGraph:
    """A causal graph (Definition 4): vertices are variables, ``(v, w)`` means w uses v.

    Attributes
    ----------
    vertices:
        Variable names (and virtual inputs after slicing), in a fixed order.
    edges:
        Directed edges ``(cause, effect)``.
    exogenous:
        Vertices without a determining equation.
    """

    vertices: tuple[str, ...]
    edges: frozenset[tuple[str, str]]
    exogenous: frozenset[str]


def causal_graph(
    names: ComponentNames, equations: Sequence[Equation]
) -> tuple[CausalGraph, dict[str, int], list[str]]:
    """Causal ordering by maximum bipartite matching (paper 002 §3.1, [17]).

    Returns the causal graph, the index of the equation determining each determined
    variable, and the keys of the equations left without a variable.
    """
    vertices = (*names.states, *names.inputs, *names.outputs, *names.variables)
    column = {v: i for i, v in enumerate(vertices)}
    matchable = set(names.outputs) | set(names.variables)
    rows: list[int] = []
    cols: list[int] = []
    for r, equation in enumerate(equations):
        if equation.kind == "difference":
            candidates = [equation.state]
        else:
            candidates = sorted(equation.variables & matchable, key=column.__getitem__)
        for name in candidates:
            rows.append(r)
            cols.append(column[name])
    import scipy.sparse  # a components model's alone: not for every model loaded
    from scipy.sparse.csgraph import maximum_bipartite_matching

    biadjacency = scipy.sparse.csr_matrix(
        (np.ones(len(rows)), (rows, cols)), shape=(len(equations), len(vertices))
    )
    match = maximum_bipartite_matching(biadjacency, perm_type="column")
    determined_by: dict[str, int] = {}
    unmatched: list[str] = []
    for r, c in enumerate(match):
        if c < 0:
            unmatched.append(equations[r].key)
        else:
            determined_by[vertices[int(c)]] = r
    edges: set[tuple[str, str]] = set()
    for variable, r in determined_by.items():
        equation = equations[r]
        for cause in equation.variables | equation.previous:
            if cause != variable:
                edges.add((cause, variable))
    exogenous = frozenset(v for v in vertices if v not in determined_by)
    return CausalGraph(vertices, frozenset(edges), exogenous), determined_by, unmatched


def undetermined_use(
    names: ComponentNames, equations: Sequence[Equation], determined_by: Mapping[str, int]
) -> tuple[str, str] | None:
    """The first equation using an output or internal variable no equation determines.

    At an assignment of known modes every variable an equation uses must be given by an
    equation (as ``simulate`` requires): one left undetermined is a gap of the model, not the
    unknown mode's (paper 002 §3.1).  Unchecked, its cluster was dropped without a word
    (``y2 = x2*w2`` with nothing giving ``w2``: no state estimated, every mode "right"), and
    the joint mode's ``h`` kept the free symbol (``imm``: numba's ``NameError``).
    """
    given = set(names.outputs) | set(names.variables)
    for equation in equations:
        for variable in sorted((equation.variables | equation.previous) & given):
            if variable not in determined_by:
                return equation.key, variable
    return None


def undetermined_message(variable: str, label: str) -> str:
    """What :func:`undetermined_use` found, after the equation's key."""
    return (
        f"uses '{variable}', which no equation of the joint mode {label} determines (an "
        f"equation determines one variable; give '{variable}' an equation in a mode of that "
        "joint mode, or remove it from this one)"
    )


def unmatched_message(key: str, label: str) -> str:
    """The refusal of equation ``key``, left without a variable at the mode assignment."""
    return (
        f"{key}: determines nothing at the mode assignment {label}: every variable it relates "
        "is determined by another equation, so it would be ignored (remove it if it is "
        "redundant; as it stands it may contradict them)"
    )


def _groups(components: Sequence[Component], names: ComponentNames) -> list[list[int]]:
    """Indices of the components, grouped by the outputs and variables their equations share.

    The connected components (:func:`scipy.sparse.csgraph.connected_components`) of the
    graph joining each component to the outputs and internal variables its equations use.
    """
    matchable = sorted(set(names.outputs) | set(names.variables))
    column = {name: len(components) + i for i, name in enumerate(matchable)}
    links = [
        (i, column[name])
        for i, component in enumerate(components)
        for mode in component.modes
        for equation in mode.equations
        for name in (equation.variables | equation.previous) & column.keys()
    ]
    size = len(components) + len(matchable)
    rows, cols = zip(*links, strict=True) if links else ((), ())
    import scipy.sparse
    from scipy.sparse.csgraph import connected_components

    graph = scipy.sparse.csr_array((np.ones(len(rows)), (rows, cols)), shape=(size, size))
    _, labels = connected_components(graph, directed=False)
    groups: dict[int, list[int]] = {}
    for i in range(len(components)):
        groups.setdefault(int(labels[i]), []).append(i)
    return list(groups.values())


def check_joint_modes(components: Sequence[Component], names: ComponentNames) -> str | None:
    """Refuse a joint known mode whose equations leave a variable undetermined or unused.

    Every joint mode of known modes, group by group (see the module docstring): an equation
    that determines nothing (:func:`unmatched_message`), or one that uses an output or
    internal variable no equation of the joint mode determines (:func:`undetermined_use`).
    The joint mode is named by every component's mode, in the model's order (``m11|m22|m31``),
    the components of other groups at their first mode.

    Returns
    -------
    str or None
        The note naming the groups with more than :data:`MAX_CHECKED_JOINT_MODES` joint
        modes, which were not enumerated; ``None`` when every joint mode was checked.

    Raises
    ------
    ModelError
        Naming the equation's key (``components.<c>.modes.<m>.equations[i]``) and the joint
        mode.
    """
    matchable = frozenset(names.outputs) | frozenset(names.variables)
    for group in _groups(components, names):
        if _count(components, group) > MAX_CHECKED_JOINT_MODES:
            continue
        parts = [
            {m.id: _Part.of(m.equations, matchable) for m in components[i].modes} for i in group
        ]
        outputs = _outputs(parts, names)
        joint_modes = itertools.product(*(components[i].mode_ids for i in group))
        while batch := list(itertools.islice(joint_modes, _BATCH)):
            joint = [[part[m] for part, m in zip(parts, modes, strict=True)] for modes in batch]
            wrong = _first_incomplete(joint, outputs, sorted(matchable))
            if wrong is not None:
                _refuse(components, names, dict(zip(group, batch[wrong], strict=True)))
    return unchecked_note(components, names)


def _outputs(parts: Sequence[Mapping[str, _Part]], names: ComponentNames) -> frozenset[str]:
    """The outputs some mode of a group's components uses: every joint mode must give them."""
    used = frozenset().union(*(p.used for part in parts for p in part.values()))
    return used & frozenset(names.outputs)


def _refuse(
    components: Sequence[Component], names: ComponentNames, chosen: Mapping[int, str]
) -> NoReturn:
    """Refuse the joint mode ``chosen`` (component index → mode id) :func:`_first_incomplete` found.

    Naming the equation and the variable as :func:`causal_graph` and
    :func:`undetermined_use` find them, else the component mode that leaves an output of
    its group without an equation; the components of other groups at their first mode in
    the joint mode's label.
    """
    label = joint_label(chosen.get(i, c.mode_ids[0]) for i, c in enumerate(components))
    equations = [e for i, m in chosen.items() for e in components[i].equations(m)]
    _, determined_by, unmatched = causal_graph(names, equations)
    if unmatched:
        raise ModelError(unmatched_message(unmatched[0], label))
    found = undetermined_use(names, equations, determined_by)
    if found is not None:
        raise ModelError(f"{found[0]}: {undetermined_message(found[1], label)}")
    for i, mode_id in chosen.items():
        component = components[i]
        mode = component.mode(mode_id)
        for other in component.modes:
            given = [
                o
                for e in other.equations
                if e.kind == "algebraic"
                for o in sorted(e.variables & set(names.outputs))
                if o not in determined_by
            ]
            if given:
                raise ModelError(
                    f"{mode.key}: no equation of the joint mode {label} gives the output "
                    f"'{given[0]}', which {other.key} gives: a known joint mode gives every "
                    "output (only the unknown mode leaves one unexplained, paper 002 §3); "
                    "write its sensor's equation in this mode"
                )
    raise ModelError(f"components: joint mode {label}: its equations do not determine it")


@dataclass(frozen=True)
class _Part:
    """What one mode's equations bring to a joint mode's matching.

    The outputs and internal variables each algebraic equation may determine, and those any
    of its equations uses.
    """

    candidates: tuple[frozenset[str], ...]
    used: frozenset[str]

    @classmethod
    def of(cls, equations: Sequence[Equation], matchable: frozenset[str]) -> _Part:
        return cls(
            tuple(e.variables & matchable for e in equations if e.kind == "algebraic"),
            frozenset().union(*((e.variables | e.previous) & matchable for e in equations)),
        )


_BATCH = 4096
"""Joint modes matched in one call of scipy's matching (a block-diagonal graph)."""


def _first_incomplete(
    joint: Sequence[Sequence[_Part]], outputs: frozenset[str], matchable: Sequence[str]
) -> int | None:
    """The first joint mode of ``joint`` whose equations leave a variable open, or ``None``.

    Complete means: the algebraic equations of its parts determine exactly the outputs and
    internal variables they use, and use every one of ``outputs`` (those of the group, which
    every joint mode must give).  That is a matching covering every algebraic equation and
    every variable used (:func:`causal_graph` then leaves none unmatched and
    :func:`undetermined_use` finds nothing): the counts must agree, and then a maximum
    matching of the equations covers the variables, as an equation matches one it uses.

    The joint modes' bipartite graphs are the blocks of one block-diagonal graph, matched by
    one call of :func:`scipy.sparse.csgraph.maximum_bipartite_matching` (a maximum matching
    of disjoint graphs is one of each): called once per joint mode, building its sparse
    matrix took 50 µs of the 55, a fifth of a second for 4,096 joint modes.  A joint mode
    refused here is matched again by :func:`causal_graph` to name the equation.
    """
    column = {name: i for i, name in enumerate(matchable)}
    spans: list[range | None] = []  # per joint mode its rows, None where the counts differ
    indices: list[int] = []
    lengths: list[int] = []
    for block, parts in enumerate(joint):
        candidates = [c for part in parts for c in part.candidates]
        used = frozenset().union(*(part.used for part in parts))
        if len(candidates) != len(used) or not outputs <= used:
            spans.append(None)
            continue
        spans.append(range(len(lengths), len(lengths) + len(candidates)))
        offset = block * len(matchable)
        for names in candidates:
            indices.extend(offset + column[name] for name in names)
            lengths.append(len(names))
    indptr = np.zeros(len(lengths) + 1, dtype=np.int64)
    np.cumsum(lengths, out=indptr[1:])
    import scipy.sparse
    from scipy.sparse.csgraph import maximum_bipartite_matching

    graph = scipy.sparse.csr_array(
        (np.ones(len(indices)), np.asarray(indices, dtype=np.int64), indptr),
        shape=(len(lengths), len(joint) * len(matchable)),
    )
    unmatched = maximum_bipartite_matching(graph, perm_type="column") < 0
    for block, rows in enumerate(spans):
        if rows is None or unmatched[rows.start : rows.stop].any():
            return block
    return None


def _count(components: Sequence[Component], group: Sequence[int]) -> int:
    return math.prod(len(components[i].modes) for i in group)


def unchecked_note(components: Sequence[Component], names: ComponentNames) -> str | None:
    """The note of the joint modes :func:`check_joint_modes` leaves unchecked, or ``None``.

    Those of the groups of components with more than :data:`MAX_CHECKED_JOINT_MODES`
    joint modes, which ``unknown-mode`` checks as it first reaches them.
    """
    skipped = [
        f"{', '.join(components[i].name for i in group)} ({_count(components, group):,} joint "
        "modes)"
        for group in _groups(components, names)
        if _count(components, group) > MAX_CHECKED_JOINT_MODES
    ]
    if not skipped:
        return None
    return (
        f"components: the joint modes of {'; '.join(skipped)} are more than "
        f"{MAX_CHECKED_JOINT_MODES:,} a group and were not checked when the file was read: a "
        "joint mode whose equations leave a variable undetermined is refused when "
        "unknown-mode first reaches it"
    )


MAX_SOLUTIONS_SHOWN = 3
"""The solutions a refusal of several lists (then ``and N more``)."""


def solve_explicitly(
    algebraic: Sequence[Equation],
    targets: Sequence[str],
    label: str,
    residuals: Sequence[sympy.Expr] | None = None,
) -> dict[sympy.Symbol, sympy.Expr]:
    """The one real solution of ``algebraic`` for ``targets`` (their symbols, real).

    A refusal names ``targets`` in the order of their names, whichever order the caller
    gave them in (``simulate`` gave outputs first, ``imm`` variables first).

    ``residuals`` are the equations' ``lhs − rhs`` to solve, their own by default (a caller
    that has substituted variables solved before gives its own); ``label`` names the joint
    mode in a refusal.  Solutions sympy writes with ``I`` (the complex cube roots of
    ``w1**3 = x1``) are not solutions of a real model and are left out.  The one answer of
    ``unknown-mode``'s clusters, ``imm``'s joint modes and ``simulate``: ``imm`` took the
    first of several solutions without a word (possibly a complex one), ``simulate`` counted
    the complex roots (``w1**3 = x1`` had "3 solutions (one is needed)"), ``unknown-mode``
    refused several real ones naming them.

    Raises
    ------
    ModelError
        ``<key>: cannot be solved explicitly for <targets> at the mode assignment <label>``,
        or ``<key>: has N solutions for <targets> ...`` listing them, with the first
        equation's key.
    """
    targets = sorted(targets)  # named alike whichever path solves: w1, y1 (it was y1, w1 too)
    unknowns = [sympy.Symbol(v, real=True) for v in targets]
    if not algebraic:
        raise ModelError(
            f"components: no equation determines {', '.join(targets)} at the mode "
            f"assignment {label}"
        )
    given = [e.residual for e in algebraic] if residuals is None else list(residuals)
    try:
        solutions = sympy.solve(given, unknowns, dict=True)
    except NotImplementedError:  # sympy's answer for equations it has no method for
        solutions = []  # refused below, naming the equation's key
    solutions = [s for s in solutions if not any(e.has(sympy.I) for e in s.values())]
    if not solutions or any(u not in solutions[0] for u in unknowns):
        raise ModelError(
            f"{algebraic[0].key}: cannot be solved explicitly for {', '.join(targets)} at the "
            f"mode assignment {label}"
        )
    if len(solutions) > 1:
        raise ModelError(_several_solutions(algebraic, targets, unknowns, solutions, label))
    for name, unknown in zip(targets, unknowns, strict=True):
        _refuse_unevaluated(algebraic, name, unknown, solutions[0][unknown], label)
    return dict(solutions[0])


def _refuse_unevaluated(
    algebraic: Sequence[Equation], name: str, unknown: sympy.Symbol, value: sympy.Expr, label: str
) -> None:
    """Refuse a solution that calls a function the generated code cannot evaluate.

    ``w + exp(w) = u1 + x1`` solves to ``w = u1 + x1 - LambertW(exp(u1 + x1))``, which
    ended ``simulate``, ``imm`` and ``unknown-mode`` with "unexpected ..." errors.  Named by
    the first equation that uses the variable.
    """
    from hybridlog.model.codegen import unevaluated_functions

    missing = unevaluated_functions(value)
    if not missing:
        return
    first = next((e for e in algebraic if unknown in e.residual.free_symbols), algebraic[0])
    raise ModelError(
        f"{first.key}: solved for {name} at the mode assignment {label} only as {name} = "
        f"{value}, which calls {', '.join(missing)}, a function hybridlog cannot evaluate; "
        f"write the equation solved for {name} ({name} = ...) with the model's functions"
    )


def _several_solutions(
    algebraic: Sequence[Equation],
    targets: Sequence[str],
    unknowns: Sequence[sympy.Symbol],
    solutions: Sequence[Mapping[sympy.Symbol, sympy.Expr]],
    label: str,
) -> str:
    """The refusal of equations that several real solutions satisfy (``w1**2 = x1 + 1``).

    The first of sympy's solutions was taken (``w1 = -sqrt(x1 + 1)``) without a word, so
    that the filter ran on a root the model's author may not have meant, and the run failed
    later, or not at all, at an EKF step far from the cause.  Named by the variables whose
    solutions differ and the first equation that uses one of them (a joint mode's other
    outputs have one value in every solution).
    """
    differing = [
        (v, u)
        for v, u in zip(targets, unknowns, strict=True)
        if len({sympy.srepr(solution[u]) for solution in solutions}) > 1
    ] or list(zip(targets, unknowns, strict=True))
    names = [v for v, _ in differing]
    first = next(
        (e for e in algebraic if any(u in e.residual.free_symbols for _, u in differing)),
        algebraic[0],
    )
    shown = "; ".join(
        ", ".join(f"{v} = {solution[u]}" for v, u in differing)
        for solution in solutions[:MAX_SOLUTIONS_SHOWN]
    )
    more = (
        f" and {len(solutions) - MAX_SOLUTIONS_SHOWN} more"
        if len(solutions) > MAX_SOLUTIONS_SHOWN
        else ""
    )
    keys = ", ".join(
        e.key
        for e in algebraic
        if e is not first and any(u in e.residual.free_symbols for _, u in differing)
    )
    also = f" (with {keys})" if keys else ""
    return (
        f"{first.key}: has {len(solutions)} solutions for {', '.join(names)} at the mode "
        f"assignment {label}{also} ({shown}{more}), and which one the plant follows is not "
        f"known; write the equation solved for {', '.join(names)} (e.g. {names[0]} = ...) "
        "with the solution meant"
    )
