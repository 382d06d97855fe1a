"""Compiled kernels of the IMM's offline passes: RTS steps, the backward loops, Viterbi.

The algorithms, their equations and sources are :mod:`hybridlog.estimators.smoothing`'s
docstring; this module holds their generic loops (any number of modes, numba-compiled on
first use), the RTS steps ``kbest``'s path smoother shares
(:mod:`hybridlog.estimators.mode_hypotheses`), and the constants with which
:mod:`hybridlog.estimators.smoother_source` writes the straight-line code of one model.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from hybridlog.estimators.common import (
    FilterBuffers,
    Fn,
    ModeStore,
)
from hybridlog.estimators.kernels import (
    PSD_TOLERANCE,
    argmax,
    cholesky,
    congruence,
    gain,
    gaussian_log_density,
    mat_mul,
    mixture_moments,
    mixture_moments_of,
    possible_sources,
    record,
    symmetrize,
)
from hybridlog.estimators.result import (
    FALLBACK_CAUSES,
)
from hybridlog.jit import jit, jit_kernel, jitable_kernel
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.signals import BoolArray, FloatArray, IntArray


@jit_kernel
def safe_log(value: float) -> float:
    """``log(value)``, ``-inf`` for ``value <= 0``."""
    return math.log(value) if value > 0.0 else -math.inf


@jit_kernel
def log_sum_exp(values: FloatArray) -> float:
    """``log Σ exp(values)``; ``-inf`` when every value is ``-inf``."""
    top = -math.inf
    for value in values:
        if value > top:
            top = value
    if top == -math.inf:
        return top
    total = 0.0
    for value in values:
        total += math.exp(value - top)
    return top + math.log(total)


@jit_kernel
def log_sum_exp_of(values: FloatArray, members: IntArray) -> float:
    """:func:`log_sum_exp` of ``values[members]`` (increasing), the others ``-inf``.

    The same sums in the same order, less terms ``exp(−∞) = 0``: the same result to the bit.
    """
    top = -math.inf
    for i in members:
        if values[i] > top:
            top = values[i]
    if top == -math.inf:
        return top
    total = 0.0
    for i in members:
        total += math.exp(values[i] - top)
    return top + math.log(total)


LINEAR_FLOOR = 1e-280
"""Smallest ``c̄_j = Σ_i Π_ij μ_i`` whose log the straight-line smoother takes directly (far
above the subnormal range, so every term keeps full precision); below it, the log-sum-exp."""

NEGLIGIBLE_WEIGHT = 1e-16
"""Smallest smoothed probability ``μ^s_j(k+1)`` of a next mode whose RTS step is taken, and of
a pair ``p_ij(k)`` whose step expectation correction takes (below it the forward estimate
stands; smoothing's docstring bounds what that changes).  Below half the spacing of doubles
at 1 (``2^-53 ≈ 1.1e-16``): added to the probabilities it is weighed against, which sum to 1,
it changes no bit of the sum."""

MAX_EC_UNROLLED_MODES = 4
"""Most modes whose expectation correction ``auto`` gives straight-line code: its code grows
with the pairs, ``n_q²``.  Measured 2026-12-05 (AMD EPYC, a cold cache), the loop written as
one function: the three-tank's (3 modes) compiled in 69 s (Kim's 11 s), a linear 4-mode
model's in 68 s, a 5-mode one's in more than two minutes, and an 8-mode one's overflowed
Python's recursion limit.  With the per-mode steps as functions of their own
(:func:`_step_function`, :func:`_pair_functions`): 22 s, 23 s and 52 s.  The generic
loop, compiled once for every model, runs 7.5 times longer on the three-tank."""

GUARD_TOLERANCE = 1e-9
"""Relative slack of the guard ``P^s_j(k+1) <= P^-_j`` (times ``trace P^-_j``)."""

ROUNDING_UNIT = 2.0**-52
"""The rounding of one float64 operation, relative to its result: what the rounding probe of
:func:`rts_step` adds for each state it rounds."""

ROUNDING_LIMIT = 0.01
"""Largest rounding probe of an RTS step, relative to the step's own standard deviation of
each state, whose step is taken (:func:`rts_step`)."""

ROUNDING_LIMIT_SQUARED = ROUNDING_LIMIT * ROUNDING_LIMIT
"""The test of :data:`ROUNDING_LIMIT` on squares: ``r² <= limit² P`` (no square root)."""

LOG_NEGLIGIBLE_WEIGHT = math.log(NEGLIGIBLE_WEIGHT)
"""``log`` :data:`NEGLIGIBLE_WEIGHT`: expectation correction counts the fallback of a pair step
whose ``log p_ij(k)`` is at least this (a pair that carries weight in the output)."""

TAKEN = 0
"""An RTS step taken (:func:`rts_cause`); the other codes say why the forward estimate stood."""
PREDICTION = 1
"""``P^-`` not positive definite."""
GUARD = 2
"""The guard ``P^s(k+1) <= P^-`` refused the step."""
ROUNDING = 3
"""The rounding probe passed :data:`ROUNDING_LIMIT`."""
COVARIANCE = 4
"""The step's covariance is not PSD to rounding (:func:`semidefinite_step`)."""
FALLBACK_WEIGHT = 1 + len(FALLBACK_CAUSES)
"""Index in a backward pass's ``fallbacks`` array of the summed weight of the refused steps."""
FALLBACKS_WIDTH = FALLBACK_WEIGHT + 1
"""Length of a backward pass's ``fallbacks`` array (float64): the samples where a weighted step
fell back to the forward estimate, then per cause (:data:`FALLBACK_CAUSES`, code − 1) the
samples where one did for that cause, then (:data:`FALLBACK_WEIGHT`) the sum over the samples
of the weight those steps carry in the output (:func:`note_fallbacks`)."""


