"""Expectation correction's backward pass as a generic loop, and the facts of a model it weighs by.

:func:`ec_backward` (the algorithm is :mod:`hybridlog.estimators.smoothing`'s docstring);
the bound on a pair's log density by which it leaves a pair out unpredicted
(:func:`density_ceilings`), the modes whose weights take the density
(:func:`positive_definite_noise`) and the order the pairs are weighed in (:func:`ec_order`),
which :mod:`hybridlog.estimators.ec_source` also writes the straight-line code by.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from hybridlog.estimators.common import FilterBuffers, Fn, ModeStore
from hybridlog.estimators.kernels import (
    argmax,
    gaussian_log_density,
    mixture_moments,
    mixture_moments_of,
    possible_sources,
    record,
)
from hybridlog.estimators.kim_loop import mixed_probe, mixed_probe_of
from hybridlog.estimators.log_space import log_sum_exp, log_sum_exp_of, safe_log
from hybridlog.estimators.rts_steps import (
    COVARIANCE,
    NEGLIGIBLE_WEIGHT,
    PREDICTION,
    TAKEN,
    RtsWork,
    forward_stands,
    note_fallbacks,
    rts_correct,
    rts_predict,
    rts_work,
    semidefinite_step,
    unpack_state,
)
from hybridlog.jit import jit, jitable_kernel
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.signals import BoolArray, FloatArray, IntArray

LOG_NEGLIGIBLE_WEIGHT = math.log(NEGLIGIBLE_WEIGHT)
"""``log`` :data:`NEGLIGIBLE_WEIGHT`: expectation correction counts the fallback of a pair step
whose ``log p_ij(k)`` is at least this (a pair that carries weight in the output)."""


class EcScratch(NamedTuple):
    """The arrays expectation correction's backward loop works in (:func:`ec_backward`)."""

    log_transitions: FloatArray
    log_mu_next: FloatArray
    """``log μ^s(k+1)``."""
    log_mu: FloatArray
    terms: FloatArray
    corrected_terms: FloatArray
    density: FloatArray
    ready: BoolArray
    """Pair ``(i, j)`` predicted in stage 1 (of the next mode ``j`` at hand)."""
    log_pair: FloatArray
    """``log Pr(q(k)=i, q(k+1)=j | Y^N)``."""
    row_total: FloatArray
    log_new: FloatArray
    weights: FloatArray
    mu_s: FloatArray
    x_f: FloatArray
    """The filtered ``x̂_i(k|k)``, ``P_i(k|k)``."""
    P_f: FloatArray
    x_pair: FloatArray
    """The RTS step of pair ``(i, j)``, its covariance and rounding probe."""
    P_pair: FloatArray
    r_pair: FloatArray
    x_new: FloatArray
    P_new: FloatArray
    x_next: FloatArray
    """``x̂^s_j(k+1)``, ``P^s_j(k+1)``: the step before's ``x_new``, ``P_new``."""
    P_next: FloatArray
    r_next: FloatArray
    """The rounding probes (:func:`rts_step`) of ``x_next`` and ``x_new``."""
    r_new: FloatArray
    gap: FloatArray
    solved: FloatArray
    w: RtsWork
    x: FloatArray
    P: FloatArray
    pair_cause: IntArray
    """:data:`TAKEN`, or why the step of pair ``(i, j)`` was not."""
    source_start: IntArray
    """Next mode ``j``'s possible previous modes (``Π_ij ≠ 0``) are
    ``sources[source_start[j]:source_start[j + 1]]``, in increasing order."""
    sources: IntArray
    target_start: IntArray
    """Mode ``i``'s possible next modes are ``targets[target_start[i]:target_start[i + 1]]``."""
    targets: IntArray


