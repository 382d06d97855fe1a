r"""An extended Kalman filter per cluster of a filter cluster (paper 002, Appendix A).

A :class:`~hybridlog.estimators.cpha.structure.Cluster` becomes a :class:`ClusterFilter`:
its ``f``, ``h`` and their Jacobians lambdified once (numpy), and :meth:`ClusterFilter.step`
the EKF of eqs. (12)–(21):

.. math::

    \hat x^- = f(\hat x, u, v),\; A = \partial f/\partial x,\;
    P^- = A P A^T + \tilde Q                                          \quad (12)-(14)

    r = y - g(\hat x^-, u, v),\; C = \partial g/\partial x,\;
    S = C P^- C^T + \tilde R                                          \quad (15)-(17)

    K = P^- C^T S^{-1},\; \hat x = \hat x^- + K r,\; P = (I - K C) P^-  \quad (18)-(20)

    \log P_O = -\tfrac12 r^T S^{-1} r                                  \quad (21)

``v`` are the virtual inputs (measured outputs of other clusters).  Their sensor noise enters
as eq. (6): :math:`\tilde Q = Q + B\,\mathrm{diag}(r_v)B^T` with
:math:`B = \partial f/\partial v` at the previous estimate (footnote 6); where a virtual input
enters an output equation at step k, likewise :math:`\tilde R = R + D\,\mathrm{diag}(r_v)D^T`
with :math:`D = \partial g/\partial v` (the same reading of eq. (6) for algebraic use).

An output the log did not measure at step k (NaN, ``AlignedSignals.measured_outputs``) is
no measurement: :meth:`ClusterFilter.step_numeric` updates on the measured rows of ``C``,
``R`` and ``r`` only, and with none of the cluster's outputs measured the step is the
prediction alone with ``log P_O = 0`` (no evidence for or against the hypothesis).  An output
row whose equation uses a virtual input not measured at k is dropped likewise and left
unpredicted (NaN); a virtual input of ``f`` at k−1 arrives either measured or as the
hypothesis' own estimate with that estimate's variance in place of ``r_v``
(:meth:`~hybridlog.estimators.cpha.hypotheses.Tracker`).

:class:`FilterCache` compiles each distinct cluster once and counts hits.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import cast

import numpy as np
import sympy

from hybridlog.estimators.cpha.structure import Cluster
from hybridlog.model.codegen import lambdify
from hybridlog.signals import BoolArray, FloatArray, IntArray

__all__ = [
    "ClusterFilter",
    "FilterCache",
    "SingularInnovationError",
    "StepResult",
    "compile_cluster",
]

_Fn = Callable[..., list[FloatArray]]


class SingularInnovationError(ArithmeticError):
    """A cluster's innovation covariance ``S`` is finite, not positive definite, of zero noise.

    ``P_O = exp(-rᵀS⁻¹r/2)`` (eq. (21)) has no value there: the model gives an output of the
    cluster no measurement noise (no virtual-input noise either) and no variance of the
    prediction reaches it.  Where every output has noise, ``S ≥ R > 0`` and a failed
    Cholesky factor is rounding of a huge ``P``: ``P_O`` is then read as 0, as before.

    The numpy step read a zero-noise ``S`` as ``P_O = 0`` too, so that with the unknown mode
    every hypothesis went unknown without a word; the straight-line step divided by ``det S = 0``
    and the refusal read "float division by zero … not finite".  Both now raise this.
    """


@dataclass(frozen=True)
class StepResult:
    """One EKF step of a cluster.

    Attributes
    ----------
    x, P:
        ``x̂(k|k)`` and ``P(k|k)`` of the cluster's states.
    y_pred:
        ``g(x̂(k|k-1))``, the one-step-ahead output prediction.
    log_po:
        ``log P_O = -rᵀS⁻¹r/2`` (eq. (21)) over the measured outputs (0 with none);
        ``-inf`` when ``S`` or ``rᵀS⁻¹r`` is not finite (a finite ``S`` that is not
        positive definite raises :class:`SingularInnovationError`).
    held:
        The cluster could not step (its ``f`` uses a virtual input at k−1 that was neither
        measured nor estimated): its mean was held and its variance grown, as for a cluster
        that is not determined (§3.1).
    """

    x: FloatArray
    P: FloatArray
    y_pred: FloatArray
    log_po: float
    held: bool = False


@dataclass(frozen=True)
class ClusterFilter:
    """A compiled cluster: index maps into the model's vectors and the lambdified model.

    Attributes
    ----------
    cluster:
        The structural cluster it was made from.
    states, outputs, inputs, virtual:
        Indices of the cluster's states, outputs, inputs and virtual inputs in the model's
        state, output, input and output vectors.
    Q, R, r_virtual:
        Process, measurement and virtual-input variances (diagonals).
    f_virtual:
        Per virtual input, whether ``f`` uses it (its value at k−1).
    h_virtual:
        Per output and virtual input, whether the output's equation uses it (at k), shape
        ``(len(outputs), len(virtual))``.
    """

    cluster: Cluster
    states: IntArray
    outputs: IntArray
    inputs: IntArray
    virtual: IntArray
    Q: FloatArray
    R: FloatArray
    r_virtual: FloatArray
    f_virtual: BoolArray
    h_virtual: BoolArray
    _predict: _Fn
    _observe: _Fn
    _ekf: Callable[..., tuple[float, ...]] | None = None
    _upper: tuple[IntArray, IntArray] = (np.zeros(0, np.int64), np.zeros(0, np.int64))
    _upper_flat: IntArray = field(default_factory=lambda: np.zeros(0, np.int64))
    _full: IntArray = field(default_factory=lambda: np.zeros((0, 0), np.int64))

    def step(
        self,
        x: FloatArray,
        P: FloatArray,
        u_prev: FloatArray,
        y_prev: FloatArray,
        u_now: FloatArray,
        y_now: FloatArray,
        measured: list[float] | None = None,
    ) -> StepResult:
        """One EKF step (eqs. (12)–(21)) from the cluster's ``x̂(k-1|k-1)``, ``P(k-1|k-1)``.

        ``u_prev``, ``y_prev`` and ``u_now``, ``y_now`` are the model's whole input and
        output vectors at k−1 and k; the cluster takes its inputs and virtual inputs there.
        ``measured``: :meth:`measured` of those, when the caller keeps it for several steps.
        """
        if self._ekf is not None:
            if measured is None:
                measured = self.measured(u_prev, y_prev, u_now, y_now)
            return self._step_unrolled(x, P, u_prev, y_prev, u_now, y_now, measured)
        return self.step_numeric(x, P, u_prev, y_prev, u_now, y_now)

    def measured(
        self, u_prev: FloatArray, y_prev: FloatArray, u_now: FloatArray, y_now: FloatArray
    ) -> list[float]:
        """The cluster's inputs and virtual inputs at k−1 and k and its outputs at k.

        The trailing arguments of the unrolled step (:func:`_unrolled`), the same for every
        estimate filtered at step k.
        """
        return [
            *u_prev[self.inputs].tolist(),
            *y_prev[self.virtual].tolist(),
            *u_now[self.inputs].tolist(),
            *y_now[self.virtual].tolist(),
            *y_now[self.outputs].tolist(),
        ]

    def _step_unrolled(
        self,
        x: FloatArray,
        P: FloatArray,
        u_prev: FloatArray,
        y_prev: FloatArray,
        u_now: FloatArray,
        y_now: FloatArray,
        measured: list[float],
    ) -> StepResult:
        """:meth:`step` by the cluster's EKF written out as scalar code (:func:`_unrolled`)."""
        assert self._ekf is not None
        n, m = len(self.states), len(self.outputs)
        n_p = len(self._upper[0])
        try:
            values = self._ekf(*x.tolist(), *P.reshape(-1)[self._upper_flat].tolist(), *measured)
        except ZeroDivisionError:  # det S = 0 (S⁻¹ by its adjugate), or the model's own 1/0
            with np.errstate(divide="raise", invalid="raise", over="raise"):
                return self.step_numeric(x, P, u_prev, y_prev, u_now, y_now)
        # one array of the results; x̂, ŷ are views of it, P its upper triangle mirrored
        try:
            array = np.array(values, dtype=np.float64)
        except TypeError as err:  # Python's (-8.0)**(1/3) is complex; numpy's would be NaN
            raise ValueError(_complex_value(values)) from err
        for minor in array[n + n_p + m : n + n_p + 2 * m].tolist():
            if not minor > 0.0:  # also NaN
                return self.step_numeric(x, P, u_prev, y_prev, u_now, y_now)
        P_new = array[self._full]
        log_po = float(values[-1])
        if not math.isfinite(log_po):
            log_po = -math.inf
        return StepResult(array[:n], P_new, array[n + n_p : n + n_p + m], log_po)

    def step_numeric(
        self,
        x: FloatArray,
        P: FloatArray,
        u_prev: FloatArray,
        y_prev: FloatArray,
        u_now: FloatArray,
        y_now: FloatArray,
        r_prev: FloatArray | None = None,
    ) -> StepResult:
        """:meth:`step` with numpy matrices (Cholesky of ``S``), on the measured outputs only.

        NaN in ``y_now`` marks an output not measured at k: its rows of ``C``, ``R`` and
        ``r`` are dropped (module docstring), as are those of an output whose equation uses
        a virtual input that is NaN at k (that output is left unpredicted).  ``r_prev``: the
        variances of the virtual inputs at k−1 (default ``r_v``; the variance of an estimate
        standing for one not measured); ``f`` must use none that is NaN in ``y_prev``, and
        the variance of one it does not use is 0.
        """
        v_prev = y_prev[self.virtual]
        noise_prev = self.r_virtual if r_prev is None else r_prev
        args = (*x, *u_prev[self.inputs], *v_prev)
        x_pred, A, B = self._predict(*args)
        x_pred = np.asarray(x_pred, dtype=np.float64).reshape(-1)
        A = np.asarray(A, dtype=np.float64).reshape(len(x), len(x))
        Q = np.diag(self.Q)
        if len(self.virtual):
            B = np.asarray(B, dtype=np.float64).reshape(len(x), len(self.virtual))
            Q = Q + (B * noise_prev) @ B.T  # eq. (6)
        P_pred = A @ P @ A.T + Q
        v_now = y_now[self.virtual]
        obs_args = (*x_pred, *u_now[self.inputs], *v_now)
        y_pred, C, D = self._observe(*obs_args)
        y_pred = np.asarray(y_pred, dtype=np.float64).reshape(-1)
        m = len(self.outputs)
        C = np.asarray(C, dtype=np.float64).reshape(m, len(x))
        y = y_now[self.outputs]
        keep = ~np.isnan(y)
        if len(self.virtual):
            unpredicted = (self.h_virtual & np.isnan(v_now)).any(axis=1)
            y_pred = np.where(unpredicted, np.nan, y_pred)
            keep &= ~unpredicted
        if not keep.any():  # nothing measured: the prediction, no evidence (log P_O = 0)
            return StepResult(x_pred, 0.5 * (P_pred + P_pred.T), y_pred, 0.0)
        C = C[keep]
        R = np.diag(self.R[keep])
        if len(self.virtual):
            D = np.asarray(D, dtype=np.float64).reshape(m, len(self.virtual))[keep]
            # a virtual input not measured at k is in no kept row (those rows are dropped)
            noise_now = np.where(np.isnan(v_now), 0.0, self.r_virtual)
            R = R + (D * noise_now) @ D.T
        r = y[keep] - y_pred[keep]
        S = C @ P_pred @ C.T + R
        try:
            L = np.linalg.cholesky(S)
        except np.linalg.LinAlgError as err:
            noise = np.diag(R).tolist()
            names = [o for o, kept in zip(self.cluster.outputs, keep.tolist(), strict=True) if kept]
            exact = [o for o, r in zip(names, noise, strict=True) if not r > 0.0]
            if exact and np.isfinite(S).all():  # else S ≥ R > 0: rounding (a huge P)
                raise SingularInnovationError(
                    "its innovation covariance S is singular (not positive definite) there: "
                    f"the model gives {', '.join(exact)} no measurement noise and no variance "
                    "of the prediction reaches it (the model's noise, initial covariance), so "
                    "P_O (paper 002 eq. (21)) has no value"
                ) from err
            return StepResult(x_pred, P_pred, y_pred, -math.inf)
        PCt = P_pred @ C.T
        K = np.linalg.solve(L.T, np.linalg.solve(L, PCt.T)).T  # eq. (18)
        x_new = x_pred + K @ r
        P_new = (np.eye(len(x)) - K @ C) @ P_pred
        P_new = 0.5 * (P_new + P_new.T)
        z = np.linalg.solve(L, r)
        log_po = -0.5 * float(z @ z)
        if not math.isfinite(log_po):
            log_po = -math.inf
        return StepResult(x_new, P_new, y_pred, log_po)

    def observe(
        self, x: FloatArray, P: FloatArray, u: FloatArray, y: FloatArray, output: int
    ) -> tuple[float, float]:
        """The estimate of the cluster's output ``output`` at ``x``, ``P`` and its variance.

        ``g_o(x̂)`` and ``C_o P C_oᵀ + D_o diag(r_v) D_oᵀ`` (eq. (17) without the output's own
        sensor noise, with the virtual inputs' as in eq. (6)), with ``u``, ``y`` the model's
        inputs and outputs at that step; NaN where the equation uses a virtual input that is
        NaN there.  What a virtual input not measured is replaced by
        (:meth:`~hybridlog.estimators.cpha.hypotheses.Tracker`).
        """
        row = int(np.flatnonzero(self.outputs == output)[0])
        v = y[self.virtual]
        y_hat, C, D = self._observe(*x, *u[self.inputs], *v)
        m, n_v = len(self.outputs), len(self.virtual)
        value = float(np.asarray(y_hat, dtype=np.float64).reshape(-1)[row])
        c = np.asarray(C, dtype=np.float64).reshape(m, len(x))[row]
        variance = float(c @ P @ c)
        if n_v:
            if (self.h_virtual[row] & np.isnan(v)).any():
                return math.nan, math.nan
            d = np.asarray(D, dtype=np.float64).reshape(m, n_v)[row]
            used = self.h_virtual[row]
            variance += float((d[used] ** 2) @ self.r_virtual[used])
        return value, variance


