r"""Structural analysis of a components model at one mode assignment (paper 002, §3.1).

For a joint mode assignment ``x_d`` the raw model is the union of the components' equations
(eq. (8)); a component in the ``unknown`` mode contributes none.  :func:`decompose` turns it
into a *filter cluster*:

1. **Causal ordering** by a maximum bipartite matching of equations to the variables they
   determine (``scipy.sparse.csgraph.maximum_bipartite_matching``): a difference equation
   ``x[k] = g(v[k-1])`` determines its state; an algebraic equation determines one of its
   outputs or internal variables (inputs are given, states are set by their difference
   equations).  A variable no equation determines is *exogenous*.  The causal graph has an
   edge ``v → w`` when ``w``'s equation uses ``v`` (Definition 4, Fig. 6).  An algebraic
   equation left without a variable (a relation among variables other equations determine:
   redundant, or contradicting them) is refused rather than silently dropped.
2. **Slicing** at the observed variables: an observed variable's outgoing edges move to a new
   vertex, its *virtual input* ``u[y]`` (Fig. 7): downstream equations use the measurement.
3. **Strongly connected components** of the sliced graph
   (``scipy.sparse.csgraph.connected_components(connection="strong")``, Definition 7).
4. **Structural observability and determination** (Definitions 5–6) by the paper's
   ``determine-SOD-of-SCC`` traversal from every observed SCC backwards; an SCC reached from
   the observed SCCs with indices ``K`` gets the cluster index set ``K``
   (``component-clustering``).  Observed SCCs whose index sets meet form one cluster; a cluster
   is kept when all its SCCs are determined (no unknown exogenous variable upstream).
5. **Explicit solving** of each kept cluster's equations with sympy, SCC by SCC in causal
   order, to ``x(k) = f(x(k-1), u(k-1))``, ``y(k) = g(x(k), u(k))`` where ``u`` are the
   model inputs and the virtual inputs the cluster uses (the model of eq. (1) with the
   additional virtual inputs).

States outside every kept cluster are neither observable nor determined at this assignment;
the estimator holds their mean and inflates their variance (§3.1, last paragraph).
"""

from __future__ import annotations

import functools
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse
import sympy
from scipy.sparse.csgraph import connected_components

from hybridlog.errors import ModelError
from hybridlog.model.component_structure import (
    CausalGraph,
    causal_graph,
    solve_explicitly,
    undetermined_message,
    unmatched_message,
)
from hybridlog.model.component_structure import ComponentNames as _Names
from hybridlog.model.component_structure import undetermined_use as _undetermined_use
from hybridlog.model.components import UNKNOWN, Component, Equation, joint_label
from hybridlog.model.expressions import previous_symbol

__all__ = [
    "CausalGraph",
    "Cluster",
    "Decomposition",
    "StructureCache",
    "decompose",
    "virtual_input",
]

Assignment = tuple[str, ...]
"""A joint mode assignment: one mode id (or ``unknown``) per component, in the model's order."""
_SolveKey = tuple[tuple[int, ...], tuple[str, ...], tuple[sympy.Expr, ...]]
"""An SCC's algebraic equations (by identity), the variables solved for and the residuals."""


def virtual_input(name: str) -> str:
    """The vertex name of observed variable ``name`` used as a virtual input (``u[yc1]``)."""
    return f"u[{name}]"


