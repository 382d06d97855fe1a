"""The limits of a simulated run, checked before it starts: its seed, end time and memory.

A run that ends later than its log holds (:data:`LATEST_S`, or its log format's own end) or
does not fit in memory with what its log's writer holds (:func:`memory_needed`) is refused up
front, naming the option or model key that set its steps (:func:`check_run`); a seed must be a
whole number of at least 0 (:func:`check_seed`), a number of
steps one of at least 1 (:func:`check_steps`).
"""

from __future__ import annotations

from decimal import Decimal
from typing import TYPE_CHECKING

import numpy as np

from hybridlog.errors import ModelError, OptionError
from hybridlog.memory import check_fits
from hybridlog.times import format_time

if TYPE_CHECKING:
    from hybridlog.model.hybrid_model import HybridModel


COPIES = 3.0
"""Copies of every simulated value alive at the peak of ``hybridlog simulate``: the arrays of
:func:`~hybridlog.simulate.simulate` and what the log writer builds from them.  Measured (peak
RSS growth of three-tank runs of 2·10^5 and 4·10^5 steps): CSV 1.3, Parquet 1.6, MCAP 1.3, ROS 2
bags 1.4 copies; the check uses the worst case, with a margin."""


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
    steps = rows - 1
    # exact in Decimal: `steps * dt` of a --steps past 1.8e308 (a number of 400 digits)
    # raised an unexpected OverflowError, converting the steps to a float
    end = Decimal(steps) * Decimal(repr(float(model.dt)))
    if end >= Decimal(repr(ends_before)):
        # a count a user reads, and an end a float holds; past them, neither is written out
        readable = steps < 10**18
        count = f"{steps:,}" if readable else f"{Decimal(steps):.3e}"
        ends = f"at t = {format_time(float(end))} s, later" if readable else "later"
        raise (OptionError if where.startswith("--") else ModelError)(
            f"{where}: {count} steps of {model.dt:g} s end {ends} than the log holds (times "
            f"before {format_time(ends_before)} s); simulate fewer steps"
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


def check_steps(steps: object) -> int | None:
    """``steps`` as an ``int`` or ``None``, refused unless it is a whole number of at least 1.

    ``steps=2.5`` failed as numpy's TypeError deep in the run, ``steps=True`` ran one step.
    """
    if steps is None:
        return None
    if isinstance(steps, bool) or not isinstance(steps, int | np.integer) or steps <= 0:
        raise OptionError("--steps: must be a positive integer")
    return int(steps)


def check_seed(seed: object) -> int:
    """``seed`` as an ``int``, refused unless it is a whole number of at least 0."""
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise OptionError("--seed: must be a non-negative integer")
    return int(seed)
