r"""Hybrid estimation with a bounded set of hypotheses (paper 002, eqs. (4)–(5)).

A hypothesis is one tracked trajectory: a joint mode assignment, its belief ``h`` and the
continuous estimate ``x̂``, ``P`` of its filter cluster.  One step:

* Every hypothesis ``j`` proposes successors ``m_i`` with the prior belief
  ``h(•k)[x̂_i] = P_T(m_i | x̂_j, u_d(k-1)) h(k-1)[x̂_j]`` (eq. (4)), where the transition
  of the composition is the product of the components' (each component moves
  independently) and the commands ``u_d(k-1)`` of the step before select the transition
  rules that apply (``when``, :meth:`Component.transition_probabilities`).
* Successors are proposed **best first** (a heap over the parents and, per component, the
  rank of its next mode in that component's sorted transition list), never by enumerating
  all assignments.  Each proposed successor is filtered (its filter cluster, one EKF per
  cluster, :mod:`~hybridlog.estimators.cpha.cluster_filter`) and scored
  ``h(•k) P_O`` (eq. (5) before normalising).  Since ``P_O = exp(-rᵀS⁻¹r/2) ≤ 1``, once the
  next proposal's prior is below the ``beam``-th best score none can enter: the ``beam``
  best trajectories are then exact.  At most ``candidates`` successors are filtered per step
  (a bound on the work when the observations explain poorly).
* The ``beam`` best are kept and normalised (eq. (5)).  Trajectories are not merged: two
  hypotheses may share an assignment through different histories (§2.2).

Successors that share a cluster (same equations) and its prior estimate share its EKF step,
computed once per step: a cluster's estimate depends only on its own history and the
measured virtual inputs, so trajectories that differ only in other clusters' modes hold the
same one.  States outside every cluster hold their mean and their
variance grows by ``variance_growth`` per step; their covariances with the other states are
dropped (§3.1).
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from hybridlog.errors import arithmetic_reason
from hybridlog.estimators.cpha.cluster_filter import (
    ClusterFilter,
    FilterCache,
    SingularInnovationError,
    StepResult,
)
from hybridlog.estimators.cpha.structure import Assignment, Cluster, StructureCache
from hybridlog.model.components import UNKNOWN, Component
from hybridlog.signals import FloatArray, IntArray

__all__ = ["ClusterStepError", "Hypothesis", "NoExplanationError", "Tracker", "TransitionTable"]


class TransitionTable:
    """Per component, source mode and commands: targets sorted by falling probability, as logs.

    ``unknown_mode=False`` removes the unknown mode (targets and initial) and renormalises;
    a component that starts only in ``unknown`` then starts uniformly over its known modes.
    ``commands`` are the command names whose values :meth:`successors` is given (in that
    order); each component's table reads those its own rules' ``when`` name, and is built
    per source mode and value of those commands when first asked for.
    """

    def __init__(
        self,
        components: Sequence[Component],
        *,
        unknown_mode: bool,
        commands: Sequence[str] = (),
    ) -> None:
        self.components = tuple(components)
        self.unknown_mode = unknown_mode
        self.commands = tuple(commands)
        # per component: the positions in ``commands`` of those its rules name
        self._reads: list[tuple[int, ...]] = []
        for component in components:
            named = {c for rule in component.rules for c in rule.when}
            missing = sorted(named.difference(self.commands))
            if missing:
                raise ValueError(f"component {component.name}: no value of command {missing[0]}")
            self._reads.append(tuple(i for i, c in enumerate(self.commands) if c in named))
        self._table: list[dict[tuple[str, tuple[float, ...]], list[tuple[float, str]]]] = [
            {} for _ in self.components
        ]
        self.initial = [
            self._sorted(c.initial_mode_probabilities)
            or self._sorted(dict.fromkeys(c.mode_ids, 1.0))  # only unknown, switched off
            for c in components
        ]

    def _sorted(self, probabilities: dict[str, float]) -> list[tuple[float, str]]:
        kept = {
            m: p for m, p in probabilities.items() if p > 0 and (self.unknown_mode or m != UNKNOWN)
        }
        total = sum(kept.values())
        if total <= 0.0:
            return []
        return sorted(((math.log(p / total), m) for m, p in kept.items()), key=lambda t: -t[0])

    def successors(
        self, assignment: Assignment, commands: tuple[float, ...] = ()
    ) -> list[list[tuple[float, str]]]:
        """Per component, the sorted ``(log P_T, target)`` out of its mode in ``assignment``.

        ``commands``: the values of :attr:`commands` (``u_d(k-1)``, paper 002 eq. (4)).
        """
        lists = []
        for c, mode in enumerate(assignment):
            values = tuple(commands[i] for i in self._reads[c])
            table = self._table[c]
            found = table.get((mode, values))
            if found is None:
                component = self.components[c]
                given = {self.commands[i]: v for i, v in zip(self._reads[c], values, strict=True)}
                found = self._sorted(component.transition_probabilities(mode, given))
                table[(mode, values)] = found
            lists.append(found)
        return lists


_Entry = tuple[Assignment, tuple[int, ...]]
"""A successor's assignment and the ids of its clusters' filters (:meth:`Tracker._filters_of`)."""


class _Successors:
    """The successors out of one joint assignment, shared by every parent holding it.

    ``lists[c]`` are component c's sorted ``(log P_T, target)``.  A rank vector ``r`` (one
    rank per component) is coded as the integer ``Σ_c r_c · stride_c``; its children (one
    rank incremented) and its assignment are derived once per code and kept.
    """

    def __init__(self, lists: Sequence[Sequence[tuple[float, str]]]) -> None:
        self.lists = lists
        self.empty = any(not options for options in lists)
        self.first = sum(o[0][0] for o in lists) if not self.empty else -math.inf
        strides = []
        stride = 1
        for options in lists:
            strides.append(stride)
            stride *= max(len(options), 1)
        self.strides = tuple(strides)
        self._children: dict[int, tuple[tuple[tuple[float, int, int], ...], ...]] = {}
        self.entries: dict[int, _Entry] = {}

    def ranks(self, code: int) -> tuple[int, ...]:
        """The rank vector of ``code``."""
        return tuple(
            (code // stride) % max(len(options), 1)
            for stride, options in zip(self.strides, self.lists, strict=True)
        )

    def children(self, code: int, last: int) -> tuple[tuple[float, int, int], ...]:
        """``(Δ score, child code, c)`` of the children incrementing a rank at ``c >= last``."""
        found = self._children.get(code)
        if found is None:
            ranks = self.ranks(code)
            kids = []
            for c, (r, options) in enumerate(zip(ranks, self.lists, strict=True)):
                if r + 1 < len(options):
                    kids.append((options[r + 1][0] - options[r][0], code + self.strides[c], c))
            found = tuple(
                tuple(kid for kid in kids if kid[2] >= start) for start in range(len(ranks))
            )
            self._children[code] = found
        return found[last]

    def assignment(self, code: int) -> Assignment:
        """The joint assignment of ``code``."""
        return tuple(options[r][1] for options, r in zip(self.lists, self.ranks(code), strict=True))


class _Proposals:
    """Best-first enumeration of ``base_j + Σ_c lists[j][c][r_c]`` over parents and ranks.

    No vector is proposed twice: a child increments one rank at or after the last
    incremented position (each rank vector has one parent in this tree).
    """

    def __init__(self, bases: Sequence[float], successors: Sequence[_Successors]) -> None:
        self.successors = successors
        self.heap: list[tuple[float, int, int, int, int]] = []
        self.counter = 0
        for j, (base, table) in enumerate(zip(bases, successors, strict=True)):
            if table.empty or not math.isfinite(base):
                continue
            self.counter += 1
            self.heap.append((-(base + table.first), self.counter, j, 0, 0))
        heapq.heapify(self.heap)

    def pop(self) -> tuple[float, int, int] | None:
        """The next best ``(score, parent, rank code)``, or None when exhausted."""
        if not self.heap:
            return None
        heap = self.heap
        negative, _, j, code, last = heapq.heappop(heap)
        score = -negative
        counter = self.counter
        for delta, child, c in self.successors[j].children(code, last):
            counter += 1
            heapq.heappush(heap, (-(score + delta), counter, j, child, c))
        self.counter = counter
        return score, j, code


class Hypothesis:
    """One tracked trajectory.

    Attributes
    ----------
    assignment:
        Mode id per component.
    log_belief:
        ``log h(k)`` (normalised over the kept hypotheses).
    x, P:
        Continuous estimate of all states (cross-cluster covariances are zero).
    y_pred:
        One-step-ahead output prediction of its clusters (NaN for outputs in none).
    sources:
        The cluster step that produced ``x``, ``P`` of each of its clusters, by the
        cluster's state indices: lets successors find a shared step by identity and read
        its estimate there (:meth:`Tracker._evaluate`); empty when unknown.

    A hypothesis made by :meth:`Tracker.step` assembles ``x``, ``P`` and ``y_pred`` from its
    parent and its cluster steps only when they are first read (most pruned hypotheses
    never are); the parent is released then.
    """

    __slots__ = ("_P", "_pending", "_x", "_y_pred", "assignment", "log_belief", "sources")

    def __init__(
        self,
        assignment: Assignment,
        log_belief: float,
        x: FloatArray | None,
        P: FloatArray | None,
        y_pred: FloatArray | None,
        sources: dict[tuple[int, ...], StepResult] | None = None,
        pending: _Pending | None = None,
    ) -> None:
        self.assignment = assignment
        self.log_belief = log_belief
        self._x = x
        self._P = P
        self._y_pred = y_pred
        self.sources = {} if sources is None else sources
        self._pending = pending

    @property
    def x(self) -> FloatArray:
        """``x̂(k|k)`` of all states."""
        if self._x is None:
            self._materialise()
        assert self._x is not None
        return self._x

    @property
    def P(self) -> FloatArray:
        """``P(k|k)`` of all states."""
        if self._P is None:
            self._materialise()
        assert self._P is not None
        return self._P

    @property
    def y_pred(self) -> FloatArray:
        """``ŷ(k|k-1)`` of all outputs."""
        if self._y_pred is None:
            self._materialise()
        assert self._y_pred is not None
        return self._y_pred

    def _materialise(self) -> None:
        """Assemble ``x``, ``P``, ``y_pred`` of this and its unassembled ancestors (oldest first).

        The successor's full estimate: its clusters' results, the rest held (§3.1).
        """
        chain = []
        h: Hypothesis | None = self
        while h is not None and h._pending is not None:
            chain.append(h)
            h = h._pending.parent
        for h in reversed(chain):
            pending = h._pending
            assert pending is not None
            parent, layout, results = pending.parent, pending.layout, pending.results
            assert parent._x is not None and parent._P is not None
            x = parent._x.copy()
            n = len(x)
            P_flat = np.zeros(n * n)
            y_pred = pending.no_prediction.copy()
            if results:
                x[layout.states] = np.concatenate([result.x for result in results])
                P_flat[layout.block] = np.concatenate([result.P.reshape(-1) for result in results])
                y_pred[layout.outputs] = np.concatenate([result.y_pred for result in results])
            P = P_flat.reshape(n, n)
            held = layout.held
            if len(held):  # past double precision: infinite, which the run's result refuses
                with np.errstate(over="ignore"):
                    P[held, held] = parent._P[held, held] * pending.variance_growth
            h._x, h._P, h._y_pred = x, P, y_pred
            h._pending = None


class _Pending(NamedTuple):
    """What :meth:`Hypothesis._materialise` needs to assemble a successor.

    The parent, the layout of the cluster set, the cluster steps, the held variances'
    growth factor and an all-NaN prediction.
    """

    parent: Hypothesis
    layout: _Layout
    results: Sequence[StepResult]
    variance_growth: float
    no_prediction: FloatArray


class ClusterStepError(ArithmeticError):
    """A cluster's EKF hit a point where its equations or their Jacobians are not finite."""


