"""Small compiled linear-algebra kernels shared by the filters.

The filters work on 2-6 dimensional states; NumPy calls on such tiny arrays cost tens of
microseconds each, so the time loops are compiled whole with numba and use these helpers,
which write into preallocated arrays.
"""

from __future__ import annotations

import math

import numba
import numpy as np

_JIT = {"cache": True, "error_model": "numpy", "nogil": True}
LOG_2PI = math.log(2.0 * math.pi)


@numba.njit(**_JIT)  # type: ignore[misc]
def mat_mul(A: np.ndarray, B: np.ndarray, out: np.ndarray) -> None:
    """``out = A @ B``."""
    for i in range(A.shape[0]):
        for j in range(B.shape[1]):
            acc = 0.0
            for k in range(A.shape[1]):
                acc += A[i, k] * B[k, j]
            out[i, j] = acc


@numba.njit(**_JIT)  # type: ignore[misc]
def mat_mul_bt(A: np.ndarray, B: np.ndarray, out: np.ndarray) -> None:
    """``out = A @ B.T``."""
    for i in range(A.shape[0]):
        for j in range(B.shape[0]):
            acc = 0.0
            for k in range(A.shape[1]):
                acc += A[i, k] * B[j, k]
            out[i, j] = acc


@numba.njit(**_JIT)  # type: ignore[misc]
def congruence(A: np.ndarray, P: np.ndarray, work: np.ndarray, out: np.ndarray) -> None:
    """``out = A P Aᵀ`` (``work`` has the shape of ``A``), symmetric by construction."""
    mat_mul(A, P, work)
    mat_mul_bt(work, A, out)
    symmetrize(out)


@numba.njit(**_JIT)  # type: ignore[misc]
def symmetrize(P: np.ndarray) -> None:
    """Replace ``P`` by ``(P + Pᵀ)/2`` in place."""
    for i in range(P.shape[0]):
        for j in range(i + 1, P.shape[0]):
            mean = 0.5 * (P[i, j] + P[j, i])
            P[i, j] = mean
            P[j, i] = mean


@numba.njit(**_JIT)  # type: ignore[misc]
def cholesky(S: np.ndarray, L: np.ndarray) -> bool:
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


@numba.njit(**_JIT)  # type: ignore[misc]
def forward_solve(L: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:
    """Solve ``L out = b`` for lower-triangular ``L``."""
    for i in range(L.shape[0]):
        acc = b[i]
        for k in range(i):
            acc -= L[i, k] * out[k]
        out[i] = acc / L[i, i]


@numba.njit(**_JIT)  # type: ignore[misc]
def backward_solve(L: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:
    """Solve ``Lᵀ out = b`` for lower-triangular ``L``."""
    n = L.shape[0]
    for i in range(n - 1, -1, -1):
        acc = b[i]
        for k in range(i + 1, n):
            acc -= L[k, i] * out[k]
        out[i] = acc / L[i, i]


@numba.njit(**_JIT)  # type: ignore[misc]
def gaussian_log_density(gamma: np.ndarray, L: np.ndarray, work: np.ndarray) -> float:
    """``log N(γ; 0, S)`` given the Cholesky factor ``L`` of ``S``."""
    forward_solve(L, gamma, work)
    quadratic = 0.0
    log_det = 0.0
    for i in range(gamma.shape[0]):
        quadratic += work[i] * work[i]
        log_det += 2.0 * math.log(L[i, i])
    return -0.5 * (quadratic + log_det + gamma.shape[0] * LOG_2PI)


@numba.njit(**_JIT)  # type: ignore[misc]
def gain(
    P: np.ndarray,
    H: np.ndarray,
    L: np.ndarray,
    PHt: np.ndarray,
    column: np.ndarray,
    solved: np.ndarray,
    K: np.ndarray,
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


@numba.njit(**_JIT)  # type: ignore[misc]
def joseph_update(
    P: np.ndarray,
    K: np.ndarray,
    H: np.ndarray,
    R: np.ndarray,
    IKH: np.ndarray,
    work_nn: np.ndarray,
    work_nm: np.ndarray,
    out: np.ndarray,
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


@numba.njit(**_JIT)  # type: ignore[misc]
def normalize_log(log_weights: np.ndarray, out: np.ndarray) -> bool:
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


@numba.njit(**_JIT)  # type: ignore[misc]
def mixture_moments(
    weights: np.ndarray,
    means: np.ndarray,
    covariances: np.ndarray,
    mean_out: np.ndarray,
    covariance_out: np.ndarray,
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