def compile_cluster(
    cluster: Cluster,
    *,
    states: tuple[str, ...],
    inputs: tuple[str, ...],
    outputs: tuple[str, ...],
    unrolled: bool = True,
) -> ClusterFilter:
    """Lambdify the cluster's ``f``, ``g`` and Jacobians (``∂/∂x`` and ``∂/∂v``).

    ``unrolled``: also write the whole EKF step out as scalar code for small clusters
    (:func:`_unrolled`, several times faster than numpy on 1–4 states); otherwise, and for
    larger clusters, :meth:`ClusterFilter.step` uses numpy matrices.
    """
    x = [sympy.Symbol(s, real=True) for s in cluster.states]
    u = [sympy.Symbol(s, real=True) for s in cluster.inputs]
    v = [sympy.Symbol(s, real=True) for s in cluster.virtual_inputs]
    f = sympy.Matrix(len(cluster.f), 1, list(cluster.f))
    h = sympy.Matrix(len(cluster.h), 1, list(cluster.h))
    F = _jacobian(cluster.f, x)
    B = _jacobian(cluster.f, v)
    H = _jacobian(cluster.h, x)
    D = _jacobian(cluster.h, v)
    args = [*x, *u, *v]
    predict = lambdify(args, [f, F, B], "numpy", cse=True)
    observe = lambdify(args, [h, H, D], "numpy", cse=True)
    ekf = _unrolled(cluster, x, u, v, f, F, B, h, H, D) if unrolled else None
    upper = np.triu_indices(len(x))
    uses = [{str(s) for s in e.free_symbols} for e in cluster.h]
    f_uses = {str(s) for e in cluster.f for s in e.free_symbols}
    return ClusterFilter(
        cluster=cluster,
        states=np.array([states.index(s) for s in cluster.states], dtype=np.int64),
        outputs=np.array([outputs.index(o) for o in cluster.outputs], dtype=np.int64),
        inputs=np.array([inputs.index(i) for i in cluster.inputs], dtype=np.int64),
        virtual=np.array([outputs.index(o) for o in cluster.virtual_inputs], dtype=np.int64),
        Q=np.array(cluster.process_noise, dtype=np.float64),
        R=np.array(cluster.measurement_noise, dtype=np.float64),
        r_virtual=np.array(cluster.virtual_noise, dtype=np.float64),
        f_virtual=np.array([v in f_uses for v in cluster.virtual_inputs], dtype=np.bool_),
        h_virtual=np.array(
            [[v in used for v in cluster.virtual_inputs] for used in uses], dtype=np.bool_
        ).reshape(len(cluster.h), len(cluster.virtual_inputs)),
        _predict=predict,
        _observe=observe,
        _ekf=ekf,
        _upper=upper,
        _upper_flat=upper[0] * len(x) + upper[1],
        _full=_mirrored(len(x)),
    )


