r"""Fixed-step integration of a continuous-time mode, compiled (numba kernels).

A continuous-time model (``time = "continuous"``) gives :math:`\dot x = f_q(x, u)` per mode
(``dx(q, x, u, out)`` of :func:`hybridlog.model.compiled.compile_continuous`) and a
:class:`~hybridlog.model.hybrid_model.Timebase`: the integration ``step`` :math:`h`, the
``method`` and the sample time ``dt = substeps · h`` of the log.  Over one sample the input
is held (zero-order hold of ``u(k)``) and the mode is fixed; the state advances ``substeps``
steps of

* ``euler`` (explicit Euler): :math:`x \leftarrow x + h\,f_q(x, u)`, error :math:`O(h)`;
* ``rk4`` (the classical Runge-Kutta method):
  :math:`k_1 = f(x),\ k_2 = f(x + \tfrac h2 k_1),\ k_3 = f(x + \tfrac h2 k_2),\
  k_4 = f(x + h k_3)`, :math:`x \leftarrow x + \tfrac h6 (k_1 + 2k_2 + 2k_3 + k_4)`,
  error :math:`O(h^4)`.

:func:`integrate_step` is plain Python; :func:`step_function` gives it compiled with one
fixed numba signature (the mode function a first-class function argument), so the time
loops that take it as an argument, like the model's functions, are compiled once for every
model, and run as plain Python with the plain function (``jit=False``).  Importing this
module imports neither numba nor sympy.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

import numpy as np

from hybridlog.model.compiled import ModelFunction
from hybridlog.signals import FloatArray

StepFunction = Callable[[ModelFunction, int, int, FloatArray, FloatArray, float, FloatArray], None]
"""``step(dx, method, q, x, u, h, work)``: :func:`integrate_step`, compiled or not."""

EULER = 0
"""Method code of explicit Euler."""
RK4 = 1
"""Method code of the classical fourth-order Runge-Kutta method."""

METHOD_CODES = {"euler": EULER, "rk4": RK4}
"""Method codes by :attr:`~hybridlog.model.hybrid_model.Timebase.method`."""


def work_buffer(n_states: int) -> FloatArray:
    """Scratch space of :func:`integrate_step` for ``n_states`` states, shape ``(5, n)``."""
    return np.zeros((5, n_states))


def integrate_step(
    dx: ModelFunction,
    method: int,
    q: int,
    x: FloatArray,
    u: FloatArray,
    h: float,
    work: FloatArray,
) -> None:
    """Advance ``x`` (in place) by one step ``h`` of ``method`` in mode ``q``, input ``u`` held.

    ``work`` is a ``(5, n)`` scratch array (:func:`work_buffer`).
    """
    n = x.shape[0]
    k1 = work[0]
    if method == EULER:
        dx(q, x, u, k1)
        for i in range(n):
            x[i] += h * k1[i]
        return
    k2, k3, k4, probe = work[1], work[2], work[3], work[4]
    dx(q, x, u, k1)
    for i in range(n):
        probe[i] = x[i] + 0.5 * h * k1[i]
    dx(q, probe, u, k2)
    for i in range(n):
        probe[i] = x[i] + 0.5 * h * k2[i]
    dx(q, probe, u, k3)
    for i in range(n):
        probe[i] = x[i] + h * k3[i]
    dx(q, probe, u, k4)
    for i in range(n):
        x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])


_COMPILED: list[Any] = []
_LOCK = threading.Lock()


def step_function(jit: bool = True) -> StepFunction:
    """:func:`integrate_step` compiled with its fixed signature (``jit``), or plain Python."""
    if not jit:
        return integrate_step
    with _LOCK:
        if not _COMPILED:
            from numba import types

            from hybridlog.jit import compile_signature

            vector = types.float64[::1]
            mode_function = types.FunctionType(types.void(types.int64, vector, vector, vector))
            signature = types.void(
                mode_function,
                types.int64,
                types.int64,
                vector,
                vector,
                types.float64,
                types.float64[:, ::1],
            )
            _COMPILED.append(compile_signature(integrate_step, signature))
        compiled: StepFunction = _COMPILED[0]
        return compiled
