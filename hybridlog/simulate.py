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
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from decimal import Decimal
from typing import TYPE_CHECKING, Any, cast

import numpy as np
import numpy.typing as npt

from hybridlog.cluster.progress import current_wait, simulating
from hybridlog.errors import ModelError, OptionError, excerpt
from hybridlog.memory import check_fits
from hybridlog.model.compiled import (
    GuardFunction,
    InputFunction,
    JumpFunction,
    ModelFunction,
    compile_continuous,
    compile_f_h,
    compile_guard,
    input_functions,
)
from hybridlog.model.schedule import parse_schedule
from hybridlog.numbers import parse_float
from hybridlog.signals import MAX_MAGNITUDE, AlignedSignals, FloatArray, IntArray
from hybridlog.times import format_time

if TYPE_CHECKING:
    from hybridlog.model.escape import Watch
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


def _origin(model: HybridModel) -> str:
    """The model file (or built-in name) errors name, so the user knows what to change."""
    return model.origin or model.name


EXACT_INTEGER = 2**53
"""Integers up to this one are exact in a float64 (the products :func:`sample_times` scales)."""


def sample_times(rows: int, dt: float) -> FloatArray:
    """``t_k = k·dt`` for ``k < rows``: each the float nearest the decimal product.

    ``np.arange(rows) * dt`` multiplied the float of ``dt``, which is not the decimal the
    model file gives: at ``dt = 0.001``, 139,554 of 10^6 times were written
    ``0.009000000000000001`` and alike in a CSV file (and so in a Parquet file).  ``dt``'s
    shortest decimal, ``n·10^-p`` (``repr``), gives ``t_k = (k·n) / 10^p``: an exact integer
    over an exact power of ten, one correctly rounded division.  A ``dt`` of so many digits
    that ``k·n`` passes 2^53 (``1/3`` written out) has no shorter decimal: its times are the
    float products, as before.
    """
    steps = np.arange(rows, dtype=float)
    _, digits, power = Decimal(repr(float(dt))).as_tuple()
    exponent = cast("int", power)  # a model's dt is finite
    whole = int("".join(map(str, digits)))
    scale = 10 ** max(-exponent, 0)
    whole *= 10 ** max(exponent, 0)
    if (rows - 1) * whole <= EXACT_INTEGER and whole <= EXACT_INTEGER and scale <= 10**22:
        exact: FloatArray = steps * float(whole) / float(scale)  # one rounding: the quotient
        return exact
    products: FloatArray = steps * dt
    return products


def mode_sequence(schedule: list[tuple[int, int]], steps: int | None) -> IntArray:
    """Mode of every row (``steps + 1`` rows); the schedule repeats when ``steps`` is longer.

    Only the rows run are built: ``--steps 5`` of a schedule ``1:10000000000,2:5`` takes
    5 rows of memory, not the schedule's 10^10 (which ran out of memory).
    """
    period = sum(count for _, count in schedule)
    total = period if steps is None else steps
    if total <= 0:
        raise OptionError("--steps: must be positive")
    rows = np.empty(total + 1, dtype=np.int64)
    filled = 0
    for mode, count in schedule:
        take = min(count, total - filled)
        if take <= 0:
            break
        rows[1 + filled : 1 + filled + take] = mode
        filled += take
    if filled < total:  # the schedule repeats
        rows[1:] = np.resize(rows[1 : 1 + filled], total)
    rows[0] = rows[1]
    return rows


def input_signal(
    model: HybridModel, name: str, function: InputFunction, time: FloatArray
) -> FloatArray:
    """Input ``name``'s ``u(k)`` at ``time`` from its expression ``function`` of ``t`` and ``k``.

    A value out of :func:`within_range` (NaN, infinite, or beyond what a log holds) is a
    :class:`ModelError` naming the key ``simulation.inputs.<name>``, the time and the step.
    """
    steps = np.arange(time.shape[0], dtype=float)
    with np.errstate(all="ignore"):  # a NaN or inf is found below, named by its key
        values = np.broadcast_to(np.asarray(function(time, steps), dtype=float), time.shape)
    if not np.all(readable := within_range(values)):
        first = int(np.argmin(readable))
        raise ModelError(
            f"{_origin(model)}: simulation.inputs.{name}: {values[first]:.6g} at t = "
            f"{format_time(float(time[first]))} s (k = {first}); the input must be a "
            f"finite number below {RANGE} in magnitude at every step"
        )
    return values


