r"""Observer gains from paper 001's poly-quadratic LMI (15), and a numerical certificate.

Find symmetric ``S_i``, and ``G_i``, ``F_i`` with

.. math::

    M_{ij} = \begin{pmatrix} G_i + G_i^T - S_j & G_i^T A_i - F_i^T C_i \\
                             A_i^T G_i - C_i^T F_i & \rho^2 S_i \end{pmatrix} \succ 0
    \qquad \forall (i, j) \in \{1..s\}^2                                            \quad (15)

then ``L_i = G_i^{-T} F_i^T``.  ``ρ = 1`` is the paper's condition; ``ρ < 1`` (option
``decay_rate``) asks for a guaranteed decay.  Why it works (Daafouz & Bernussou 2001): with
``Ã_i = A_i − L_i C_i``, ``G_i^T A_i − F_i^T C_i = G_i^T Ã_i``, and
``G_i + G_i^T − S_j ⪯ G_i^T S_j^{-1} G_i``; a Schur complement then gives

.. math::

    \tilde A_i^T S_j \tilde A_i \prec \rho^2 S_i \qquad \forall (i, j),

so ``V(ε, q) = εᵀ S_q ε`` decreases by at least ``ρ²`` per step along the error dynamics
(10) ``ε(k+1) = Ã_{q(k)} ε(k)`` under *arbitrary* switching.  (The paper writes
``P_i = S_i^{-1}``; with its block order the Lyapunov matrices are the ``S_i`` themselves.)

The LMIs are solved with cvxpy as ``maximise t`` subject to ``M_ij ⪰ t I`` and
``S_i ⪯ I`` (the LMI is homogeneous, so the bound only fixes the scale and the optimum is the
best-conditioned solution).  Clarabel is tried first, SCS second.  After solving, the
certificate ``ρ² S_i − Ã_iᵀ S_j Ã_i ≻ 0`` is checked numerically with the recovered gains and
its margin reported; every ``Ã_i`` must also be Schur (spectral radius < 1).  If no solver
finds a certified solution, :class:`ObserverDesignError` names the modes at fault: a mode
whose own LMI (``i = j``) is infeasible is not detectable at that decay rate (an eigenvalue
the outputs do not see is at least ``ρ`` in size, named), or, observable enough, too hard
for the solvers there (said so); otherwise the modes are only jointly infeasible.

References
----------
Paper 001 (``papers/001_73b6a953d073a2d8.txt``), §4.B, eqs. (8)–(15), Theorem 3.
J. Daafouz, J. Bernussou, "Parameter dependent Lyapunov functions for discrete time systems
with time varying parametric uncertainties", Systems & Control Letters 43 (2001) 355-359.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from hybridlog.errors import ModelError
from hybridlog.signals import FloatArray

__all__ = [
    "SOLVERS",
    "ObserverDesignError",
    "ObserverGains",
    "certificate",
    "observer_gains",
    "unobservable_eigenvalues",
]

SOLVERS = ("CLARABEL", "SCS")
"""Solvers tried in order."""

_MARGIN_MIN = 1e-9
"""Smallest certified margin (relative to the largest eigenvalue of the S_i) accepted."""


class ObserverDesignError(ModelError):
    """The LMI (15) has no (certified) solution for the model's modes."""


@dataclass(frozen=True)
class ObserverGains:
    """Gains ``L_i`` of eq. (8) and their certificate.

    Attributes
    ----------
    gains:
        ``L_i``, shape ``(s, n, p)``.
    lyapunov:
        ``S_i``, shape ``(s, n, n)``: ``V(ε, q) = εᵀ S_q ε``.
    decay_rate:
        The ``ρ`` asked for.
    margin:
        ``min_ij λ_min(ρ² S_i − Ã_iᵀ S_j Ã_i) / max_i λ_max(S_i)`` (> 0: certified).
    decay_bound:
        ``max_ij √λ_max(S_i^{-1/2} Ã_iᵀ S_j Ã_i S_i^{-1/2})``: ``√V`` shrinks at least by this
        factor per step (≤ ρ when certified).
    spectral_radii:
        Spectral radius of each ``A_i − L_i C_i``.
    solver:
        Name of the solver whose solution was certified.
    """

    gains: FloatArray
    lyapunov: FloatArray
    decay_rate: float
    margin: float
    decay_bound: float
    spectral_radii: FloatArray
    solver: str


