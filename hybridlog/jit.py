"""numba compilation settings shared by every compiled kernel."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar, cast

import numba

F = TypeVar("F", bound=Callable[..., Any])


def jit(function: F) -> F:
    """Compile ``function`` with numba: nopython, cached on disk, NumPy error model, no GIL."""
    return cast(F, numba.njit(cache=True, error_model="numpy", nogil=True)(function))


def jit_signature(signature: Any) -> Callable[[F], F]:
    """Like :func:`jit`, compiled eagerly for one explicit signature.

    Kernels that take model functions as first-class ``FunctionType`` arguments need the
    explicit signature: their machine code is then independent of the model and cached once.
    """

    def decorate(function: F) -> F:
        return cast(F, numba.njit(signature, cache=True, error_model="numpy", nogil=True)(function))

    return decorate