def ec_backward(
    f: Fn,
    F: Fn,
    inputs: FloatArray,
    transitions: FloatArray,
    Q: FloatArray,
    corrected: BoolArray,
    ceilings: FloatArray,
    mu: FloatArray,
    store: ModeStore,
    out: FilterBuffers,
    fallbacks: FloatArray,
) -> None:
    """Rows ``0 … N−2`` of expectation correction's smoothed result (smoothing's docstring).

    ``store`` holds the filtered per-mode ``x̂_i(k|k)``, ``P_i(k|k)`` in every row (the IMM's
    ``filtered_store``), ``mu`` the filtered mode probabilities; ``corrected[j]`` whether the
    weights of next mode ``j`` take the density of the smoothed state (its process noise
    positive definite), else Kim's, and ``ceilings[j]`` the largest log density a pair into it
    can give (:func:`density_ceilings`), by which a pair is left out unpredicted where its
    weight cannot reach :data:`NEGLIGIBLE_WEIGHT` (smoothing's docstring, "pairs that carry
    no weight").  ``fallbacks`` (:data:`FALLBACKS_WIDTH` zeros) gets the
    samples where a pair step that carries weight (``p_ij(k)`` at least
    :data:`NEGLIGIBLE_WEIGHT`) left its forward estimate standing, by cause
    (:func:`note_fallbacks`).  Row ``N−1`` is the caller's (the filtered one).  Plain Python
    that numba compiles on first use; one machine code for every model (the mode functions
    are first-class functions).  Allocates the loop's :class:`EcScratch`, then runs
    :func:`_ec_rows`, which allocates nothing.
    """
    n_q = transitions.shape[0]
    n = Q.shape[1]
    # Only the pairs Π_ij ≠ 0 are weighed (a model's mode pairs: n_q^1.5 of n_q²); the others'
    # log p_ij(k) stay -∞, and their terms in the sums over i or j are exact zeros
    # (kernels.possible_sources).  Into j from sources[...], from i into targets[...].
    source_start, sources = possible_sources(transitions)
    target_start, targets = possible_sources(np.ascontiguousarray(transitions.T))
    scratch = EcScratch(
        np.empty((n_q, n_q)),
        np.empty(n_q),
        np.empty(n_q),
        np.empty(n_q),
        np.empty(n_q),
        np.empty(n_q),
        np.zeros(n_q, dtype=np.bool_),
        np.empty((n_q, n_q)),
        np.empty(n_q),
        np.empty(n_q),
        np.empty(n_q),
        np.empty(n_q),
        np.empty((n_q, n)),
        np.empty((n_q, n, n)),
        np.empty((n_q, n_q, n)),
        np.empty((n_q, n_q, n, n)),
        np.zeros((n_q, n_q, n)),
        np.empty((n_q, n)),
        np.empty((n_q, n, n)),
        np.empty((n_q, n)),
        np.empty((n_q, n, n)),
        np.zeros((n_q, n)),
        np.zeros((n_q, n)),
        np.empty(n),
        np.empty(n),
        rts_work(n),
        np.empty(n),
        np.empty((n, n)),
        np.zeros((n_q, n_q), dtype=np.int64),
        source_start,
        sources,
        target_start,
        targets,
    )
    _ec_rows(f, F, inputs, transitions, Q, corrected, ceilings, mu, store, out, fallbacks, scratch)


