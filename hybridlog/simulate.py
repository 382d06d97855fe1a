r"""Simulation of a hybrid model with a mode schedule: logs with ground truth.

Row ``k`` of a simulated log holds ``t_k = k·dt``, the input ``u(k)``, the measured output
``y(k) = h_{q(k)}(x(k), u(k)) + ω(k)``, the true mode ``q(k)`` and state ``x(k)``, with

.. math::

    x(k+1) = f_{q(k+1)}(x(k), u(k)) + \xi(k)

as in paper 000, eq. (2): the mode of row ``k+1`` governs the step into it.  A model may
bound the true states from below (``[simulation] state_min``, e.g. tank levels at 0): the
plant then stays physical while the estimators still use the unbounded model.  A schedule
``"1:100,2:100,3:100"`` gives the number of steps spent in each mode; row 0 (the initial
state) carries the first scheduled mode, so 300 steps make 301 rows.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy
from numba import types

from hybridlog.errors import ModelError, OptionError
from hybridlog.jit import jit_signature
from hybridlog.model.compiled import VECTOR_FUNCTION, ModelFunction, compile_model
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.signals import FloatArray, IntArray


@dataclass(frozen=True)
class SimulatedLog:
    """A simulated run: the columns of the log ``simulate`` writes."""

    time: FloatArray
    inputs: FloatArray
    outputs: FloatArray
    modes: IntArray
    states: FloatArray

    def columns(self, model: HybridModel) -> dict[str, FloatArray | list[str]]:
        """Log columns by name: ``t``, inputs, outputs, ``mode`` (mode ids) and true states."""
        columns: dict[str, FloatArray | list[str]] = {"t": self.time}
        for j, name in enumerate(model.inputs):
            columns[name] = self.inputs[:, j]
        for j, name in enumerate(model.outputs):
            columns[name] = self.outputs[:, j]
        ids = model.mode_ids
        columns["mode"] = [ids[q] for q in self.modes]
        for j, name in enumerate(model.states):
            columns[name] = self.states[:, j]
        return columns


def parse_schedule(text: str, mode_ids: tuple[str, ...]) -> list[tuple[int, int]]:
    """``"1:100,2:50"`` → ``[(index of mode '1', 100), (index of mode '2', 50)]``."""
    schedule: list[tuple[int, int]] = []
    for part in text.split(","):
        part = part.strip()
        mode, sep, count = part.rpartition(":")
        if not sep or not mode:
            raise OptionError(f"--schedule: '{part}' is not MODE:STEPS")
        if mode not in mode_ids:
            raise OptionError(f"--schedule: unknown mode '{mode}' (modes: {', '.join(mode_ids)})")
        try:
            steps = int(count)
        except ValueError as err:
            raise OptionError(f"--schedule: '{count}' in '{part}' is not a whole number") from err
        if steps <= 0:
            raise OptionError(f"--schedule: the step count in '{part}' must be positive")
        schedule.append((mode_ids.index(mode), steps))
    return schedule


def mode_sequence(schedule: list[tuple[int, int]], steps: int | None) -> IntArray:
    """Mode of every row (``steps + 1`` rows); the schedule repeats when ``steps`` is longer."""
    pattern = np.concatenate([np.full(count, mode, dtype=np.int64) for mode, count in schedule])
    total = len(pattern) if steps is None else steps
    if total <= 0:
        raise OptionError("--steps: must be positive")
    repeated = np.resize(pattern, total)
    return np.concatenate([repeated[:1], repeated])


def input_signals(model: HybridModel, time: FloatArray) -> FloatArray:
    """Inputs ``u(k)`` from the model's ``[simulation.inputs]`` expressions of ``t`` and ``k``."""
    t, k = sympy.Symbol("t", real=True), sympy.Symbol("k", real=True)
    steps = np.arange(time.shape[0], dtype=float)
    columns = []
    for name in model.inputs:
        if name not in model.simulation_inputs:
            raise ModelError(
                f"{model.name}: simulation.inputs.{name}: no input signal to simulate with"
            )
        function = sympy.lambdify((t, k), model.simulation_inputs[name], modules="numpy")
        values = np.broadcast_to(np.asarray(function(time, steps), dtype=float), time.shape)
        if not np.all(np.isfinite(values)):
            raise ModelError(f"{model.name}: simulation.inputs.{name}: non-finite values")
        columns.append(values)
    if not columns:
        return np.zeros((time.shape[0], 0))
    return np.ascontiguousarray(np.stack(columns, axis=1))