def input_hint(name: str) -> str:
    """What to write for an input ``simulate`` has no signal for (docs/model_files.md)."""
    return f'write {name} = "..." (an expression of t and k) under [simulation.inputs]'


def input_signals(model: HybridModel, time: FloatArray) -> FloatArray:
    """Inputs ``u(k)`` from the model's ``[simulation.inputs]`` expressions of ``t`` and ``k``."""
    functions = input_functions(model)
    columns = []
    for name in model.inputs:
        if name not in functions:
            raise ModelError(
                f"{_origin(model)}: simulation.inputs.{name}: no input signal to simulate with; "
                f"{input_hint(name)}"
            )
        columns.append(input_signal(model, name, functions[name], time))
    if not columns:
        return np.zeros((time.shape[0], 0))
    return np.ascontiguousarray(np.stack(columns, axis=1))


RANGE = f"2^480 = {MAX_MAGNITUDE:.3g}"
"""What every value of a simulated log stays below (:data:`~hybridlog.signals.MAX_MAGNITUDE`)."""


def within_range(values: FloatArray) -> npt.NDArray[np.bool_]:
    """Where ``values`` are numbers a log hybridlog reads may hold: finite, below 2^480.

    The readers refuse a larger magnitude as corrupt (:data:`~hybridlog.signals.MAX_MAGNITUDE`),
    so a simulation that writes one has written a log that ``analyze`` refuses; NaN is out.
    """
    return np.asarray(np.abs(values) < MAX_MAGNITUDE)


def out_of_range(
    origin: str, name: str, value: float, time: float, noise: str | None = None
) -> ModelError:
    """The error of a run that reached ``value`` in column ``name`` at ``time``: diverged.

    ``noise``: the noise key and its standard deviation where the noise alone reaches
    ``value`` (:func:`_noise_reaching`): the run did not diverge, its noise is that large.
    """
    problem = (
        "not a finite number"
        if not np.isfinite(value)
        else f"out of range (|value| >= {RANGE}, more than a log hybridlog reads may hold)"
    )
    what = "the simulation diverged" if noise is None else "the simulation's noise"
    cause = "" if noise is None else f": {noise} reaches it alone"
    return ModelError(
        f"{origin}: {what}: {name} = {value:.6g} at t = {format_time(time)} s "
        f"is {problem}{cause}; nothing was written"
    )


def start_state(model: HybridModel) -> FloatArray:
    """Where a run starts: ``[simulation] state``, else ``[initial] state``, within range.

    A start beyond :func:`within_range` (``state = [1e200]``) was refused as "the simulation
    diverged: x = 1e+200 at t = 0 s", naming no key, as if the run had got there.
    """
    given = model.simulation_state is not None
    start = model.initial_state if model.simulation_state is None else model.simulation_state
    outside = np.flatnonzero(~within_range(start))
    if outside.size:
        j = int(outside[0])
        where = "" if given else " (the file gives no simulation.state)"
        raise model.error(
            f"{'simulation' if given else 'initial'}.state[{j}]",
            f"the run would start with {model.states[j]} = {start[j]:.6g}{where}, more than a "
            f"log hybridlog reads may hold (|value| >= {RANGE}); start it within that",
        )
    return start


