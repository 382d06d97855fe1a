"""The model expression a simulation left the domain of, named where the run is not finite.

A run whose state or output turns NaN (or infinite) is run again where it first did, in plain
Python, and the expression that turned a finite point into one is named with its key: a jump
map (:func:`check_jumps`), a continuous model's ``dx`` (:func:`check_dx_domain`), ``f`` or
``h`` (:func:`check_f_h_domain`), or the guard that compared a NaN where no mode's guard
holds (:func:`check_guard_domain`); :mod:`hybridlog.model.escape` says what left its domain.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from hybridlog.errors import excerpt
from hybridlog.model.compiled import GuardFunction, JumpFunction, ModelFunction
from hybridlog.signals import FloatArray, IntArray
from hybridlog.simulation_range import within_range
from hybridlog.times import format_time

if TYPE_CHECKING:
    from hybridlog.model.escape import Watch
    from hybridlog.model.hybrid_model import HybridModel


def check_jumps(
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


def check_dx_domain(model: HybridModel, arguments: tuple[Any, ...]) -> None:
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


def check_f_h_domain(
    model: HybridModel,
    f: ModelFunction | None,
    h: ModelFunction,
    arrays: tuple[IntArray, FloatArray, FloatArray, FloatArray, FloatArray],
    *,
    mode_of_step: Callable[[int], int],
) -> None:
    """Name the ``f`` or ``h`` expression that turned the run's first finite point into NaN.

    ``sqrt(x)`` of an output at a state stepping below 0, or ``x**(1/3) - 2`` of a discrete-time
    state, made "the simulation diverged: y = nan", naming neither the mode nor the expression
    (the continuous ``dx`` has :func:`check_dx_domain`).  At the first row that is not finite,
    ``h`` is evaluated again at its state when that is finite, else ``f`` (``None`` in
    continuous time) at the row before, in the mode ``mode_of_step`` gives the step into the
    row.  A point already beyond the range a log holds is said by the range check
    (:func:`~hybridlog.simulation_range.check_columns`), as the earlier fault.  A linear mode
    (``A, B, C, D``: no ``f`` or ``h`` in its file) leaves no domain; its overflow is said by
    the range check.  ``arrays``: the run's ``modes, inputs, time, states, outputs``.
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


def check_guard_domain(
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