@jit_kernel
def unpack_state(record: FloatArray, x: FloatArray, P: FloatArray) -> None:
    """Read one packed :class:`~hybridlog.estimators.common.ModeStore` record into ``x``, ``P``."""
    n = x.shape[0]
    index = n
    for a in range(n):
        x[a] = record[a]
        for b in range(a, n):
            P[a, b] = record[index]
            P[b, a] = record[index]
            index += 1


class RtsWork(NamedTuple):
    """Scratch arrays of :func:`rts_step` for ``n`` states (:func:`rts_work`)."""

    x_pred: FloatArray
    F: FloatArray
    FP: FloatArray
    P_pred: FloatArray
    L: FloatArray
    column: FloatArray
    solved: FloatArray
    J: FloatArray
    IJF: FloatArray
    work: FloatArray
    part: FloatArray
    congruent: FloatArray


@jit
def rts_work(n: int) -> RtsWork:
    """The scratch arrays of :func:`rts_step`."""
    return RtsWork(
        np.empty(n),
        np.empty((n, n)),
        np.empty((n, n)),
        np.empty((n, n)),
        np.zeros((n, n)),
        np.empty(n),
        np.empty(n),
        np.empty((n, n)),
        np.empty((n, n)),
        np.empty((n, n)),
        np.empty((n, n)),
        np.empty((n, n)),
    )


@jitable_kernel
def rts_step(
    f: Fn,
    F: Fn,
    mode: int,
    x: FloatArray,
    P: FloatArray,
    u: FloatArray,
    Q: FloatArray,
    x_next: FloatArray,
    P_next: FloatArray,
    x_out: FloatArray,
    P_out: FloatArray,
    w: RtsWork,
    r_next: FloatArray,
    r_out: FloatArray,
) -> bool:
    r"""One extended RTS step from ``x̂, P`` at ``k`` and the smoothed ``x̂^s, P^s`` at ``k+1``.

    .. math::

        \hat x^- = f(\hat x),\quad P^- = F P F^T + Q,\quad J = P F^T (P^-)^{-1}

        \hat x^s = \hat x + J(\hat x^s(k+1) - \hat x^-),\quad
        P^s = (I - JF) P (I - JF)^T + J (Q + P^s(k+1)) J^T

    (Rauch, Tung, Striebel 1965; the covariance as a sum of congruences of PSD matrices, equal
    to ``P − J (P^- − P^s(k+1)) Jᵀ``), ``f, F`` of ``mode`` linearised at ``x̂``.  Returns
    False, with ``x_out, P_out`` set to ``x, P`` (the forward estimate stands) and ``r_out``
    to 0, where ``P^-`` is not positive definite, or where ``P^s(k+1)`` is wider than ``P^-``
    (by more than :data:`GUARD_TOLERANCE` of its trace): the exact smoother never has that,
    and a collapsed mixture that does would widen the estimate backwards (through ``F⁻¹`` when
    ``Q`` is small; smoothing's docstring); or where the rounding probe is past
    :data:`ROUNDING_LIMIT` of the step's standard deviation of a state.  (The IMM smoothers
    also refuse a ``P^s`` that is not PSD, :func:`semidefinite_step`; the k-best path's
    smoother keeps its covariances PSD in its own way.)

    The rounding probe ``r`` follows the rounding of the backward pass through the gains:
    ``r(k) = J (r(k+1) + u (|x̂^s(k+1)| + |x̂^-|)) + u |x̂^s(k)|`` per state (``u`` =
    :data:`ROUNDING_UNIT`; ``r_next`` is ``r(k+1)``, 0 where the step after was not taken).
    With little process noise ``J ≈ F⁻¹``, which grows by ``1/|λ|`` per step for a stable
    mode's eigenvalue ``λ``: the rounding of every step is amplified backwards without end
    (a stable plant without process noise: 177 at sample 0 of 600, 1e139 after 5,000 steps,
    from the last digits of the forward pass), while the covariances stay as small as the
    data make them.  Past the limit the sample takes the forward estimate, and the pass goes
    on from there with ``r = 0``.  ``x_out`` and ``P_out`` must not be ``x`` and ``P``.
    """
    return (
        rts_cause(f, F, mode, x, P, u, Q, x_next, P_next, x_out, P_out, w, r_next, r_out) == TAKEN
    )