def _complex_value(values: tuple[float, ...]) -> str:
    """Why the unrolled EKF step gave a complex number (a refusal, never a guess).

    A fractional power of a negative number (``x1**(1/3)`` at ``x1 < 0``, the real root
    sympy's solution of ``w1**3 = x1`` is written as) is complex in Python's arithmetic:
    the step's results could not be compared or stored, and the run ended in a TypeError
    crash instead of the error naming the cluster and the values where it failed.
    """
    first = next(v for v in values if isinstance(v, complex))
    return (
        f"a complex value ({first:.6g}): a fractional power of a negative number, which has "
        "no real value there"
    )


def _jacobian(expressions: tuple[sympy.Expr, ...], symbols: list[sympy.Symbol]) -> sympy.Matrix:
    """``∂ expressions / ∂ symbols``, of shape ``(len(expressions), len(symbols))``.

    Also where either is empty: a cluster whose outputs its inputs or other outputs alone
    determine (``y1 = u1``, a flow a closed valve sets to 0) has no state, and sympy's
    ``jacobian`` of its empty ``f`` raised a TypeError that ended the run as a crash.
    """
    return sympy.Matrix(
        len(expressions),
        len(symbols),
        lambda i, j: sympy.diff(expressions[i], symbols[j]),
    )


def _mirrored(n: int) -> IntArray:
    """Where each entry of the ``n × n`` covariance is in the results of :func:`_unrolled`.

    ``n`` states come first, then the upper triangle row by row; the lower triangle mirrors it.
    """
    position = np.zeros((n, n), dtype=np.int64)
    for p, (i, j) in enumerate(zip(*np.triu_indices(n), strict=True)):
        position[i, j] = position[j, i] = n + p
    return position


