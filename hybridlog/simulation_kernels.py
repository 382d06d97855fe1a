r"""The time loops of :mod:`hybridlog.simulate`, as plain Python compiled on first use.

Kept apart from :mod:`hybridlog.simulate` so that importing the command's module does not
import numba: this module is imported when a simulation runs.  The loops take the model's
compiled functions (:mod:`hybridlog.model.compiled`) as arguments; their numba signatures are
derived from the arguments of the first call (:func:`hybridlog.jit.compile_for`).
"""

from __future__ import annotations

import numpy as np

from hybridlog.jit import jit
from hybridlog.model.compiled import GuardFunction, JumpFunction, ModelFunction
from hybridlog.model.integration import StepFunction
from hybridlog.signals import FloatArray, IntArray


@jit
def add_noise(
    clean: FloatArray, factor: FloatArray, draws: FloatArray, lower: FloatArray, out: FloatArray
) -> None:
    """``out = max(clean + G w, lower)`` for a noise factor ``G`` and standard normal ``w``."""
    for a in range(out.shape[0]):
        acc = clean[a]
        for b in range(draws.shape[0]):
            acc += factor[a, b] * draws[b]
        out[a] = max(acc, lower[a])


def simulate_steps(
    f: ModelFunction,
    h: ModelFunction,
    modes: IntArray,
    inputs: FloatArray,
    process_factors: FloatArray,
    process_draws: FloatArray,
    measurement_factors: FloatArray,
    measurement_draws: FloatArray,
    states: FloatArray,
    outputs: FloatArray,
    state_min: FloatArray,
) -> None:
    r"""Scheduled modes: :math:`x(k+1) = f_{q(k+1)}(x(k), u(k)) + \xi(k)` (paper 000, eq. (2))."""
    clean = np.empty(states.shape[1])
    measured = np.empty(outputs.shape[1])
    no_bound = np.full(outputs.shape[1], -np.inf)
    for k in range(states.shape[0]):
        q = modes[k]
        if k > 0:
            f(q, states[k - 1], inputs[k - 1], clean)
            add_noise(clean, process_factors[q], process_draws[k], state_min, states[k])
        h(q, states[k], inputs[k], measured)
        add_noise(measured, measurement_factors[q], measurement_draws[k], no_bound, outputs[k])


def simulate_guarded_steps(
    f: ModelFunction,
    h: ModelFunction,
    guard: GuardFunction,
    inputs: FloatArray,
    process_factors: FloatArray,
    process_draws: FloatArray,
    measurement_factors: FloatArray,
    measurement_draws: FloatArray,
    states: FloatArray,
    outputs: FloatArray,
    modes: IntArray,
    state_min: FloatArray,
) -> int:
    r"""State-driven modes: :math:`x(k+1) = f_{q(k)}(x(k), u(k)) + \xi(k)` (paper 001, eq. (1)).

    Returns the row where no guard held (or one compared a NaN: ``guard`` < -1), or -1.
    """
    clean = np.empty(states.shape[1])
    measured = np.empty(outputs.shape[1])
    no_bound = np.full(outputs.shape[1], -np.inf)
    for k in range(states.shape[0]):
        if k > 0:
            q = modes[k - 1]
            f(q, states[k - 1], inputs[k - 1], clean)
            add_noise(clean, process_factors[q], process_draws[k], state_min, states[k])
        q = guard(states[k], inputs[k])
        if q < 0:
            return k
        modes[k] = q
        h(q, states[k], inputs[k], measured)
        add_noise(measured, measurement_factors[q], measurement_draws[k], no_bound, outputs[k])
    return -1


def simulate_continuous_steps(
    advance: StepFunction,
    dx: ModelFunction,
    h: ModelFunction,
    jump: JumpFunction,
    method: int,
    step: float,
    substeps: int,
    modes: IntArray,
    inputs: FloatArray,
    time: FloatArray,
    process_factors: FloatArray,
    process_draws: FloatArray,
    measurement_factors: FloatArray,
    measurement_draws: FloatArray,
    disturbance: FloatArray,
    states: FloatArray,
    outputs: FloatArray,
    state_min: FloatArray,
) -> None:
    r"""Continuous time: the interval :math:`(t_{k-1}, t_k]` runs in mode ``q(k)``, ``u(k-1)`` held.

    At a switch (``q(k) ≠ q(k-1)``) the jump map is applied first,
    :math:`x \leftarrow R(q(k-1), q(k), x(t_{k-1}))` (paper 004, eq. (3)); then ``substeps``
    integration steps of ``method`` (``advance``, from
    :func:`hybridlog.model.integration.step_function`),
    each followed by the disturbance :math:`h\,\varepsilon(x, t)` of paper 003 eq. (49),
    :math:`\varepsilon_i = a \sum_j |x_j| \sin(\omega t)` with ``disturbance = (a, ω)``
    evaluated before the step (Euler on :math:`f + \varepsilon` for ``euler``), and the
    Euler-Maruyama increment :math:`G\sqrt h\,w` of the process noise (``G Gᵀ`` the
    intensity ``Q_q``), then the bound ``state_min``.  ``process_draws`` has one row per
    integration step (``(N - 1) · substeps`` rows).
    """
    n = states.shape[1]
    work = np.zeros((5, n))
    x = states[0].copy()
    jumped = np.empty(n)
    measured = np.empty(outputs.shape[1])
    no_bound = np.full(outputs.shape[1], -np.inf)
    root = np.sqrt(step)
    amplitude, omega = disturbance[0], disturbance[1]
    for k in range(states.shape[0]):
        q = modes[k]
        if k > 0:
            if q != modes[k - 1]:
                jump(modes[k - 1], q, x, jumped)
                x[:] = jumped
            for s in range(substeps):
                push = 0.0
                if amplitude != 0.0:
                    size = 0.0
                    for i in range(n):
                        size += abs(x[i])
                    push = step * amplitude * size * np.sin(omega * (time[k - 1] + s * step))
                advance(dx, method, q, x, inputs[k - 1], step, work)
                row = (k - 1) * substeps + s
                for i in range(n):
                    acc = 0.0
                    for j in range(n):
                        acc += process_factors[q, i, j] * process_draws[row, j]
                    x[i] = max(x[i] + push + root * acc, state_min[i])
        states[k, :] = x
        h(q, x, inputs[k], measured)
        add_noise(measured, measurement_factors[q], measurement_draws[k], no_bound, outputs[k])