@jitable_kernel
def rts_cause(
    f: Fn,
    F: Fn,
    mode: int,
    x: FloatArray,
    P: FloatArray,
    u: FloatArray,
    Q: FloatArray,
    x_next: FloatArray,
    P_next: FloatArray,
    x_out: FloatArray,
    P_out: FloatArray,
    w: RtsWork,
    r_next: FloatArray,
    r_out: FloatArray,
) -> int:
    """:func:`rts_step`, returning :data:`TAKEN` or why the forward estimate stood.

    :data:`PREDICTION`, :data:`GUARD` or :data:`ROUNDING`, the first check that refused it.
    """
    if not rts_predict(f, F, mode, x, P, u, Q, w):
        _forward_stands(x, P, x_out, P_out, r_out)
        return PREDICTION
    return rts_correct(x, P, Q, x_next, P_next, x_out, P_out, w, r_next, r_out)


@jitable_kernel
def rts_predict(
    f: Fn, F: Fn, mode: int, x: FloatArray, P: FloatArray, u: FloatArray, Q: FloatArray, w: RtsWork
) -> bool:
    """The prediction of :func:`rts_step` into ``w``; False where ``P^-`` is not positive definite.

    ``w.x_pred = f(x̂)``, ``w.F``, ``w.P_pred = F P Fᵀ + Q`` and its lower Cholesky factor ``w.L``.
    """
    n = x.shape[0]
    x_pred, F_x, FP, P_pred, L = w.x_pred, w.F, w.FP, w.P_pred, w.L
    f(mode, x, u, x_pred)
    F(mode, x, u, F_x)
    congruence(F_x, P, FP, P_pred)  # FP = F P
    for a in range(n):
        for b in range(n):
            P_pred[a, b] += Q[a, b]
    return cholesky(P_pred, L)