def check_columns(
    origin: str,
    time: FloatArray,
    columns: dict[str, FloatArray],
    noise: Callable[[str, int, float], str | None] | None = None,
) -> None:
    """Refuse the run at its first value out of :func:`within_range`, naming its column.

    ``columns``: every simulated column of the log (row ``k`` at ``time[k]``); of the
    columns out of range at the earliest row, the first is named.  ``noise(column, row,
    value)``: the noise that alone reaches the value, if any (:func:`_noise_reaching`).
    """
    first: tuple[int, str] | None = None
    for name, values in columns.items():
        readable = within_range(values)
        if not np.all(readable):
            row = int(np.argmin(readable))
            if first is None or row < first[0]:
                first = (row, name)
    if first is not None:
        row, name = first
        value = float(columns[name][row])
        cause = None if noise is None else noise(name, row, value)
        raise out_of_range(origin, name, value, float(time[row]), cause)


_NOISE_REACH = 40.0
"""Standard deviations past which no normal draw goes (probability below 1e-300)."""


def _noise_reaching(
    model: HybridModel, modes: IntArray, noise: bool
) -> Callable[[str, int, float], str | None]:
    """The noise key whose standard deviation alone reaches a column's value at a row.

    ``[noise] measurement = 1e308`` made outputs of 1e154, refused as "the simulation diverged:
    y1 = -1.75e+154", naming neither the noise nor its key.  An output's is the measurement
    noise of its row's mode; a state's the process noise of the step into it
    (:func:`~hybridlog.simulation_kernels.simulate_steps`), in discrete time (a continuous run
    draws it per integration step, and is not told). Within :data:`_NOISE_REACH` standard
    deviations of the value, the noise is named.
    """

    def reaching(name: str, row: int, value: float) -> str | None:
        if not noise or not np.isfinite(value):
            return None
        if name in model.outputs:
            mode = model.modes[int(modes[row])]
            j = model.outputs.index(name)
            variance, key = float(mode.measurement_noise[j, j]), mode.measurement_noise_key
        elif name in model.states and row > 0 and not model.is_continuous:
            # the step into x(k): of q(k) scheduled (paper 000 eq. (2)), of q(k-1) by guards
            mode = model.modes[int(modes[row - 1] if model.state_driven else modes[row])]
            j = model.states.index(name)
            variance, key = float(mode.process_noise[j, j]), mode.process_noise_key
        else:
            return None
        deviation = math.sqrt(variance) if variance > 0 else 0.0
        if deviation * _NOISE_REACH < abs(value):
            return None
        return f"{key}'s variance {variance:.6g} (a standard deviation of {deviation:.3g})"

    return reaching


def _check_jumps(
    model: HybridModel, jump: JumpFunction, modes: IntArray, states: FloatArray, time: FloatArray
) -> None:
    """Name the jump map when the run's first state that is not finite follows a switch.

    At a switch the jump map is applied before the interval is integrated
    (:func:`~hybridlog.simulation_kernels.simulate_continuous_steps`): a map that leaves its
    domain (``sqrt(x - 2)`` at ``x = 1``) made "the simulation diverged: x = nan", naming no
    key.  The map is evaluated again at the state before the switch.
    """
    finite = np.isfinite(states).all(axis=1)
    if finite.all():
        return
    row = int(np.argmin(finite))
    if row == 0 or modes[row] == modes[row - 1]:
        return
    source, target = int(modes[row - 1]), int(modes[row])
    found = model.jump_between(source, target)
    if found is None:
        return
    from hybridlog.model.escape import Escape, escape_error

    reset = np.empty(model.n_states)
    before = np.ascontiguousarray(states[row - 1])
    with np.errstate(all="ignore"):
        jump(source, target, before, reset)
    if np.isfinite(reset).all():
        return
    raise escape_error(
        model,
        Escape("reset", source, target, before.copy(), np.zeros(0), reset),
        f"at t = {format_time(float(time[row - 1]))} s",
        "the simulation diverged there; nothing was written",
    )


