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

:class:`FilterCache` compiles each distinct cluster once and counts hits.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import sympy

from hybridlog.estimators.cpha.structure import Cluster
from hybridlog.signals import FloatArray, IntArray

__all__ = ["ClusterFilter", "FilterCache", "StepResult", "compile_cluster"]

_Fn = Callable[..., list[FloatArray]]


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
        ``log P_O = -rᵀS⁻¹r/2`` (eq. (21)); ``-inf`` when ``S`` is not positive definite.
    """

    x: FloatArray
    P: FloatArray
    y_pred: FloatArray
    log_po: float


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
    """

    cluster: Cluster
    states: IntArray
    outputs: IntArray
    inputs: IntArray
    virtual: IntArray
    Q: FloatArray
    R: FloatArray
    r_virtual: FloatArray
    _predict: _Fn
    _observe: _Fn

    def step(
        self,
        x: FloatArray,
        P: FloatArray,
        u_prev: FloatArray,
        y_prev: FloatArray,
        u_now: FloatArray,
        y_now: FloatArray,
    ) -> StepResult:
        """One EKF step (eqs. (12)–(21)) from the cluster's ``x̂(k-1|k-1)``, ``P(k-1|k-1)``.

        ``u_prev``, ``y_prev`` and ``u_now``, ``y_now`` are the model's whole input and
        output vectors at k−1 and k; the cluster takes its inputs and virtual inputs there.
        """
        args = (*x, *u_prev[self.inputs], *y_prev[self.virtual])
        x_pred, A, B = self._predict(*args)
        x_pred = np.asarray(x_pred, dtype=np.float64).reshape(-1)
        A = np.asarray(A, dtype=np.float64).reshape(len(x), len(x))
        Q = np.diag(self.Q)
        if len(self.virtual):
            B = np.asarray(B, dtype=np.float64).reshape(len(x), len(self.virtual))
            Q = Q + (B * self.r_virtual) @ B.T  # eq. (6)
        P_pred = A @ P @ A.T + Q
        obs_args = (*x_pred, *u_now[self.inputs], *y_now[self.virtual])
        y_pred, C, D = self._observe(*obs_args)
        y_pred = np.asarray(y_pred, dtype=np.float64).reshape(-1)
        m = len(self.outputs)
        C = np.asarray(C, dtype=np.float64).reshape(m, len(x))
        R = np.diag(self.R)
        if len(self.virtual):
            D = np.asarray(D, dtype=np.float64).reshape(m, len(self.virtual))
            R = R + (D * self.r_virtual) @ D.T
        r = y_now[self.outputs] - y_pred
        S = C @ P_pred @ C.T + R
        try:
            L = np.linalg.cholesky(S)
        except np.linalg.LinAlgError:
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


def compile_cluster(
    cluster: Cluster,
    *,
    states: tuple[str, ...],
    inputs: tuple[str, ...],
    outputs: tuple[str, ...],
) -> ClusterFilter:
    """Lambdify the cluster's ``f``, ``g`` and Jacobians (``∂/∂x`` and ``∂/∂v``)."""
    x = [sympy.Symbol(s, real=True) for s in cluster.states]
    u = [sympy.Symbol(s, real=True) for s in cluster.inputs]
    v = [sympy.Symbol(s, real=True) for s in cluster.virtual_inputs]
    f = sympy.Matrix(cluster.f)
    h = sympy.Matrix(cluster.h)
    xv = sympy.Matrix(x)
    vv = sympy.Matrix(v) if v else sympy.zeros(0, 1)
    F = f.jacobian(xv)
    B = f.jacobian(vv) if v else sympy.zeros(len(x), 0)
    H = h.jacobian(xv)
    D = h.jacobian(vv) if v else sympy.zeros(len(cluster.outputs), 0)
    args = [*x, *u, *v]
    predict = sympy.lambdify(args, [f, F, B], modules="numpy", cse=True)
    observe = sympy.lambdify(args, [h, H, D], modules="numpy", cse=True)
    return ClusterFilter(
        cluster=cluster,
        states=np.array([states.index(s) for s in cluster.states], dtype=np.int64),
        outputs=np.array([outputs.index(o) for o in cluster.outputs], dtype=np.int64),
        inputs=np.array([inputs.index(i) for i in cluster.inputs], dtype=np.int64),
        virtual=np.array([outputs.index(o) for o in cluster.virtual_inputs], dtype=np.int64),
        Q=np.array(cluster.process_noise, dtype=np.float64),
        R=np.array(cluster.measurement_noise, dtype=np.float64),
        r_virtual=np.array(cluster.virtual_noise, dtype=np.float64),
        _predict=predict,
        _observe=observe,
    )


class FilterCache:
    """Compiled cluster filters by cluster signature; :attr:`hits`, :attr:`misses` count."""

    def __init__(
        self, *, states: tuple[str, ...], inputs: tuple[str, ...], outputs: tuple[str, ...]
    ) -> None:
        self.names = (states, inputs, outputs)
        self._cache: dict[tuple[object, ...], ClusterFilter] = {}
        self.hits = 0
        self.misses = 0

    def get(self, cluster: Cluster) -> ClusterFilter:
        """The compiled filter of ``cluster`` (compiled on first use)."""
        key = cluster.signature
        found = self._cache.get(key)
        if found is not None:
            self.hits += 1
            return found
        self.misses += 1
        states, inputs, outputs = self.names
        compiled = compile_cluster(cluster, states=states, inputs=inputs, outputs=outputs)
        self._cache[key] = compiled
        return compiled
