"""Logs of probabilities, compiled: a safe ``log`` and the log-sum-exp of the backward passes.

Kim's and expectation correction's generic loops (:mod:`hybridlog.estimators.kim_loop`,
:mod:`hybridlog.estimators.ec_loop`) keep the mode probabilities as logs and sum them with
these; the straight-line code of :mod:`hybridlog.estimators.kim_source` writes the same sums.
"""

from __future__ import annotations

import math

from hybridlog.jit import jit_kernel
from hybridlog.signals import FloatArray, IntArray


@jit_kernel
def safe_log(value: float) -> float:
    """``log(value)``, ``-inf`` for ``value <= 0``."""
    return math.log(value) if value > 0.0 else -math.inf


@jit_kernel
def log_sum_exp(values: FloatArray) -> float:
    """``log Σ exp(values)``; ``-inf`` when every value is ``-inf``."""
    top = -math.inf
    for value in values:
        if value > top:
            top = value
    if top == -math.inf:
        return top
    total = 0.0
    for value in values:
        total += math.exp(value - top)
    return top + math.log(total)


@jit_kernel
def log_sum_exp_of(values: FloatArray, members: IntArray) -> float:
    """:func:`log_sum_exp` of ``values[members]`` (increasing), the others ``-inf``.

    The same sums in the same order, less terms ``exp(−∞) = 0``: the same result to the bit.
    """
    top = -math.inf
    for i in members:
        if values[i] > top:
            top = values[i]
    if top == -math.inf:
        return top
    total = 0.0
    for i in members:
        total += math.exp(values[i] - top)
    return top + math.log(total)
