"""Source of the extended RTS step of the straight-line backward passes.

The prediction (:func:`rts_prediction_source`), then the guard, gain, mean, covariance and
rounding probe (:func:`rts_correction_source`) of
:func:`~hybridlog.estimators.rts_steps.rts_step` for one next mode, written out in
:mod:`hybridlog.estimators.unrolled`'s program, each test of positive definiteness by the
pivots of ``L D Lᵀ`` (:func:`_positive_pivots`).  Kim's pass writes the step whole
(:func:`~hybridlog.estimators.generated_helpers.step_function`), expectation correction's
in two stages (:mod:`hybridlog.estimators.ec_source`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

from hybridlog.estimators.kernels import PSD_TOLERANCE
from hybridlog.estimators.rts_steps import (
    COVARIANCE,
    GUARD,
    GUARD_TOLERANCE,
    PREDICTION,
    ROUNDING,
    ROUNDING_LIMIT_SQUARED,
    ROUNDING_UNIT,
)
from hybridlog.estimators.unrolled import Entry, Matrix, Program, Vector, product, reshape, term
from hybridlog.model.hybrid_model import HybridModel


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


class PredictionSource(NamedTuple):
    """The variables of one generated RTS prediction (:func:`rts_prediction_source`)."""

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


class StepSource(NamedTuple):
    """The variables of one generated RTS step (:func:`rts_step_source`)."""

    taken: str
    """Whether the step was taken (else the forward estimate stands)."""
    cause: str
    """An expression of the cause's bit (``1 << (cause − 1)``, :func:`note_fallbacks`) of a
    step not taken: the first check that refused it, in :func:`rts_cause`'s order."""
    x: Vector
    P: Matrix
    r: Vector
    """The rounding probe."""


def rts_prediction_source(
    p: Program, model: HybridModel, j: int, x0: Vector, P0: Matrix, u: Vector, Q: Matrix
) -> PredictionSource:
    """Emit the prediction of next mode ``j``'s RTS step (:func:`rts_predict`) from ``x0, P0``."""
    n = len(x0)
    x_pred = p.mode_values(model, j, "f", x0, u)
    F = reshape(p.mode_values(model, j, "F", x0, u), n, n)
    P_pred = p.congruence(f"pp{j}_", F, P0, add=Q)
    L = p.cholesky(f"lc{j}_", P_pred)
    predicted = p.assign("pd", " and ".join(f"{term(L[a][a])} > 0.0" for a in range(n)))
    return PredictionSource(x_pred, F, P_pred, L, predicted)


def rts_step_source(
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
) -> StepSource:
    """Emit the extended RTS step of next mode ``j`` (:func:`rts_step`); its variables.

    Returns the guard's condition (``P^-_j`` and ``P^-_j − P^s_j(k+1)`` positive definite,
    the rounding probe within :data:`ROUNDING_LIMIT`), the step's mean, covariance and
    rounding probe, from ``x0, P0`` (the mixed prior; expectation correction: mode ``i``'s
    filtered estimate) and the smoothed ``xn, Pn`` (rounding probe ``rn``) of the next
    sample.
    """
    prediction = rts_prediction_source(p, model, j, x0, P0, u, Q)
    return rts_correction_source(p, j, x0, P0, Q, xn, Pn, rn, prediction)


def rts_correction_source(
    p: Program,
    j: int,
    x0: Vector,
    P0: Matrix,
    Q: Matrix,
    xn: Vector,
    Pn: Matrix,
    rn: Vector,
    prediction: PredictionSource,
) -> StepSource:
    """Emit the rest of :func:`rts_step_source` once ``prediction`` is emitted.

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
    return StepSource(taken, cause, x_rts, P_rts, r_rts)
