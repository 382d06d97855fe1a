r"""Hybrid estimation with a bounded set of hypotheses (paper 002, eqs. (4)–(5)).

A hypothesis is one tracked trajectory: a joint mode assignment, its belief ``h`` and the
continuous estimate ``x̂``, ``P`` of its filter cluster.  One step:

* Every hypothesis ``j`` proposes successors ``m_i`` with the prior belief
  ``h(•k)[x̂_i] = P_T(m_i | x̂_j) h(k-1)[x̂_j]`` (eq. (4)), where the transition of the
  composition is the product of the components' (each component moves independently).
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

import numpy as np

from hybridlog.estimators.cpha.cluster_filter import ClusterFilter, FilterCache, StepResult
from hybridlog.estimators.cpha.structure import Assignment, StructureCache
from hybridlog.model.components import UNKNOWN, Component
from hybridlog.signals import FloatArray, IntArray

__all__ = ["Hypothesis", "Tracker", "TransitionTable"]


class TransitionTable:
    """Per component and source mode: targets sorted by falling probability, as logs.

    ``unknown_mode=False`` removes the unknown mode (targets and initial) and renormalises.
    Commands are not read from logs in this version: rules with ``when`` do not apply.
    """

    def __init__(self, components: Sequence[Component], *, unknown_mode: bool) -> None:
        self.components = tuple(components)
        self.unknown_mode = unknown_mode
        self._table: list[dict[str, list[tuple[float, str]]]] = []
        for component in components:
            sources = (*component.mode_ids, *((UNKNOWN,) if unknown_mode else ()))
            table = {}
            for source in sources:
                table[source] = self._sorted(component.transition_probabilities(source))
            self._table.append(table)
        self.initial = [self._sorted(c.initial_mode_probabilities) for c in components]

    def _sorted(self, probabilities: dict[str, float]) -> list[tuple[float, str]]:
        kept = {
            m: p for m, p in probabilities.items() if p > 0 and (self.unknown_mode or m != UNKNOWN)
        }
        total = sum(kept.values())
        if total <= 0.0:
            return []
        return sorted(((math.log(p / total), m) for m, p in kept.items()), key=lambda t: -t[0])

    def successors(self, assignment: Assignment) -> list[list[tuple[float, str]]]:
        """Per component, the sorted ``(log P_T, target)`` out of its mode in ``assignment``."""
        return [table[mode] for table, mode in zip(self._table, assignment, strict=True)]


class _Proposals:
    """Best-first enumeration of ``base_j + Σ_c lists[j][c][r_c]`` over parents and ranks.

    No vector is proposed twice: a child increments one rank at or after the last
    incremented position (each rank vector has one parent in this tree).
    """

    def __init__(
        self, bases: Sequence[float], lists: Sequence[Sequence[Sequence[tuple[float, str]]]]
    ) -> None:
        self.lists = lists
        self.heap: list[tuple[float, int, int, tuple[int, ...], int]] = []
        self.counter = 0
        for j, (base, per_component) in enumerate(zip(bases, lists, strict=True)):
            if any(not options for options in per_component) or not math.isfinite(base):
                continue
            ranks = (0,) * len(per_component)
            self._push(base + sum(o[0][0] for o in per_component), j, ranks, 0)

    def _push(self, score: float, j: int, ranks: tuple[int, ...], last: int) -> None:
        self.counter += 1
        heapq.heappush(self.heap, (-score, self.counter, j, ranks, last))

    def peek(self) -> float:
        """The score of the next proposal (``-inf`` when there is none)."""
        return -self.heap[0][0] if self.heap else -math.inf

    def pop(self) -> tuple[float, int, Assignment] | None:
        """The next best ``(score, parent, assignment)``, or None when exhausted."""
        if not self.heap:
            return None
        negative, _, j, ranks, last = heapq.heappop(self.heap)
        score = -negative
        per_component = self.lists[j]
        for c in range(last, len(ranks)):
            r = ranks[c]
            if r + 1 < len(per_component[c]):
                child = (*ranks[:c], r + 1, *ranks[c + 1 :])
                delta = per_component[c][r + 1][0] - per_component[c][r][0]
                self._push(score + delta, j, child, c)
        assignment = tuple(per_component[c][r][1] for c, r in enumerate(ranks))
        return score, j, assignment


@dataclass
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
    """

    assignment: Assignment
    log_belief: float
    x: FloatArray
    P: FloatArray
    y_pred: FloatArray