def _check_dx_domain(model: HybridModel, arguments: tuple[Any, ...]) -> None:
    """Name the expression of ``dx`` that left its domain where the run first is not finite.

    ``log(h1)`` of a level stepping below 0 made "the simulation diverged: h1 = nan",
    naming neither the mode nor the expression.  The interval into the first row that is
    not finite is run again in plain Python (the same kernel, the same noise draws, from
    the state before), ``dx`` watched at every evaluation: the first that is not finite at
    a finite state names its key, its expression and the point (NaN: out of the domain;
    infinite: beyond float64, ``exp`` of a state running away).  ``arguments`` are those of
    :func:`~hybridlog.simulation_kernels.simulate_continuous_steps`.
    """
    from hybridlog.model.escape import escape_error, replayed
    from hybridlog.model.integration import integrate_step
    from hybridlog.simulation_kernels import simulate_continuous_steps

    (_, dx, h, jump, method, step, substeps, modes, inputs, time) = arguments[:10]
    process_factors, process_draws, measurement_factors, measurement_draws = arguments[10:14]
    disturbance, states, outputs, state_min = arguments[14:18]
    finite = np.isfinite(states).all(axis=1)
    if finite.all():
        return
    row = int(np.argmin(finite))

    def replay(watch: Watch) -> None:
        simulate_continuous_steps(
            integrate_step,
            watch.vector("dx", dx),
            h,
            jump,
            method,
            step,
            substeps,
            modes[row - 1 : row + 1].copy(),
            inputs[row - 1 : row + 1],
            time[row - 1 : row + 1],
            process_factors,
            process_draws[(row - 1) * substeps : row * substeps],
            measurement_factors,
            measurement_draws[row - 1 : row + 1],
            disturbance,
            states[row - 1 : row + 1].copy(),
            np.zeros((2, outputs.shape[1])),
            state_min,
        )

    found = replayed(replay)
    if found is not None:
        raise escape_error(
            model,
            found,
            f"a step of the interval from t = {format_time(float(time[row - 1]))} s to "
            f"{format_time(float(time[row]))} s",
            "the simulation diverged; nothing was written",
        )


def _check_f_h_domain(
    model: HybridModel,
    f: ModelFunction | None,
    h: ModelFunction,
    arrays: tuple[IntArray, FloatArray, FloatArray, FloatArray, FloatArray],
    *,
    mode_of_step: Callable[[int], int],
) -> None:
    """Name the ``f`` or ``h`` expression that turned the run's first finite point into NaN.

    ``sqrt(x)`` of an output at a state stepping below 0, or ``x**(1/3) - 2`` of a
    discrete-time state, made "the simulation diverged: y = nan", naming neither the mode
    nor the expression (the continuous ``dx`` has :func:`_check_dx_domain`).  At the first
    row that is not finite, ``h`` is evaluated again at its state when that is finite, else
    ``f`` (``None`` in continuous time) at the row before, in the mode ``mode_of_step``
    gives the step into the row.  A point already beyond the range a log holds is said by
    the range check (:func:`check_columns`), as the earlier fault.  A linear mode (``A, B,
    C, D``: no ``f`` or ``h`` in its file) leaves no domain; its overflow is said by the
    range check.  ``arrays``: the run's ``modes, inputs, time, states, outputs``.
    """
    from hybridlog.model.escape import Escape, escape_error

    modes, inputs, time, states, outputs = arrays
    finite = np.isfinite(states).all(axis=1) & np.isfinite(outputs).all(axis=1)
    if finite.all():
        return
    row = int(np.argmin(finite))
    if np.isfinite(states[row]).all():
        function, q, at, call = "h", int(modes[row]), row, h
        where = f"at t = {format_time(float(time[row]))} s"
    elif f is not None and row > 0:
        function, q, at, call = "f", mode_of_step(row), row - 1, f
        where = (
            f"the step from t = {format_time(float(time[row - 1]))} s to "
            f"{format_time(float(time[row]))} s"
        )
    else:
        return
    if model.modes[q].linear_form is not None:
        return
    x, u = np.ascontiguousarray(states[at]), np.ascontiguousarray(inputs[at])
    out = np.empty(model.n_outputs if function == "h" else model.n_states)
    with np.errstate(all="ignore"):
        call(q, x, u, out)
    escape = Escape(function, q, -1, x.copy(), u.copy(), out)
    if within_range(x).all() and within_range(u).all() and not np.isfinite(out).all():
        raise escape_error(model, escape, where, "the simulation diverged; nothing was written")


