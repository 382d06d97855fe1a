"""Kim's backward pass as a generic loop: any number of modes, compiled by numba on first use.

:func:`kim_backward` (the recursion is :mod:`hybridlog.estimators.smoothing`'s docstring),
and the rounding probe of a mixture's mean (:func:`mixed_probe`), which expectation
correction's loop shares.  The straight-line code of one model is
:mod:`hybridlog.estimators.kim_source`'s.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from hybridlog.estimators.common import FilterBuffers, Fn, ModeStore
from hybridlog.estimators.kernels import (
    argmax,
    mixture_moments,
    mixture_moments_of,
    possible_sources,
    record,
)
from hybridlog.estimators.log_space import log_sum_exp, log_sum_exp_of, safe_log
from hybridlog.estimators.rts_steps import (
    COVARIANCE,
    NEGLIGIBLE_WEIGHT,
    TAKEN,
    RtsWork,
    note_fallbacks,
    rts_cause,
    rts_work,
    semidefinite_step,
    unpack_state,
)
from hybridlog.jit import jit_kernel, jitable_kernel
from hybridlog.signals import FloatArray, IntArray


class KimScratch(NamedTuple):
    """The arrays Kim's backward loop works in (:func:`kim_backward` allocates them)."""

    log_transitions: FloatArray
    log_mu_next: FloatArray
    """``log μ^s(k+1)``."""
    log_mu: FloatArray
    log_c: FloatArray
    terms: FloatArray
    log_pair: FloatArray
    row_total: FloatArray
    log_new: FloatArray
    weights: FloatArray
    mu_s: FloatArray
    x_j: FloatArray
    """``E[x(k) | q(k+1)=j, Y^N]`` and its covariance ``P_j``."""
    P_j: FloatArray
    x_new: FloatArray
    P_new: FloatArray
    x: FloatArray
    P: FloatArray
    x_prior: FloatArray
    """The mixed priors ``x̂⁰_j(k)``, ``P⁰_j(k)``."""
    P_prior: FloatArray
    x_next: FloatArray
    """``x̂^s_j(k+1)``, ``P^s_j(k+1)``: the step before's ``x_new``, ``P_new``."""
    P_next: FloatArray
    r_next: FloatArray
    """The rounding probes (:func:`rts_step`) of ``x_next``, ``x_j`` and ``x_new``."""
    r_j: FloatArray
    r_new: FloatArray
    w: RtsWork
    source_start: IntArray
    """Next mode ``j``'s possible previous modes (``Π_ij ≠ 0``) are
    ``sources[source_start[j]:source_start[j + 1]]``, in increasing order."""
    sources: IntArray
    target_start: IntArray
    """Mode ``i``'s possible next modes are ``targets[target_start[i]:target_start[i + 1]]``."""
    targets: IntArray


def kim_backward(
    f: Fn,
    F: Fn,
    inputs: FloatArray,
    transitions: FloatArray,
    Q: FloatArray,
    mu: FloatArray,
    store: ModeStore,
    out: FilterBuffers,
    fallbacks: FloatArray,
) -> None:
    """Rows ``0 … N−2`` of the smoothed result (smoothing's docstring), compiled on first use.

    ``mu`` are the filtered mode probabilities, ``store`` what the forward pass kept (read
    only: the smoothed per-mode estimates of the next sample are carried in arrays).  Row
    ``N−1`` is the caller's (the filtered one).  ``fallbacks`` (:data:`FALLBACKS_WIDTH`
    zeros) gets the samples where the step of a next mode that carries weight (at least
    :data:`NEGLIGIBLE_WEIGHT`) left its forward prior standing, by cause
    (:func:`note_fallbacks`).  Allocates the loop's :class:`KimScratch`, then runs
    :func:`_kim_rows`, which allocates nothing.
    """
    n_q = transitions.shape[0]
    n = Q.shape[1]
    source_start, sources = possible_sources(transitions)
    target_start, targets = possible_sources(np.ascontiguousarray(transitions.T))
    scratch = KimScratch(
        np.empty((n_q, n_q)),
        np.empty(n_q),
        np.empty(n_q),
        np.empty(n_q),
        np.empty(n_q),
        np.empty((n_q, n_q)),
        np.empty(n_q),
        np.empty(n_q),
        np.empty(n_q),
        np.empty(n_q),
        np.empty((n_q, n)),
        np.empty((n_q, n, n)),
        np.empty((n_q, n)),
        np.empty((n_q, n, n)),
        np.empty(n),
        np.empty((n, n)),
        np.empty((n_q, n)),
        np.empty((n_q, n, n)),
        np.empty((n_q, n)),
        np.empty((n_q, n, n)),
        np.zeros((n_q, n)),
        np.zeros((n_q, n)),
        np.zeros((n_q, n)),
        rts_work(n),
        source_start,
        sources,
        target_start,
        targets,
    )
    _kim_rows(f, F, inputs, transitions, Q, mu, store, out, fallbacks, scratch)


