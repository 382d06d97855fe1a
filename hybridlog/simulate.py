r"""Simulation of a hybrid model with a mode schedule: logs with ground truth.

Row ``k`` of a simulated log holds ``t_k = k·dt`` (the float nearest the decimal product,
:func:`sample_times`), the input ``u(k)``, the measured output
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
exists).  A row where no guard holds is an error.

Continuous time (``time = "continuous"``, paper 003 eq. (1), paper 004 eq. (2)): row ``k``
is sampled at ``t_k = k·dt`` and the same convention holds, the mode of row ``k`` governs
the interval :math:`(t_{k-1}, t_k]` into it, with the input ``u(k-1)`` held over it; the
switch from ``q(k-1)`` to ``q(k)`` happens at :math:`t_{k-1}^+`, where the model's jump map
resets the state first, :math:`x \leftarrow R(q(k-1), q(k), x(t_{k-1}))` (paper 004,
eq. (3)); row ``k-1`` keeps the state before the jump.  The state is integrated with the
model's fixed step and method (:mod:`hybridlog.model.integration`), ``dt / step`` steps a
row; the model's process noise ``Q_q`` is an intensity (Euler-Maruyama, ``√step`` scaled draws per
step), the optional :class:`Disturbance` is paper 003's eq. (49).  A schedule's counts are
rows (``"7:50"`` at ``dt = 0.01`` is a dwell of 0.5 s).

The model's functions, guards and input signals come from the one compiled-code cache
(:mod:`hybridlog.model.compiled`): with a warm cache a simulation runs no sympy and compiles
nothing, and 10^4 steps take milliseconds.  Importing this module imports neither numba nor
sympy (the loops live in :mod:`hybridlog.simulation_kernels`).

The parts of a run live beside it: its times, inputs, start state and disturbance in
:mod:`hybridlog.simulation_inputs`, its schedule in :mod:`hybridlog.simulation_schedule`, the
limits checked before it starts in :mod:`hybridlog.simulation_limits`, and the checks of where
it went in :mod:`hybridlog.simulation_range` (values a log may hold) and
:mod:`hybridlog.simulation_domains` (the expression that left its domain).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, cast

import numpy as np
import numpy.typing as npt

from hybridlog.cluster.progress import current_wait, simulating
from hybridlog.errors import ModelError, OptionError
from hybridlog.model.compiled import compile_continuous, compile_f_h, compile_guard
from hybridlog.model.schedule import parse_schedule
from hybridlog.signals import AlignedSignals, FloatArray, IntArray
from hybridlog.simulation_domains import (
    check_dx_domain,
    check_f_h_domain,
    check_guard_domain,
    check_jumps,
)
from hybridlog.simulation_inputs import (
    Disturbance,
    input_signals,
    model_origin,
    sample_times,
    start_state,
)
from hybridlog.simulation_limits import check_run, check_seed, check_steps
from hybridlog.simulation_range import check_columns, noise_reaching
from hybridlog.simulation_schedule import impossible_switches, mode_sequence
from hybridlog.times import format_time

if TYPE_CHECKING:
    from hybridlog.model.hybrid_model import HybridModel


@dataclass(frozen=True)
class SimulatedLog:
    """A simulated run: the columns of the log ``simulate`` writes."""

    time: FloatArray
    inputs: FloatArray
    outputs: FloatArray
    modes: IntArray
    states: FloatArray
    notes: tuple[str, ...] = ()

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


def _noise_factor(covariance: FloatArray) -> FloatArray:
    """``G`` with ``G Gᵀ = covariance`` for a PSD (possibly singular) covariance."""
    values, vectors = np.linalg.eigh(covariance)
    factor: FloatArray = vectors * np.sqrt(np.clip(values, 0.0, None))
    return factor


def _compile_model_code(model: HybridModel) -> None:
    """Generate and compile the model's functions the run calls, saying so on a first run.

    Inside the installed reporter's wait (:func:`~hybridlog.cluster.progress.current_wait`),
    as ``analyze`` compiles its filters: a model's first run generates its code with sympy
    and compiles it (minutes for a linear model of 30 states and 40 modes), and ``simulate``
    sat silent meanwhile.  The functions stay compiled in the process for the run.
    """
    with current_wait()(
        f"simulate: compiling machine code for model {model.name!r}",
        "its first run; later runs load it from the cache",
    ):
        if model.is_continuous:
            compile_continuous(model)
        else:
            compile_f_h(model)
            if model.state_driven:
                compile_guard(model)


CHUNK_WORK = 262_144
"""Integration steps (rows × steps a row) one call of a compiled simulation loop runs.