def _check_guard_domain(
    model: HybridModel, guard: GuardFunction, x: FloatArray, u: FloatArray, at: float
) -> None:
    """Name the guard that compared a NaN at the row where no mode's guard holds.

    ``sqrt(x) > 0.5`` at ``x = -0.1`` does not hold (``-2 - i`` from the guard function,
    :mod:`hybridlog.model.codegen`, where no other guard held): the state or input left
    its domain, which the error says rather than only that no guard held.
    """
    from hybridlog.model.escape import point
    from hybridlog.model.toml_text import key_path

    code = int(guard(np.ascontiguousarray(x), np.ascontiguousarray(u)))
    if code > -2:
        return
    n_modes = len(model.modes)
    infinite = code < -1 - n_modes  # -2 - n - i: a side of mode i's guard is infinite
    mode = model.modes[-2 - n_modes - code if infinite else -2 - code]
    where = f"{key_path('modes', mode.id)}.guard"
    if infinite:
        raise model.error(
            where,
            f"{excerpt(str(mode.guard))} has an infinite side at {point(model, x, u)}, "
            f"t = {format_time(float(at))} s (a pole, a division by 0 or a log of 0 there, or "
            "past float64): whether it holds cannot be told; nothing was written",
        )
    read = {str(symbol) for symbol in mode.guard.free_symbols} if mode.guard is not None else set()
    states, inputs = bool(read & set(model.states)), bool(read & set(model.inputs))
    left = "the input" if inputs and not states else "the state or input" if inputs else "the state"
    raise model.error(
        where,
        f"{excerpt(str(mode.guard))} is undefined (a side is nan) at {point(model, x, u)}, "
        f"t = {format_time(float(at))} s ({left} left the domain of the guard there), "
        "and no other mode's guard holds: no mode can be chosen; nothing was written",
    )


def _noise_factor(covariance: FloatArray) -> FloatArray:
    """``G`` with ``G Gᵀ = covariance`` for a PSD (possibly singular) covariance."""
    values, vectors = np.linalg.eigh(covariance)
    factor: FloatArray = vectors * np.sqrt(np.clip(values, 0.0, None))
    return factor


COPIES = 3.0
"""Copies of every simulated value alive at the peak of ``hybridlog simulate``: the arrays of
:func:`simulate` and what the log writer builds from them.  Measured (peak RSS growth of
three-tank runs of 2·10^5 and 4·10^5 steps): CSV 1.3, Parquet 1.6, MCAP 1.3, ROS 2 bags 1.4
copies; the check uses the worst case, with a margin."""


def memory_needed(model: HybridModel, rows: int, log_format: str | None = None) -> int:
    """Bytes a simulation of ``rows`` rows needs at its peak, writing its log included.

    Every row holds ``t``, the mode, ``u``, ``y`` and ``x`` plus one noise draw per output and
    per state and integration step (``dt / step`` steps a row in continuous time, else 1);
    a components model's rows also hold the commands, the controller's memory, every plant
    variable, and per component its scheduled mode, override, joint-mode entry and log
    entry (:mod:`hybridlog.simulate_components`): 8 bytes each, times :data:`COPIES`.  And
    every column of the log but ``t`` is a message a row, each costing the writer of
    ``log_format`` (:data:`~hybridlog.io.bag_writers.LOG_FORMATS`; ``None``: no log)
    :func:`~hybridlog.io.bag_writers.message_bytes` until the log is closed: a ROS 1 bag's
    alone.  Counted for every format, they had a CSV run of 2·10^7 three-tank steps refused
    as needing 27.7 GB, where it takes 5.
    """
    from hybridlog.io.bag_writers import message_bytes

    substeps = model.timebase.substeps
    values = 2 + model.n_inputs + 2 * model.n_outputs + model.n_states * (1 + substeps)
    messages = model.n_inputs + model.n_outputs + model.n_states + 1  # 1: the true mode
    if model.has_components:
        memory = len(model.scenario.controller_states) if model.scenario is not None else 0
        plant = model.n_states + model.n_inputs + model.n_outputs + len(model.variables)
        components = len(model.components)
        values += len(model.commands) + memory + plant + 4 * components + 7  # 7: a tuple
        messages += len(model.commands) + components - 1  # a true mode per component
    per_message = 0 if log_format is None else message_bytes(log_format)
    return int(rows * (values * 8 * COPIES + messages * per_message))


