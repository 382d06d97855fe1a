"""What a simulation is given: its times, inputs, start state and disturbance.

The times of the rows (:func:`sample_times`), the inputs ``u(k)`` from the model's
``[simulation.inputs]`` expressions (:func:`input_signals`), the state a run starts from
(:func:`start_state`) and paper 003's disturbance (:class:`Disturbance`, ``--disturbance``),
for :func:`hybridlog.simulate.simulate` and a components model's run
(:mod:`hybridlog.simulate_components`); :func:`model_origin` is the model file their errors
name.
"""

from __future__ import annotations

from dataclasses import dataclass
from decimal import Decimal
from typing import TYPE_CHECKING, cast

import numpy as np

from hybridlog.errors import ModelError, OptionError, excerpt
from hybridlog.model.compiled import InputFunction, input_functions
from hybridlog.numbers import parse_float
from hybridlog.signals import FloatArray
from hybridlog.simulation_range import RANGE, within_range
from hybridlog.times import format_time

if TYPE_CHECKING:
    from hybridlog.model.hybrid_model import HybridModel


def model_origin(model: HybridModel) -> str:
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
            f"{model_origin(model)}: simulation.inputs.{name}: {values[first]:.6g} at t = "
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
                f"{model_origin(model)}: simulation.inputs.{name}: no input signal to simulate "
                f"with; {input_hint(name)}"
            )
        columns.append(input_signal(model, name, functions[name], time))
    if not columns:
        return np.zeros((time.shape[0], 0))
    return np.ascontiguousarray(np.stack(columns, axis=1))


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
