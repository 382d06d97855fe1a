r"""Offline passes after a filter: the fixed-interval IMM smoother and the Viterbi path (issue 12).

**Smoother: Kim's backward mode recursion with a per-mode extended RTS step on the IMM's mixed
prior.**  Mode probabilities: Kim C.-J., "Dynamic linear models with Markov-switching",
*Journal of Econometrics* 60 (1994) 1-22, eqs. (2.20)-(2.21) (Kim and Nelson, *State-Space
Models with Regime Switching*, 1999, §5.2.2).  States: an RTS step (Rauch, Tung, Striebel
1965) per *next* mode ``j``, from the forward IMM's own mixed prior of mode ``j``, close in
structure to Lopez and Danès' low-complexity IMM smoother (IEEE TAES 2017; their equations
were not checked line by line): what is implemented is written out below.  The forward pass keeps
(:class:`~hybridlog.estimators.common.ModeStore`) the mixed priors ``x̂⁰_j(k)``, ``P⁰_j(k)``
(the estimate of ``x(k)`` given ``q(k+1) = j``, Blom and Bar-Shalom's mixing), the per-mode
estimates of the last sample and the filtered ``μ(k)``.  For ``k = N−2 … 0``:

.. math::

    \log \bar c_j(k+1) = \operatorname{logsumexp}_i(\log\Pi_{ij} + \log\mu_i(k))

    \log p_{ij}(k) = \log\mu^s_j(k+1) + \log\mu_i(k) + \log\Pi_{ij} - \log\bar c_j(k+1)
        \qquad \text{(Kim eq. (2.20))}

    \log\mu^s_i(k) = \operatorname{logsumexp}_j \log p_{ij}(k),\qquad
    w_{j|i} = p_{ij}/\mu^s_i \qquad \text{(eq. (2.21))}

    \hat x^-_j = f_j(\hat x^0_j, u_k),\; F_j = \partial f_j/\partial x|_{\hat x^0_j},\;
    P^-_j = F_j P^0_j F_j^T + Q_j \qquad \text{(the IMM's own prediction of mode } j)

    J_j = P^0_j F_j^T (P^-_j)^{-1},\quad
    \hat x^{(j)} = \hat x^0_j + J_j(\hat x^s_j(k+1) - \hat x^-_j)

    P^{(j)} = (I - J_j F_j) P^0_j (I - J_j F_j)^T + J_j (Q_j + P^s_j(k+1)) J_j^T

    \hat x^s_i(k) = \textstyle\sum_j w_{j|i}\hat x^{(j)},\quad
    P^s_i(k) = \sum_j w_{j|i}(P^{(j)} + (\hat x^{(j)}-\hat x^s_i)(\cdot)^T)

The output is ``Σ_i μ^s_i x̂^s_i = Σ_j Pr(q(k+1)=j|Y^N) E[x(k) | q(k+1)=j, Y^N]`` with its
covariance.  The approximations: Gaussian per mode (as the IMM), and
``E[x(k) | q(k)=i, q(k+1)=j, Y^N] ≈ E[x(k) | q(k+1)=j, Y^N]`` for the per-mode estimates.
Kim's own state step (one RTS step per pair ``(i, j)`` from ``x̂_i(k|k)``) takes ``n_q²``
RTS steps per sample; this one ``n_q``.  Nonlinear modes are linearised where the forward
IMM linearised them (at ``x̂⁰_j``).  The covariance above equals ``P⁰ + J(P^s − P^-)Jᵀ``
for this ``J`` and is a sum of congruences of PSD matrices, so it stays PSD up to rounding;
every covariance is symmetrised.  Mode probabilities are combined in log space and
renormalised at every step (the straight-line code for small models does the same
arithmetic in linear space on the samples where every probability involved is at least
1e-280, where the log space adds no range and the two agree to rounding; see
``_mode_recursion_source``).  At the last sample the smoothed estimate is the filtered one.
A mode whose ``P^-_j`` is not positive definite gets ``J_j = 0``.

Guard: the exact RTS step has ``P^s_j(k+1) ≤ P^-_j`` (the smoothed estimate is no wider than
the prediction).  The collapsed mixture ``P^s_j(k+1)`` holds the spread between the next
modes' hypotheses and can break it; with little process noise ``J_j ≈ F_j⁻¹`` then widens the
estimate at every step backwards, without end (on the double cart, no process noise: states
of 1e29 after 600 steps, docs/smoothing.md).  Where ``P^-_j − P^s_j(k+1)`` is not positive
definite (slack ``1e-9 trace P^-_j``) the step of mode ``j`` is skipped: ``x̂^{(j)} = x̂⁰_j``,
the forward prior, and the backward pass goes on from there.  With one mode, or with the stay
probability at 1 and the true mode known, this is the RTS smoother of that mode (when the
guard holds, as it does for the exact RTS).

Rounding: without process noise ``J_j = F_j⁻¹``, which grows by ``1/|λ|`` per step
backwards for a stable mode, so the backward pass would amplify its own rounding without
end; each step carries a probe of it (:func:`rts_step`), and a step whose probe passes
:data:`ROUNDING_LIMIT` of its standard deviation of a state is skipped in the same way.
The smallest eigenvalue of a covariance grows the same way (by ``1/λ²`` through
``J P^s Jᵀ``): a step whose ``P^{(j)}`` is not positive semi-definite to
:data:`~hybridlog.estimators.kernels.PSD_TOLERANCE` of its largest variance is skipped too.

Negligible next modes: where ``μ^s_j(k+1) <`` :data:`NEGLIGIBLE_WEIGHT` (``1e-16``) the RTS
step of mode ``j`` is skipped in the same way (``x̂^{(j)} = x̂⁰_j``).  Its result enters the
output only with the weight ``Σ_i μ^s_i(k) w_{j|i} = Σ_i p_ij(k) = μ^s_j(k+1)``, so the
smoothed mean moves by at most ``1e-16 |J_j(x̂^s_j(k+1) − x̂^-_j)|``: a double's rounding
(``2^-53`` relative) unless that step moves the mode's estimate by far more than the
estimate's own size.  It is the mode the backward pass skips most (on the three-tank
benchmark log 45 % of the smoothed probabilities are below 1e-30; the skip took Kim's
backward pass from 0.30 to 0.22 s).  Measured 2026-12-05 on the 70 three-tank logs of
``docs/studies/smoothing.py`` (seeds 0..29 and 100..139), expectation correction with the
threshold at 1e-16 against 1e-30: smoothed probabilities within 2.0e-15, states within
1.2e-15 relative, no mode label changed; its backward pass 1.9× against 2.1× the filter's
time (with the filter, CPU time, a loaded machine).

Fallbacks: each backward pass counts the samples where a step that carries weight (a next
mode of at least :data:`NEGLIGIBLE_WEIGHT`; expectation correction: a pair ``p_ij(k)`` of
at least it) was refused, by cause (:data:`PREDICTION`, :data:`GUARD`, :data:`ROUNDING`,
:data:`COVARIANCE`, :func:`note_fallbacks`), into
:attr:`~hybridlog.estimators.result.PostProcessing.fallbacks`; the negligible next modes
above are not counted.

**Expectation correction** (``smoother = "ec"``, :func:`ec_backward`): D. Barber,
"Expectation Correction for Smoothed Inference in Switching Linear Dynamical Systems",
*Journal of Machine Learning Research* 7 (2006) 2515-2540, with one Gaussian per mode and
the "mean" approximation of its expectation over ``x(k+1)``.  Kim's recursion takes
``Pr(q(k)=i | q(k+1)=j, Y^N) ≈ Pr(q(k)=i | q(k+1)=j, Y^k)``; expectation correction
conditions on the smoothed state of ``k+1`` as well, at its mean.  The forward pass keeps the
mode-matched filtered ``x̂_i(k|k)``, ``P_i(k|k)`` in every row of the store instead of the
mixed priors (the IMM's ``filtered_store``; same size).  For ``k = N−2 … 0`` and each pair
``(i, j)``, an extended RTS step (:func:`rts_predict`, :func:`rts_correct`, the guard and the
rounding probe of :func:`rts_step`) from the filtered estimate of mode ``i`` with the
dynamics of mode ``j``:

.. math::

    \hat x^-_{ij} = f_j(\hat x_i(k|k), u_k),\; F_{ij} = \partial f_j/\partial x,\;
    P^-_{ij} = F_{ij} P_i(k|k) F_{ij}^T + Q_j,\;
    J_{ij} = P_i(k|k) F_{ij}^T (P^-_{ij})^{-1}

    \hat x^{(ij)} = \hat x_i(k|k) + J_{ij}(\hat x^s_j(k+1) - \hat x^-_{ij}),\quad
    P^{(ij)} = (I - J_{ij}F_{ij}) P_i(k|k) (\cdot)^T + J_{ij}(Q_j + P^s_j(k+1))J_{ij}^T

    \log w_{i|j} = \log\mu_i(k) + \log\Pi_{ij}
        + \log N(\hat x^s_j(k+1);\ \hat x^-_{ij}, P^-_{ij}) - \text{(normaliser over } i)

    \log p_{ij} = \log w_{i|j} + \log\mu^s_j(k+1),\quad
    \log\mu^s_i(k) = \operatorname{logsumexp}_j \log p_{ij},\quad
    v_{j|i} = p_{ij}/\mu^s_i(k)

    \hat x^s_i(k) = \textstyle\sum_j v_{j|i}\hat x^{(ij)},\quad
    P^s_i(k) = \sum_j v_{j|i}(P^{(ij)} + (\hat x^{(ij)} - \hat x^s_i)(\cdot)^T)

and the output is the mixture over ``i`` with ``μ^s_i(k)``.  The approximations: one
Gaussian per mode (forward and backward, each mixture collapsed to its moments), the
expectation of ``p(q(k) | q(k+1), x(k+1), Y^k)`` over ``x(k+1)`` taken at its mean
``x̂^s_j(k+1)``, and nonlinear modes linearised at ``x̂_i(k|k)``.  ``n_q²`` RTS steps a
sample against Kim's ``n_q``.  Kim's weights (the density term left out) are taken for next
mode ``j`` where ``Q_j`` is not positive definite (without process noise ``P^-_{ij} =
F P_i Fᵀ`` is nearly singular and the density decides by rounding: on the double cart the
prototype of ``docs/studies/smoothing_ec.py`` put 52-83 % of a log's samples in the wrong
mode), where a pair's ``P^-_{ij}`` is not positive definite, where the density is ``-inf`` for
every ``i``, and for a negligible next mode (``μ^s_j(k+1) <`` :data:`NEGLIGIBLE_WEIGHT`, whose
pair steps are skipped: ``x̂^{(ij)} = x̂_i(k|k)``).  A pair step the guard or the probe
refuses leaves ``x̂^{(ij)} = x̂_i(k|k)``, as in Kim's pass.

Pairs that carry no weight: a pair's RTS step is taken only where ``p_ij(k) >=``
:data:`NEGLIGIBLE_WEIGHT` (elsewhere ``x̂^{(ij)} = x̂_i(k|k)``, whose weight in the output is
``p_ij(k)``, and in mode ``i``'s own mixture ``p_ij/μ^s_i``, which matters only where
``μ^s_i(k)`` is itself that small), and a pair's prediction and density only where its weight
can still reach it: the densities are taken in :func:`ec_order` (the stay ``i = j`` first),
and since ``P^-_{ij} ⪰ Q_j`` the density is at most ``c_j`` (:func:`density_ceilings`), so a
pair with ``log μ_i + log Π_ij + c_j`` below ``log NEGLIGIBLE_WEIGHT − log μ^s_j(k+1)`` plus
the largest ``log μ_i' + log Π_i'j + log N_i'j`` found so far has ``p_ij(k)`` below
:data:`NEGLIGIBLE_WEIGHT` whatever its density, and is left out.  On the three-tank
benchmark log that leaves 2.7 predictions and about 2.2 steps a sample of the ``n_q² = 9``.
(Should a prediction fail, the mode takes Kim's weights, and a pair left out that they make
count stands for want of a prediction, counted as a ``prediction`` fallback.)  The
straight-line code computes the weights in linear space (one ``exp`` a pair with a density,
relative to the largest; Kim's weights as products, from the logs only where they underflow):
the loop's log-space weights to rounding, except probabilities below some 1e-300, which it
may flush to zero and which enter nothing that counts (a mode that small is negligible at the
next step back).  With one mode, or the stay
probability at 1 and the true mode known, it is the RTS smoother; where the state forgets
its past (``F = 0``) the density is the same for every ``i`` and it is Kim's, exact on a
Markov chain with Gaussian emissions.  Like Kim's pass, it has straight-line code for small
models (:func:`generate_ec_smoother_source`).

**Viterbi.**  The most likely mode sequence given the forward pass's per-mode log-likelihoods
``ℓ_j(k) = log N(γ_j(k); 0, S_j(k))``: ``δ_j(0) = log μ_j(0)``,
``δ_j(k) = max_i(δ_i(k−1) + log Π_ij) + ℓ_j(k)`` and back-tracking (Rabiner 1989, eqs.
(32a)-(35)), in log space.  The likelihoods are those of the IMM's mode-matched filters, so the
path is exact for the chain only as far as the IMM's Gaussian mixture reduction is.

Both passes are compiled with numba; the smoother calls the model's compiled ``f`` and ``F``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any, NamedTuple, cast

import numpy as np

from hybridlog.estimators.common import (
    FilterBuffers,
    FilterRun,
    Fn,
    ModeStore,
    contiguous,
    packed_width,
    upper_pairs,
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
    EstimationResult,
    Fallbacks,
    PostProcessing,
)
from hybridlog.estimators.unrolled import (
    Entry,
    Matrix,
    Program,
    Vector,
    matrix_names,
    module_source,
    noise_matrices,
    product,
    reshape,
    term,
    upper,
    use_unrolled,
    vector_names,
)
from hybridlog.jit import compile_for, jit, jit_kernel, jitable_kernel
from hybridlog.model.compiled import compile_generated, compile_model
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.prefault import populated_beside
from hybridlog.signals import AlignedSignals, BoolArray, FloatArray, IntArray

__all__ = ["KIM_DESCRIPTION", "post_process", "viterbi"]

KIM = "kim-rts"
"""``PostProcessing.smoothing`` of the IMM smoother."""

KIM_DESCRIPTION = (
    "fixed-interval IMM smoother: Kim (1994) eqs. (2.20)-(2.21) for the mode probabilities "
    "(log space), an extended RTS step per next mode from the IMM's mixed prior for the states"
)
VITERBI_DESCRIPTION = (
    "Viterbi path over the Markov chain with the forward filters' per-mode likelihoods "
    "(Rabiner 1989, eqs. (32)-(35))"
)
KBEST_DESCRIPTION = (
    "modes: the most likely of the {beam} best mode histories, each with its own EKF, never "
    "mixed (k-best trajectory tracking, paper 002 eqs. (4)-(5)); states: {states}"
)
FILTERS_OWN = "states and mode probabilities: the filter's"
"""What a Viterbi path without ``smooth`` leaves as it was: its description says so, as
``kbest``'s without ``smooth`` says its mode probabilities are the filter's (the timeline's
``p_<mode>`` columns equal the ``_filtered`` ones, while its ``mode`` column is the path)."""
PATH_RTS = "kim-rts+path-rts"
"""``PostProcessing.smoothing`` with ``kbest``: Kim's mode probabilities, the states smoothed
along the path."""
EC = "ec-rts"
"""``PostProcessing.smoothing`` of expectation correction (``smoother = "ec"``)."""
EC_PATH_RTS = "ec-rts+path-rts"
"""``PostProcessing.smoothing`` with ``smoother = "ec"`` and ``kbest``: expectation
correction's mode probabilities, the states smoothed along the path."""
EC_DESCRIPTION = (
    "fixed-interval IMM smoother: expectation correction (Barber 2006, JMLR 7, one Gaussian "
    "per mode), an extended RTS step per pair of modes from the filtered estimates, the mode "
    "weights corrected by the density of the smoothed next state (log space)"
)


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
stands; the module docstring bounds what that changes).  Below half the spacing of doubles
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
    ``Q`` is small; the module docstring); or where the rounding probe is past
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
    """Rows ``0 … N−2`` of the smoothed result (the module docstring), compiled on first use.

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
    """Rows ``0 … N−2`` of expectation correction's smoothed result (the module docstring).

    ``store`` holds the filtered per-mode ``x̂_i(k|k)``, ``P_i(k|k)`` in every row (the IMM's
    ``filtered_store``), ``mu`` the filtered mode probabilities; ``corrected[j]`` whether the
    weights of next mode ``j`` take the density of the smoothed state (its process noise
    positive definite), else Kim's, and ``ceilings[j]`` the largest log density a pair into it
    can give (:func:`density_ceilings`), by which a pair is left out unpredicted where its
    weight cannot reach :data:`NEGLIGIBLE_WEIGHT` (the module docstring, "pairs that carry
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


def _log(values: FloatArray) -> FloatArray:
    with np.errstate(divide="ignore"):
        return contiguous(np.log(values))


def post_process(
    model: HybridModel,
    signals: AlignedSignals,
    filtered: EstimationResult,
    store: ModeStore,
    transitions: FloatArray,
    *,
    smooth: bool,
    mode_sequence: str,
    jit: bool,
    kernel: str = "auto",
    beam: int = 20,
    smoother: str = "kim",
    paired: HybridModel | None = None,
) -> EstimationResult:
    """The result after the offline passes asked for, with the filter's beside it.

    ``smooth``: the Kim smoother's states, variances, probabilities and modes (argmax of the
    smoothed probabilities); ``mode_sequence == "viterbi"``: the Viterbi path as the modes;
    ``"kbest"``: the best of ``beam`` mode histories
    (:func:`hybridlog.estimators.mode_hypotheses.best_history`) as the modes, and the states
    of the EKF along it (``smooth``: of the RTS smoother along it; the mode probabilities are
    then Kim's).
    ``output_predictions`` stay the filter's.  The runtime adds the passes to the filter's.
    ``kernel`` as for the filter: straight-line code (:func:`generate_smoother_source`) where
    it applies, else the generic :func:`kim_backward`.  ``smoother == "ec"``: expectation
    correction in place of Kim's (:func:`generate_ec_smoother_source`, else :func:`ec_backward`);
    ``store`` must then hold the filtered per-mode estimates (the IMM's ``filtered_store``).
    ``paired``: the model ``model`` holds the mode pairs of
    (:func:`~hybridlog.estimators.mode_pairs.pair_mode_model`), whose modes a refusal names.
    """
    start = time.perf_counter()
    compile_s = 0.0
    result = filtered
    descriptions: list[str] = []
    fallbacks = np.zeros(FALLBACKS_WIDTH)
    if smooth:
        n = filtered.n_samples
        # The backward pass writes no output predictions: the filter's array stands in (no
        # 8 N n_y bytes of NaN written per run).
        buffers = FilterBuffers(
            modes=np.zeros(n, dtype=np.int64),
            mode_probabilities=np.zeros((n, model.n_modes)),
            state_means=np.zeros((n, model.n_states)),
            state_variances=np.zeros((n, model.n_states)),
            output_predictions=filtered.output_predictions,
            covariances=np.zeros(
                (n if filtered.covariances is not None else 0, model.n_states, model.n_states)
            ),
            surprise=np.zeros(0),
            whitened=np.zeros((0, model.n_outputs)),
        )
        if n:
            compile_start = time.perf_counter()
            loop, arguments = _backward_pass(
                model, signals, filtered, store, transitions, buffers, fallbacks,
                ec=smoother == "ec", jit=jit, kernel=kernel,
            )  # fmt: skip
            compile_s += time.perf_counter() - compile_start
            with populated_beside(buffers):
                loop(*arguments)
            last = n - 1
            buffers.modes[last] = int(np.argmax(filtered.mode_probabilities[last]))
            buffers.mode_probabilities[last] = filtered.mode_probabilities[last]
            buffers.state_means[last] = filtered.state_means[last]
            buffers.state_variances[last] = filtered.state_variances[last]
            if filtered.covariances is not None:
                buffers.covariances[last] = filtered.covariances[last]
        result = replace(
            filtered,
            modes=buffers.modes,
            mode_probabilities=buffers.mode_probabilities,
            state_means=buffers.state_means,
            state_variances=buffers.state_variances,
            covariances=buffers.covariances if filtered.covariances is not None else None,
        )
        descriptions.append(EC_DESCRIPTION if smoother == "ec" else KIM_DESCRIPTION)
    if mode_sequence == "viterbi":
        inputs_v = (
            _log(transitions),
            _log(model.initial_mode_probabilities),
            contiguous(store.log_likelihoods),
        )
        compile_start = time.perf_counter()
        decode = compile_for(viterbi, inputs_v) if jit else viterbi
        compile_s += time.perf_counter() - compile_start
        path = decode(*inputs_v)
        result = replace(result, modes=path)
        descriptions.append(
            VITERBI_DESCRIPTION if smooth else f"{VITERBI_DESCRIPTION}; {FILTERS_OWN}"
        )
    elif mode_sequence == "kbest":
        fallbacks[:] = 0  # the states are those of the RTS smoother along the path
        result, spent = _kbest(
            model, signals, result, transitions, beam, smooth, jit, kernel, fallbacks, paired
        )
        compile_s += spent
        descriptions = [
            KBEST_DESCRIPTION.format(
                beam=beam,
                states="the extended RTS smoother along that path; mode probabilities: "
                + ("expectation correction" if smoother == "ec" else "Kim's smoother")
                if smooth
                else "the EKF along that path; mode probabilities: the filter's",
            )
        ]
    elapsed = time.perf_counter() - start - compile_s
    return replace(
        result,
        runtime_s=filtered.runtime_s + elapsed,
        compile_s=filtered.compile_s + compile_s,
        post_processing=PostProcessing(
            smoothing=_method(smoother, kbest=mode_sequence == "kbest") if smooth else None,
            mode_sequence=mode_sequence,
            description="; ".join(descriptions),
            filtered=filtered,
            fallbacks=_fallbacks(fallbacks, filtered.n_samples) if smooth else None,
        ),
    )


def straight_line_backward(model: HybridModel, kernel: str, *, ec: bool) -> bool:
    """Whether the backward pass runs straight-line code for ``model`` under ``kernel``.

    As the filters (:func:`~hybridlog.estimators.unrolled.use_unrolled`), but expectation
    correction's with ``auto`` only up to :data:`MAX_EC_UNROLLED_MODES` modes.
    """
    if ec and kernel == "auto" and model.n_modes > MAX_EC_UNROLLED_MODES:
        return False
    return use_unrolled(model, kernel)


def _backward_pass(
    model: HybridModel,
    signals: AlignedSignals,
    filtered: EstimationResult,
    store: ModeStore,
    transitions: FloatArray,
    buffers: FilterBuffers,
    fallbacks: FloatArray,
    *,
    ec: bool,
    jit: bool,
    kernel: str,
) -> tuple[Callable[..., object], tuple[Any, ...]]:
    """The compiled backward pass asked for and its arguments.

    Kim's, or expectation correction's with ``ec``: the straight-line code of the model where
    it applies (:func:`generate_smoother_source`, :func:`generate_ec_smoother_source`; for
    expectation correction with ``auto`` only up to :data:`MAX_EC_UNROLLED_MODES` modes),
    else the generic loop (:func:`kim_backward`, :func:`ec_backward`).
    """
    tail = (filtered.mode_probabilities, store, buffers, fallbacks)
    if jit and straight_line_backward(model, kernel, ec=ec):
        name = "imm_smooth_ec" if ec else "imm_smooth"
        generate = generate_ec_smoother_source if ec else generate_smoother_source
        arguments: tuple[Any, ...] = (
            contiguous(signals.inputs), contiguous(transitions), _log(transitions), *tail
        )  # fmt: skip
        loop, _ = compile_generated(
            model,
            name,
            lambda: module_source(model, generate(model)),
            (__name__, "hybridlog.estimators.unrolled"),
            name,
            arguments,
        )
        return loop, arguments
    compiled = compile_model(model, jit=jit)
    noise = contiguous(np.stack([m.process_noise for m in model.modes]))
    head = (compiled.f, compiled.F, contiguous(signals.inputs), contiguous(transitions), noise)
    generic: Callable[..., object] = ec_backward if ec else kim_backward
    weights = (positive_definite_noise(model), density_ceilings(model))
    arguments = (*head, *weights, *tail) if ec else (*head, *tail)
    return (compile_for(generic, arguments) if jit else generic), arguments


def _fallbacks(counts: FloatArray, n_samples: int) -> Fallbacks:
    """:class:`Fallbacks` of a backward pass's ``fallbacks`` array over ``n_samples``."""
    of = max(n_samples - 1, 0)
    return Fallbacks(
        samples=int(counts[0]),
        of=of,
        by_cause={cause: int(counts[c]) for c, cause in enumerate(FALLBACK_CAUSES, start=1)},
        weight=min(float(counts[FALLBACK_WEIGHT]) / of, 1.0) if of else 0.0,
    )


def _method(smoother: str, *, kbest: bool) -> str:
    """``PostProcessing.smoothing`` of ``smoother`` (``kim``, ``ec``), with ``kbest`` or not."""
    if smoother == "ec":
        return EC_PATH_RTS if kbest else EC
    return PATH_RTS if kbest else KIM


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
    nearly singular and decides by rounding (module docstring).
    """
    definite = np.zeros(model.n_modes, dtype=np.bool_)
    for j, mode in enumerate(model.modes):
        try:
            np.linalg.cholesky(mode.process_noise)
        except np.linalg.LinAlgError:
            continue
        definite[j] = True
    return definite


def _kbest(
    model: HybridModel,
    signals: AlignedSignals,
    result: EstimationResult,
    transitions: FloatArray,
    beam: int,
    smooth: bool,
    jit: bool,
    kernel: str,
    fallbacks: FloatArray,
    paired: HybridModel | None,
) -> tuple[EstimationResult, float]:
    """``result`` with the ``kbest`` path as its modes and the states of the EKF along it.

    :mod:`hybridlog.estimators.mode_hypotheses`: the path (straight-line code where
    ``kernel`` asks for it and the log measured every output,
    :func:`~hybridlog.estimators.mode_hypotheses.generate_kbest_source`, else the generic
    loop, which updates on the measured outputs alone), then the EKF that follows it
    (``smooth``: and the extended RTS smoother along it, its fallbacks counted into
    ``fallbacks``).  Returns the compile time too.  ``paired`` as for :func:`post_process`.
    """
    from hybridlog.estimators import mode_hypotheses
    from hybridlog.estimators.mode_hypotheses import best_history, follow_path, smooth_path

    compiled = compile_model(model, jit=jit)
    run = FilterRun.of(model, signals, "imm")
    n, n_x = signals.n_samples, model.n_states
    means = np.zeros((n, n_x))
    covariances = np.zeros((n, n_x, n_x))
    compile_start = time.perf_counter()
    searched: tuple[Any, ...]
    search: Callable[..., Any]
    if jit and use_unrolled(model, kernel) and signals.measures_every_output:
        searched = (run, _log(transitions), beam)
        search, _ = compile_generated(
            model,
            "kbest",
            lambda: module_source(model, mode_hypotheses.generate_kbest_source(model)),
            (mode_hypotheses.__name__, "hybridlog.estimators.unrolled"),
            "kbest_run",
            searched,
        )
    else:
        searched = (compiled.f, compiled.F, compiled.h, compiled.H, run, _log(transitions), beam)
        search = compile_for(best_history, searched) if jit else best_history
    compile_s = time.perf_counter() - compile_start
    path = cast(IntArray, search(*searched))
    followed = (compiled.f, compiled.F, compiled.h, compiled.H, run, path, means, covariances)
    compile_start = time.perf_counter()
    follow = compile_for(follow_path, followed) if jit else follow_path
    compile_s += time.perf_counter() - compile_start
    unweighed = follow(*followed)
    if unweighed >= 0:
        _refuse_unweighed_path(model, signals, path, unweighed, paired)
    if smooth:
        smoothed = (compiled.f, compiled.F, run, path, means, covariances, fallbacks)
        compile_start = time.perf_counter()
        backward = compile_for(smooth_path, smoothed) if jit else smooth_path
        compile_s += time.perf_counter() - compile_start
        backward(*smoothed)
    return (
        replace(
            result,
            modes=path,
            state_means=means,
            state_variances=np.ascontiguousarray(np.diagonal(covariances, axis1=1, axis2=2)),
            covariances=covariances if result.covariances is not None else None,
        ),
        compile_s,
    )


def _refuse_unweighed_path(
    model: HybridModel,
    signals: AlignedSignals,
    path: IntArray,
    row: int,
    paired: HybridModel | None = None,
) -> None:
    """Refuse a ``kbest`` path whose EKF cannot weigh the measurement of sample ``row``.

    There the innovation covariance ``S = H P Hᵀ + R`` of the path's mode, from the path's
    own prior, is not finite and positive definite in double precision (paper 000 eq. (9)):
    no update exists, and its prediction would stand in for an estimate of the log
    (:func:`~hybridlog.estimators.mode_hypotheses.follow_path`).  On the mode pairs of
    ``paired`` the mode is named in ``paired``'s modes: ``'down' (after a step of mode 'up')``,
    not the pair ``'up->down'`` the model file does not have.
    """
    from hybridlog.errors import DivergenceError, excerpt
    from hybridlog.estimators.mode_pairs import pair_named
    from hybridlog.times import format_time

    index = int(path[row])
    mode = excerpt(model.modes[index].id) if paired is None else pair_named(index, paired)
    raise DivergenceError(
        f"{model.origin or model.name}: imm (mode_sequence kbest) cannot weigh the measurement "
        f"at t = {format_time(signals.time[row])} s (sample {row}) along its most likely mode "
        f"path: mode {mode}'s innovation covariance "
        "H P Hᵀ + R is not finite and positive definite in double precision there, so no "
        "update exists"
    )


def _log_sum_exp_source(p: Program, hint: str, expressions: list[str]) -> str:
    """Emit ``log Σ exp(expressions)`` as :func:`log_sum_exp` computes it; its variable."""
    return _log_sum_exp_parts(p, hint, expressions)[0]


def _log_sum_exp_parts(p: Program, hint: str, expressions: list[str]) -> tuple[str, list[str], str]:
    """``log Σ exp(a_i)`` as :func:`log_sum_exp` computes it (the same operations), with its parts.

    Returns the variables of the result, of ``e_i = exp(a_i − max a)`` and of ``s = Σ e_i``,
    so that the normalised weights ``exp(a_i − log Σ exp a)`` are ``e_i / s`` without another
    ``exp`` (equal to rounding).  When every ``a_i`` is ``-inf``: ``-inf``, zeros and 1.
    """
    terms = [p.assign(hint + "t", e) for e in expressions]
    top = terms[0] if len(terms) == 1 else p.assign(hint + "top", f"max({', '.join(terms)})")
    result = p.fresh(hint)
    exps = [p.fresh(hint + "e") for _ in terms]
    total = p.fresh(hint + "s")
    p.emit(f"if {top} == -math.inf:")
    p.emit(f"    {result} = -math.inf")
    for e in exps:
        p.emit(f"    {e} = 0.0")
    p.emit(f"    {total} = 1.0")
    p.emit("else:")
    for e, t in zip(exps, terms, strict=True):
        p.emit(f"    {e} = math.exp({t} - {top})")
    p.emit(f"    {total} = {' + '.join(exps)}")
    p.emit(f"    {result} = {top} + math.log({total})")
    return result, exps, total


def _select(
    p: Program,
    condition: str,
    bundle: str,
    chosen: Sequence[Entry],
    other: Sequence[Entry],
) -> None:
    """Bind the tuple ``bundle`` to ``chosen`` where ``condition`` holds, else to ``other``."""
    with p.block(f"if {condition}:"):
        _bind(p, bundle, chosen)
    with p.block("else:"):
        _bind(p, bundle, other)


def _bind(p: Program, bundle: str, values: Sequence[Entry]) -> None:
    """``bundle = (values…)``: one tuple where a branch would assign every value's name.

    numba rebuilds SSA form for each variable assigned in more than one place, in a pass
    over every block of the function: a name per value assigned in each branch made that
    pass, not LLVM, most of a straight-line smoother's compile time (expectation
    correction's for three modes: 70 s), where one tuple per branch, unpacked once after
    them (:func:`_unpack`), costs one such variable and no run time.

    The tuple is built under a name of its own, assigned once, and then bound to ``bundle``:
    CPython builds a tuple display of more than 30 entries through a list (a step's values
    for 6 states are 6 + 21 + 6 = 33), and numba's rewrite of that list back into a tuple
    refuses a target assigned in more than one place (an ``AssertionError`` compiling the
    pass).
    """
    built = p.fresh(bundle + "_")
    p.emit(f"{built} = ({', '.join(term(value) for value in values)},)")
    p.emit(f"{bundle} = {built}")


def _unpack(p: Program, names: Sequence[str], bundle: str) -> None:
    """``names… = bundle`` after the branches that bound it (:func:`_bind`)."""
    p.emit(f"{', '.join(names)}, = {bundle}")


def _triangular_solves(
    p: Program, hint: str, L: Matrix, inverse: Sequence[Entry], b: Vector
) -> Vector:
    """``(L Lᵀ)⁻¹ b``: ``L z = b`` then ``Lᵀ y = z``, with ``inverse[i] = 1/L[i][i]``.

    :meth:`~hybridlog.estimators.unrolled.Program.forward_solve` and ``backward_solve``
    with a multiplication by the reciprocal in place of each division.
    """
    size = len(L)
    z: Vector = []
    for i in range(size):
        partial = p.let(hint + "fp", [b[i], *[_negated(product(L[i][k], z[k])) for k in range(i)]])
        z.append(
            partial
            if partial == 0.0
            else p.assign(hint + "f", f"{term(partial)}*{term(inverse[i])}")
        )
    y: Vector = [0.0] * size
    for i in range(size - 1, -1, -1):
        partial = p.let(
            hint + "bp",
            [z[i], *[_negated(product(L[k][i], y[k])) for k in range(i + 1, size)]],
        )
        y[i] = (
            partial
            if partial == 0.0
            else p.assign(hint + "b", f"{term(partial)}*{term(inverse[i])}")
        )
    return y


def _negated(value: Entry | None) -> Entry | None:
    """``−value`` for :meth:`Program.let` (``None`` stays a structural zero)."""
    if value is None:
        return None
    if isinstance(value, float):
        return -value
    return f"-{value}" if "*" not in value else f"-({value})"


def _mode_recursion_source(
    p: Program, T: Matrix, log_T: Matrix, log_next: Vector, mu_next: Vector
) -> tuple[Vector, Vector, list[Vector]]:
    """Emit one step of Kim's mode recursion; variables of ``log μ^s(k)``, ``μ^s(k)``, ``w_{j|i}``.

    ``log_next`` and ``mu_next`` hold ``log μ^s(k+1)`` and ``μ^s(k+1)``; ``mu[k]`` is read.
    Two branches, equal to rounding:

    * linear, when every quantity is in full-precision range -- each ``c̄_j``, each
      ``μ^s_j(k+1)`` (unless ``−inf`` in log space) and each ``μ_i(k)`` and unnormalised
      ``μ^s_i(k)`` (unless ``μ_i(k) = 0``) at least :data:`LINEAR_FLOOR`: ``q_j = μ^s_j(k+1) /
      c̄_j``, ``a_ij = Π_ij q_j`` (``= p_ij / μ_i``), ``s_i = Σ_j a_ij``, ``μ^s_i ∝ μ_i s_i``,
      ``w_{j|i} = a_ij / s_i`` and ``log μ^s_i = log(μ^s_i)``: the log space adds no range
      there (no ``exp``, ``n_q`` ``log``);
    * else the log-space recursion of the module docstring as :func:`kim_backward` computes
      it, with fewer ``exp``: ``log c̄_j`` as the log of the linear sum (``μ(k)`` is stored
      linear) unless it is below :data:`LINEAR_FLOOR`, and ``w_{j|i}``, ``μ^s_i`` as the exps
      each log-sum-exp already took, normalised (:func:`_log_sum_exp_parts`).

    A row with ``μ_i(k) = 0`` (``log μ^s_i(k) = −inf``) takes ``w_{j|i} = μ^s_j(k+1)``, as
    :func:`kim_backward` does.
    """
    n_q = len(T)
    floor = repr(LINEAR_FLOOR)
    mu_k = [p.assign("mk", f"mu[k, {i}]") for i in range(n_q)]
    c_bar = [p.let("cb", [f"{T[i][j]}*{mu_k[i]}" for i in range(n_q)]) for j in range(n_q)]
    ratio = [p.assign("q", f"{mu_next[j]} / {term(c_bar[j])}") for j in range(n_q)]
    a = [[p.assign("a", f"{T[i][j]}*{ratio[j]}") for j in range(n_q)] for i in range(n_q)]
    s = [p.let("s", list(a[i])) for i in range(n_q)]
    b = [p.assign("b", f"{mu_k[i]}*{term(s[i])}") for i in range(n_q)]
    b_total = p.let("bt", list(b))
    conditions = (
        [f"{term(c_bar[j])} >= {floor}" for j in range(n_q)]
        + [f"({log_next[j]} == -math.inf or {mu_next[j]} >= {floor})" for j in range(n_q)]
        + [
            f"({mu_k[i]} == 0.0 or ({mu_k[i]} >= {floor} and {b[i]} >= {floor}))"
            for i in range(n_q)
        ]
        + [f"{term(b_total)} >= {floor}"]
    )
    fast = p.assign("fast", " and ".join(conditions))
    log_new: Vector = [p.fresh("ln") for _ in range(n_q)]
    mu_s: Vector = [p.fresh("ms") for _ in range(n_q)]
    weights: list[Vector] = [[p.fresh("w") for _ in range(n_q)] for _ in range(n_q)]
    p.emit(f"if {fast}:")
    p.indent += "    "
    for i in range(n_q):
        p.emit(f"{mu_s[i]} = {b[i]} / {term(b_total)}")
        p.emit(f"{log_new[i]} = math.log({mu_s[i]}) if {mu_s[i]} > 0.0 else -math.inf")
        for j in range(n_q):
            p.emit(
                f"{weights[i][j]} = {mu_next[j]} if {mu_k[i]} == 0.0 else {a[i][j]} / {term(s[i])}"
            )
    p.indent = p.indent[:-4]
    p.emit("else:")
    p.indent += "    "
    log_mu = [
        p.assign("lmu", f"math.log({mu_k[i]}) if {mu_k[i]} > 0.0 else -math.inf")
        for i in range(n_q)
    ]
    log_c: list[str] = []
    for j in range(n_q):
        result = p.fresh("lc")
        p.emit(f"if {term(c_bar[j])} > {floor}:")
        p.emit(f"    {result} = math.log({term(c_bar[j])})")
        p.emit("else:")
        p.indent += "    "
        exact = _log_sum_exp_source(p, "lc", [f"{log_T[i][j]} + {log_mu[i]}" for i in range(n_q)])
        p.emit(f"{result} = {exact}")
        p.indent = p.indent[:-4]
        log_c.append(result)
    log_pair = [
        [
            p.assign(
                "lp",
                f"-math.inf if ({log_c[j]} == -math.inf or {log_next[j]} == -math.inf) else "
                f"{log_next[j]} + {log_mu[i]} + {log_T[i][j]} - {log_c[j]}",
            )
            for j in range(n_q)
        ]
        for i in range(n_q)
    ]
    rows = [_log_sum_exp_parts(p, "rt", list(log_pair[i])) for i in range(n_q)]
    total, total_exps, total_sum = _log_sum_exp_parts(p, "tot", [row[0] for row in rows])
    p.emit(f"if {total} == -math.inf:")
    for i in range(n_q):
        p.emit(f"    {log_new[i]} = {log_mu[i]}")
        p.emit(f"    {mu_s[i]} = math.exp({log_mu[i]})")
    p.emit("else:")
    for i in range(n_q):
        p.emit(f"    {log_new[i]} = {rows[i][0]} - {total}")
        p.emit(f"    {mu_s[i]} = {total_exps[i]} / {total_sum}")
    for i in range(n_q):
        _, row_exps, row_sum = rows[i]
        for j in range(n_q):
            p.emit(
                f"{weights[i][j]} = {mu_next[j]} if ({log_new[i]} == -math.inf or "
                f"{total} == -math.inf) else {row_exps[j]} / {row_sum}"
            )
    p.indent = p.indent[:-4]
    return log_new, mu_s, weights


def _positive_pivots(p: Program, hint: str, S: Matrix) -> str:
    """Emit the pivots of ``S = L D Lᵀ`` (unit lower ``L``); the condition "each pivot > 0".

    The decision of :func:`~hybridlog.estimators.kernels.cholesky` (and of
    :meth:`~hybridlog.estimators.unrolled.Program.cholesky`'s "every diagonal entry > 0"),
    which the generic loop takes in :func:`rts_correct` and :func:`semidefinite_step`, for
    less: the pivots are the squares of the Cholesky factor's diagonal (``d_j = l_jj²``,
    ``L_ij = l_ij / l_jj``), so the two agree in exact arithmetic, while this form takes no
    square root and ``n − 1`` divisions (one reciprocal a pivot, as
    :func:`_triangular_solves`) in place of ``n`` roots and ``n(n−1)/2`` divisions, which
    sat one after the other on the step's longest chain.  In floating point both are
    backward stable (each decides for a matrix within a few ``n·u·|S|`` of ``S``), so they
    can disagree only on a matrix within that rounding of singular: where the caller's
    ``S`` (the guard's ``P^- − P^s(k+1)``, the step's covariance, each shifted by its
    tolerance, :data:`GUARD_TOLERANCE` of the trace,
    :data:`~hybridlog.estimators.kernels.PSD_TOLERANCE` of the largest variance) sits on
    that tolerance's edge to about 1e-16 of its size, and the Cholesky test decides it by
    its last bits too (the straight-line code and the generic loop already differ there:
    their ``S`` agree to rounding, not bit for bit).  On the sample logs and the
    10⁶-sample benchmark every decision and result is bit-identical with either test
    (docs/smoothing.md, "Speed").  NaN fails both, and infinite entries are decided alike
    (a reciprocal of ``inf`` is 0 as the factor's quotients by it are;
    ``tests/estimators/test_smoothing_rounding.py``).  With ``W_ij = L_ij d_j``:

    .. code-block:: text

        d_j = s_jj − Σ_{k<j} W_jk L_jk,   W_ij = s_ij − Σ_{k<j} W_ik L_jk,   L_ij = W_ij / d_j
    """
    size = len(S)
    W: Matrix = [[0.0] * size for _ in range(size)]
    L: Matrix = [[0.0] * size for _ in range(size)]
    pivots: list[Entry] = []
    for j in range(size):
        pivot = p.let(
            hint + "d", [S[j][j], *[_negated(product(W[j][k], L[j][k])) for k in range(j)]]
        )
        pivots.append(pivot)
        if j == size - 1:
            break
        inverse = p.assign(hint + "r", f"1.0 / {term(pivot)}")
        for i in range(j + 1, size):
            W[i][j] = p.let(
                hint + "w", [S[i][j], *[_negated(product(W[i][k], L[j][k])) for k in range(j)]]
            )
            L[i][j] = (
                W[i][j] if W[i][j] == 0.0 else p.assign(hint + "l", f"{term(W[i][j])}*{inverse}")
            )
    return " and ".join(f"{term(d)} > 0.0" for d in pivots)


class _PredictionSource(NamedTuple):
    """The variables of one generated RTS prediction (:func:`_rts_prediction_source`)."""

    x_pred: Vector
    """``f_j(x̂)``."""
    F: Matrix
    """``∂f_j/∂x`` at ``x̂``."""
    P_pred: Matrix
    """``P^- = F P Fᵀ + Q_j``."""
    L: Matrix
    """The Cholesky factor of ``P^-`` (NaN on its diagonal where it is not positive definite)."""
    predicted: str
    """Whether ``P^-`` is positive definite."""


class _StepSource(NamedTuple):
    """The variables of one generated RTS step (:func:`_rts_step_source`)."""

    taken: str
    """Whether the step was taken (else the forward estimate stands)."""
    cause: str
    """An expression of the cause's bit (``1 << (cause − 1)``, :func:`note_fallbacks`) of a
    step not taken: the first check that refused it, in :func:`rts_cause`'s order."""
    x: Vector
    P: Matrix
    r: Vector
    """The rounding probe."""


def _rts_prediction_source(
    p: Program, model: HybridModel, j: int, x0: Vector, P0: Matrix, u: Vector, Q: Matrix
) -> _PredictionSource:
    """Emit the prediction of next mode ``j``'s RTS step (:func:`rts_predict`) from ``x0, P0``."""
    n = len(x0)
    x_pred = p.mode_values(model, j, "f", x0, u)
    F = reshape(p.mode_values(model, j, "F", x0, u), n, n)
    P_pred = p.congruence(f"pp{j}_", F, P0, add=Q)
    L = p.cholesky(f"lc{j}_", P_pred)
    predicted = p.assign("pd", " and ".join(f"{term(L[a][a])} > 0.0" for a in range(n)))
    return _PredictionSource(x_pred, F, P_pred, L, predicted)


def _rts_step_source(
    p: Program,
    model: HybridModel,
    j: int,
    x0: Vector,
    P0: Matrix,
    u: Vector,
    Q: Matrix,
    xn: Vector,
    Pn: Matrix,
    rn: Vector,
) -> _StepSource:
    """Emit the extended RTS step of next mode ``j`` (:func:`rts_step`); its variables.

    Returns the guard's condition (``P^-_j`` and ``P^-_j − P^s_j(k+1)`` positive definite,
    the rounding probe within :data:`ROUNDING_LIMIT`), the step's mean, covariance and
    rounding probe, from ``x0, P0`` (the mixed prior; expectation correction: mode ``i``'s
    filtered estimate) and the smoothed ``xn, Pn`` (rounding probe ``rn``) of the next
    sample.
    """
    prediction = _rts_prediction_source(p, model, j, x0, P0, u, Q)
    return _rts_correction_source(p, j, x0, P0, Q, xn, Pn, rn, prediction)


def _rts_correction_source(
    p: Program,
    j: int,
    x0: Vector,
    P0: Matrix,
    Q: Matrix,
    xn: Vector,
    Pn: Matrix,
    rn: Vector,
    prediction: _PredictionSource,
) -> _StepSource:
    """Emit the rest of :func:`_rts_step_source` once ``prediction`` is emitted.

    The guard, gain, mean, covariance and rounding probe of :func:`rts_correct`, and
    :func:`semidefinite_step`'s check.
    """
    n = len(x0)
    x_pred, F, P_pred, L, predicted = prediction
    FP = p.matmul(f"fp{j}_", F, P0)
    # J = P⁰Fᵀ(P^-)⁻¹ column by column of F P⁰, two triangular solves each, multiplying by
    # the reciprocals of L's diagonal (n divisions per mode instead of 2n²; equal to rounding).
    inverse = [p.assign(f"rl{j}_", f"1.0 / {term(L[a][a])}") for a in range(n)]
    J: Matrix = [[0.0] * n for _ in range(n)]
    for b in range(n):
        solved = _triangular_solves(p, f"j{j}_", L, inverse, [FP[a][b] for a in range(n)])
        for a in range(n):
            J[b][a] = solved[a]
    trace = p.let("tr", [P_pred[a][a] for a in range(n)])
    D: Matrix = [[0.0] * n for _ in range(n)]
    for a in range(n):
        for b in range(a, n):
            extra = f" + {GUARD_TOLERANCE!r}*{term(trace)}" if a == b else ""
            D[a][b] = D[b][a] = p.assign("dg", f"{term(P_pred[a][b])} - {term(Pn[a][b])}{extra}")
    guard = _positive_pivots(p, f"ld{j}_", D)  # the guard of rts_correct, without roots
    guarded = p.assign("gd", guard)
    gap = [p.difference("gp", xn[b], x_pred[b]) for b in range(n)]
    x_rts = [p.let("xr", [x0[a], *[product(J[a][b], gap[b]) for b in range(n)]]) for a in range(n)]
    JF = p.matmul(f"jF{j}_", J, F)
    IJF: Matrix = [
        [p.difference("ij", 1.0 if a == b else 0.0, JF[a][b]) for b in range(n)] for a in range(n)
    ]
    part: Matrix = [[0.0] * n for _ in range(n)]
    for a in range(n):
        for b in range(a, n):
            part[a][b] = part[b][a] = p.let("qp", [Q[a][b], Pn[a][b]])
    P_rts = p.symmetric_sum(
        f"pr{j}_", [p.congruence(f"c1{j}_", IJF, P0), p.congruence(f"c2{j}_", J, part)]
    )
    # P^(j) PSD to rounding: P^(j) + PSD_TOLERANCE·max_a P_aa·I positive definite
    # (semidefinite_step's decision, by the pivots of L D Lᵀ: _positive_pivots)
    variances = [f"abs({term(P_rts[a][a])})" for a in range(n)]
    spread = p.assign("sa", f"max({', '.join(variances)})" if n > 1 else variances[0])
    shifted: Matrix = [[0.0] * n for _ in range(n)]
    for a in range(n):
        for b in range(a, n):
            extra = f" + {PSD_TOLERANCE!r}*{term(spread)}" if a == b else ""
            shifted[a][b] = shifted[b][a] = p.assign("sh", f"{term(P_rts[a][b])}{extra}")
    semidefinite = _positive_pivots(p, f"ls{j}_", shifted)
    unit = repr(ROUNDING_UNIT)
    rounded = [
        p.assign("ri", f"{term(rn[b])} + {unit}*(abs({term(xn[b])}) + abs({term(x_pred[b])}))")
        for b in range(n)
    ]
    r_rts = [
        p.let(
            "rr",
            [p.assign("ra", f"{unit}*abs({term(x_rts[a])})")]
            + [product(J[a][b], rounded[b]) for b in range(n)],
        )
        for a in range(n)
    ]
    precise = " and ".join(
        f"{term(r_rts[a])}*{term(r_rts[a])} <= "
        f"{ROUNDING_LIMIT_SQUARED!r}*max({term(P_rts[a][a])}, 0.0)"
        for a in range(n)
    )
    semidefinite_ = p.assign("sd", semidefinite)
    precise_ = p.assign("pc", precise)
    taken = p.assign("ok", f"{predicted} and {guarded} and {precise_} and {semidefinite_}")
    bits = [1 << (code - 1) for code in (PREDICTION, GUARD, ROUNDING, COVARIANCE)]
    cause = (
        f"({bits[0]} if not {predicted} else {bits[1]} if not {guarded} else "
        f"{bits[2]} if not {precise_} else {bits[3]})"
    )
    return _StepSource(taken, cause, x_rts, P_rts, r_rts)


class _Frame(NamedTuple):
    """The variables a generated backward pass carries from one sample to the one before."""

    log_next: Vector
    """``log μ^s(k+1)``."""
    mu_next: Vector
    """``μ^s(k+1)``."""
    transitions: Matrix
    log_transitions: Matrix
    x_next: list[Vector]
    """``x̂^s_j(k+1)``."""
    P_next: list[Matrix]
    """``P^s_j(k+1)`` (symmetric names)."""
    r_next: list[Vector]
    """Their rounding probes."""
    u: Vector
    """``u(k)``."""


def _backward_frame(p: Program, model: HybridModel) -> _Frame:
    """Emit the start of a generated backward pass, up to the inputs of sample ``k``.

    The output arrays unpacked, the last sample's filtered estimates (the store's last row)
    and probabilities as the carried ``k+1``, the Markov matrix and its log, then the loop
    over ``k = N−2 … 0`` opened (the lines after it are its body).
    """
    n, n_u, n_q = model.n_states, model.n_inputs, model.n_modes
    p.emit("states = store.states")
    for name, field in (
        ("modes_out", "modes"),
        ("probabilities_out", "mode_probabilities"),
        ("means_out", "state_means"),
        ("variances_out", "state_variances"),
        ("covariances_out", "covariances"),
    ):
        p.emit(f"{name} = out.{field}")
    p.emit("n_samples = states.shape[0]")
    p.emit("store_covariances = covariances_out.shape[0] == n_samples")
    log_next = vector_names("lmn", n_q)  # log μ^s(k+1), carried
    for j in range(n_q):
        last = f"mu[n_samples - 1, {j}]"
        p.emit(f"{log_next[j]} = math.log({last}) if {last} > 0.0 else -math.inf")
    mu_carried = vector_names("mxc", n_q)  # exp(log μ^s(k+1)), carried
    for j in range(n_q):
        p.emit(f"{mu_carried[j]} = math.exp({log_next[j]})")
    log_T = matrix_names("lT", n_q, n_q)
    T = matrix_names("T", n_q, n_q)
    for i in range(n_q):
        for j in range(n_q):
            p.emit(f"{log_T[i][j]} = log_T[{i}, {j}]")
            p.emit(f"{T[i][j]} = transitions[{i}, {j}]")
    # x̂^s_j(k+1), P^s_j(k+1) (upper triangle), carried: the pass keeps them in variables
    # and writes nothing back to the store.
    x_next = [vector_names(f"xn{j}_", n) for j in range(n_q)]
    P_next = [matrix_names(f"pn{j}_", n, n, symmetric=True) for j in range(n_q)]
    packed = range(n, packed_width(n))  # the covariance's entries in a record, upper_pairs order
    r_next = [vector_names(f"rn{j}_", n) for j in range(n_q)]  # their rounding probes
    for j in range(n_q):
        p.carry(x_next[j], [f"states[n_samples - 1, {j}, {a}]" for a in range(n)])
        p.carry(upper(P_next[j]), [f"states[n_samples - 1, {j}, {e}]" for e in packed])
        p.carry(r_next[j], ["0.0"] * n)
    p.emit("for k in range(n_samples - 2, -1, -1):")
    p.indent += "    "
    u = vector_names("u", n_u)
    p.carry(u, [f"inputs[k, {c}]" for c in range(n_u)])
    return _Frame(log_next, mu_carried, T, log_T, x_next, P_next, r_next, u)


class _Helper(NamedTuple):
    """A generated function the backward pass's loop calls for one next mode."""

    name: str
    source: str
    """``@jit``-decorated definition (:data:`HELPER_IMPORT` in scope)."""


HELPER_IMPORT = "import numpy as np\n\nfrom hybridlog.jit import jit"
"""The generated module's imports: the decorator its helper functions carry, and NumPy for
the array expectation correction's stages share (:data:`SCRATCH`)."""


def _helper(name: str, parameters: Sequence[Entry], body: Program, returned: str) -> _Helper:
    """``name(parameters…)`` with ``body``'s lines, returning ``returned``.

    The backward passes' per-mode steps are written as functions of their own, each compiled
    once per next mode, where the loop writes one call per pair: numba's passes over a
    function (SSA form, reaching definitions, liveness) grow with its blocks times its
    variables, and expectation correction's loop for three modes, written out whole,
    spent about 55 of its 70 s of compiling in them.
    """
    body.emit(f"return {returned}")
    listed = ", ".join(str(x) for x in parameters)
    return _Helper(name, f"@jit\ndef {name}({listed}):\n{body.source()}\n")


class _Arguments(NamedTuple):
    """Parameter names of a step function (symmetric matrices by their upper triangle)."""

    x0: Vector
    P0: Matrix
    u: Vector
    xn: Vector
    Pn: Matrix
    rn: Vector


def _step_arguments(model: HybridModel) -> _Arguments:
    """The parameter names of ``model``'s step functions."""
    n, n_u = model.n_states, model.n_inputs
    return _Arguments(
        vector_names("x0", n),
        matrix_names("p0", n, n, symmetric=True),
        vector_names("u", n_u),
        vector_names("xn", n),
        matrix_names("pn", n, n, symmetric=True),
        vector_names("rn", n),
    )


def _standing(x: Vector, P: Matrix) -> list[Entry]:
    """A step's values where it is not taken: ``x``, ``P``'s upper triangle, a zero probe.

    The generated counterpart of :func:`_forward_stands`.
    """
    return [*x, *upper(P), *([0.0] * len(x))]


def _chosen(p: Program, step: _StepSource, x0: Vector, P0: Matrix) -> str:
    """``((x, P upper, r) of the step where taken else the forward estimate, cause bit)``."""
    bundle = p.fresh("sq")
    _select(p, step.taken, bundle, step.x + upper(step.P) + step.r, _standing(x0, P0))
    cause = p.assign("cb", f"0 if {step.taken} else {step.cause}")
    return f"{bundle}, {cause}"


def _step_function(model: HybridModel, j: int, Q: Matrix) -> _Helper:
    """``rts_step_j(x0, P0, u, xn, Pn, rn)``: next mode ``j``'s RTS step (:func:`_rts_step_source`).

    Returns ``(values, cause)``: the step's mean, covariance (upper triangle) and rounding
    probe where it was taken, else ``x0, P0`` and a zero probe; ``cause`` 0 where taken,
    else the bit of the check that refused it (:func:`note_fallbacks`).
    """
    a = _step_arguments(model)
    body = Program(indent="    ")
    step = _rts_step_source(body, model, j, a.x0, a.P0, a.u, Q, a.xn, a.Pn, a.rn)
    returned = _chosen(body, step, a.x0, a.P0)
    parameters = [*a.x0, *upper(a.P0), *a.u, *a.xn, *upper(a.Pn), *a.rn]
    return _helper(f"rts_step_{j}", parameters, body, returned)


SCRATCH = "held"
"""The generated expectation correction's array of each pair's prediction, a row per mode
``i`` of the current next mode's pairs: its stage-1 function writes it, its stage-3 function
reads it (:func:`_pair_functions`)."""


def _pair_functions(model: HybridModel, j: int, Q: Matrix) -> tuple[_Helper, int, _Helper]:
    """Stage 1 and stage 3 of expectation correction for next mode ``j``, as functions.

    ``ec_density_j(x0, P0, u, xn, held, i)`` returns ``(predicted, log N(xn; f_j(x0),
    F P0 Fᵀ + Q_j))``: whether the prediction's covariance is positive definite, and the
    density (``-inf`` where not finite); it writes the prediction's named entries (``x^-``,
    ``F``, ``P^-``, ``L``) into row ``i`` of ``held``.  ``ec_correct_j(x0, P0, xn, Pn, rn,
    held, i)`` reads them back and returns as :func:`_step_function` does.  Returns both and
    the number of entries a row holds.  Measured on the three-tank's benchmark log, against
    the loop written as one function (0.40 s): the row 0.41 s (compiled in 22 s); passing
    the entries as a tuple from one call to the other 0.51 s (12 s); predicting each pair
    again in stage 3 0.46 s (12 s).
    """
    a = _step_arguments(model)
    body = Program(indent="    ")
    prediction = _rts_prediction_source(body, model, j, a.x0, a.P0, a.u, Q)
    gap = [body.difference("gq", a.xn[b], prediction.x_pred[b]) for b in range(len(a.xn))]
    log_density = _log_density_source(body, "ld", gap, prediction.L)
    density = body.assign("dn", f"{log_density} if {log_density} > -math.inf else -math.inf")
    named = _variables(prediction)
    for column, name in enumerate(named):
        body.emit(f"{SCRATCH}[i, {column}] = {name}")
    returned = f"{prediction.predicted}, {density}"
    parameters = [*a.x0, *upper(a.P0), *a.u, *a.xn, SCRATCH, "i"]
    density_function = _helper(f"ec_density_{j}", parameters, body, returned)
    body = Program(indent="    ")
    held = [body.assign("h", f"{SCRATCH}[i, {column}]") for column in range(len(named))]
    mapping = dict(zip(named, held, strict=True))

    def rename(entries: Vector) -> Vector:
        return [mapping[e] if isinstance(e, str) else e for e in entries]

    read = _PredictionSource(
        rename(prediction.x_pred),
        [rename(row) for row in prediction.F],
        [rename(row) for row in prediction.P_pred],
        [rename(row) for row in prediction.L],
        "True",  # stage 3 corrects only the pairs whose prediction is positive definite
    )
    step = _rts_correction_source(body, j, a.x0, a.P0, Q, a.xn, a.Pn, a.rn, read)
    returned = _chosen(body, step, a.x0, a.P0)
    parameters = [*a.x0, *upper(a.P0), *a.xn, *upper(a.Pn), *a.rn, SCRATCH, "i"]
    return density_function, len(named), _helper(f"ec_correct_{j}", parameters, body, returned)


def _variables(prediction: _PredictionSource) -> list[str]:
    """The named entries of a prediction (``x^-``, ``F``, ``P^-``, ``L``), each once, in order."""
    flat = [
        *prediction.x_pred,
        *[e for row in prediction.F for e in row],
        *[e for row in prediction.P_pred for e in row],
        *[e for row in prediction.L for e in row],
    ]
    return list(dict.fromkeys(e for e in flat if isinstance(e, str)))


def _call(name: str, arguments: Sequence[Entry]) -> str:
    """Source of a call of a generated helper."""
    return f"{name}({', '.join(term(x) for x in arguments)})"


def _with_helpers(helpers: Sequence[_Helper], function: str) -> str:
    """The generated module's functions: the helpers, then the loop that calls them."""
    return "\n\n".join([HELPER_IMPORT, *(h.source for h in helpers), function])


def generate_smoother_source(model: HybridModel) -> str:
    """Straight-line source of :func:`kim_backward` for ``model`` (see ``unrolled.py``).

    Defines ``imm_smooth(inputs, transitions, log_T, mu, store, out, fallbacks)``: the same
    backward pass (``fallbacks`` counted as :func:`kim_backward` counts them)
    with the mode functions, the process noise and the small matrix products written out,
    each next mode's RTS step a function of its own (:func:`_step_function`).
    Its mode recursion (:func:`_mode_recursion_source`) takes the linear form of the same
    equations where every probability involved is in full-precision range (no ``exp``, three
    ``log`` per sample for three modes, against 33 ``exp`` and 10 ``log`` of the log-space
    form; 95 % of the three-tank benchmark's samples) and the log-space form elsewhere; the
    gain's triangular solves multiply by the reciprocals of the factor's diagonal; each next
    mode's RTS step sits under a branch that skips it below :data:`NEGLIGIBLE_WEIGHT`, as the
    generic loop does.  Equal to the generic loop up to rounding
    (``tests/estimators/test_smoothing.py``).  It reads the store's packed records
    (:class:`~hybridlog.estimators.common.ModeStore`), carries ``x̂^s_j(k+1)``, ``P^s_j(k+1)``
    and ``μ^s(k+1)`` from one step to the next in variables and writes nothing back to the
    store.
    """
    n, n_q = model.n_states, model.n_modes
    Q, _ = noise_matrices(model)
    steps = [_step_function(model, j, Q[j]) for j in range(n_q)]
    p = Program(indent="    ")
    log_next, mu_carried, T, log_T, x_next, P_next, r_next, u = _backward_frame(p, model)
    p.emit("fell = 0")
    p.emit("fell_weight = 0.0")
    log_new, mu_s, weights = _mode_recursion_source(p, T, log_T, log_next, mu_carried)
    X_s: list[Vector] = []
    P_s: list[Matrix] = []
    R_s: list[Vector] = []
    for j in range(n_q):
        x0: Vector = [p.assign("xz", f"states[k, {j}, {a}]") for a in range(n)]
        P0: Matrix = [[0.0] * n for _ in range(n)]
        for index, (a, b) in enumerate(upper_pairs(n), start=n):
            P0[a][b] = P0[b][a] = p.assign("pz", f"states[k, {j}, {index}]")
        x_sel, P_sel = vector_names(f"xs{j}", n), matrix_names(f"ps{j}", n, n, symmetric=True)
        r_sel = vector_names(f"rs{j}", n)
        chosen = [str(name) for name in [*x_sel, *upper(P_sel), *r_sel]]
        stands = _standing(x0, P0)
        bundle, cause = p.fresh("sq"), p.fresh("cb")
        arguments = [*x0, *upper(P0), *u, *x_next[j], *upper(P_next[j]), *r_next[j]]
        with p.block(f"if {mu_carried[j]} >= {NEGLIGIBLE_WEIGHT!r}:"):
            p.emit(f"{bundle}, {cause} = {_call(steps[j].name, arguments)}")
            p.emit(f"if {cause}:")
            p.emit(f"    fell |= {cause}")
            p.emit(f"    fell_weight += {mu_carried[j]}")
        with p.block("else:"):  # a negligible next mode: the forward prior stands
            _bind(p, bundle, stands)
        _unpack(p, chosen, bundle)
        X_s.append(x_sel)
        P_s.append(P_sel)
        R_s.append(r_sel)
    x_new: list[Vector] = []
    P_new: list[Matrix] = []
    r_new: list[Vector] = []
    for i in range(n_q):
        x_i, P_i = p.mixture(f"nm{i}_", weights[i], X_s, P_s)
        x_new.append(x_i)
        P_new.append(P_i)
        pairs = list(zip(weights[i], R_s, strict=True))
        r_new.append([p.let("rm", [product(w_j, r_j[a]) for w_j, r_j in pairs]) for a in range(n)])
    x, P = p.mixture("cm", mu_s, x_new, P_new)
    p.record("k", p.argmax(mu_s), mu_s, x, P)
    p.carry(log_next, log_new)
    p.carry(mu_carried, mu_s)
    for i in range(n_q):
        p.carry(x_next[i], x_new[i])
        p.carry(upper(P_next[i]), upper(P_new[i]))
        p.carry(r_next[i], r_new[i])
    _count_fallbacks(p)
    header = "def imm_smooth(inputs, transitions, log_T, mu, store, out, fallbacks):"
    return _with_helpers(steps, f"{header}\n{p.source()}\n")


def _count_fallbacks(p: Program) -> None:
    """Emit :func:`note_fallbacks` of the sample's ``fell`` into ``fallbacks``, written out."""
    p.emit("if fell:")
    p.emit("    fallbacks[0] += 1")
    for c in range(1, FALLBACK_WEIGHT):
        p.emit(f"    if fell & {1 << (c - 1)}:")
        p.emit(f"        fallbacks[{c}] += 1")
    p.emit(f"    fallbacks[{FALLBACK_WEIGHT}] += min(fell_weight, 1.0)")


def _ec_densities(
    p: Program,
    j: int,
    density: _Helper,
    x_f: list[Vector],
    P_f: list[Matrix],
    u: Vector,
    prior: list[str],
    x_next: Vector,
    log_next: Entry,
    counts: str,
    ceiling: float,
    weighed: str,
) -> tuple[list[str], list[str]]:
    """Emit stage 1 of :func:`ec_backward` for next mode ``j``: predictions and densities.

    In :func:`ec_order`, each pair whose weight can still reach :data:`NEGLIGIBLE_WEIGHT`
    (its ``prior`` plus ``ceiling`` against the largest prior plus density so far) is
    predicted by a call of ``density`` (:func:`_pair_functions`) under a branch, which
    leaves the prediction in row ``i`` of :data:`SCRATCH`.  ``weighed`` is set False
    where a prediction fails (Kim's weights).  Returns the names of whether each pair's
    prediction is positive definite (false where the pair was left out) and of the
    densities (``-inf`` where left out).
    """
    n_q = len(prior)
    floor = p.assign("fl", "-math.inf")
    p.emit(f"{weighed} = {counts}")
    predicted = [p.fresh("rd") for _ in range(n_q)]
    densities = [p.fresh("dn") for _ in range(n_q)]
    for step in range(n_q):
        i = int(ec_order(j, step))
        reachable = (
            f"{weighed} and {prior[i]} > -math.inf and "
            f"{prior[i]} + {ceiling!r} >= {floor} + {LOG_NEGLIGIBLE_WEIGHT!r} - {term(log_next)}"
        )
        with p.block(f"if {reachable}:"):
            arguments = [*x_f[i], *upper(P_f[i]), *u, *x_next, SCRATCH, str(i)]
            p.emit(f"{predicted[i]}, {densities[i]} = {_call(density.name, arguments)}")
            with p.block(f"if {predicted[i]}:"):
                p.emit(f"{floor} = max({floor}, {prior[i]} + {densities[i]})")
            with p.block("else:"):  # no density for this pair: Kim's weights for mode j
                p.emit(f"{weighed} = False")
        with p.block("else:"):
            p.emit(f"{predicted[i]} = False")
            p.emit(f"{densities[i]} = -math.inf")
    return predicted, densities


DETERMINANT_RANGE = 1e280
"""Where the product of a Cholesky factor's diagonal lies in ``(1/range, range)``, the
generated expectation correction takes one ``log`` of it, else one per entry."""


def _log_density_source(p: Program, hint: str, gap: Vector, L: Matrix) -> str:
    """``log N(gap; 0, L Lᵀ)`` as :meth:`Program.gaussian_log_density`, with one ``log``.

    ``log det`` is ``2 log Π L_aa`` where the product is well inside the range of floats
    (:data:`DETERMINANT_RANGE`), else ``2 Σ log L_aa`` (equal to rounding); NaN where ``L``
    has a NaN.
    """
    z = p.forward_solve(hint + "z", L, gap)
    quadratic = p.assign(
        hint + "q", " + ".join(f"{term(v)}*{term(v)}" for v in z if v != 0.0) or "0.0"
    )
    diagonal = [term(L[a][a]) for a in range(len(L))]
    product_ = p.assign(hint + "dp", "*".join(diagonal))
    bound = repr(DETERMINANT_RANGE)
    logs = " + ".join(f"math.log({d})" for d in diagonal)
    half_log_det = p.assign(
        hint + "hd",
        f"math.log({product_}) if {1.0 / DETERMINANT_RANGE!r} < {product_} < {bound} else ({logs})",
    )
    return p.assign(hint, f"-0.5*{quadratic} - {half_log_det} - {0.5 * len(gap)}*LOG_2PI")


def _ec_weights(
    p: Program,
    prior: list[str],
    kim_linear: list[str],
    densities: list[str] | None,
    weighed: str,
    mu_next: Entry,
    names: tuple[list[str], list[str]],
) -> None:
    """Emit stage 2 of :func:`ec_backward` for one next mode, in linear space.

    ``names``: the variables of ``p_ij(k)`` and of ``p_ij(k) >= NEGLIGIBLE_WEIGHT`` for
    ``i = 0 … n_q − 1``.  ``prior[i] = log Π_ij + log μ_i(k)``; with ``densities`` (a mode
    whose weights may take them) the corrected weights where ``weighed`` holds and some pair
    has a density, each ``exp(prior + density − the largest)`` (one ``exp`` a pair: the logs
    stay logs, as a density far in a tail has no linear form), else Kim's,
    ``μ^s_j Π_ij μ_i / Σ_i Π_ij μ_i`` with no ``exp`` (``kim_linear[i] = μ_i Π_ij``), or
    from the logs where ``Σ_i Π_ij μ_i`` is below :data:`LINEAR_FLOOR` (``weighed`` is
    updated to say which).  The loop's log-space weights to rounding, except where they are
    below some 1e-300 (the module docstring).
    """
    n_q = len(prior)
    pair, carries = names
    if densities is not None:
        with_density = [
            p.assign("td", f"{prior[i]} + {densities[i]} if {weighed} else -math.inf")
            for i in range(n_q)
        ]
        for name in with_density:
            p.emit(f"if not {name} > -math.inf:")
            p.emit(f"    {name} = -math.inf")
        top = with_density[0] if n_q == 1 else p.assign("tt", f"max({', '.join(with_density)})")
        p.emit(f"{weighed} = {weighed} and {top} > -math.inf")
        parts = [p.fresh("ew") for _ in range(n_q)]
        for i in range(n_q):
            relative = (  # no exp of -inf: a pair left out (most of them) costs nothing
                f"(math.exp({with_density[i]} - {top}) if {with_density[i]} > -math.inf else 0.0)"
            )
            p.emit(f"{parts[i]} = {relative} if {weighed} else {kim_linear[i]}")
    else:
        parts = [p.assign("ew", kim_linear[i]) for i in range(n_q)]
    total = p.assign("sw", " + ".join(parts))
    with p.block(f"if {total} < {LINEAR_FLOOR!r}:"):  # Kim's products underflow: from the logs
        top_prior = p.assign("tp", f"max({', '.join(prior)})" if n_q > 1 else prior[0])
        for i in range(n_q):
            relative = f"math.exp({prior[i]} - {top_prior})"
            p.emit(f"{parts[i]} = {relative} if {top_prior} > -math.inf else 0.0")
        p.emit(f"{total} = {' + '.join(parts)}")
    for i in range(n_q):
        p.emit(f"{pair[i]} = {term(mu_next)}*{parts[i]} / {total} if {total} > 0.0 else 0.0")
        p.emit(f"{carries[i]} = {pair[i]} >= {NEGLIGIBLE_WEIGHT!r}")


def generate_ec_smoother_source(model: HybridModel) -> str:
    """Straight-line source of :func:`ec_backward` for ``model`` (see ``unrolled.py``).

    Defines ``imm_smooth_ec(inputs, transitions, log_T, mu, store, out, fallbacks)``,
    counting the samples whose steps fell back into ``fallbacks`` as :func:`ec_backward`
    does: the same backward pass (the module docstring) with the mode functions, the process
    noise and the small matrix products written out, the pair steps as functions of each
    next mode, defined before it and called once per pair that needs them: stage 1's
    prediction and density and stage 3's correction of that prediction, which stage 1 leaves
    in a row of the array :data:`SCRATCH` (:func:`_pair_functions`), or for a next mode
    without a density the whole RTS step (:func:`_step_function`); and the mode recursion
    in log space.  Whether next mode ``j``
    takes the density of the smoothed state (``Q_j`` positive definite,
    :func:`positive_definite_noise`) is decided here, once: the code of a mode without it
    holds no density.  Equal to the generic loop up to
    rounding (``tests/estimators/test_smoothing_ec.py``).
    """
    n, n_q = model.n_states, model.n_modes
    Q, _ = noise_matrices(model)
    corrected = positive_definite_noise(model)
    ceilings = density_ceilings(model)
    p = Program(indent="    ")
    helpers: list[_Helper] = []
    widest = 0
    frame = _backward_frame(p, model)
    _, mu_next, T, log_T, x_next, P_next, r_next, u = frame
    # the loop over k is open: its body follows
    x_f: list[Vector] = []
    P_f: list[Matrix] = []
    mu_f: list[str] = []
    log_mu: list[str] = []
    for i in range(n_q):
        x_f.append([p.assign("xf", f"states[k, {i}, {a}]") for a in range(n)])
        P_i: Matrix = [[0.0] * n for _ in range(n)]
        for index, (a, b) in enumerate(upper_pairs(n), start=n):
            P_i[a][b] = P_i[b][a] = p.assign("pf", f"states[k, {i}, {index}]")
        P_f.append(P_i)
        mu_f.append(p.assign("muf", f"mu[k, {i}]"))
        log_mu.append(p.assign("lmu", f"math.log({mu_f[i]}) if {mu_f[i]} > 0.0 else -math.inf"))
    # pair (i, j): its result (the forward estimate where not taken) and log density
    X: list[list[Vector]] = [
        [vector_names(f"xq{i}{j}_", n) for j in range(n_q)] for i in range(n_q)
    ]
    P: list[list[Matrix]] = [
        [matrix_names(f"pq{i}{j}_", n, n, symmetric=True) for j in range(n_q)] for i in range(n_q)
    ]
    R: list[list[Vector]] = [
        [vector_names(f"rq{i}{j}_", n) for j in range(n_q)] for i in range(n_q)
    ]
    cause_bit = [[p.fresh("cz") for _ in range(n_q)] for _ in range(n_q)]  # 0: taken
    pair = [[p.fresh("pq") for _ in range(n_q)] for _ in range(n_q)]  # p_ij(k)
    carries = [[p.fresh("cq") for _ in range(n_q)] for _ in range(n_q)]  # p_ij(k) >= NEGLIGIBLE
    for j in range(n_q):
        counts = f"{mu_next[j]} >= {NEGLIGIBLE_WEIGHT!r}"  # q(k+1) = j is not negligible
        log_next = p.assign("lnx", f"math.log({mu_next[j]}) if {counts} else -math.inf")
        prior = [p.assign("tk", f"{log_T[i][j]} + {log_mu[i]}") for i in range(n_q)]
        predicted: list[str] | None = None
        densities: list[str] | None = None
        weighed = p.fresh("wd")
        if corrected[j]:
            density, width, step = _pair_functions(model, j, Q[j])
            helpers += [density, step]
            widest = max(widest, width)
            predicted, densities = _ec_densities(
                p, j, density, x_f, P_f, u, prior, x_next[j], log_next, counts,
                float(ceilings[j]), weighed,
            )  # fmt: skip
        else:
            step = _step_function(model, j, Q[j])
            helpers.append(step)
            p.emit(f"{weighed} = False")
        kim_linear = [f"{mu_f[i]}*{T[i][j]}" for i in range(n_q)]
        column = [row[j] for row in pair], [row[j] for row in carries]
        _ec_weights(p, prior, kim_linear, densities, weighed, mu_next[j], column)
        for i in range(n_q):
            # the RTS step of a pair that carries weight; elsewhere the forward estimate
            chosen = [str(name) for name in [*X[i][j], *upper(P[i][j]), *R[i][j]]]
            stands = _standing(x_f[i], P_f[i])
            bundle, cause = p.fresh("sq"), cause_bit[i][j]
            nexts = [*x_next[j], *upper(P_next[j]), *r_next[j]]
            with p.block(f"if {counts} and {carries[i][j]}:"):
                if predicted is None:  # the whole step: no stage 1 for this mode
                    arguments = [*x_f[i], *upper(P_f[i]), *u, *nexts]
                    p.emit(f"{bundle}, {cause} = {_call(step.name, arguments)}")
                else:  # the correction of stage 1's prediction
                    with p.block(f"if {predicted[i]}:"):
                        arguments = [*x_f[i], *upper(P_f[i]), *nexts, SCRATCH, str(i)]
                        p.emit(f"{bundle}, {cause} = {_call(step.name, arguments)}")
                    with p.block("else:"):  # left out by stage 1, or its prediction failed
                        _bind(p, bundle, stands)
                        p.emit(f"{cause} = {1 << (PREDICTION - 1)}")
            with p.block("else:"):
                _bind(p, bundle, stands)
                p.emit(f"{cause} = 0")
            _unpack(p, chosen, bundle)
    p.emit("fell = 0")  # the causes of the sample's fallbacks among pairs that carry weight
    p.emit("fell_weight = 0.0")
    for i in range(n_q):
        for j in range(n_q):
            p.emit(f"if {cause_bit[i][j]} and {carries[i][j]}:")
            p.emit(f"    fell |= {cause_bit[i][j]}")
            p.emit(f"    fell_weight += {pair[i][j]}")
    _count_fallbacks(p)
    # μ^s(k) and the weights v_j|i of each row's mixture
    mu_s = [p.fresh("msq") for _ in range(n_q)]
    weights = [[p.fresh("vq") for _ in range(n_q)] for _ in range(n_q)]
    row_sums = [p.assign("rw", " + ".join(pair[i])) for i in range(n_q)]
    total = p.assign("tw", " + ".join(row_sums))
    with p.block(f"if {total} > 0.0:"):
        for i in range(n_q):
            p.emit(f"{mu_s[i]} = {row_sums[i]} / {total}")
            for j in range(n_q):
                p.emit(
                    f"{weights[i][j]} = {pair[i][j]} / {row_sums[i]} if {row_sums[i]} > 0.0 "
                    f"else {mu_next[j]}"
                )
    with p.block("else:"):  # nothing links the two samples: the filtered probabilities stand
        for i in range(n_q):
            p.emit(f"{mu_s[i]} = {mu_f[i]}")
            for j in range(n_q):  # any finite estimate does for the rows
                p.emit(f"{weights[i][j]} = {mu_next[j]}")
    x_new: list[Vector] = []
    P_new: list[Matrix] = []
    r_new: list[Vector] = []
    for i in range(n_q):
        row: Vector = list(weights[i])
        x_i, P_i = p.mixture(f"nq{i}_", row, X[i], P[i])
        x_new.append(x_i)
        P_new.append(P_i)
        pairs = list(zip(row, R[i], strict=True))
        r_new.append([p.let("rm", [product(w_j, r_j[a]) for w_j, r_j in pairs]) for a in range(n)])
    probabilities: Vector = list(mu_s)
    x, P_out = p.mixture("cm", probabilities, x_new, P_new)
    p.record("k", p.argmax(probabilities), probabilities, x, P_out)
    p.carry(mu_next, probabilities)
    for i in range(n_q):
        p.carry(x_next[i], x_new[i])
        p.carry(upper(P_next[i]), upper(P_new[i]))
        p.carry(r_next[i], r_new[i])
    header = "def imm_smooth_ec(inputs, transitions, log_T, mu, store, out, fallbacks):"
    scratch = f"    {SCRATCH} = np.empty(({n_q}, {max(widest, 1)}))"
    return _with_helpers(helpers, f"{header}\n{scratch}\n{p.source()}\n")