@jitable_kernel
def rts_correct(
    x: FloatArray,
    P: FloatArray,
    Q: FloatArray,
    x_next: FloatArray,
    P_next: FloatArray,
    x_out: FloatArray,
    P_out: FloatArray,
    w: RtsWork,
    r_next: FloatArray,
    r_out: FloatArray,
) -> int:
    """The rest of :func:`rts_step` once :func:`rts_predict` succeeded (``w`` holds it).

    The guard, the gain, the smoothed mean, its rounding probe and its covariance.  Returns
    :data:`TAKEN`, else :data:`GUARD` or :data:`ROUNDING` (the forward estimate stands).
    """
    n = x.shape[0]
    x_pred, F_x, FP, P_pred, L, column, solved, J, IJF, work, part, congruent = w
    scale = 0.0
    for a in range(n):
        scale += P_pred[a, a]
    for a in range(n):
        for b in range(n):
            work[a, b] = P_pred[a, b] - P_next[a, b]
        work[a, a] += GUARD_TOLERANCE * scale
    if not cholesky(work, IJF):
        _forward_stands(x, P, x_out, P_out, r_out)
        return GUARD
    gain(P, F_x, L, FP, column, solved, J)  # J = P Fᵀ (P^-)⁻¹: a Kalman gain with H = F
    for a in range(n):
        acc = x[a]
        for b in range(n):
            acc += J[a, b] * (x_next[b] - x_pred[b])
        x_out[a] = acc
    for b in range(n):
        column[b] = r_next[b] + ROUNDING_UNIT * (abs(x_next[b]) + abs(x_pred[b]))
    for a in range(n):
        acc = ROUNDING_UNIT * abs(x_out[a])
        for b in range(n):
            acc += J[a, b] * column[b]
        r_out[a] = acc
    mat_mul(J, F_x, IJF)
    for a in range(n):
        for b in range(n):
            IJF[a, b] = (1.0 if a == b else 0.0) - IJF[a, b]
            part[a, b] = Q[a, b] + P_next[a, b]
    congruence(IJF, P, work, P_out)
    congruence(J, part, work, congruent)
    for a in range(n):
        for b in range(n):
            P_out[a, b] += congruent[a, b]
    symmetrize(P_out)
    for a in range(n):
        # |r| <= ROUNDING_LIMIT sqrt(P), squared: no square root (NaN fails either form)
        if not r_out[a] * r_out[a] <= ROUNDING_LIMIT_SQUARED * max(P_out[a, a], 0.0):
            _forward_stands(x, P, x_out, P_out, r_out)
            return ROUNDING
    return TAKEN


@jitable_kernel
def semidefinite_step(
    x: FloatArray,
    P: FloatArray,
    x_out: FloatArray,
    P_out: FloatArray,
    r_out: FloatArray,
    w: RtsWork,
) -> bool:
    """Whether the step's ``P_out`` is PSD to rounding; if not, the forward ``x, P`` stand.

    Tests ``P_out + PSD_TOLERANCE·max_a P_aa·I`` for a Cholesky factor (the workspaces of
    ``w``).  Without process noise ``J = F⁻¹`` amplifies the rounding of the smallest
    eigenvalue of ``P^s(k+1)`` by ``1/λ²`` per step, as the rounding probe's of the means
    (:func:`rts_step`); the exact ``P^s`` is PSD.  Returns False with ``x_out, P_out = x, P``
    and ``r_out = 0`` where it is not.
    """
    n = x.shape[0]
    shifted, factor = w.work, w.IJF
    largest = 0.0
    for a in range(n):
        largest = max(largest, abs(P_out[a, a]))
    for a in range(n):
        for b in range(n):
            shifted[a, b] = P_out[a, b]
        shifted[a, a] += PSD_TOLERANCE * largest
    if cholesky(shifted, factor):
        return True
    return _forward_stands(x, P, x_out, P_out, r_out)


@jit_kernel
def _forward_stands(
    x: FloatArray, P: FloatArray, x_out: FloatArray, P_out: FloatArray, r_out: FloatArray
) -> bool:
    """:func:`rts_step` not taken: ``x_out, P_out = x, P``, no rounding carried; False."""
    for a in range(x.shape[0]):
        x_out[a] = x[a]
        r_out[a] = 0.0
        for b in range(x.shape[0]):
            P_out[a, b] = P[a, b]
    return False


@jit_kernel
def note_fallbacks(fell: int, weight: float, fallbacks: FloatArray) -> None:
    """Count a sample whose steps fell back for the causes of bit mask ``fell`` (0: none).

    Bit ``c − 1`` of ``fell`` is set where a weighted step of the sample was refused for cause
    ``c`` (:data:`PREDICTION` … :data:`COVARIANCE`); ``fallbacks[0]`` counts the samples with
    any, ``fallbacks[c]`` those with cause ``c``; ``weight`` (the summed weight in the output
    of the sample's refused steps, at most 1) is added to ``fallbacks[FALLBACK_WEIGHT]``.
    """
    if fell == 0:
        return
    fallbacks[0] += 1
    for c in range(1, FALLBACK_WEIGHT):
        if fell & (1 << (c - 1)):
            fallbacks[c] += 1
    fallbacks[FALLBACK_WEIGHT] += min(weight, 1.0)


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
                _mixed_probe(mu_s, r_j, r_new[i])
                continue
            out_of = targets[target_start[i] : target_start[i + 1]]
            for j in out_of:
                weights[j] = math.exp(log_pair[i, j] - row_total[i])
            mixture_moments_of(weights, out_of, x_j, P_j, x_new[i], P_new[i])
            _mixed_probe_of(weights, out_of, r_j, r_new[i])
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
def _mixed_probe(weights: FloatArray, probes: FloatArray, out: FloatArray) -> None:
    """The rounding probe of a mixture's mean: ``Σ_j weights_j probes_j``."""
    for a in range(out.shape[0]):
        acc = 0.0
        for j in range(weights.shape[0]):
            acc += weights[j] * probes[j, a]
        out[a] = acc