def certificate(
    A: FloatArray, C: FloatArray, L: FloatArray, S: FloatArray, decay_rate: float = 1.0
) -> tuple[float, float, FloatArray]:
    """Check ``ρ² S_i − Ã_iᵀ S_j Ã_i ≻ 0`` for all ``(i, j)`` numerically.

    Returns
    -------
    tuple
        ``(margin, decay_bound, spectral radii)`` as in :class:`ObserverGains`; the margin
        is negative when the certificate fails, and ``-inf`` (with an infinite bound) when
        no ``S_i`` has a positive eigenvalue, or a gain, ``A_i − L_i C_i`` or ``S_i`` is
        not finite: a solver's
        inaccurate solution holding NaN was "certified" (``min`` passes NaN over, margin
        inf), and ``S_i`` all negative definite gave a positive margin (divided by a
        negative scale); an infinite gain ended as an unexpected ``LinAlgError``.
    """
    s = A.shape[0]
    with np.errstate(over="ignore", invalid="ignore"):
        closed = A - L @ C
    if not (np.all(np.isfinite(closed)) and np.all(np.isfinite(S))):
        return -np.inf, np.inf, np.full(s, np.inf)
    radii = np.array([float(np.abs(np.linalg.eigvals(closed[i])).max()) for i in range(s)])
    scale = max(float(np.linalg.eigvalsh(S[i]).max()) for i in range(s))
    if not scale > 0.0:  # no S_i has a positive eigenvalue: nothing to normalise by
        return -np.inf, np.inf, radii
    margins: list[float] = []  # np.min below: a NaN among them is no margin (min() skips it)
    bound = 0.0
    with np.errstate(over="ignore", invalid="ignore"):
        for i in range(s):
            smallest = float(np.linalg.eigvalsh(S[i]).min())
            margins.append(smallest / scale)
            if not smallest > 0.0:
                bound = np.inf
                continue
            values, vectors = np.linalg.eigh(S[i])
            inverse_root = vectors @ np.diag(values**-0.5) @ vectors.T
            for j in range(s):
                contraction = closed[i].T @ S[j] @ closed[i]
                if not np.all(np.isfinite(contraction)):  # the products overflowed
                    return -np.inf, np.inf, radii
                difference = decay_rate**2 * S[i] - contraction
                symmetric = (difference + difference.T) / 2
                margins.append(float(np.linalg.eigvalsh(symmetric).min()) / scale)
                normalised = inverse_root @ contraction @ inverse_root
                top = float(np.linalg.eigvalsh((normalised + normalised.T) / 2).max())
                bound = max(bound, float(np.sqrt(max(top, 0.0))))
    margin = float(np.min(margins))
    if not np.isfinite(margin):
        return -np.inf, np.inf, radii
    return float(margin), bound, radii


def _value(variable: Any) -> FloatArray:
    value = variable.value
    assert value is not None  # the problem was solved
    return np.asarray(value, dtype=np.float64)


