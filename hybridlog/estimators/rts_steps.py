"""The extended RTS step of the offline passes, compiled: its checks, causes and fallbacks.

:func:`rts_step` from a forward estimate and the smoothed one of the next sample (in two
parts, :func:`rts_predict` and :func:`rts_correct`, for expectation correction's pairs), the
check of its covariance (:func:`semidefinite_step`), the codes of why a step was refused and
the forward estimate stands (:data:`TAKEN` … :data:`COVARIANCE`), their count per sample
(:func:`note_fallbacks`), and :data:`NEGLIGIBLE_WEIGHT`, below which no step is taken.  Kim's
and expectation correction's generic loops take these steps, as ``kbest``'s path smoother
does (:mod:`hybridlog.estimators.mode_hypotheses`); the straight-line code writes them with
the same constants (:mod:`hybridlog.estimators.rts_source`).  The algorithms are
:mod:`hybridlog.estimators.smoothing`'s docstring.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from hybridlog.estimators.common import Fn
from hybridlog.estimators.kernels import (
    PSD_TOLERANCE,
    cholesky,
    congruence,
    gain,
    mat_mul,
    symmetrize,
)
from hybridlog.estimators.result import FALLBACK_CAUSES
from hybridlog.jit import jit, jit_kernel, jitable_kernel
from hybridlog.signals import FloatArray

NEGLIGIBLE_WEIGHT = 1e-16
"""Smallest smoothed probability ``μ^s_j(k+1)`` of a next mode whose RTS step is taken, and of
a pair ``p_ij(k)`` whose step expectation correction takes (below it the forward estimate
stands; smoothing's docstring bounds what that changes).  Below half the spacing of doubles
at 1 (``2^-53 ≈ 1.1e-16``): added to the probabilities it is weighed against, which sum to 1,
it changes no bit of the sum."""


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
        forward_stands(x, P, x_out, P_out, r_out)
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
        forward_stands(x, P, x_out, P_out, r_out)
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
            forward_stands(x, P, x_out, P_out, r_out)
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
    return forward_stands(x, P, x_out, P_out, r_out)


@jit_kernel
def forward_stands(
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