UNROLLED_MAX_STATES = 4
UNROLLED_MAX_OUTPUTS = 3


def _unrolled(
    cluster: Cluster,
    x: list[sympy.Symbol],
    u: list[sympy.Symbol],
    v: list[sympy.Symbol],
    f: sympy.Matrix,
    F: sympy.Matrix,
    B: sympy.Matrix,
    h: sympy.Matrix,
    H: sympy.Matrix,
    D: sympy.Matrix,
) -> Callable[..., tuple[float, ...]] | None:
    """The cluster's whole EKF step (eqs. (12)–(21), (6)) as one scalar function.

    Written out symbolically (``S⁻¹`` by its adjugate) and lambdified with common
    subexpressions for small clusters (at most :data:`UNROLLED_MAX_STATES` states and
    :data:`UNROLLED_MAX_OUTPUTS` outputs); ``None`` otherwise.  Arguments: ``x``, the upper
    triangle of ``P`` row by row, ``u(k-1)``, ``v(k-1)``, ``u(k)``, ``v(k)``, ``y(k)``.
    Returns ``x̂(k|k)``, the upper triangle of ``P(k|k)``, ``g(x̂(k|k-1))``, the leading
    principal minors of ``S`` (all positive when ``S`` is positive definite) and
    ``log P_O``.
    """
    n, m = len(x), len(cluster.outputs)
    if n > UNROLLED_MAX_STATES or m > UNROLLED_MAX_OUTPUTS or m == 0:
        return None
    p = {(i, j): sympy.Symbol(f"p_{i}_{j}", real=True) for i in range(n) for j in range(i, n)}
    P = sympy.Matrix(n, n, lambda i, j: p[(min(i, j), max(i, j))])
    u_prev = [sympy.Symbol(f"uprev_{s}", real=True) for s in u]
    v_prev = [sympy.Symbol(f"vprev_{s}", real=True) for s in v]
    y = [sympy.Symbol(f"meas_{o}", real=True) for o in cluster.outputs]
    at_prev = dict(zip([*u, *v], [*u_prev, *v_prev], strict=True))
    f_k, F_k, B_k = (e.xreplace(at_prev) for e in (f, F, B))
    Q = sympy.diag(*cluster.process_noise)
    if v:
        Q = Q + B_k * sympy.diag(*cluster.virtual_noise) * B_k.T  # eq. (6)
    P_pred = F_k * P * F_k.T + Q
    at_pred = dict(zip(x, list(f_k), strict=True))
    h_k, H_k, D_k = (e.xreplace(at_pred) for e in (h, H, D))
    R = sympy.diag(*cluster.measurement_noise)
    if v:
        R = R + D_k * sympy.diag(*cluster.virtual_noise) * D_k.T
    S = H_k * P_pred * H_k.T + R
    minors = [S[:i, :i].det() for i in range(1, m + 1)]
    S_inv = S.adjugate() / minors[-1]
    K = P_pred * H_k.T * S_inv
    r = sympy.Matrix(y) - h_k
    x_new = f_k + K * r
    P_new = (sympy.eye(n) - K * H_k) * P_pred
    upper = [P_new[i, j] for i in range(n) for j in range(i, n)]
    log_po = -(r.T * S_inv * r)[0, 0] / 2
    args = [*x, *p.values(), *u_prev, *v_prev, *u, *v, *y]
    outputs = [*x_new, *upper, *h_k, *minors, log_po]
    function = lambdify(args, outputs, "math", cse=True)
    return cast(Callable[..., tuple[float, ...]], function)


class FilterCache:
    """Compiled cluster filters by cluster signature; :attr:`hits`, :attr:`misses` count."""

    def __init__(
        self, *, states: tuple[str, ...], inputs: tuple[str, ...], outputs: tuple[str, ...]
    ) -> None:
        self.names = (states, inputs, outputs)
        self._cache: dict[tuple[object, ...], ClusterFilter] = {}
        self.hits = 0
        self.misses = 0
        self.seconds = 0.0

    def get(self, cluster: Cluster) -> ClusterFilter:
        """The compiled filter of ``cluster`` (compiled on first use, timed in ``seconds``)."""
        key = cluster.signature
        found = self._cache.get(key)
        if found is not None:
            self.hits += 1
            return found
        self.misses += 1
        start = time.perf_counter()
        states, inputs, outputs = self.names
        compiled = compile_cluster(cluster, states=states, inputs=inputs, outputs=outputs)
        self._cache[key] = compiled
        self.seconds += time.perf_counter() - start
        return compiled