def _solve(
    A: FloatArray, C: FloatArray, decay_rate: float, solver: str
) -> tuple[FloatArray, FloatArray] | str:
    """Solve (15); the gains and S, or the solver's status when it found nothing usable."""
    import cvxpy as cp
    from cvxpy.atoms.affine.bmat import bmat

    s, n, _ = A.shape
    p = C.shape[1]
    S = [cp.Variable((n, n), symmetric=True) for _ in range(s)]
    G = [cp.Variable((n, n)) for _ in range(s)]
    F = [cp.Variable((p, n)) for _ in range(s)]
    t = cp.Variable()
    identity = np.eye(2 * n)
    constraints = []
    for i in range(s):
        off = G[i].T @ A[i] - F[i].T @ C[i]
        constraints.append(S[i] << np.eye(n))
        for j in range(s):
            block = bmat(  # type: ignore[no-untyped-call]
                [[G[i] + G[i].T - S[j], off], [off.T, decay_rate**2 * S[i]]]
            )
            constraints.append((block + block.T) / 2 - t * identity >> 0)
    problem = cp.Problem(cp.Maximize(t), constraints)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            problem.solve(solver=solver)  # type: ignore[no-untyped-call]
    except (cp.error.SolverError, ArithmeticError, ValueError) as err:
        return f"{solver} failed ({type(err).__name__})"
    if problem.status not in ("optimal", "optimal_inaccurate") or t.value is None:
        return f"{solver}: {problem.status}"
    if float(t.value) <= 0.0:
        return f"{solver}: infeasible (best margin {float(t.value):.3g})"
    values = [(_value(G[i]), _value(F[i]), _value(S[i])) for i in range(s)]
    try:
        gains = np.stack([np.linalg.solve(g.T, f.T) for g, f, _ in values])
    except np.linalg.LinAlgError:  # an inaccurate "solution" of a badly scaled model
        return f"{solver}: a G_i of its solution is singular"
    lyapunov = np.stack([(v + v.T) / 2 for _, _, v in values])
    return gains, lyapunov


def _certified(A: FloatArray, C: FloatArray, decay_rate: float, solver: str) -> ObserverGains | str:
    """Solve (15) with one solver and check the certificate; the gains or why not."""
    solved = _solve(A, C, decay_rate, solver)
    if isinstance(solved, str):
        return solved
    gains, lyapunov = solved
    margin, bound, radii = certificate(A, C, gains, lyapunov, decay_rate)
    if margin > _MARGIN_MIN and np.all(radii < 1.0):
        return ObserverGains(
            gains=gains,
            lyapunov=lyapunov,
            decay_rate=decay_rate,
            margin=margin,
            decay_bound=bound,
            spectral_radii=radii,
            solver=solver,
        )
    if margin == -np.inf:
        return f"{solver}: certificate failed (its solution is not finite, or no S_i is positive)"
    return f"{solver}: certificate failed (margin {margin:.3g})"


def observer_gains(
    A: FloatArray,
    C: FloatArray,
    mode_ids: Sequence[str],
    *,
    decay_rate: float = 1.0,
    model_name: str = "model",
    solvers: Sequence[str] = SOLVERS,
) -> ObserverGains:
    """Gains ``L_i`` of the switched observer (8) from the LMI (15), certified.

    Parameters
    ----------
    A, C:
        ``A_i`` ``(s, n, n)`` and ``C_i`` ``(s, p, n)``.
    mode_ids:
        Mode ids, for error messages.
    decay_rate:
        ``ρ`` in ``(0, 1]``: the Lyapunov function must shrink at least by ``ρ²`` per step.
    model_name:
        For error messages.
    solvers:
        cvxpy solver names to try in order.

    Raises
    ------
    ObserverDesignError
        When no solver gives a solution whose certificate holds; names the modes.
    """
    A = np.asarray(A, dtype=np.float64)
    C = np.asarray(C, dtype=np.float64)
    if not 0.0 < decay_rate <= 1.0:
        raise ObserverDesignError(f"decay_rate: must be in (0, 1], got {decay_rate!r}")
    statuses: list[str] = []
    for solver in solvers:
        outcome = _certified(A, C, decay_rate, solver)
        if isinstance(outcome, ObserverGains):
            return outcome
        statuses.append(outcome)
    raise ObserverDesignError(_infeasible_message(A, C, mode_ids, decay_rate, model_name, statuses))