LATEST_S = 9.2e9
"""The latest time of a log: hybridlog reads times as int64 nanoseconds (up to 9.2e9 s,
:func:`hybridlog.io.source.seconds_to_ns`), and MCAP files and ROS 2 bags store them so."""


def check_run(model: HybridModel, rows: int, where: str, log_format: str | None) -> None:
    """Refuse up front a run that ends later than its log holds, or cannot fit in memory.

    Either names the option or model key that set the number of steps.  ``log_format``: of
    the log to be written (:func:`memory_needed`); ``None``: none, the times ending before
    :data:`LATEST_S`.
    """
    from hybridlog.io.bag_writers import times_before

    ends_before = LATEST_S if log_format is None else times_before(log_format)
    end = (rows - 1) * model.dt
    if end >= ends_before:
        raise (OptionError if where.startswith("--") else ModelError)(
            f"{where}: {rows - 1:,} steps of {model.dt:g} s end at t = {format_time(end)} s, later "
            f"than the log holds (times before {format_time(ends_before)} s); simulate fewer steps"
        )
    check_fits(
        [
            (
                "the simulated rows and the log written from them",
                memory_needed(model, rows, log_format),
            )
        ],
        what=f"{where}: {rows - 1:,} steps",
        remedy="simulate fewer steps",
        error=OptionError if where.startswith("--") else ModelError,
    )


def check_seed(seed: object) -> int:
    """``seed`` as an ``int``, refused unless it is a whole number of at least 0."""
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise OptionError("--seed: must be a non-negative integer")
    return int(seed)


@dataclass(frozen=True)
class Disturbance:
    r"""The state-dependent disturbance of paper 003, eq. (49), added to a continuous ``dx``.

    .. math::

        \varepsilon_i(x, t) = a \,(|x_1| + \dots + |x_n|)\,\sin(\omega t), \qquad i = 1 \dots n

    (the paper: ``a = 0.1``, ω not given).

    Attributes
    ----------
    amplitude:
        ``a``, in 1/s (ε has the units of ``dx``).
    frequency:
        ω in rad/s.
    """

    amplitude: float
    frequency: float