class NoExplanationError(ArithmeticError):
    """No successor of a step has a belief above 0: the step has no hybrid estimate.

    The previous step's hypotheses were kept instead, without a word: a model without the
    unknown mode whose filters' ``S`` is singular (no noise at all) reported its initial
    state with variance 0 on every sample of the log, as a certain estimate.
    """


class Tracker:
    """Hybrid estimation over one log: :meth:`start`, then :meth:`step` for k = 1, 2, ….

    Parameters
    ----------
    components, structure, filters:
        The model's components and the caches of decompositions and compiled filters.
    inputs, outputs:
        The log, shapes ``(N, n_u)`` and ``(N, n_y)``.
    commands:
        The values of the commands the components' rules name, shape ``(N, n_c)``, columns
        in the order of ``command_names``; ``None`` when no rule names one.  Step k's
        transition probabilities are selected by row ``k-1`` (eq. (4)).
    command_names:
        The commands' names.
    beam:
        Number of hypotheses kept.
    candidates:
        Most successors filtered per step, at least ``beam``.
    variance_growth:
        Factor on the variance of a held (unobservable or undetermined) state per step.
    unknown_mode:
        Whether the unknown mode is a mode of every component.
    """

    def __init__(
        self,
        components: Sequence[Component],
        structure: StructureCache,
        filters: FilterCache,
        inputs: FloatArray,
        outputs: FloatArray,
        *,
        beam: int,
        candidates: int,
        variance_growth: float,
        unknown_mode: bool,
        commands: FloatArray | None = None,
        command_names: Sequence[str] = (),
    ) -> None:
        self.components = tuple(components)
        self.structure = structure
        self.filters = filters
        self.inputs = inputs
        self.outputs = outputs
        if candidates < beam:  # was raised to the beam without a word
            raise ValueError(f"candidates ({candidates}) below the beam ({beam})")
        self.beam = beam
        self.candidates = candidates
        self.variance_growth = variance_growth
        self.transitions = TransitionTable(
            components, unknown_mode=unknown_mode, commands=command_names
        )
        if commands is None and command_names:
            raise ValueError("command names without their values")
        self.commands = commands
        self.filtered = 0
        self.proposed = 0
        self.truncated = 0
        """Steps at which ``candidates`` stopped the search before the beam was exact."""
        self.parents: list[int] = []
        """Per hypothesis the last :meth:`step` returned, its parent's index in the list that
        step was given (the back-pointers of the trajectories, for an offline mode sequence)."""
        self.prediction = np.full(outputs.shape[1], np.nan)
        """``ŷ(k|k-1)`` of the last :meth:`step`: that of its most likely successor before
        ``y(k)`` is weighed (see :meth:`step`); NaN before the first step."""
        self.surprise = math.nan
        """The smallest ``rᵀS⁻¹r`` (``-2 log P_O``, eq. (21)) over the successors the last
        :meth:`step` filtered: past :func:`~hybridlog.estimators.vouch.surprise_limit` no
        successor explains ``y(k)``, and the beam holds hypotheses that do not either (with
        the unknown mode a successor whose unknown component leaves the output unchecked
        explains it, ``P_O = 1``); NaN before the first step."""
        self.n_states = len(structure.names.states)
        self._no_prediction = np.full(outputs.shape[1], np.nan)
        # Per mode assignment (kept across steps): its successor table, its clusters' filters
        # (by small integer ids), and per cluster set the indices its results are written to.
        self._successors: dict[tuple[Assignment, tuple[float, ...]], _Successors] = {}
        self._assignment_filters: dict[Assignment, tuple[int, ...]] = {}
        self._compiled: list[ClusterFilter] = []
        self._state_keys: list[tuple[int, ...]] = []
        self._compiled_ids: dict[int, int] = {}
        self._layouts: dict[tuple[int, ...], _Layout] = {}
        # per filter: its measured arguments at step _measured_k (ClusterFilter.measured)
        self._measured: dict[int, list[float]] = {}
        self._measured_k = -1
        # per parent and output not measured at _measured_k - 1: the parent's estimate of it
        self._estimates: dict[tuple[int, int], tuple[float, float]] = {}

    def start(self, x0: FloatArray, P0: FloatArray) -> list[Hypothesis]:
        """The ``beam`` most likely initial assignments (product of the components' priors)."""
        initial = _Successors(self.transitions.initial)
        proposals = _Proposals([0.0], [initial])
        hypotheses: list[Hypothesis] = []
        nan = np.full(self.outputs.shape[1], np.nan)
        while len(hypotheses) < self.beam:
            item = proposals.pop()
            if item is None:
                break
            score, _, code = item
            assignment = initial.assignment(code)
            hypotheses.append(Hypothesis(assignment, score, x0.copy(), P0.copy(), nan))
        _normalise(hypotheses)
        return hypotheses

    def successor(self, parent: Hypothesis, assignment: Assignment, k: int) -> Hypothesis:
        """The filtered successor of ``parent`` in ``assignment`` at step k (belief = log P_O)."""
        ids = self._filters_of(assignment)
        log_po, results = self._evaluate(0, parent, ids, k, {}, {}, [{}])
        return self._assemble(parent, assignment, ids, results, log_po)

    def _evaluate(
        self,
        j: int,
        parent: Hypothesis,
        ids: tuple[int, ...],
        k: int,
        memo: dict[tuple[object, ...], StepResult],
        shared: dict[tuple[int, int], StepResult],
        per_parent: list[dict[int, StepResult]],
    ) -> tuple[float, tuple[StepResult, ...]]:
        """``log P_O`` of the filter cluster ``ids`` from parent ``j`` (eq. (7)).

        ``per_parent[j]`` remembers parent j's cluster steps; ``memo`` shares a cluster step
        between parents that hold the same estimate (the same bytes) of that cluster, and
        ``shared`` finds it faster when they hold it from the same earlier step object (the
        parent's ``sources``: then the bytes are the same).
        """
        log_po = 0.0
        results = []
        steps = per_parent[j]
        for i in ids:
            result = steps.get(i)
            if result is None:
                result = steps[i] = self._cluster_step(parent, i, k, memo, shared)
            results.append(result)
            log_po += result.log_po
        return log_po, tuple(results)

    def _cluster_step(
        self,
        parent: Hypothesis,
        i: int,
        k: int,
        memo: dict[tuple[object, ...], StepResult],
        shared: dict[tuple[int, int], StepResult],
    ) -> StepResult:
        """The EKF step of filter ``i`` from ``parent``'s estimate (see :meth:`_evaluate`).

        Where an output the filter uses is not measured (NaN, module docstring of
        :mod:`~hybridlog.estimators.cpha.cluster_filter`) the step is
        :meth:`~ClusterFilter.step_numeric` on what was measured; a virtual input of ``f``
        not measured at k−1 is replaced by the parent's estimate of it
        (:meth:`_estimate_before`), which makes the step the parent's own (not shared).
        """
        source = parent.sources.get(self._state_keys[i])
        if source is not None:
            result = shared.get((i, id(source)))
            if result is not None:
                return result
        compiled = self._compiled[i]
        idx = compiled.states
        if source is not None:  # the same bytes as the parent's x[idx], P block
            x_parent = source.x
            P_parent = source.P.reshape(-1)
        else:
            x_parent = parent.x[idx]
            P_parent = parent.P.reshape(-1)[self._layout((i,)).block]
        u_prev, y_prev, u_now, y_now = (
            self.inputs[k - 1],
            self.outputs[k - 1],
            self.inputs[k],
            self.outputs[k],
        )
        # the filter's measured arguments at step k, kept for its other estimates
        if self._measured_k != k:
            self._measured_k = k
            self._measured.clear()
            self._estimates.clear()
        measured = self._measured.get(i)
        if measured is None:
            measured = self._measured[i] = compiled.measured(u_prev, y_prev, u_now, y_now)
        complete = not math.isnan(sum(measured))  # the log's values are far below overflow
        r_prev = None
        key: tuple[object, ...] = (i, x_parent.tobytes(), P_parent.tobytes())
        if not complete:
            estimated = self._virtual_before(parent, compiled, k)
            if estimated is None:
                return self._held(compiled, x_parent, P_parent)
            y_prev, r_prev = estimated
            if r_prev is not None:  # the parent's estimates: its own step
                key = (*key, y_prev.tobytes(), r_prev.tobytes())
        result = memo.get(key)
        if result is None:
            P_prior = P_parent.reshape(len(idx), len(idx))
            try:
                if complete:
                    result = compiled.step(
                        x_parent, P_prior, u_prev, y_prev, u_now, y_now, measured
                    )
                else:
                    result = compiled.step_numeric(
                        x_parent, P_prior, u_prev, y_prev, u_now, y_now, r_prev
                    )
            except SingularInnovationError as err:
                cluster = compiled.cluster
                raise ClusterStepError(
                    f"the EKF of the cluster of {', '.join(cluster.states or cluster.outputs)} "
                    f"(components {', '.join(cluster.components)}) cannot step at sample {k} "
                    f"({_values(cluster, x_parent, y_now[compiled.outputs])}): {err}"
                ) from err
            except (ArithmeticError, ValueError, RuntimeWarning) as err:  # 1/0, sqrt(-1)
                cluster = compiled.cluster
                why = (
                    "its equations or their Jacobian are not finite there"
                    if np.isfinite(x_parent).all() and np.isfinite(P_parent).all()
                    else "its prior is not finite (a variance grown past double precision "
                    "while its states were held: variance_growth, the initial covariance)"
                )
                raise ClusterStepError(
                    f"the EKF of the cluster of {', '.join(cluster.states or cluster.outputs)} "
                    f"(components {', '.join(cluster.components)}) cannot step at sample {k}: "
                    f"{why} ({_values(cluster, x_parent, y_now[compiled.outputs])}): "
                    f"{arithmetic_reason(err)}"
                ) from err  # the cause last: a line cut in the middle (a long path) keeps it
            memo[key] = result
            self.filtered += 1
        if source is not None and r_prev is None:
            shared[(i, id(source))] = result
        return result

    def _virtual_before(
        self, parent: Hypothesis, compiled: ClusterFilter, k: int
    ) -> tuple[FloatArray, FloatArray | None] | None:
        """The outputs at k−1 and the variances of ``compiled``'s virtual inputs there.

        A virtual input ``f`` uses that was not measured at k−1 is given the parent's
        estimate of it and that estimate's variance in place of ``r_v`` (eq. (6)): the
        hypothesis' own knowledge of the variable, never a value the log does not hold.
        ``None`` when the parent has no estimate of one (no cluster of its assignment
        determines it, or its equation uses a virtual input not measured either): then the
        filter is not determined at k (§3.1, :meth:`_held`).  The variances are ``None``
        where ``f`` needs no estimate (the outputs as the log has them, ``r_v``).
        """
        y_prev = self.outputs[k - 1]
        needed = np.flatnonzero(np.isnan(y_prev[compiled.virtual]) & compiled.f_virtual)
        if not needed.size:
            return y_prev, None
        y_prev = y_prev.copy()
        variances = compiled.r_virtual.copy()
        for j in needed.tolist():
            output = int(compiled.virtual[j])
            value, variance = self._estimate_before(parent, output, k)
            if math.isnan(value) or math.isnan(variance):
                return None
            y_prev[output] = value
            variances[j] = variance
        return y_prev, variances

    def _estimate_before(self, parent: Hypothesis, output: int, k: int) -> tuple[float, float]:
        """``parent``'s estimate of ``output`` at k−1 and its variance (NaN when it has none).

        From the cluster of the parent's assignment that determines the output, at the
        parent's ``x̂(k-1|k-1)``, ``P(k-1|k-1)`` (:meth:`ClusterFilter.observe`); kept for
        the step.
        """
        key = (id(parent), output)
        found = self._estimates.get(key)
        if found is None:
            found = (math.nan, math.nan)
            ids = self._assignment_filters.get(parent.assignment)  # not a look-up to count
            for i in self._filters_of(parent.assignment) if ids is None else ids:
                producer = self._compiled[i]
                if output in producer.outputs:
                    idx = producer.states
                    found = producer.observe(
                        parent.x[idx],
                        parent.P[np.ix_(idx, idx)],
                        self.inputs[k - 1],
                        self.outputs[k - 1],
                        output,
                    )
                    break
            self._estimates[key] = found
        return found

    def _held(self, compiled: ClusterFilter, x: FloatArray, P_flat: FloatArray) -> StepResult:
        """The step of a filter that is not determined at k: mean held, variances grown.

        As a state in no cluster (§3.1): ``P`` keeps its diagonal, times ``variance_growth``;
        no prediction, no evidence (``log P_O = 0``).
        """
        n = len(compiled.states)
        with np.errstate(over="ignore"):  # past double precision: refused as the result leaves
            P = np.diag(np.diag(P_flat.reshape(n, n)) * self.variance_growth)
        return StepResult(x, P, np.full(len(compiled.outputs), np.nan), 0.0, held=True)

    def _filters_of(self, assignment: Assignment) -> tuple[int, ...]:
        """The ids of the compiled filters of the assignment's clusters, in cluster order.

        Looked up in the caches once per assignment; later uses count as cache hits.
        """
        found = self._assignment_filters.get(assignment)
        if found is not None:
            self.structure.hits += 1
            self.filters.hits += len(found)
            return found
        decomposition = self.structure.get(assignment)
        ids = []
        for cluster in decomposition.clusters:
            compiled = self.filters.get(cluster)
            i = self._compiled_ids.get(id(compiled))
            if i is None:
                i = self._compiled_ids[id(compiled)] = len(self._compiled)
                self._compiled.append(compiled)
                self._state_keys.append(tuple(compiled.states.tolist()))
            ids.append(i)
        found = tuple(ids)
        self._assignment_filters[assignment] = found
        return found

    def _layout(self, ids: tuple[int, ...]) -> _Layout:
        """Where the results of the filters ``ids`` go in the full ``x``, ``P`` and ``ŷ``."""
        found = self._layouts.get(ids)
        if found is None:
            n = self.n_states
            covered = np.zeros(n, dtype=bool)
            blocks = []
            for i in ids:
                idx = self._compiled[i].states
                blocks.append((idx[:, None] * n + idx[None, :]).reshape(-1))
                covered[idx] = True
            empty = np.zeros(0, np.int64)
            found = _Layout(
                np.concatenate([self._compiled[i].states for i in ids]) if ids else empty,
                np.concatenate(blocks) if blocks else empty,
                np.concatenate([self._compiled[i].outputs for i in ids]) if ids else empty,
                np.flatnonzero(~covered),
                tuple(self._state_keys[i] for i in ids),
            )
            self._layouts[ids] = found
        return found

    def _assemble(
        self,
        parent: Hypothesis,
        assignment: Assignment,
        ids: tuple[int, ...],
        results: Sequence[StepResult],
        log_belief: float,
    ) -> Hypothesis:
        """The successor's full estimate: its clusters' results, the rest held (§3.1)."""
        layout = self._layout(ids)
        sources = dict(zip(layout.keys, results, strict=True))
        pending = _Pending(parent, layout, results, self.variance_growth, self._no_prediction)
        return Hypothesis(assignment, log_belief, None, None, None, sources, pending)

    @staticmethod
    def _likeliest(table: _Successors, assignment: Assignment) -> Assignment:
        """Per component its most likely target out of ``assignment``; a tie stays put.

        Out of ``unknown``, left readily, every target may be equally likely (docs/bioplex.md):
        the first one listed would be an arbitrary pick, the mode held is the estimate's own.
        """
        chosen = []
        for options, mode in zip(table.lists, assignment, strict=True):
            likeliest = [target for p, target in options if p == options[0][0]] or [mode]
            chosen.append(mode if mode in likeliest else likeliest[0])
        return tuple(chosen)

    def _predicted(self, ids: tuple[int, ...], results: Sequence[StepResult]) -> FloatArray:
        """``ŷ(k|k-1)`` of all outputs from a successor's cluster steps (NaN in none)."""
        y_pred = self._no_prediction.copy()
        if results:
            y_pred[self._layout(ids).outputs] = np.concatenate([r.y_pred for r in results])
        return y_pred

    def _table(self, assignment: Assignment, commands: tuple[float, ...] = ()) -> _Successors:
        """The successor table out of ``assignment`` under ``commands`` (built once for each)."""
        key = (assignment, commands)
        found = self._successors.get(key)
        if found is None:
            found = _Successors(self.transitions.successors(assignment, commands))
            self._successors[key] = found
        return found

    def commands_before(self, k: int) -> tuple[float, ...]:
        """``u_d(k-1)``: the command values that select the transitions into step k."""
        if self.commands is None:
            return ()
        return tuple(self.commands[k - 1].tolist())

    def step(self, hypotheses: Sequence[Hypothesis], k: int) -> list[Hypothesis]:
        """Eqs. (4)–(5) at step k: the ``beam`` best filtered successors, normalised.

        Also sets :attr:`prediction`, the one-step-ahead output prediction of step k made
        before ``y(k)`` is used (SPEC §8): the ``ŷ(k|k-1)`` of the most likely hypothesis of
        step k−1 (the hybrid estimate, §2.2) in its most likely successor assignment
        (:meth:`_likeliest`), as paper 001's observer predicts in the mode decided before.
        The most likely hypothesis *after* the step is chosen by ``P_O``, that is by
        ``y(k)``: its ``ŷ(k|k-1)`` was the kept one nearest ``y(k)``, and a spike only an
        unknown component explained left the sample unpredicted, out of the metrics.
        """
        bases = [h.log_belief for h in hypotheses]
        commands = self.commands_before(k)
        tables = [self._table(h.assignment, commands) for h in hypotheses]
        proposals = _Proposals(bases, tables)
        memo: dict[tuple[object, ...], StepResult] = {}
        shared: dict[tuple[int, int], StepResult] = {}
        per_parent: list[dict[int, StepResult]] = [{} for _ in hypotheses]
        # ŷ(k|k-1) before y(k) is weighed; its cluster steps are the loop's too (per_parent)
        top = max(range(len(hypotheses)), key=bases.__getitem__)
        held = self._filters_of(self._likeliest(tables[top], hypotheses[top].assignment))
        _, steps_held = self._evaluate(top, hypotheses[top], held, k, memo, shared, per_parent)
        self.prediction = self._predicted(held, steps_held)
        # min-heap of the beam best: (score, order, parent, rank code, cluster results)
        best: list[tuple[float, int, int, int, list[StepResult]]] = []
        tried = hits = filter_hits = 0
        # the proposals' best-first pop (_Proposals.pop) and the shared-step look-up of
        # _cluster_step, inlined: this loop runs ~40 times per step
        heap = proposals.heap
        counter = proposals.counter
        beam = self.beam
        state_keys = self._state_keys
        heappop, heappush = heapq.heappop, heapq.heappush
        floor = -math.inf  # the beam's lowest score once it is full
        nearest = -math.inf  # the largest log P_O filtered (self.surprise)
        while tried < self.candidates:
            if not heap:
                break
            if -heap[0][0] <= floor and len(best) >= beam:
                break  # P_O ≤ 1: no later proposal can beat the beam
            negative, _, j, code, last = heappop(heap)
            prior = -negative
            table = tables[j]
            kids = table._children.get(code)  # table.children(code, last), inlined
            for delta, child, c in table.children(code, last) if kids is None else kids[last]:
                score = prior + delta
                # a child below the floor (which only rises) would stop the loop when on
                # top, as the next proposal after it does then: it is not pushed
                if score >= floor:
                    counter += 1
                    heappush(heap, (-score, counter, j, child, c))
            tried += 1
            found = table.entries.get(code)
            if found is None:
                found = self._entry(table, code)
            else:  # the assignment's decomposition and filters, looked up before
                hits += 1
                filter_hits += len(found[1])
            # eq. (7): log P_O of the successor's filter cluster, as in _evaluate
            steps = per_parent[j]
            parent = hypotheses[j]
            log_po = 0.0
            results = []
            for i in found[1]:
                result = steps.get(i)
                if result is None:
                    source = parent.sources.get(state_keys[i])
                    if source is not None:
                        result = shared.get((i, id(source)))
                    if result is None:
                        result = self._cluster_step(parent, i, k, memo, shared)
                    steps[i] = result
                results.append(result)
                log_po += result.log_po
            if log_po > nearest:
                nearest = log_po
            entry = (prior + log_po, tried, j, code, results)
            if len(best) < beam:
                heappush(best, entry)
                if len(best) == beam:
                    floor = best[0][0]
            elif entry[0] > floor:
                heapq.heapreplace(best, entry)
                floor = best[0][0]
        proposals.counter = counter
        self.surprise = -2.0 * nearest if tried else math.nan
        self.proposed += tried
        if heap and tried >= self.candidates and (len(best) < beam or -heap[0][0] > floor):
            self.truncated += 1  # a successor not filtered might have entered the beam
        self.structure.hits += hits
        self.filters.hits += filter_hits
        best.sort(key=lambda e: (-e[0], e[1]))
        kept = []
        # _assemble, inlined
        layouts, growth, no_prediction = self._layouts, self.variance_growth, self._no_prediction
        for score, _, j, code, results in best:
            assignment, ids = tables[j].entries[code]
            layout = layouts.get(ids)
            if layout is None:
                layout = self._layout(ids)
            sources = dict(zip(layout.keys, results, strict=True))
            pending = _Pending(hypotheses[j], layout, results, growth, no_prediction)
            kept.append(Hypothesis(assignment, score, None, None, None, sources, pending))
        if not kept or not any(math.isfinite(h.log_belief) for h in kept):
            raise NoExplanationError(self._unexplained(hypotheses, tables, best, per_parent, k))
        self.parents = [j for _, _, j, _, _ in best]
        # A kept successor holds its parent until it is assembled, the parent its own, and
        # so on: a trajectory kept but never the most likely one (nor needing its parent's
        # held states) kept every ancestor alive, with their cluster steps, to the end of
        # the log (about 19 hypotheses a step at beam 20, 6 KB a sample for one state).
        # Assembling the parents cuts each chain at one step.
        for j in set(self.parents):
            if hypotheses[j]._pending is not None:
                hypotheses[j]._materialise()
        _normalise(kept)
        return kept

    def _unexplained(
        self,
        hypotheses: Sequence[Hypothesis],
        tables: Sequence[_Successors],
        best: Sequence[tuple[float, int, int, int, list[StepResult]]],
        per_parent: Sequence[dict[int, StepResult]],
        k: int,
    ) -> str:
        """Why no successor of step k has a belief above 0 (:class:`NoExplanationError`)."""
        if not best:
            for h, table in zip(hypotheses, tables, strict=True):
                for c, options in enumerate(table.lists):
                    if not options:
                        component = self.components[c]
                        return (
                            f"no hypothesis has a successor at sample {k}: component "
                            f"{component.name} cannot leave mode '{h.assignment[c]}' for a "
                            f"modelled mode (its transitions there go to '{UNKNOWN}' only, "
                            "and the unknown mode is switched off: unknown_mode = false)"
                        )
            return f"no hypothesis has a successor at sample {k}"
        _, _, j, code, _ = best[0]
        for i in tables[j].entries[code][1]:
            result = per_parent[j].get(i)
            if result is not None and result.log_po == -math.inf:
                cluster = self._compiled[i].cluster
                return (
                    f"no hypothesis explains sample {k}: every successor's P_O is 0, as the "
                    f"EKF of the cluster of {', '.join(cluster.states or cluster.outputs)} "
                    f"(components {', '.join(cluster.components)}) gives it, whose innovation "
                    "covariance S or weighted residual rᵀS⁻¹r is not finite there"
                )
        return f"no hypothesis explains sample {k}: every successor's P_O is 0"

    def _entry(self, table: _Successors, code: int) -> _Entry:
        """The assignment of ``code`` in ``table`` and its filters, kept in ``table``.

        Later uses in :meth:`step` count as cache hits.
        """
        assignment = table.assignment(code)
        found = (assignment, self._filters_of(assignment))
        table.entries[code] = found
        return found


