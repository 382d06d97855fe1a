r"""The time loops of :mod:`hybridlog.simulate`, as plain Python compiled on first use.

Kept apart from :mod:`hybridlog.simulate` so that importing the command's module does not
import numba: this module is imported when a simulation runs.  The loops take the model's
compiled functions (:mod:`hybridlog.model.compiled`) as arguments; their numba signatures are
derived from the arguments of the first call (:func:`hybridlog.jit.compile_for`).
"""

from __future__ import annotations

import numpy as np

from hybridlog.jit import jit
from hybridlog.model.compiled import GuardFunction, ModelFunction
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

    Returns the row where no guard held, or -1.
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