def parse_disturbance(text: str) -> Disturbance:
    """``"A,OMEGA"`` (``--disturbance``) as a :class:`Disturbance`; an :class:`OptionError` else."""
    parts = text.split(",")
    try:
        amplitude, frequency = (parse_float(part) for part in parts)
    except ValueError as err:
        raise OptionError(
            f"--disturbance: expected A,OMEGA (two finite numbers), got {excerpt(text)}"
        ) from err
    return Disturbance(amplitude, frequency)


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
        writer holds (:func:`memory_needed`); ``None``: no log is written (times before
        :data:`LATEST_S`).

    Raises
    ------
    OptionError
        A bad ``schedule``, ``steps`` or ``seed``, or more steps than the memory holds.
    ModelError
        A bad ``[simulation]`` table, a row where no guard holds, a diverging run, or
        ``noise`` on a model whose file gives no measurement noise covariance.
    """
    seed = check_seed(seed)
    origin = _origin(model)
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
        if steps is not None and steps <= 0:
            raise OptionError("--steps: must be positive")
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
        if steps is not None and steps <= 0:
            raise OptionError("--steps: must be positive")
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
        _check_jumps(model, functions.jump, modes, states, time)
        check_step(model, functions, modes, states, inputs, time, state_min)
        _check_dx_domain(model, arguments)
        run = (modes, inputs, time, states, outputs)
        _check_f_h_domain(model, None, functions.h, run, mode_of_step=lambda k: int(modes[k]))
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
        _check_f_h_domain(
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
            _check_guard_domain(model, guard, states[stuck], inputs[stuck], time[stuck])
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
        _check_f_h_domain(model, f, h, run, mode_of_step=lambda k: int(modes[k]))
    check_columns(
        origin,
        time,
        {
            **{name: states[:, j] for j, name in enumerate(model.states)},
            **{name: outputs[:, j] for j, name in enumerate(model.outputs)},
        },
        _noise_reaching(model, modes, noise),
    )
    notes = () if model.state_driven else impossible_switches(model, modes, time, schedule)
    return SimulatedLog(
        time=time, inputs=inputs, outputs=outputs, modes=modes, states=states, notes=notes
    )


def unreached_modes(model: HybridModel, modes: IntArray, schedule: str | None) -> dict[str, int]:
    """Mode id → the step the schedule first plays it, for each mode of it the run never had.

    ``modes``: the run's (:attr:`SimulatedLog.modes`); ``schedule``: the ``--schedule``
    given, else the model's ``[simulation] schedule`` (none: the first mode throughout,
    which every run has).  Only a ``--steps`` shorter than the schedule leaves one out; row 0
    carries the first scheduled mode (:func:`mode_sequence`), an entry after it starts one
    row after the steps before it.  Empty for a state-driven model (its guards decide).
    """
    parsed = _run_schedule(model, schedule)
    if parsed is None:
        return {}
    starts: dict[str, int] = {}
    before = 0
    for mode, count in parsed:
        if not np.any(modes == mode):
            starts.setdefault(model.mode_ids[mode], before + 1 if before else 0)
        before += count
    return starts


def _run_schedule(model: HybridModel, schedule: str | None) -> list[tuple[int, int]] | None:
    """The schedule a run followed, parsed.

    ``--schedule`` if given, else the model's ``[simulation] schedule``; ``None`` for a
    state-driven model (its guards decide) or one without a schedule (its first mode
    throughout).
    """
    if model.state_driven:
        return None
    if schedule is not None:
        return parse_schedule(schedule, model.mode_ids)
    if model.simulation_schedule:
        where = f"{_origin(model)}: simulation.schedule"
        return parse_schedule(model.simulation_schedule, model.mode_ids, where=where)
    return None


def switches_made(model: HybridModel, modes: IntArray) -> set[tuple[str, str]]:
    """The switches ``(from id, to id)`` between consecutive rows of a run's ``modes``."""
    changed = np.flatnonzero(modes[1:] != modes[:-1])
    pairs = np.unique(np.stack([modes[changed], modes[changed + 1]], axis=1), axis=0)
    ids = model.mode_ids
    return {(ids[int(a)], ids[int(b)]) for a, b in pairs}


def unmade_switches(
    model: HybridModel, modes: IntArray, schedule: str | None
) -> dict[tuple[str, str], int]:
    """Switch ``(from id, to id)`` → the step the schedule first makes it, the run not having.

    As :func:`unreached_modes`: ``schedule`` is the ``--schedule`` given, else the model's;
    an entry after the first starts one row after the steps before it, and the schedule
    repeats, so its last mode switches to its first one row after its total.  Empty for a
    state-driven model (its guards decide) and a model without a schedule (one mode).
    """
    parsed = _run_schedule(model, schedule)
    if parsed is None:
        return {}
    made = switches_made(model, modes)
    steps: dict[tuple[str, str], int] = {}
    before = 0
    previous = parsed[-1][0]  # the repeat's switch into the first entry
    for i, (mode, count) in enumerate(parsed):
        if mode != previous:
            switch = (model.mode_ids[previous], model.mode_ids[mode])
            at = before + 1 if i else sum(c for _, c in parsed) + 1
            if switch not in made:
                steps[switch] = min(at, steps.get(switch, at))
        previous = mode
        before += count
    return steps