The loops of :mod:`hybridlog.simulation_kernels` ran a whole run in one call: a
continuous-time model of 10^5 integration steps a row (``dt = 1``, ``step = 1e-5``) ran
2,000 rows for 73 s without a word, and ``SIGTERM`` or Ctrl-C waited the whole run out (a
signal is handled between calls of compiled code).  A chunk of this many steps takes
10-100 ms (at 40-400 ns a step), against the 0.1-0.2 ms a call costs (numba converting its
arguments, the model's compiled functions among them): under 2 % more."""


def _run_in_chunks(
    kernel: Callable[..., int | None],
    arguments: tuple[object, ...],
    row_arrays: tuple[int, ...],
    origin: str,
    *,
    jit: bool,
    substeps: int = 1,
    draws_at: int | None = None,
) -> int:
    """Run a simulation loop of :mod:`hybridlog.simulation_kernels` over its rows in chunks.

    ``arguments`` are the loop's for the whole run; at ``row_arrays`` the arrays of one row
    per log row, and at ``draws_at`` the process draws of ``substeps`` rows per interval
    between two log rows (a continuous-time run's).  Each call is given the rows from the
    one before its chunk (which the loop recomputes, as its row 0, to the same values: it
    is where the chunk's first step starts) to the chunk's end, about :data:`CHUNK_WORK`
    integration steps, so that a long run says how long it takes
    (:func:`~hybridlog.cluster.progress.simulating`) and a signal ends it within a chunk.
    Returns the loop's value for the run: the row a guarded loop stopped at, else -1.
    """
    from hybridlog.jit import compile_for

    rows = cast("npt.NDArray[Any]", arguments[row_arrays[0]]).shape[0]
    size = max(1, CHUNK_WORK // max(substeps, 1))
    stepping = simulating(rows, origin)
    run: Callable[..., int | None] | None = None
    with stepping:
        start = 0
        while start < rows:
            stop = min(rows, start + size)
            first = max(start - 1, 0)
            chunk = list(arguments)
            for at in row_arrays:
                chunk[at] = cast("npt.NDArray[Any]", arguments[at])[first:stop]
            if draws_at is not None:
                draws = cast("npt.NDArray[Any]", arguments[draws_at])
                chunk[draws_at] = draws[first * substeps : (stop - 1) * substeps]
            if run is None:
                run = compile_for(kernel, chunk) if jit else kernel
            stuck = run(*chunk)
            if stuck is not None and stuck >= 0:
                return first + int(stuck)
            stepping.reached(stop)
            start = stop
    return -1


def simulate(
    model: HybridModel,
    *,
    schedule: str | None = None,
    steps: int | None = None,
    seed: int = 0,
    jit: bool = True,
    noise: bool = True,
    disturbance: Disturbance | None = None,
    log_format: str | None = None,
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
        Seed of the noise generator (NumPy PCG64), a non-negative integer: the same seed
        gives the same log.
    jit:
        Compiled loop (default) or the same code in plain Python (tests).
    noise:
        Draw the model's process and measurement noise (default); ``False``: a noise-free
        run (the draws are made all the same, so they do not shift with this flag).
    disturbance:
        The disturbance of paper 003 eq. (49) on a continuous-time model; ``None``: none.
    log_format:
        The format the run will be written in (:data:`~hybridlog.io.bag_writers.LOG_FORMATS`):
        the run must end before the times its log holds (a ROS 1 bag's end earlier,
        :func:`~hybridlog.io.bag_writers.times_before`) and fit in memory with what its
        writer holds (:func:`~hybridlog.simulation_limits.memory_needed`); ``None``: no log
        is written (times before :data:`~hybridlog.simulation_limits.LATEST_S`).

    Raises
    ------
    OptionError
        A bad ``schedule``, ``steps`` or ``seed``, or more steps than the memory holds.
    ModelError
        A bad ``[simulation]`` table, a row where no guard holds, a diverging run, or
        ``noise`` on a model whose file gives no measurement noise covariance.
    """
    seed = check_seed(seed)
    steps = check_steps(steps)
    origin = model_origin(model)
    if model.is_continuous:
        model.check_supported("simulate", continuous=True, jumps=True)
        if model.state_driven:
            first = next(m for m in model.modes if m.has_guard)
            raise model.error(
                f"modes.{first.id}.guard",
                "simulate does not switch a continuous-time model by its guards, and a "
                "schedule does not apply while it has them: remove the guards to simulate "
                "it along a schedule",
            )
    else:
        if model.has_jumps:  # check_supported's line would read as if no model's were applied
            raise model.error(
                model.jumps[0].key,
                "simulate applies jump maps to continuous-time models only (the state resets "
                "of paper 004); this model is discrete-time",
            )
        model.check_supported("simulate")
        if disturbance is not None:
            raise OptionError(
                "--disturbance: the disturbance of paper 003 eq. (49) needs a continuous-time "
                f"model; {origin} is discrete-time"
            )
    if model.state_driven:
        if schedule is not None:
            raise OptionError(
                f"--schedule: {origin} switches by its mode guards (modes.<id>.guard); "
                "a schedule does not apply"
            )
        rows = (steps or 100) + 1
        check_run(model, rows, "--steps", log_format)
        modes = np.zeros(rows, dtype=np.int64)
    else:
        if schedule is not None:  # given, if empty: refused, never the model's schedule
            parsed = parse_schedule(schedule, model.mode_ids)
        elif model.simulation_schedule:
            where = f"{origin}: simulation.schedule"
            parsed = parse_schedule(model.simulation_schedule, model.mode_ids, where=where)
        else:
            parsed = [(0, steps or 100)]
        if steps is not None:
            check_run(model, steps + 1, "--steps", log_format)
        else:
            total = sum(count for _, count in parsed)
            where = "--schedule" if schedule is not None else f"{origin}: simulation.schedule"
            check_run(model, total + 1, where, log_format)
        modes = mode_sequence(parsed, steps)
    n_rows = modes.shape[0]
    time = sample_times(n_rows, model.dt)
    if jit:
        _compile_model_code(model)
    inputs = input_signals(model, time)
    if noise:
        model.require_measurement_noise(
            "simulate draws the outputs' measurement noise (or run it with --no-noise)"
        )
    rng = np.random.default_rng(seed)
    substeps = model.timebase.substeps if model.is_continuous else 1
    process_rows = (n_rows - 1) * substeps if model.is_continuous else n_rows
    process_draws = rng.standard_normal((process_rows, model.n_states))
    measurement_draws = rng.standard_normal((n_rows, model.n_outputs))
    states = np.zeros((n_rows, model.n_states))
    states[0] = start_state(model)
    outputs = np.zeros((n_rows, model.n_outputs))
    scale = 1.0 if noise else 0.0
    process_factors = np.ascontiguousarray(
        np.stack([scale * _noise_factor(m.process_noise) for m in model.modes])
    )
    measurement_factors = np.ascontiguousarray(  # unstated (NaN) only with noise off
        np.stack(
            [
                _noise_factor(m.measurement_noise) if noise else np.zeros_like(m.measurement_noise)
                for m in model.modes
            ]
        )
    )
    state_min = (
        np.full(model.n_states, -np.inf)
        if model.simulation_state_min is None
        else model.simulation_state_min
    )
    from hybridlog import simulation_kernels as kernels

    arguments: tuple[object, ...]
    if model.is_continuous:
        from hybridlog.model.integration import METHOD_CODES, step_function
        from hybridlog.model.stability import check_step

        functions = compile_continuous(model, jit=jit)
        timebase = model.timebase
        arguments = (
            step_function(jit),
            functions.dx,
            functions.h,
            functions.jump,
            METHOD_CODES[timebase.method or "rk4"],
            timebase.step,
            substeps,
            modes,
            inputs,
            time,
            process_factors,
            process_draws,
            measurement_factors,
            measurement_draws,
            np.array(
                [0.0, 0.0]
                if disturbance is None
                else [disturbance.amplitude, disturbance.frequency],
            ),
            states,
            outputs,
            state_min,
        )
        _run_in_chunks(
            kernels.simulate_continuous_steps,
            arguments,
            (7, 8, 9, 13, 15, 16),
            origin,
            jit=jit,
            substeps=substeps,
            draws_at=11,
        )
        check_jumps(model, functions.jump, modes, states, time)
        check_step(model, functions, modes, states, inputs, time, state_min)
        check_dx_domain(model, arguments)
        run = (modes, inputs, time, states, outputs)
        check_f_h_domain(model, None, functions.h, run, mode_of_step=lambda k: int(modes[k]))
    elif model.state_driven:
        f, h = compile_f_h(model, jit=jit)
        guard = compile_guard(model, jit=jit)
        arguments = (
            f,
            h,
            guard,
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
        stuck = _run_in_chunks(
            kernels.simulate_guarded_steps, arguments, (3, 5, 7, 8, 9, 10), origin, jit=jit
        )
        # x(k) = f_q(k-1)(x(k-1), u(k-1)); a row past `stuck` was never run
        end = len(modes) if stuck < 0 else stuck + 1
        check_f_h_domain(
            model,
            f,
            h,
            (modes[:end], inputs[:end], time[:end], states[:end], outputs[:end]),
            mode_of_step=lambda k: int(modes[k - 1]),
        )
        if stuck >= 0:  # a NaN state holds no guard: the run diverged, which is said first
            check_columns(
                origin,
                time,
                {name: states[: stuck + 1, j] for j, name in enumerate(model.states)},
            )
            check_guard_domain(model, guard, states[stuck], inputs[stuck], time[stuck])
            from hybridlog.model.escape import point  # the guards read states and inputs

            raise ModelError(
                f"{origin}: no mode's guard (modes.<id>.guard) holds at t = "
                f"{format_time(time[stuck])} s ({point(model, states[stuck], inputs[stuck])})"
            )
    else:
        f, h = compile_f_h(model, jit=jit)
        arguments = (
            f,
            h,
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
        _run_in_chunks(kernels.simulate_steps, arguments, (2, 3, 5, 7, 8, 9), origin, jit=jit)
        run = (modes, inputs, time, states, outputs)
        check_f_h_domain(model, f, h, run, mode_of_step=lambda k: int(modes[k]))
    check_columns(
        origin,
        time,
        {
            **{name: states[:, j] for j, name in enumerate(model.states)},
            **{name: outputs[:, j] for j, name in enumerate(model.outputs)},
        },
        noise_reaching(model, modes, noise),
    )
    notes = () if model.state_driven else impossible_switches(model, modes, time, schedule)
    return SimulatedLog(
        time=time, inputs=inputs, outputs=outputs, modes=modes, states=states, notes=notes
    )