@jit_kernel
def _mixed_probe_of(
    weights: FloatArray, members: IntArray, probes: FloatArray, out: FloatArray
) -> None:
    """:func:`_mixed_probe` over ``members`` (increasing) alone, as ``mixture_moments_of``."""
    for a in range(out.shape[0]):
        acc = 0.0
        for j in members:
            acc += weights[j] * probes[j, a]
        out[a] = acc


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
                    _forward_stands(x_f[i], P_f[i], x_pair[i, j], P_pair[i, j], r_pair[i, j])
                    continue
                x_out, P_out, r_out = x_pair[i, j], P_pair[i, j], r_pair[i, j]
                if (corrected[j] and not ready[i]) or not rts_predict(
                    f, F, j, x_f[i], P_f[i], u, Q[j], w
                ):
                    _forward_stands(x_f[i], P_f[i], x_out, P_out, r_out)
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
                _forward_stands(x_f[i], P_f[i], x_new[i], P_new[i], r_new[i])
                continue
            if total == -math.inf:
                # Nothing links the two samples: q(k+1)'s weights, every pair's (one Π_ij = 0
                # rules out: its forward estimate, as one that carries no weight).
                for j in range(n_q):
                    if transitions[i, j] == 0.0:
                        _forward_stands(x_f[i], P_f[i], x_pair[i, j], P_pair[i, j], r_pair[i, j])
                mixture_moments(mu_s, x_pair[i], P_pair[i], x_new[i], P_new[i])
                _mixed_probe(mu_s, r_pair[i], r_new[i])
                continue
            out_of = targets[target_start[i] : target_start[i + 1]]
            for j in out_of:
                weights[j] = math.exp(log_pair[i, j] - row_total[i])
            mixture_moments_of(weights, out_of, x_pair[i], P_pair[i], x_new[i], P_new[i])
            _mixed_probe_of(weights, out_of, r_pair[i], r_new[i])
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


def viterbi(
    log_transitions: FloatArray, log_prior: FloatArray, log_likelihoods: FloatArray
) -> IntArray:
    """Most likely mode path: argmax over paths of ``log μ_{q0}(0) + Σ (log Π + ℓ)``.

    ``log_likelihoods[k, j]`` is ``ℓ_j(k)`` (row 0 unused: the prior stands for it).  Ties go
    to the lowest mode index.  A sample where no mode has a finite likelihood counts every
    mode alike (its row is taken as 0).  Plain Python that numba compiles on first use.
    """
    n_samples, n_q = log_likelihoods.shape
    path = np.zeros(n_samples, dtype=np.int64)
    if n_samples == 0:
        return path
    back = np.zeros((n_samples, n_q), dtype=np.int64)
    delta = log_prior.copy()
    new = np.empty(n_q)
    for k in range(1, n_samples):
        finite = False
        for j in range(n_q):
            if log_likelihoods[k, j] > -math.inf:
                finite = True
        top = -math.inf
        for j in range(n_q):
            best = 0
            best_value = -math.inf
            for i in range(n_q):
                value = delta[i] + log_transitions[i, j]
                if value > best_value:
                    best_value = value
                    best = i
            back[k, j] = best
            new[j] = best_value + (log_likelihoods[k, j] if finite else 0.0)
            if new[j] > top:
                top = new[j]
        if top == -math.inf:  # no path reaches sample k: restart from its likelihoods
            for j in range(n_q):
                delta[j] = log_likelihoods[k, j] if finite else 0.0
        else:
            for j in range(n_q):
                delta[j] = new[j] - top
    path[n_samples - 1] = argmax(delta)
    for k in range(n_samples - 1, 0, -1):
        path[k - 1] = back[k, path[k]]
    return path


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