@dataclass(frozen=True)
class Cluster:
    """One filter of the filter cluster: an observable, determined subsystem.

    Attributes
    ----------
    states, outputs:
        The cluster's states and observed variables, in the model's order.
    inputs:
        Model inputs the cluster's equations use, in the model's order.
    virtual_inputs:
        Observed variables the cluster uses as inputs (their measurements), model order.
    components:
        Names of the components whose equations the cluster holds.
    equations:
        The equations (difference and algebraic) of the cluster, in causal order.
    f, h:
        ``x(k) = f`` over the states, ``y(k) = h`` over the outputs, as sympy expressions in
        the plain symbols of :attr:`states` (at k−1 for ``f``, at k for ``h``), of
        :attr:`inputs` and of :attr:`virtual_inputs` (named as the observed variables).
    process_noise:
        Variance of each state's disturbance (from the mode defining it).
    measurement_noise:
        Variance of each output's sensor noise (from the mode determining it).
    virtual_noise:
        Variance of each virtual input's measurement (``r`` of eq. (6)).
    """

    states: tuple[str, ...]
    outputs: tuple[str, ...]
    inputs: tuple[str, ...]
    virtual_inputs: tuple[str, ...]
    components: tuple[str, ...]
    equations: tuple[Equation, ...]
    f: tuple[sympy.Expr, ...]
    h: tuple[sympy.Expr, ...]
    process_noise: tuple[float, ...]
    measurement_noise: tuple[float, ...]
    virtual_noise: tuple[float, ...]

    @functools.cached_property
    def signature(self) -> tuple[object, ...]:
        """What the compiled filter depends on (its cache key)."""
        return (
            self.states,
            self.outputs,
            self.inputs,
            self.virtual_inputs,
            tuple(e.key for e in self.equations),
            self.process_noise,
            self.measurement_noise,
            self.virtual_noise,
        )


@dataclass(frozen=True)
class Decomposition:
    """The structural analysis of one mode assignment.

    Attributes
    ----------
    assignment:
        Mode id per component.
    causal_graph, sliced_graph:
        The causal graph before and after slicing at the observed variables.
    sccs:
        Strongly connected components of the sliced graph (sets of vertices).
    observable, determined:
        Per SCC (same order as :attr:`sccs`): structurally observable / determined.
    cluster_indices:
        Per SCC: the indices of the observed SCCs it feeds (``cluster-index``).
    clusters:
        The kept (observable and determined) clusters.
    rejected:
        Observed variables of clusters dropped because something upstream is undetermined.
    held_states:
        States in no kept cluster (held mean, growing variance).
    unmatched:
        Keys of algebraic equations no variable was left for (not used).
    """

    assignment: Assignment
    causal_graph: CausalGraph
    sliced_graph: CausalGraph
    sccs: tuple[frozenset[str], ...]
    observable: tuple[bool, ...]
    determined: tuple[bool, ...]
    cluster_indices: tuple[frozenset[int], ...]
    clusters: tuple[Cluster, ...]
    rejected: tuple[str, ...]
    held_states: tuple[str, ...]
    unmatched: tuple[str, ...] = field(default=())


def _owner_modes(
    components: Sequence[Component], assignment: Assignment
) -> list[tuple[Equation, str, str]]:
    """Equations of the assignment (eq. (8)) with their component and mode."""
    out = []
    for component, mode in zip(components, assignment, strict=True):
        for equation in component.equations(mode):
            out.append((equation, component.name, mode))
    return out


def _slice(graph: CausalGraph, observed: Sequence[str]) -> CausalGraph:
    """Move every observed variable's outgoing edges to its virtual input (Fig. 7)."""
    observed_set = set(observed)
    sources = {a for a, _ in graph.edges}
    cut = [o for o in observed if o in sources]
    edges = {(virtual_input(a) if a in observed_set else a, b) for a, b in graph.edges}
    virtual = tuple(virtual_input(o) for o in cut)
    return CausalGraph(
        (*graph.vertices, *virtual), frozenset(edges), graph.exogenous | frozenset(virtual)
    )


def _sccs(graph: CausalGraph) -> tuple[list[frozenset[str]], dict[str, int]]:
    """Strongly connected components, numbered in the order of their first vertex."""
    index = {v: i for i, v in enumerate(graph.vertices)}
    n = len(graph.vertices)
    if graph.edges:
        a, b = zip(*((index[x], index[y]) for x, y in graph.edges), strict=True)
    else:
        a, b = (), ()
    adjacency = scipy.sparse.csr_matrix((np.ones(len(a)), (a, b)), shape=(n, n))
    _, labels = connected_components(adjacency, directed=True, connection="strong")
    order: dict[int, int] = {}
    for label in labels:
        order.setdefault(int(label), len(order))
    members: list[set[str]] = [set() for _ in order]
    of: dict[str, int] = {}
    for v, label in zip(graph.vertices, labels, strict=True):
        i = order[int(label)]
        members[i].add(v)
        of[v] = i
    return [frozenset(m) for m in members], of