def _noise_factor(covariance: FloatArray) -> FloatArray:
    """``G`` with ``G Gᵀ = covariance`` for a PSD (possibly singular) covariance."""
    values, vectors = np.linalg.eigh(covariance)
    factor: FloatArray = vectors * np.sqrt(np.clip(values, 0.0, None))
    return factor


_SIGNATURE = types.void(
    VECTOR_FUNCTION,
    VECTOR_FUNCTION,
    types.int64[::1],
    types.float64[:, ::1],
    types.float64[:, :, ::1],
    types.float64[:, ::1],
    types.float64[:, :, ::1],
    types.float64[:, ::1],
    types.float64[:, ::1],
    types.float64[:, ::1],
    types.float64[::1],
)


def _simulate_steps(
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
) -> None:  # compiled as simulate
    n = states.shape[1]
    m = outputs.shape[1]
    clean = np.empty(n)
    measured = np.empty(m)
    for k in range(states.shape[0]):
        q = modes[k]
        if k > 0:
            f(q, states[k - 1], inputs[k - 1], clean)
            for a in range(n):
                acc = clean[a]
                for b in range(n):
                    acc += process_factors[q, a, b] * process_draws[k, b]
                states[k, a] = max(acc, state_min[a])
        h(q, states[k], inputs[k], measured)
        for a in range(m):
            acc = measured[a]
            for b in range(m):
                acc += measurement_factors[q, a, b] * measurement_draws[k, b]
            outputs[k, a] = acc


_simulate_loop = jit_signature(_SIGNATURE)(_simulate_steps)


def simulate(
    model: HybridModel, *, schedule: str | None = None, steps: int | None = None, seed: int = 0
) -> SimulatedLog:
    """Simulate ``model`` along a mode schedule with Gaussian process and measurement noise.

    Parameters
    ----------
    schedule:
        ``"MODE:STEPS,..."``; defaults to the model's ``[simulation] schedule``, else the first
        mode for ``steps`` steps.
    steps:
        Number of steps (rows − 1); defaults to the schedule's total.
    seed:
        Seed of the noise generator (NumPy PCG64): the same seed gives the same log.
    """
    text = schedule or model.simulation_schedule or f"{model.mode_ids[0]}:{steps or 100}"
    modes = mode_sequence(parse_schedule(text, model.mode_ids), steps)
    n_rows = modes.shape[0]
    time = np.arange(n_rows, dtype=float) * model.dt
    inputs = input_signals(model, time)
    rng = np.random.default_rng(seed)
    process_draws = rng.standard_normal((n_rows, model.n_states))
    measurement_draws = rng.standard_normal((n_rows, model.n_outputs))
    states = np.zeros((n_rows, model.n_states))
    states[0] = model.initial_state if model.simulation_state is None else model.simulation_state
    outputs = np.zeros((n_rows, model.n_outputs))
    compiled = compile_model(model)
    _simulate_loop(
        compiled.f,
        compiled.h,
        modes,
        inputs,
        np.ascontiguousarray(np.stack([_noise_factor(m.process_noise) for m in model.modes])),
        process_draws,
        np.ascontiguousarray(np.stack([_noise_factor(m.measurement_noise) for m in model.modes])),
        measurement_draws,
        states,
        outputs,
        np.full(model.n_states, -np.inf)
        if model.simulation_state_min is None
        else model.simulation_state_min,
    )
    if not np.all(np.isfinite(states)) or not np.all(np.isfinite(outputs)):
        row = int(np.argmax(~np.all(np.isfinite(np.hstack([states, outputs])), axis=1)))
        raise ModelError(f"{model.name}: the simulation diverged (non-finite at t = {time[row]})")
    return SimulatedLog(time=time, inputs=inputs, outputs=outputs, modes=modes, states=states)