def unobservable_eigenvalues(A: FloatArray, C: FloatArray) -> list[complex]:
    """The eigenvalues of ``A`` that ``y = C x`` does not see (PBH: ``[λI − A; C]`` rank-deficient).

    Rank is judged by the smallest singular value against ``√ε`` times the size of
    ``[A; C]`` (an eigenvalue is only as accurate as that for a non-normal ``A``).  Each
    row of ``C`` is scaled to length 1 first, which changes no rank: an output
    ``y = x1 + 1e308*x2`` made the size of ``[A; C]`` overflow to inf and every eigenvalue
    "unobservable", and one ``y = 1e-300*x1`` saw nothing against ``√ε``.
    """
    n = A.shape[0]
    C = np.asarray(C, dtype=np.float64)
    largest = np.max(np.abs(C), axis=1, keepdims=True) if C.size else np.ones((0, 1))
    C = C / np.where(largest > 0.0, largest, 1.0)  # no overflow in the norm below
    lengths = np.linalg.norm(C, axis=1, keepdims=True)
    C = C / np.where(lengths > 0.0, lengths, 1.0)
    scale = max(1.0, float(np.linalg.norm(np.vstack([A, C]), 2)))
    tolerance = float(np.sqrt(np.finfo(np.float64).eps)) * scale
    unseen: list[complex] = []
    for value in np.linalg.eigvals(A):
        pencil = np.vstack([value * np.eye(n) - A, C.astype(np.complex128)])
        if np.linalg.svd(pencil, compute_uv=False)[-1] <= tolerance:
            unseen.append(complex(value))
    return unseen


def _shown(value: complex) -> str:
    return f"{value.real:.4g}" if value.imag == 0.0 else f"{value:.4g}"


def _undetectable(A: FloatArray, C: FloatArray, mode: str, decay_rate: float) -> str | None:
    """Why mode ``mode`` alone has no gain at ``ρ``, when an unseen eigenvalue is the reason.

    The LMI of one mode is feasible exactly when some ``L`` makes the spectral radius of
    ``A − L C`` below ``ρ``, that is when every eigenvalue the outputs do not see is below
    ``ρ`` in size; ``None`` when every one is (the solvers, not the mode, failed).
    """
    slow = [v for v in unobservable_eigenvalues(A, C) if abs(v) >= decay_rate]
    if not slow:
        return None
    worst = max(slow, key=abs)
    return (
        f"mode '{mode}' is not detectable at decay rate {decay_rate:g}: its eigenvalue "
        f"{_shown(worst)} (|λ| = {abs(worst):.4g}) is unobservable from the outputs"
    )


def _infeasible_message(
    A: FloatArray,
    C: FloatArray,
    mode_ids: Sequence[str],
    decay_rate: float,
    model_name: str,
    statuses: list[str],
) -> str:
    alone = [
        i
        for i in range(A.shape[0])
        if A.shape[0] == 1
        or isinstance(_certified(A[i : i + 1], C[i : i + 1], decay_rate, SOLVERS[0]), str)
    ]
    detail = "; ".join(statuses)
    if alone:
        # an observable mode at a small decay rate (the double cart at 0.01) was said to be
        # "not detectable from the outputs": its LMI is only too hard for the solvers there
        found = {i: _undetectable(A[i], C[i], mode_ids[i], decay_rate) for i in alone}
        reasons = [why for why in found.values() if why is not None]
        hard = [f"'{mode_ids[i]}'" for i, why in found.items() if why is None]
        if hard:
            reasons.append(
                f"mode(s) {', '.join(hard)} admit a gain in theory (every eigenvalue the "
                f"outputs do not see is below {decay_rate:g} in size), but no solver found a "
                "certified one"
                + (": a decay rate nearer 1 asks less of them" if decay_rate < 1.0 else "")
            )
        return (
            f"{model_name}: the observer LMI (15) of paper 001 is infeasible at decay rate "
            f"{decay_rate:g}: {'; '.join(reasons)} [{detail}]"
        )
    names = ", ".join(f"'{m}'" for m in mode_ids)
    return (
        f"{model_name}: the observer LMI (15) of paper 001 is infeasible for modes {names} "
        f"jointly at decay rate {decay_rate:g} (no common poly-quadratic Lyapunov function) "
        f"[{detail}]"
    )