def decompose(
    components: Sequence[Component],
    assignment: Assignment,
    *,
    states: tuple[str, ...],
    inputs: tuple[str, ...],
    outputs: tuple[str, ...],
    variables: tuple[str, ...],
    solved: dict[_SolveKey, dict[sympy.Symbol, sympy.Expr]] | None = None,
) -> Decomposition:
    """The structural analysis and filter clusters of ``assignment`` (paper 002 §3.1).

    Parameters
    ----------
    components:
        The model's components.
    assignment:
        Mode id (or ``unknown``) per component, in the same order.
    states, inputs, outputs, variables:
        The model's names; ``outputs`` are the observed variables ``y_c``.
    solved:
        Explicit solutions of strongly connected algebraic equations already found, by the
        equations and what was substituted into them (:class:`StructureCache` keeps one
        across the assignments it decomposes); ``None``: none kept.

    Raises
    ------
    ModelError
        A cluster's algebraic equations cannot be solved explicitly for the variables they
        determine, or an equation determines nothing (naming the equation's key and the
        assignment).
    """
    names = _Names(states, inputs, outputs, variables)
    owned = _owner_modes(components, assignment)
    equations = [e for e, _, _ in owned]
    graph, determined_by, unmatched = causal_graph(names, equations)
    if unmatched:  # found when the file is read (check_joint_modes) but past its bound
        raise ModelError(unmatched_message(unmatched[0], joint_label(assignment)))
    if UNKNOWN not in assignment:  # checked when the file is read, unless past its bound
        undetermined = _undetermined_use(names, equations, determined_by)
        if undetermined is not None:
            key, variable = undetermined
            label = joint_label(assignment)
            raise ModelError(f"{key}: {undetermined_message(variable, label)}")
    sliced = _slice(graph, outputs)
    sccs, scc_of = _sccs(sliced)
    n_scc = len(sccs)
    uplinks: list[set[int]] = [set() for _ in range(n_scc)]
    for a, b in sliced.edges:
        if scc_of[a] != scc_of[b]:
            uplinks[scc_of[b]].add(scc_of[a])
    known = set(inputs) | {v for v in sliced.vertices if v.startswith("u[")}

    # determine-SOD-of-SCC and component-clustering (paper 002 §3.1).
    done = [False] * n_scc
    observable = [False] * n_scc
    determined = [False] * n_scc
    indices: list[frozenset[int]] = [frozenset()] * n_scc

    def sod(i: int, k: int) -> None:
        stack = [(i, False)]
        while stack:  # iterative post-order traversal of the uplinks
            j, expanded = stack.pop()
            if done[j]:
                continue
            scc = sccs[j]
            if len(scc) == 1 and next(iter(scc)) in sliced.exogenous:
                determined[j] = next(iter(scc)) in known
                done[j] = True
                continue
            if not expanded:
                stack.append((j, True))
                stack.extend((u, False) for u in uplinks[j] if not done[u])
                continue
            observable[j] = True
            determined[j] = all(determined[u] for u in uplinks[j])
            indices[j] = frozenset({k}).union(*(indices[u] for u in uplinks[j]))
            done[j] = True

    output_sccs: list[int] = []
    for name in outputs:
        j = scc_of[name]
        if name in sliced.exogenous or j in output_sccs:
            continue
        sod(j, len(output_sccs))
        output_sccs.append(j)

    # Observed SCCs whose index sets meet are one cluster (union-find over the indices).
    parent = list(range(len(output_sccs)))

    def root(a: int) -> int:
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    for index_set in indices:
        ordered_set = sorted(index_set)
        for other in ordered_set[1:]:
            parent[root(other)] = root(ordered_set[0])
    groups: dict[int, list[int]] = {}
    for j in range(n_scc):
        if indices[j]:
            groups.setdefault(root(min(indices[j])), []).append(j)

    equation_owner = {id(e): (c, m) for e, c, m in owned}
    comp_by_name = {c.name: c for c in components}
    clusters: list[Cluster] = []
    rejected: list[str] = []
    in_cluster: set[str] = set()
    for members in groups.values():
        variables_in = {v for j in members for v in sccs[j]}
        observed_in = [o for o in outputs if o in variables_in]
        if not all(determined[j] for j in members):
            rejected.extend(observed_in)
            continue
        cluster = _solve_cluster(
            names,
            assignment,
            members,
            sccs,
            uplinks,
            sliced,
            {v: equations[r] for v, r in determined_by.items() if v in variables_in},
            equation_owner,
            comp_by_name,
            determined_by,
            equations,
            {} if solved is None else solved,
        )
        clusters.append(cluster)
        in_cluster |= set(cluster.states)
    return Decomposition(
        assignment=assignment,
        causal_graph=graph,
        sliced_graph=sliced,
        sccs=tuple(sccs),
        observable=tuple(observable),
        determined=tuple(determined),
        cluster_indices=tuple(indices),
        clusters=tuple(clusters),
        rejected=tuple(o for o in outputs if o in rejected),
        held_states=tuple(s for s in states if s not in in_cluster),
        unmatched=tuple(unmatched),
    )


