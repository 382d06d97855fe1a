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

State-driven switching: when every mode has a ``guard`` (``guard = "x3 <= 0"``), the mode of
row ``k`` is the first mode, in file order, whose guard holds at ``x(k)`` (and ``u(k)``); it
gives ``y(k)`` and also governs the step out of row ``k``,

.. math::

    x(k+1) = f_{q(k)}(x(k), u(k)) + \xi(k), \qquad q(k) = \text{mode whose guard holds at } x(k)

as in paper 001, eq. (1) (the mode cannot be decided by ``x(k+1)`` before that state
exists).  A row where no guard holds is an error.  The guards are compiled with numba
(cached on disk beside the model's functions), so 10^4 steps take milliseconds.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numba
import numpy as np
import sympy
from numba import types
from sympy.printing.pycode import PythonCodePrinter

from hybridlog.errors import ModelError, OptionError
from hybridlog.jit import jit, jit_signature
from hybridlog.model.compiled import (
    VECTOR_FUNCTION,
    ModelFunction,
    compile_model,
    load_generated,
)
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.signals import AlignedSignals, FloatArray, IntArray


@dataclass(frozen=True)
class SimulatedLog:
    """A simulated run: the columns of the log ``simulate`` writes."""

    time: FloatArray
    inputs: FloatArray
    outputs: FloatArray
    modes: IntArray
    states: FloatArray

    def signals(self, model: HybridModel, source: str = "simulation") -> AlignedSignals:
        """The run as the estimators' input, ground truth (modes and states) included."""
        return AlignedSignals(
            source=source,
            time=self.time,
            input_names=model.inputs,
            output_names=model.outputs,
            inputs=self.inputs,
            outputs=self.outputs,
            truth_modes=self.modes,
            state_names=model.states,
            truth_states=self.states,
        )

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


_simulate_loop = jit_signature(_SIGNATURE)(_simulate_steps)

GUARD_SIGNATURE = types.int64(types.float64[::1], types.float64[::1])
"""``guard(x, u)``: index of the first mode whose guard holds, or -1."""
GUARD_FUNCTION = types.FunctionType(GUARD_SIGNATURE)
GuardFunction = Callable[[FloatArray, FloatArray], int]


def guard_source(model: HybridModel) -> str:
    """Python source of ``guard(x, u)`` for a state-driven model."""
    xs, us = model.symbols()
    names = {x: sympy.Symbol(f"x_{i}") for i, x in enumerate(xs)}
    names.update({u: sympy.Symbol(f"u_{i}") for i, u in enumerate(us)})
    printer = PythonCodePrinter({"fully_qualified_modules": True, "standard": "python3"})
    lines = ["import math", "", "", "def guard(x, u):"]
    lines += [f"    x_{i} = x[{i}]" for i in range(model.n_states)]
    lines += [f"    u_{i} = u[{i}]" for i in range(model.n_inputs)]
    for index, mode in enumerate(model.modes):
        assert mode.guard is not None
        lines.append(f"    if {printer.doprint(mode.guard.xreplace(names))}:  # mode {mode.id!r}")
        lines.append(f"        return {index}")
    lines.append("    return -1")
    return "\n".join(lines) + "\n"


_GUARDS: dict[str, GuardFunction] = {}


def compile_guard(model: HybridModel, *, jit: bool = True) -> GuardFunction:
    """The model's guard function, compiled (cached on disk) or as plain Python."""
    source = guard_source(model)
    memo = f"{jit}|{source}"
    if memo in _GUARDS:
        return _GUARDS[memo]
    if jit:
        module = load_generated(source)
        function: GuardFunction = numba.njit(GUARD_SIGNATURE, cache=True)(module.guard)
    else:
        namespace: dict[str, Any] = {}
        exec(compile(source, f"<hybridlog guards {model.name}>", "exec"), namespace)
        function = namespace["guard"]
    _GUARDS[memo] = function
    return function


_GUARDED_SIGNATURE = types.int64(
    VECTOR_FUNCTION,
    VECTOR_FUNCTION,
    GUARD_FUNCTION,
    types.float64[:, ::1],
    types.float64[:, :, ::1],
    types.float64[:, ::1],
    types.float64[:, :, ::1],
    types.float64[:, ::1],
    types.float64[:, ::1],
    types.float64[:, ::1],
    types.int64[::1],
    types.float64[::1],
)


def _simulate_guarded_steps(
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
) -> int:  # compiled as simulate (state-driven); returns the row where no guard held, or -1
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


_simulate_guarded_loop = jit_signature(_GUARDED_SIGNATURE)(_simulate_guarded_steps)


def simulate(
    model: HybridModel,
    *,
    schedule: str | None = None,
    steps: int | None = None,
    seed: int = 0,
    jit: bool = True,
) -> SimulatedLog:
    """Simulate ``model`` with Gaussian process and measurement noise.

    Parameters
    ----------
    schedule:
        ``"MODE:STEPS,..."``; defaults to the model's ``[simulation] schedule``, else the first
        mode for ``steps`` steps.  Not allowed for a state-driven model (mode guards).
    steps:
        Number of steps (rows − 1); defaults to the schedule's total (100 for a state-driven
        model).
    seed:
        Seed of the noise generator (NumPy PCG64): the same seed gives the same log.
    jit:
        Compiled loop (default) or the same code in plain Python (tests).
    """
    model.check_supported("simulate")
    if model.state_driven:
        if schedule:
            raise OptionError(
                f"--schedule: {model.name} switches by its mode guards (modes.<id>.guard); "
                "a schedule does not apply"
            )
        if steps is not None and steps <= 0:
            raise OptionError("--steps: must be positive")
        modes = np.zeros((steps or 100) + 1, dtype=np.int64)
    else:
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
    compiled = compile_model(model, jit=jit)
    process_factors = np.ascontiguousarray(
        np.stack([_noise_factor(m.process_noise) for m in model.modes])
    )
    measurement_factors = np.ascontiguousarray(
        np.stack([_noise_factor(m.measurement_noise) for m in model.modes])
    )
    state_min = (
        np.full(model.n_states, -np.inf)
        if model.simulation_state_min is None
        else model.simulation_state_min
    )
    if model.state_driven:
        loop = _simulate_guarded_loop if jit else _simulate_guarded_steps
        stuck = loop(
            compiled.f,
            compiled.h,
            compile_guard(model, jit=jit),
            inputs,
            process_factors,
            process_draws,
            measurement_factors,
            measurement_draws,
            states,
            outputs,
            modes,
            state_min,
        )
        if stuck >= 0:
            raise ModelError(
                f"{model.name}: no mode's guard (modes.<id>.guard) holds at t = {time[stuck]} "
                f"(x = {states[stuck].tolist()})"
            )
    else:
        (_simulate_loop if jit else _simulate_steps)(
            compiled.f,
            compiled.h,
            modes,
            inputs,
            process_factors,
            process_draws,
            measurement_factors,
            measurement_draws,
            states,
            outputs,
            state_min,
        )
    if not np.all(np.isfinite(states)) or not np.all(np.isfinite(outputs)):
        row = int(np.argmax(~np.all(np.isfinite(np.hstack([states, outputs])), axis=1)))
        raise ModelError(f"{model.name}: the simulation diverged (non-finite at t = {time[row]})")
    return SimulatedLog(time=time, inputs=inputs, outputs=outputs, modes=modes, states=states)