def cut_schedule(
    model: HybridModel, modes: IntArray, steps: int | None, schedule: str | None
) -> tuple[str, ...]:
    """A note when ``steps`` stops a scheduled run before one of its modes is reached.

    ``--schedule 1:100,2:100 --steps 50`` wrote a log of mode 1 alone without a word, which
    a user who asked for both modes took for a run through both.  ``modes``: the run's
    (:attr:`SimulatedLog.modes`); ``schedule``: the ``--schedule`` given, else the model's
    ``[simulation] schedule`` is meant (none: nothing was scheduled, nothing to note).
    """
    if steps is None or model.state_driven:
        return ()
    if schedule is not None:
        where = "--schedule"
        parsed = parse_schedule(schedule, model.mode_ids)
    elif model.simulation_schedule:
        where = f"{_origin(model)}: simulation.schedule"
        parsed = parse_schedule(model.simulation_schedule, model.mode_ids, where=where)
    else:
        return ()
    missing = [m for m in dict.fromkeys(m for m, _ in parsed) if not np.any(modes == m)]
    if not missing:
        return ()
    total = sum(count for _, count in parsed)
    named = ", ".join(f"'{model.mode_ids[m]}'" for m in missing)
    return (
        f"--steps {steps:,} ends the run within the schedule's {total:,} steps ({where}): "
        f"{'mode' if len(missing) == 1 else 'modes'} {named} never run",
    )


def impossible_switches(
    model: HybridModel, modes: IntArray, time: FloatArray, schedule: str | None
) -> tuple[str, ...]:
    """What a scheduled run does that the model gives probability 0, one note per kind.

    A switch ``a → b`` whose ``[transitions]`` entry is 0 (the first time, and how many
    more): the log is valid, but an estimator that weighs the model's Markov matrix
    (``imm``, its Viterbi and k-best passes) cannot follow the run there, which its mode
    metrics then count as errors.  ``schedule``: the ``--schedule`` given, if any (else the
    model's ``[simulation] schedule`` or its first mode throughout was followed), named in
    the notes.  A first mode that ``[initial]`` gives probability 0 is not noted: it costs
    one sample (the Markov matrix lets the estimate leave the prior's mode at the next),
    and the paper's own three-tank scenario starts so on purpose (a prior of mode 2 for a
    run in mode 1), where a note on every ``simulate`` would be noise.
    """
    if schedule is not None:
        where = "--schedule"
    elif model.simulation_schedule:
        where = f"{_origin(model)}: simulation.schedule"
    else:
        where = f"{_origin(model)}: the first mode throughout (no schedule)"
    notes: list[str] = []
    ids = model.mode_ids
    markov = model.transitions
    if markov is None or modes.size < 2:
        return ()
    rows = np.flatnonzero(modes[1:] != modes[:-1]) + 1  # the first row of each new mode
    impossible = rows[markov[modes[rows - 1], modes[rows]] == 0.0]
    # one note per switch a -> b, at its first row (a repeated schedule makes millions)
    pairs = modes[impossible - 1] * model.n_modes + modes[impossible]
    _, first, counts = np.unique(pairs, return_index=True, return_counts=True)
    for index, count in sorted(zip(first.tolist(), counts.tolist(), strict=True)):
        row = int(impossible[index])
        source, target = int(modes[row - 1]), int(modes[row])
        more = count - 1
        notes.append(
            f"{where}: switches from mode '{ids[source]}' to '{ids[target]}' at "
            f"t = {format_time(time[row])} s (row {row})"
            + (f" and {more} more time{'s' if more > 1 else ''}" if more else "")
            # the switch named by its modes: the file may write [transitions] as stay = 1,
            # a matrix keyed by mode id or one in the modes' order
            + ", which [transitions] gives probability 0: the model rules it out, so imm "
            "weighs it as impossible and its Viterbi and k-best mode sequences cannot take it"
        )
    return tuple(notes)