def _topological(members: Sequence[int], uplinks: Sequence[set[int]]) -> list[int]:
    """The member SCCs in causal order (every uplink before the SCC it feeds)."""
    inside = set(members)
    order: list[int] = []
    seen: set[int] = set()

    def visit(j: int) -> None:
        stack = [(j, False)]
        while stack:
            i, expanded = stack.pop()
            if expanded:
                order.append(i)
                continue
            if i in seen:
                continue
            seen.add(i)
            stack.append((i, True))
            stack.extend((u, False) for u in sorted(uplinks[i]) if u in inside and u not in seen)

    for j in sorted(members):
        visit(j)
    return order


def _solve_cluster(
    names: _Names,
    assignment: Assignment,
    members: Sequence[int],
    sccs: Sequence[frozenset[str]],
    uplinks: Sequence[set[int]],
    sliced: CausalGraph,
    determining: Mapping[str, Equation],
    equation_owner: Mapping[int, tuple[str, str]],
    components: Mapping[str, Component],
    determined_by: Mapping[str, int],
    all_equations: Sequence[Equation],
    known_solutions: dict[_SolveKey, dict[sympy.Symbol, sympy.Expr]],
) -> Cluster:
    """Solve one cluster's raw model explicitly (sympy), SCC by SCC in causal order.

    A component's mode recurs in many assignments with the same algebraic equations and the
    same solved variables substituted into them: each such system is solved once
    (``known_solutions``).  Every assignment solved every SCC again, about 3 ms of sympy
    each: a model of 14 independent components spent 21 s on 13,693 solves of the 42
    distinct systems (0.7 s estimating).  A refusal is not kept: it ends the run.
    """
    observed = set(names.outputs)
    current = {n: sympy.Symbol(n, real=True) for n in sliced.vertices if not n.startswith("u[")}
    solved: dict[str, sympy.Expr] = {}  # internal (unobserved) algebraic variables at step k
    output_expr: dict[str, sympy.Expr] = {}
    ordered: list[Equation] = []
    for j in _topological(members, uplinks):
        targets = [v for v in sorted(sccs[j]) if v not in names.states]
        algebraic = [determining[v] for v in targets]
        ordered.extend(determining[v] for v in sorted(sccs[j]) if v in names.states)
        if not targets:
            continue
        ordered.extend(algebraic)
        unknowns = [current[v] for v in targets]
        substituted = [e.residual.xreplace(solved) for e in algebraic]
        key = (tuple(id(e) for e in algebraic), tuple(targets), tuple(substituted))
        solution = known_solutions.get(key)
        if solution is None:
            label = joint_label(assignment)
            solution = known_solutions[key] = solve_explicitly(
                algebraic, targets, label, substituted
            )
        for v, symbol in zip(targets, unknowns, strict=True):
            expr = solution[symbol]
            if v in observed:
                output_expr[v] = expr
            else:
                solved[symbol] = expr
    # Observed variables keep their own symbol where others use them: the virtual input.
    shift = {
        previous_symbol(str(s)): e.xreplace({c: previous_symbol(str(c)) for c in e.free_symbols})
        for s, e in solved.items()
    }
    cluster_vars = {v for j in members for v in sccs[j]}
    states = tuple(s for s in names.states if s in cluster_vars)
    outputs = tuple(o for o in names.outputs if o in cluster_vars)
    f_prev = [determining[s].rhs.xreplace(shift) for s in states]
    h_now = [output_expr[o] for o in outputs]
    to_plain = {previous_symbol(n): sympy.Symbol(n, real=True) for n in current}
    f = tuple(sympy.sympify(e).xreplace(to_plain) for e in f_prev)
    h = tuple(sympy.sympify(e) for e in h_now)
    used = {str(s) for e in (*f, *h) for s in e.free_symbols}
    inputs = tuple(u for u in names.inputs if u in used)
    virtual = tuple(o for o in names.outputs if o in used and o not in states)
    process = []
    for s in states:
        component, mode = equation_owner[id(determining[s])]
        process.append(float(components[component].mode(mode).process_noise[s]))
    measurement = []
    for o in outputs:
        component, mode = equation_owner[id(determining[o])]
        measurement.append(float(components[component].mode(mode).measurement_noise[o]))
    virtual_noise = [
        _observed_variance(o, determined_by, all_equations, equation_owner, components)
        for o in virtual
    ]
    owners = {equation_owner[id(e)][0] for e in ordered}
    return Cluster(
        states=states,
        outputs=outputs,
        inputs=inputs,
        virtual_inputs=virtual,
        components=tuple(c for c in components if c in owners),
        equations=tuple(ordered),
        f=f,
        h=h,
        process_noise=tuple(process),
        measurement_noise=tuple(measurement),
        virtual_noise=tuple(virtual_noise),
    )