class Tracker:
    """Hybrid estimation over one log: :meth:`start`, then :meth:`step` for k = 1, 2, ….

    Parameters
    ----------
    components, structure, filters:
        The model's components and the caches of decompositions and compiled filters.
    inputs, outputs:
        The log, shapes ``(N, n_u)`` and ``(N, n_y)``.
    beam:
        Number of hypotheses kept.
    candidates:
        Most successors filtered per step.
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
    ) -> None:
        self.components = tuple(components)
        self.structure = structure
        self.filters = filters
        self.inputs = inputs
        self.outputs = outputs
        self.beam = beam
        self.candidates = max(candidates, beam)
        self.variance_growth = variance_growth
        self.transitions = TransitionTable(components, unknown_mode=unknown_mode)
        self.filtered = 0
        self.proposed = 0
        self._blocks: dict[int, IntArray] = {}
        self.n_states = len(structure.names.states)
        self._no_prediction = np.full(outputs.shape[1], np.nan)
        self._held: dict[tuple[int, ...], IntArray] = {}
        self._assignment_filters: dict[Assignment, list[tuple[ClusterFilter, IntArray]]] = {}

    def start(self, x0: FloatArray, P0: FloatArray) -> list[Hypothesis]:
        """The ``beam`` most likely initial assignments (product of the components' priors)."""
        proposals = _Proposals([0.0], [self.transitions.initial])
        hypotheses: list[Hypothesis] = []
        nan = np.full(self.outputs.shape[1], np.nan)
        while len(hypotheses) < self.beam:
            item = proposals.pop()
            if item is None:
                break
            score, _, assignment = item
            hypotheses.append(Hypothesis(assignment, score, x0.copy(), P0.copy(), nan))
        _normalise(hypotheses)
        return hypotheses

    def successor(self, parent: Hypothesis, assignment: Assignment, k: int) -> Hypothesis:
        """The filtered successor of ``parent`` in ``assignment`` at step k (belief = log P_O)."""
        log_po, results = self._evaluate(0, parent, assignment, k, {}, {})
        return self._assemble(parent, assignment, results, log_po)

    def _evaluate(
        self,
        j: int,
        parent: Hypothesis,
        assignment: Assignment,
        k: int,
        memo: dict[tuple[object, ...], StepResult],
        per_parent: dict[tuple[int, int], StepResult],
    ) -> tuple[float, list[tuple[ClusterFilter, StepResult]]]:
        """``log P_O`` of the filter cluster of ``assignment`` from parent ``j`` (eq. (7)).

        ``per_parent`` remembers each parent's cluster steps; ``memo`` shares a cluster step
        between parents that hold the same estimate of that cluster.
        """
        log_po = 0.0
        results = []
        for compiled, block in self._filters_of(assignment):
            result = per_parent.get((j, id(compiled)))
            if result is None:
                idx = compiled.states
                x_parent = parent.x[idx]
                P_parent = parent.P.reshape(-1)[block]
                key = (id(compiled), x_parent.tobytes(), P_parent.tobytes())
                result = memo.get(key)
                if result is None:
                    result = compiled.step(
                        x_parent,
                        P_parent.reshape(len(idx), len(idx)),
                        self.inputs[k - 1],
                        self.outputs[k - 1],
                        self.inputs[k],
                        self.outputs[k],
                    )
                    memo[key] = result
                    self.filtered += 1
                per_parent[(j, id(compiled))] = result
            results.append((compiled, result))
            log_po += result.log_po
        return log_po, results

    def _filters_of(self, assignment: Assignment) -> list[tuple[ClusterFilter, IntArray]]:
        """The compiled filters of the assignment's clusters and their covariance blocks.

        Looked up in the caches once per assignment; later uses count as cache hits.
        """
        found = self._assignment_filters.get(assignment)
        if found is not None:
            self.structure.hits += 1
            self.filters.hits += len(found)
            return found
        decomposition = self.structure.get(assignment)
        found = []
        for cluster in decomposition.clusters:
            compiled = self.filters.get(cluster)
            found.append((compiled, self._block(compiled)))
        self._assignment_filters[assignment] = found
        return found

    def _block(self, compiled: ClusterFilter) -> IntArray:
        """Indices of the cluster's covariance block in the flattened full ``P``."""
        block = self._blocks.get(id(compiled))
        if block is None:
            n = self.n_states
            idx = compiled.states
            block = (idx[:, None] * n + idx[None, :]).reshape(-1)
            self._blocks[id(compiled)] = block
        return block

    def _assemble(
        self,
        parent: Hypothesis,
        assignment: Assignment,
        results: Sequence[tuple[ClusterFilter, StepResult]],
        log_belief: float,
    ) -> Hypothesis:
        """The successor's full estimate: its clusters' results, the rest held (§3.1)."""
        x = parent.x.copy()
        n = len(x)
        P_flat = np.zeros(n * n)
        y_pred = self._no_prediction.copy()
        for compiled, result in results:
            x[compiled.states] = result.x
            P_flat[self._block(compiled)] = result.P.reshape(-1)
            y_pred[compiled.outputs] = result.y_pred
        P = P_flat.reshape(n, n)
        covering = tuple(id(compiled) for compiled, _ in results)
        held = self._held.get(covering)
        if held is None:
            covered = np.zeros(n, dtype=bool)
            for compiled, _ in results:
                covered[compiled.states] = True
            held = np.flatnonzero(~covered)
            self._held[covering] = held
        P[held, held] = parent.P[held, held] * self.variance_growth
        return Hypothesis(assignment, log_belief, x, P, y_pred)

    def step(self, hypotheses: Sequence[Hypothesis], k: int) -> list[Hypothesis]:
        """Eqs. (4)–(5) at step k: the ``beam`` best filtered successors, normalised."""
        bases = [h.log_belief for h in hypotheses]
        lists = [self.transitions.successors(h.assignment) for h in hypotheses]
        proposals = _Proposals(bases, lists)
        memo: dict[tuple[object, ...], StepResult] = {}
        per_parent: dict[tuple[int, int], StepResult] = {}
        # min-heap of the beam best: (score, order, parent, assignment, cluster results)
        best: list[tuple[float, int, int, Assignment, list[tuple[ClusterFilter, StepResult]]]]
        best = []
        tried = 0
        while tried < self.candidates:
            if len(best) >= self.beam and proposals.peek() <= best[0][0]:
                break  # P_O ≤ 1: no later proposal can beat the beam
            item = proposals.pop()
            if item is None:
                break
            prior, j, assignment = item
            tried += 1
            self.proposed += 1
            log_po, results = self._evaluate(j, hypotheses[j], assignment, k, memo, per_parent)
            entry = (prior + log_po, tried, j, assignment, results)
            if len(best) < self.beam:
                heapq.heappush(best, entry)
            elif entry[0] > best[0][0]:
                heapq.heapreplace(best, entry)
        best.sort(key=lambda e: (-e[0], e[1]))
        kept = [self._assemble(hypotheses[j], a, r, score) for score, _, j, a, r in best]
        if not kept or not any(math.isfinite(h.log_belief) for h in kept):
            return _fallback(hypotheses)
        _normalise(kept)
        return kept


def _fallback(hypotheses: Sequence[Hypothesis]) -> list[Hypothesis]:
    """No successor explains the observation at all: keep the previous hypotheses."""
    return list(hypotheses)


def _normalise(hypotheses: list[Hypothesis]) -> None:
    """Eq. (5): beliefs normalised in log space (``-inf`` stays)."""
    finite = [h.log_belief for h in hypotheses if math.isfinite(h.log_belief)]
    if not finite:
        return
    top = max(finite)
    total = top + math.log(sum(math.exp(v - top) for v in finite))
    for h in hypotheses:
        h.log_belief -= total