@dataclass(frozen=True)
class _Layout:
    """Where the results of a set of clusters go, in cluster order.

    ``states``, ``outputs``: their states and outputs in the full ``x`` and ``ŷ``; ``block``:
    their covariance blocks in the flattened full ``P``; ``held``: the states in none of
    them; ``keys``: each cluster's state indices (the keys of ``Hypothesis.sources``).
    """

    states: IntArray
    block: IntArray
    outputs: IntArray
    held: IntArray
    keys: tuple[tuple[int, ...], ...]


def _values(cluster: Cluster, x: FloatArray, y: FloatArray) -> str:
    """``xc3 = -1e+06 before the step, measured yc3 = -1e+06``: where a cluster failed.

    A log the model cannot explain (a CO2 sensor reading -1e6 ppm) drove a state to where an
    equation overflows, and the error named only the model's cluster, so that the user
    looked for the fault in the model; the values point at the log.  An output the log did
    not measure there (NaN) is said to be, never shown as a value.
    """
    states = ", ".join(f"{n} = {v:.6g}" for n, v in zip(cluster.states, x.tolist(), strict=True))
    pairs = list(zip(cluster.outputs, y.tolist(), strict=True))
    measured = ", ".join(f"{n} = {v:.6g}" for n, v in pairs if not math.isnan(v))
    unmeasured = ", ".join(n for n, v in pairs if math.isnan(v))
    parts = [f"{states} before the step"] if states else []
    if measured:
        parts.append(f"measured {measured}")
    if unmeasured:
        parts.append(f"{unmeasured} not measured")
    return ", ".join(parts)


def _normalise(hypotheses: list[Hypothesis]) -> None:
    """Eq. (5): beliefs normalised in log space (``-inf`` stays)."""
    finite = [h.log_belief for h in hypotheses if math.isfinite(h.log_belief)]
    if not finite:
        return
    top = max(finite)
    total = top + math.log(sum(math.exp(v - top) for v in finite))
    for h in hypotheses:
        h.log_belief -= total