def _observed_variance(
    name: str,
    determined_by: Mapping[str, int],
    equations: Sequence[Equation],
    equation_owner: Mapping[int, tuple[str, str]],
    components: Mapping[str, Component],
) -> float:
    """Sensor variance of observed variable ``name``.

    That of the mode determining it, else the largest any mode of the model gives it (its
    component is in the unknown mode).
    """
    if name in determined_by:
        component, mode = equation_owner[id(equations[determined_by[name]])]
        return float(components[component].mode(mode).measurement_noise[name])
    listed = [
        m.measurement_noise[name]
        for c in components.values()
        for m in c.modes
        if name in m.measurement_noise
    ]
    return float(max(listed)) if listed else 0.0


class StructureCache:
    """Decompositions per mode assignment, computed once.

    Paper 002 §5: decompositions are cached for re-use; :attr:`hits` and :attr:`misses`
    count the look-ups.
    """

    def __init__(
        self,
        components: Sequence[Component],
        *,
        states: tuple[str, ...],
        inputs: tuple[str, ...],
        outputs: tuple[str, ...],
        variables: tuple[str, ...],
    ) -> None:
        self.components = tuple(components)
        self.names = _Names(states, inputs, outputs, variables)
        self._cache: dict[Assignment, Decomposition] = {}
        self._solved: dict[_SolveKey, dict[sympy.Symbol, sympy.Expr]] = {}
        self.hits = 0
        self.misses = 0
        self.seconds = 0.0

    def get(self, assignment: Assignment) -> Decomposition:
        """The decomposition of ``assignment`` (computed on first use, timed in ``seconds``)."""
        found = self._cache.get(assignment)
        if found is not None:
            self.hits += 1
            return found
        self.misses += 1
        start = time.perf_counter()
        n = self.names
        result = decompose(
            self.components,
            assignment,
            states=n.states,
            inputs=n.inputs,
            outputs=n.outputs,
            variables=n.variables,
            solved=self._solved,
        )
        self._cache[assignment] = result
        self.seconds += time.perf_counter() - start
        return result
