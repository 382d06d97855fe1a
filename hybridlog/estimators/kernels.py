"""Small compiled kernels shared by the filters' generic loops.

The filters work on 2-6 dimensional states; NumPy calls on such tiny arrays cost tens of
microseconds each, so the time loops are compiled whole with numba and use these helpers,
which write into preallocated arrays: linear algebra, and the frame every loop shares
(:func:`dimensions` of its :class:`~hybridlog.estimators.common.FilterRun`, :func:`record`
of one row into its :class:`~hybridlog.estimators.common.FilterBuffers`).  They allocate
nothing (but :func:`workspace`, and :func:`keep_psd`'s rare eigendecomposition), so they
are compiled without reference counts and inlined into their callers
(:func:`~hybridlog.jit.jit_kernel`); an array copy is a loop (numba's ``a[:] = b`` may
allocate a temporary where the two overlap).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from hybridlog.jit import jit, jit_kernel
from hybridlog.signals import FloatArray, IntArray

if TYPE_CHECKING:
    from hybridlog.estimators.common import FilterBuffers, FilterRun

LOG_2PI = math.log(2.0 * math.pi)


@jit_kernel
def mat_mul(A: FloatArray, B: FloatArray, out: FloatArray) -> None:
    """``out = A @ B``."""
    for i in range(A.shape[0]):
        for j in range(B.shape[1]):
            acc = 0.0
            for k in range(A.shape[1]):
                acc += A[i, k] * B[k, j]
            out[i, j] = acc


@jit_kernel
def mat_mul_bt(A: FloatArray, B: FloatArray, out: FloatArray) -> None:
    """``out = A @ B.T``."""
    for i in range(A.shape[0]):
        for j in range(B.shape[0]):
            acc = 0.0
            for k in range(A.shape[1]):
                acc += A[i, k] * B[j, k]
            out[i, j] = acc


@jit_kernel
def congruence(A: FloatArray, P: FloatArray, work: FloatArray, out: FloatArray) -> None:
    """``out = A P Aᵀ`` (``work`` has the shape of ``A``), symmetric by construction."""
    mat_mul(A, P, work)
    mat_mul_bt(work, A, out)
    symmetrize(out)


@jit_kernel
def symmetrize(P: FloatArray) -> None:
    """Replace ``P`` by ``(P + Pᵀ)/2`` in place."""
    for i in range(P.shape[0]):
        for j in range(i + 1, P.shape[0]):
            mean = 0.5 * (P[i, j] + P[j, i])
            P[i, j] = mean
            P[j, i] = mean


@jit_kernel
def cholesky(S: FloatArray, L: FloatArray) -> bool:
    """Lower Cholesky factor of the symmetric matrix ``S`` into ``L``; False if not PD."""
    n = S.shape[0]
    for j in range(n):
        acc = S[j, j]
        for k in range(j):
            acc -= L[j, k] * L[j, k]
        if not acc > 0.0:
            return False
        d = math.sqrt(acc)
        L[j, j] = d
        for i in range(j + 1, n):
            acc = S[i, j]
            for k in range(j):
                acc -= L[i, k] * L[j, k]
            L[i, j] = acc / d
        for i in range(j):
            L[i, j] = 0.0
    return True


PSD_TOLERANCE = 1e-12
""":func:`keep_psd` takes a symmetric matrix whose ``P + tolerance·trace(P)·I`` is positive
definite as it is: its smallest eigenvalue is at least ``-tolerance·trace``, the rounding of
a covariance update, well inside what :mod:`hybridlog.estimators.vouch` accepts."""


@jit
def keep_psd(P: FloatArray, shifted: FloatArray, L: FloatArray) -> bool:
    """Make the symmetric ``P`` positive semi-definite in place; True if it had to be changed.

    A ``P`` within :data:`PSD_TOLERANCE` is left alone (a Cholesky factorisation of the
    shifted matrix, ``shifted`` and ``L`` its workspaces); otherwise its negative eigenvalues
    are set to 0 (the nearest PSD matrix in the Frobenius norm; Higham 1988).
    """
    n = P.shape[0]
    trace = 0.0
    for a in range(n):
        trace += abs(P[a, a])
    for a in range(n):
        for b in range(n):
            shifted[a, b] = P[a, b]
        shifted[a, a] += PSD_TOLERANCE * trace
    if cholesky(shifted, L):
        return False
    values, vectors = np.linalg.eigh(P)
    for a in range(n):
        for b in range(n):
            acc = 0.0
            for c in range(n):
                if values[c] > 0.0:
                    acc += vectors[a, c] * values[c] * vectors[b, c]
            P[a, b] = acc
    symmetrize(P)
    return True


@jit_kernel
def forward_solve(L: FloatArray, b: FloatArray, out: FloatArray) -> None:
    """Solve ``L out = b`` for lower-triangular ``L``."""
    for i in range(L.shape[0]):
        acc = b[i]
        for k in range(i):
            acc -= L[i, k] * out[k]
        out[i] = acc / L[i, i]


@jit_kernel
def backward_solve(L: FloatArray, b: FloatArray, out: FloatArray) -> None:
    """Solve ``Lᵀ out = b`` for lower-triangular ``L``."""
    n = L.shape[0]
    for i in range(n - 1, -1, -1):
        acc = b[i]
        for k in range(i + 1, n):
            acc -= L[k, i] * out[k]
        out[i] = acc / L[i, i]


@jit_kernel
def gaussian_log_density(gamma: FloatArray, L: FloatArray, work: FloatArray) -> float:
    """``log N(γ; 0, S)`` given the Cholesky factor ``L`` of ``S``."""
    forward_solve(L, gamma, work)
    quadratic = 0.0
    log_det = 0.0
    for i in range(gamma.shape[0]):
        quadratic += work[i] * work[i]
        log_det += 2.0 * math.log(L[i, i])
    return float(-0.5 * (quadratic + log_det + gamma.shape[0] * LOG_2PI))


@jit_kernel
def left_out(y: FloatArray) -> int:
    """How many outputs of ``y`` were not measured (NaN: ``AlignedSignals.measured_outputs``)."""
    count = 0
    for b in range(y.shape[0]):
        if y[b] != y[b]:
            count += 1
    return count


@jit_kernel
def leave_out_unmeasured(
    y: FloatArray, H: FloatArray, gamma: FloatArray, R: FloatArray, R_out: FloatArray
) -> None:
    """Make an update of the measured outputs of ``y`` alone, in place of all of them.

    For each output ``b`` not measured (``y[b]`` NaN) the row ``b`` of ``H`` and ``γ[b]`` are
    set to 0, and ``R_out`` is ``R`` with row and column ``b`` those of the identity.  Then
    ``S = H P Hᵀ + R_out`` is block diagonal, ``S[b, b] = 1``; the gain's column ``b`` is 0, so
    :func:`kalman_update` updates on the measured outputs alone (the prediction stands where
    none is), exactly as with the measured sub-vector's rows of ``H``, ``R`` and ``γ``; and
    :func:`gaussian_log_density` of ``γ`` under ``S`` is the measured sub-vector's, less
    ``log(2π)/2`` per output left out (:func:`measured_log_density` adds it back).
    """
    m = y.shape[0]
    for b in range(m):
        missing_b = y[b] != y[b]
        if missing_b:
            gamma[b] = 0.0
            for a in range(H.shape[1]):
                H[b, a] = 0.0
        for c in range(m):
            if missing_b or y[c] != y[c]:
                R_out[b, c] = 1.0 if b == c else 0.0
            else:
                R_out[b, c] = R[b, c]


@jit_kernel
def measured_log_density(gamma: FloatArray, L: FloatArray, work: FloatArray, left: int) -> float:
    """``log N`` of the measured outputs' innovation, after :func:`leave_out_unmeasured`.

    ``left`` outputs left out; 0 when none was (then :func:`gaussian_log_density` itself).
    """
    return gaussian_log_density(gamma, L, work) + 0.5 * left * LOG_2PI


@jit_kernel
def weighed(distance: float, log_likelihood: float) -> bool:
    """Whether a mode's update weighed the sample: its ``γᵀ S⁻¹ γ`` is ``distance``.

    ``S = ∞`` weighs nothing (log-likelihood ``-∞`` beside a distance of 0 or NaN), nor does a
    ``S`` without Cholesky factor (the caller's).  A distance that overflowed to ``∞``
    (log-likelihood ``-∞`` too) is one: the sample is further from the mode than double
    precision holds, a sample no mode explains
    (:func:`~hybridlog.estimators.vouch.check_surprise`), not one no mode could weigh.
    """
    return (distance < math.inf and log_likelihood > -math.inf) or distance == math.inf


@jit_kernel
def gain(
    P: FloatArray,
    H: FloatArray,
    L: FloatArray,
    PHt: FloatArray,
    column: FloatArray,
    solved: FloatArray,
    K: FloatArray,
) -> None:
    """Kalman gain ``K = P Hᵀ S⁻¹`` with ``S = L Lᵀ`` (Cholesky factor ``L``)."""
    mat_mul_bt(P, H, PHt)
    n, m = PHt.shape
    for i in range(n):
        for j in range(m):
            column[j] = PHt[i, j]
        forward_solve(L, column, solved)
        backward_solve(L, solved, column)
        for j in range(m):
            K[i, j] = column[j]


@jit_kernel
def joseph_update(
    P: FloatArray,
    K: FloatArray,
    H: FloatArray,
    R: FloatArray,
    IKH: FloatArray,
    work_nn: FloatArray,
    work_nm: FloatArray,
    out: FloatArray,
) -> None:
    """``out = (I − K H) P (I − K H)ᵀ + K R Kᵀ`` (Joseph form: symmetric PSD by construction)."""
    n = P.shape[0]
    mat_mul(K, H, IKH)
    for i in range(n):
        for j in range(n):
            IKH[i, j] = (1.0 if i == j else 0.0) - IKH[i, j]
    mat_mul(IKH, P, work_nn)
    mat_mul_bt(work_nn, IKH, out)
    mat_mul(K, R, work_nm)
    m = K.shape[1]
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for k in range(m):
                acc += work_nm[i, k] * K[j, k]
            out[i, j] += acc
    symmetrize(out)


@jit_kernel
def normalize_log(log_weights: FloatArray, out: FloatArray) -> bool:
    """``out = exp(w − logsumexp(w))``; False (``out`` untouched) when no weight is finite."""
    top = -np.inf
    for value in log_weights:
        if value > top:
            top = value
    if not top > -np.inf or not math.isfinite(top):
        return False
    total = 0.0
    for i in range(log_weights.shape[0]):
        total += math.exp(log_weights[i] - top)
    log_total = top + math.log(total)
    for i in range(log_weights.shape[0]):
        out[i] = math.exp(log_weights[i] - log_total)
    return True


@jit_kernel
def mixture_moments(
    weights: FloatArray,
    means: FloatArray,
    covariances: FloatArray,
    mean_out: FloatArray,
    covariance_out: FloatArray,
) -> None:
    """Mean and covariance of a Gaussian mixture (paper 000, eqs. (36)-(37)).

    ``covariance_out = Σ w_i (P_i + (x_i − x̄)(x_i − x̄)ᵀ)``; ``covariances`` may be None-like
    (shape ``(n_modes, 0, 0)``) to get the spread of the means only.
    """
    n = mean_out.shape[0]
    for a in range(n):
        acc = 0.0
        for i in range(weights.shape[0]):
            acc += weights[i] * means[i, a]
        mean_out[a] = acc
    with_covariances = covariances.shape[1] == n
    for a in range(n):
        for b in range(a, n):
            acc = 0.0
            for i in range(weights.shape[0]):
                spread = (means[i, a] - mean_out[a]) * (means[i, b] - mean_out[b])
                if with_covariances:
                    spread += covariances[i, a, b]
                acc += weights[i] * spread
            covariance_out[a, b] = acc
            covariance_out[b, a] = acc


@jit_kernel
def mixture_moments_of(
    weights: FloatArray,
    members: IntArray,
    means: FloatArray,
    covariances: FloatArray,
    mean_out: FloatArray,
    covariance_out: FloatArray,
) -> None:
    """:func:`mixture_moments` of the components ``members`` (increasing) alone.

    The same sums in the same order, less the terms of the components left out: where their
    weights are 0 and their moments finite, those terms are exact zeros, so the result is
    :func:`mixture_moments`'s to the bit.
    """
    n = mean_out.shape[0]
    for a in range(n):
        acc = 0.0
        for i in members:
            acc += weights[i] * means[i, a]
        mean_out[a] = acc
    for a in range(n):
        for b in range(a, n):
            acc = 0.0
            for i in members:
                spread = (means[i, a] - mean_out[a]) * (means[i, b] - mean_out[b])
                acc += weights[i] * (spread + covariances[i, a, b])
            covariance_out[a, b] = acc
            covariance_out[b, a] = acc


@jit
def possible_sources(transitions: FloatArray) -> tuple[IntArray, IntArray]:
    """For each mode ``j`` the modes ``i`` with ``Π[i, j] ≠ 0``: ``(start, sources)``, CSR.

    Mode ``j``'s are ``sources[start[j]:start[j + 1]]``, in increasing order (of ``Πᵀ``:
    the modes each mode can be followed by).  The IMM's mixing and expectation correction's
    pairs sum over them alone: a term with ``Π[i, j] = 0`` adds an exact 0 (``0·x`` or
    ``exp(−∞)``, ``x`` finite; a NaN or infinite estimate still reaches the combined one,
    which mixes every mode), so the sums are the same to the bit.  A model's mode pairs
    (:mod:`~hybridlog.estimators.mode_pairs`) leave ``n`` of their ``n²`` previous pairs
    possible.
    """
    n_q = transitions.shape[0]
    start = np.zeros(n_q + 1, dtype=np.int64)
    for j in range(n_q):
        count = 0
        for i in range(n_q):
            if transitions[i, j] != 0.0:
                count += 1
        start[j + 1] = start[j] + count
    sources = np.empty(start[n_q], dtype=np.int64)
    for j in range(n_q):
        index = start[j]
        for i in range(n_q):
            if transitions[i, j] != 0.0:
                sources[index] = i
                index += 1
    return start, sources


@jit_kernel
def dimensions(run: FilterRun) -> tuple[int, int, int, int]:
    """Samples (of the whole log), states, outputs and modes of a filter run."""
    return run.outputs.shape[0], run.x0.shape[0], run.outputs.shape[1], run.mu0.shape[0]


@jit_kernel
def argmax(values: FloatArray) -> int:
    """Index of the largest value (the first on ties)."""
    best = 0
    for i in range(values.shape[0]):
        if values[i] > values[best]:
            best = i
    return best


@jit_kernel
def record(
    out: FilterBuffers, row: int, mode: int, mu: FloatArray, x: FloatArray, P: FloatArray
) -> None:
    """Write row ``row`` of a filter's output: mode, mode probabilities, mean, covariance.

    ``row`` is the buffers' row: the log's row less the chunk's first
    (:class:`~hybridlog.estimators.common.Chunk`).  The full covariance only where the
    buffers hold them (``covariances`` has no rows otherwise).
    """
    out.modes[row] = mode
    for i in range(mu.shape[0]):
        out.mode_probabilities[row, i] = mu[i]
    for a in range(x.shape[0]):
        out.state_means[row, a] = x[a]
        out.state_variances[row, a] = P[a, a]
    if out.covariances.shape[0] > row:
        for a in range(x.shape[0]):
            for b in range(x.shape[0]):
                out.covariances[row, a, b] = P[a, b]


class Workspace(NamedTuple):
    """Scratch arrays of a filter loop for ``n`` states and ``m`` outputs (:func:`workspace`)."""

    nn: FloatArray
    mn: FloatArray
    nm: FloatArray
    IKH: FloatArray
    K: FloatArray
    S: FloatArray
    L: FloatArray
    m: FloatArray
    m2: FloatArray


@jit
def workspace(n: int, m: int) -> Workspace:
    """The scratch arrays :func:`kalman_update` and the filters' loops work in."""
    return Workspace(
        np.empty((n, n)),
        np.empty((m, n)),
        np.empty((n, m)),
        np.empty((n, n)),
        np.empty((n, m)),
        np.empty((m, m)),
        np.zeros((m, m)),
        np.empty(m),
        np.empty(m),
    )


