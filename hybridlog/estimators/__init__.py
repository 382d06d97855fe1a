"""Hybrid estimators: pure algorithms from (model, aligned signals) to one result type.

The registry (:mod:`hybridlog.estimators.registry`) lists them; importing this package loads
only the registry, never an estimator's module (numba, sympy, cvxpy ...) until it is used.
"""

from hybridlog.estimators.capabilities import Capabilities
from hybridlog.estimators.registry import (
    CHUNK_ROWS,
    ESTIMATORS,
    Estimator,
    Prepared,
    get_estimator,
    prepare,
    refuse_unrunnable,
    resolve_estimator,
)

__all__ = [
    "CHUNK_ROWS",
    "ESTIMATORS",
    "Capabilities",
    "Estimator",
    "Prepared",
    "get_estimator",
    "prepare",
    "refuse_unrunnable",
    "resolve_estimator",
]