@jitable_kernel
def _kim_rows(
    f: Fn,
    F: Fn,
    inputs: FloatArray,
    transitions: FloatArray,
    Q: FloatArray,
    mu: FloatArray,
    store: ModeStore,
    out: FilterBuffers,
    fallbacks: FloatArray,
    scratch: KimScratch,
) -> None:
    """The backward loop of :func:`kim_backward`, in its ``scratch``.

    Compiled without reference counts (:data:`~hybridlog.jit.WITHOUT_REFCOUNTS`): it slices
    views freely, and every array copy is a loop.  The sums over previous and next modes run
    over the pairs ``Π_ij ≠ 0`` alone (:func:`~hybridlog.estimators.kernels.possible_sources`;
    a model's mode pairs: ``n_q^1.5`` of ``n_q²``): the others' ``log p_ij(k)`` are ``-inf``,
    their terms exact zeros, so the sums are the same to the bit.
    """
    n_samples, n_q, _ = store.states.shape
    n = Q.shape[1]
    log_T, log_mu_next, log_mu, log_c, terms, log_pair, row_total, log_new = scratch[:8]
    weights, mu_s, x_j, P_j, x_new, P_new, x, P, x_prior, P_prior = scratch[8:18]
    x_next, P_next, r_next, r_j, r_new, w = scratch[18:24]
    source_start, sources, target_start, targets = scratch[24:]
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
        for j in range(n_q):
            unpack_state(store.states[k, j], x_prior[j], P_prior[j])
        for i in range(n_q):
            log_mu[i] = safe_log(mu[k, i])
        for j in range(n_q):
            into = sources[source_start[j] : source_start[j + 1]]
            for i in into:
                terms[i] = log_T[i, j] + log_mu[i]
            log_c[j] = log_sum_exp_of(terms, into)
        for i in range(n_q):
            out_of = targets[target_start[i] : target_start[i + 1]]
            for j in out_of:
                if log_c[j] == -math.inf or log_mu_next[j] == -math.inf:
                    log_pair[i, j] = -math.inf
                else:
                    log_pair[i, j] = log_mu_next[j] + log_mu[i] + log_T[i, j] - log_c[j]
            row_total[i] = log_sum_exp_of(log_pair[i], out_of)
        total = log_sum_exp(row_total)
        # RTS step of each next mode j from its mixed prior.
        fell = 0  # the causes of this sample's fallbacks, a bit each
        fell_weight = 0.0  # and the weight of the refused steps: Σ μ^s_j(k+1)
        for j in range(n_q):
            for a in range(n):
                x_j[j, a] = x_prior[j, a]
                r_j[j, a] = 0.0
                for b in range(n):
                    P_j[j, a, b] = P_prior[j, a, b]
            if math.exp(log_mu_next[j]) < NEGLIGIBLE_WEIGHT:
                continue  # q(k+1) = j carries no weight that counts: the prior stands
            cause = rts_cause(f, F, j, x_prior[j], P_prior[j], u, Q[j], x_next[j], P_next[j],
                              x_j[j], P_j[j], w, r_next[j], r_j[j])  # fmt: skip
            if cause == TAKEN and not semidefinite_step(
                x_prior[j], P_prior[j], x_j[j], P_j[j], r_j[j], w
            ):
                cause = COVARIANCE
            if cause != TAKEN:
                fell |= 1 << (cause - 1)
                fell_weight += math.exp(log_mu_next[j])
        note_fallbacks(fell, fell_weight, fallbacks)
        if total == -math.inf:  # nothing links the two samples: the filtered probabilities
            for i in range(n_q):
                log_new[i] = log_mu[i]
        else:
            for i in range(n_q):
                log_new[i] = row_total[i] - total
        for i in range(n_q):
            mu_s[i] = math.exp(log_mu_next[i])
        for i in range(n_q):
            if log_new[i] == -math.inf or total == -math.inf:
                # No weight on q(k) = i: any finite estimate does; the combined one.
                mixture_moments(mu_s, x_j, P_j, x_new[i], P_new[i])
                mixed_probe(mu_s, r_j, r_new[i])
                continue
            out_of = targets[target_start[i] : target_start[i + 1]]
            for j in out_of:
                weights[j] = math.exp(log_pair[i, j] - row_total[i])
            mixture_moments_of(weights, out_of, x_j, P_j, x_new[i], P_new[i])
            mixed_probe_of(weights, out_of, r_j, r_new[i])
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


@jit_kernel
def mixed_probe(weights: FloatArray, probes: FloatArray, out: FloatArray) -> None:
    """The rounding probe of a mixture's mean: ``Σ_j weights_j probes_j``."""
    for a in range(out.shape[0]):
        acc = 0.0
        for j in range(weights.shape[0]):
            acc += weights[j] * probes[j, a]
        out[a] = acc


@jit_kernel
def mixed_probe_of(
    weights: FloatArray, members: IntArray, probes: FloatArray, out: FloatArray
) -> None:
    """:func:`mixed_probe` over ``members`` (increasing) alone, as ``mixture_moments_of``."""
    for a in range(out.shape[0]):
        acc = 0.0
        for j in members:
            acc += weights[j] * probes[j, a]
        out[a] = acc