@jitable_kernel
def _ec_rows(
    f: Fn,
    F: Fn,
    inputs: FloatArray,
    transitions: FloatArray,
    Q: FloatArray,
    corrected: BoolArray,
    ceilings: FloatArray,
    mu: FloatArray,
    store: ModeStore,
    out: FilterBuffers,
    fallbacks: FloatArray,
    scratch: EcScratch,
) -> None:
    """The backward loop of :func:`ec_backward`, in its ``scratch``.

    Compiled without reference counts (:data:`~hybridlog.jit.WITHOUT_REFCOUNTS`), as
    :func:`_kim_rows`: it slices views freely, and every array copy is a loop.
    """
    n_samples, n_q, _ = store.states.shape
    n = Q.shape[1]
    s = scratch
    log_T, log_mu_next, log_mu, terms = s.log_transitions, s.log_mu_next, s.log_mu, s.terms
    corrected_terms, density, ready, log_pair = s.corrected_terms, s.density, s.ready, s.log_pair
    row_total, log_new, weights, mu_s = s.row_total, s.log_new, s.weights, s.mu_s
    x_f, P_f, x_pair, P_pair, r_pair = s.x_f, s.P_f, s.x_pair, s.P_pair, s.r_pair
    x_new, P_new, x_next, P_next = s.x_new, s.P_new, s.x_next, s.P_next
    r_next, r_new, gap, solved, w, x, P = s.r_next, s.r_new, s.gap, s.solved, s.w, s.x, s.P
    pair_cause, source_start, sources = s.pair_cause, s.source_start, s.sources
    target_start, targets = s.target_start, s.targets
    for i in range(n_q):
        for j in range(n_q):
            log_T[i, j] = safe_log(transitions[i, j])
            log_pair[i, j] = -math.inf
    for j in range(n_q):
        log_mu_next[j] = safe_log(mu[n_samples - 1, j])
    if n_samples > 0:
        for j in range(n_q):
            unpack_state(store.states[n_samples - 1, j], x_next[j], P_next[j])
    for k in range(n_samples - 2, -1, -1):
        u = inputs[k]
        for i in range(n_q):
            unpack_state(store.states[k, i], x_f[i], P_f[i])
            log_mu[i] = safe_log(mu[k, i])
        for j in range(n_q):
            # Stage 1: the densities of x̂^s_j(k+1) under the pairs into next mode j (mode i's
            # filtered estimate through mode j's dynamics), the pair of q(k) = j first; a pair
            # whose weight cannot reach NEGLIGIBLE_WEIGHT however likely x̂^s_j(k+1) is under
            # it (its prior plus the density's ceiling below the largest prior plus density
            # found so far) is not predicted (_ec_weights).
            negligible = math.exp(log_mu_next[j]) < NEGLIGIBLE_WEIGHT
            weighed = corrected[j] and not negligible
            floor = -math.inf  # the largest log μ_i(k) + log Π_ij + density found so far
            into = sources[source_start[j] : source_start[j + 1]]
            for step in range(into.shape[0] + 1):  # j first, as ec_order; then the others
                if step == 0:
                    if transitions[j, j] == 0.0:
                        continue
                    i = j
                else:
                    i = into[step - 1]
                    if i == j:
                        continue
                density[i] = -math.inf if weighed else 0.0
                ready[i] = False
                terms[i] = log_T[i, j] + log_mu[i]
                if not terms[i] > -math.inf:  # NaN too
                    terms[i] = -math.inf
                if not weighed or terms[i] == -math.inf:
                    continue
                if terms[i] + ceilings[j] < floor + LOG_NEGLIGIBLE_WEIGHT - log_mu_next[j]:
                    continue  # provably negligible: its weight stays below NEGLIGIBLE_WEIGHT
                if not rts_predict(f, F, j, x_f[i], P_f[i], u, Q[j], w):
                    weighed = False  # no density for this pair: Kim's weights for mode j
                    continue
                ready[i] = True
                for a in range(n):
                    gap[a] = x_next[j, a] - w.x_pred[a]
                density[i] = gaussian_log_density(gap, w.L, solved)
                if not density[i] > -math.inf:
                    density[i] = -math.inf
                floor = max(floor, terms[i] + density[i])
            # Stage 2: the weights log p_ij(k), corrected unless no pair gave a density
            if weighed:
                for i in into:
                    corrected_terms[i] = terms[i] + density[i]
                log_norm = log_sum_exp_of(corrected_terms, into)
                weighed = log_norm > -math.inf
            if not weighed:  # Kim's: Pr(q(k)=i | q(k+1)=j, Y^k), as kim_backward
                for i in into:
                    corrected_terms[i] = terms[i]
                log_norm = log_sum_exp_of(terms, into)
            for i in into:
                if (
                    log_norm == -math.inf
                    or log_mu_next[j] == -math.inf
                    or corrected_terms[i] == -math.inf
                ):
                    log_pair[i, j] = -math.inf
                elif weighed:
                    log_pair[i, j] = log_mu_next[j] + corrected_terms[i] - log_norm
                else:  # kim_backward's sum, in its order
                    log_pair[i, j] = log_mu_next[j] + log_mu[i] + log_T[i, j] - log_norm
            # Stage 3: the RTS step of each pair that carries weight (p_ij(k) at least
            # NEGLIGIBLE_WEIGHT, in a next mode that is not negligible); elsewhere the forward
            # estimate stands.  With the density (corrected[j]) only a pair stage 1 predicted
            # is stepped: a pair it left out that Kim's weights make count (a prediction of
            # mode j failed) stands for want of a prediction.
            for i in into:
                r_pair[i, j] = 0.0
                pair_cause[i, j] = TAKEN
                if negligible or log_pair[i, j] < LOG_NEGLIGIBLE_WEIGHT:
                    forward_stands(x_f[i], P_f[i], x_pair[i, j], P_pair[i, j], r_pair[i, j])
                    continue
                x_out, P_out, r_out = x_pair[i, j], P_pair[i, j], r_pair[i, j]
                if (corrected[j] and not ready[i]) or not rts_predict(
                    f, F, j, x_f[i], P_f[i], u, Q[j], w
                ):
                    forward_stands(x_f[i], P_f[i], x_out, P_out, r_out)
                    pair_cause[i, j] = PREDICTION
                    continue
                cause = rts_correct(
                    x_f[i], P_f[i], Q[j], x_next[j], P_next[j], x_out, P_out, w, r_next[j], r_out
                )
                if cause == TAKEN and not semidefinite_step(x_f[i], P_f[i], x_out, P_out, r_out, w):
                    cause = COVARIANCE
                pair_cause[i, j] = cause
        fell = 0  # the causes of this sample's fallbacks among pairs that carry weight
        fell_weight = 0.0  # and the weight of those pairs: Σ p_ij(k)
        for i in range(n_q):
            out_of = targets[target_start[i] : target_start[i + 1]]
            row_total[i] = log_sum_exp_of(log_pair[i], out_of)
            for j in out_of:
                if pair_cause[i, j] != TAKEN and log_pair[i, j] >= LOG_NEGLIGIBLE_WEIGHT:
                    fell |= 1 << (pair_cause[i, j] - 1)
                    fell_weight += math.exp(log_pair[i, j])
        note_fallbacks(fell, fell_weight, fallbacks)
        total = log_sum_exp(row_total)
        if total == -math.inf:  # nothing links the two samples: the filtered probabilities
            for i in range(n_q):
                log_new[i] = log_mu[i]
        else:
            for i in range(n_q):
                log_new[i] = row_total[i] - total
        for j in range(n_q):
            mu_s[j] = math.exp(log_mu_next[j])
        for i in range(n_q):
            if log_new[i] == -math.inf and total > -math.inf:
                # No weight on q(k) = i: any finite estimate does, as it is weighed by 0 here
                # and a next mode of no weight is neither weighed nor stepped into at k - 1;
                # every pair from i carries none, so it is the forward estimate x̂_i(k|k)
                # (mixed over its pairs, each x̂_i(k|k), it cost n_q² a sample on many pairs).
                forward_stands(x_f[i], P_f[i], x_new[i], P_new[i], r_new[i])
                continue
            if total == -math.inf:
                # Nothing links the two samples: q(k+1)'s weights, every pair's (one Π_ij = 0
                # rules out: its forward estimate, as one that carries no weight).
                for j in range(n_q):
                    if transitions[i, j] == 0.0:
                        forward_stands(x_f[i], P_f[i], x_pair[i, j], P_pair[i, j], r_pair[i, j])
                mixture_moments(mu_s, x_pair[i], P_pair[i], x_new[i], P_new[i])
                mixed_probe(mu_s, r_pair[i], r_new[i])
                continue
            out_of = targets[target_start[i] : target_start[i + 1]]
            for j in out_of:
                weights[j] = math.exp(log_pair[i, j] - row_total[i])
            mixture_moments_of(weights, out_of, x_pair[i], P_pair[i], x_new[i], P_new[i])
            mixed_probe_of(weights, out_of, r_pair[i], r_new[i])
        for i in range(n_q):
            mu_s[i] = math.exp(log_new[i])
            log_mu_next[i] = log_new[i]
            for a in range(n):
                x_next[i, a] = x_new[i, a]
                r_next[i, a] = r_new[i, a]
                for b in range(n):
                    P_next[i, a, b] = P_new[i, a, b]
        mixture_moments(mu_s, x_new, P_new, x, P)
        record(out, k, argmax(mu_s), mu_s, x, P)


