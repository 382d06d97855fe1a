"""What a simulated log may hold, and the error of a run that went past it.

Every value of a simulated log stays below 2^480 in magnitude (:data:`RANGE`), what the
readers take (:func:`within_range`); a run that reached a value beyond it, or NaN, is refused
naming the first such column and its time (:func:`check_columns`, :func:`out_of_range`), and
the noise whose standard deviation alone reaches the value where there is one
(:func:`noise_reaching`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from hybridlog.errors import ModelError
from hybridlog.signals import MAX_MAGNITUDE, FloatArray, IntArray
from hybridlog.times import format_time

if TYPE_CHECKING:
    from hybridlog.model.hybrid_model import HybridModel


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
    ``value`` (:func:`noise_reaching`): the run did not diverge, its noise is that large.
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


def check_columns(
    origin: str,
    time: FloatArray,
    columns: dict[str, FloatArray],
    noise: Callable[[str, int, float], str | None] | None = None,
) -> None:
    """Refuse the run at its first value out of :func:`within_range`, naming its column.

    ``columns``: every simulated column of the log (row ``k`` at ``time[k]``); of the
    columns out of range at the earliest row, the first is named.  ``noise(column, row,
    value)``: the noise that alone reaches the value, if any (:func:`noise_reaching`).
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


def noise_reaching(
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