@jit_kernel
def kalman_update(
    x_pred: FloatArray,
    P_pred: FloatArray,
    H: FloatArray,
    R: FloatArray,
    gamma: FloatArray,
    work: Workspace,
    x_out: FloatArray,
    P_out: FloatArray,
) -> bool:
    """Extended Kalman filter measurement update with the residual ``gamma``.

    ``S = H P Hᵀ + R``, ``K = P Hᵀ S⁻¹``, ``x_out = x_pred + K γ`` and ``P_out`` in the
    Joseph form (paper 000, eqs. (9), (11), (32); the IMM's mode-matched EKF update).
    Returns whether ``S`` is positive definite; ``work.L`` then holds its Cholesky factor
    (otherwise the outputs are not meaningful).
    """
    nn, mn, nm, IKH, K, S, L, vec, vec2 = work  # once: each field access costs a reference
    congruence(H, P_pred, mn, S)
    for b in range(R.shape[0]):
        for c in range(R.shape[1]):
            S[b, c] += R[b, c]
    positive = cholesky(S, L)
    gain(P_pred, H, L, nm, vec, vec2, K)
    for a in range(x_pred.shape[0]):
        acc = x_pred[a]
        for b in range(gamma.shape[0]):
            acc += K[a, b] * gamma[b]
        x_out[a] = acc
    joseph_update(P_pred, K, H, R, IKH, nn, nm, P_out)
    return positive