CEILING_MARGIN = 1.0
"""Nats added to each density ceiling (:func:`density_ceilings`): ``P^-_ij ⪰ Q_j`` holds in
exact arithmetic, and the rounding of ``F P Fᵀ + Q`` and of its factor is some 1e-15 of it."""


def density_ceiling(Q: FloatArray) -> float:
    r"""A bound on the log density a pair ``(i, j)`` with process noise ``Q = Q_j`` can give.

    ``P^-_{ij} = F P_i Fᵀ + Q ⪰ Q``, so ``det P^-_{ij} >= det Q`` and
    ``log N(x; m, P^-_{ij}) <= −(n log 2π + log det Q)/2`` for every ``x``, ``F`` and PSD
    ``P_i``; plus :data:`CEILING_MARGIN`.  ``+inf`` where ``Q`` is not positive definite (no
    bound; :func:`positive_definite_noise`: those modes take Kim's weights).
    """
    try:
        factor = np.linalg.cholesky(Q)
    except np.linalg.LinAlgError:
        return math.inf
    log_det = 2.0 * float(np.sum(np.log(np.diag(factor))))
    return float(-0.5 * (Q.shape[0] * math.log(2.0 * math.pi) + log_det) + CEILING_MARGIN)


def density_ceilings(model: HybridModel) -> FloatArray:
    """:func:`density_ceiling` of each mode's process noise."""
    return np.array([density_ceiling(mode.process_noise) for mode in model.modes])


@jit
def ec_order(j: int, step: int) -> int:
    """The ``step``-th previous mode ``i`` whose pair into next mode ``j`` is weighed.

    ``j`` first (the stay, often the largest prior: the sooner the largest is found, the more
    pairs its weight leaves out), then the others in order.
    """
    if step == 0:
        return j
    return step - 1 if step - 1 < j else step


def positive_definite_noise(model: HybridModel) -> BoolArray:
    """Per mode, whether its process noise ``Q_j`` is positive definite (its Cholesky exists).

    Expectation correction weighs next mode ``j`` by the density of the smoothed state only
    where it is: without process noise the density of ``x̂^s_j(k+1)`` under ``F P_i Fᵀ`` is
    nearly singular and decides by rounding (smoothing's docstring).
    """
    definite = np.zeros(model.n_modes, dtype=np.bool_)
    for j, mode in enumerate(model.modes):
        try:
            np.linalg.cholesky(mode.process_noise)
        except np.linalg.LinAlgError:
            continue
        definite[j] = True
    return definite
