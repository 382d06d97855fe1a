"""numba compilation settings shared by every compiled kernel, and compilation on first use.

Importing this module does not import numba: :func:`jit` imports it when it decorates (so a
module of kernels pays for numba when *it* is imported), and :func:`compile_for` when it
first compiles.  Nothing is compiled at import time: :func:`jit` kernels compile on their
first call, :func:`compile_for` when a caller first needs a function for given arguments;
both keep the machine code in numba's on-disk cache (``cache=True``).
"""

from __future__ import annotations

import sys
import threading
from collections.abc import Callable, Sequence
from typing import Any, TypeVar, cast

F = TypeVar("F", bound=Callable[..., Any])

OPTIONS: dict[str, Any] = {"cache": True, "error_model": "numpy", "nogil": True}
"""nopython, cached on disk, NumPy's floating-point error model (no exceptions), no GIL."""


def _one(x: float) -> float:
    return x


BLAS_PROBE = "scipy.linalg.cython_blas"
"""What numba's array maths imports when its CPU target loads, to see whether BLAS is there."""


def set_up() -> None:
    """Import numba and set up its CPU target now, not in the first compile or cache load.

    That set-up takes 0.3-1 s of Python (it holds the GIL), the same for every kernel: a
    batch worker's forkserver does it once, while the batch process still checks the inputs,
    and ``analyze`` while a thread reads the log.  Compiles a one-line function.

    Loading the target imports ``numba.np.arraymath``, which probes for BLAS by importing
    :data:`BLAS_PROBE` (all of ``scipy.linalg``: 0.17 s and 13 MiB measured here).  Only
    numba's ``np.correlate``/``np.convolve`` read what the probe found (they then use a
    plain loop); hybridlog's kernels call no BLAS, and a kernel that calls ``np.dot`` still
    imports SciPy's BLAS when it is compiled (``numba.np.linalg.ensure_blas``).  So the probe
    is made to fail fast here, where SciPy is not loaded yet: for the moment of the set-up
    that one module is marked missing (``sys.modules[name] = None``).  Nothing else is
    importing it meanwhile: the readers running beside ``analyze``'s set-up use no SciPy.
    """
    import numba

    probe_skipped = "scipy.linalg" not in sys.modules and BLAS_PROBE not in sys.modules
    if probe_skipped:
        sys.modules[BLAS_PROBE] = None  # type: ignore[assignment]
    try:
        compiled: Any = numba.njit(_one)
        compiled(1.0)
    finally:
        if probe_skipped and sys.modules.get(BLAS_PROBE, 0) is None:
            del sys.modules[BLAS_PROBE]


def jit(function: F) -> F:
    """Compile ``function`` with numba (:data:`OPTIONS`) on its first call."""
    import numba

    return cast(F, numba.njit(**OPTIONS)(function))


def jitable(function: F) -> F:
    """``function`` as plain Python when called from Python, compiled into a compiled caller.

    For the small steps the generic loops share that take model functions as arguments
    (numba cannot type a Python function passed to a compiled one): the plain-Python
    reference path (``jit=False``) calls them as they are, the compiled loops inline them.
    """
    from numba.extending import register_jitable

    registered: F = register_jitable(function)
    return registered


def signature_of(arguments: Sequence[Any]) -> tuple[Any, ...]:
    """The numba argument types of a call (numba infers the result type from them).

    A compiled function passed as an argument (a numba dispatcher compiled for one explicit
    signature, as the model functions of :mod:`hybridlog.model.compiled` are) is typed as a
    first-class function of that signature, so a kernel taking it is compiled once for every
    model rather than once per model function.
    """
    from numba import types
    from numba.core.dispatcher import Dispatcher

    def type_of(value: Any) -> Any:
        if isinstance(value, Dispatcher):
            (signature,) = value.nopython_signatures
            return types.FunctionType(signature)
        return numba_typeof(value)

    return tuple(type_of(value) for value in arguments)


def numba_typeof(value: Any) -> Any:
    """The numba type of a Python value (``float64[:, ::1]`` for a C-contiguous 2-d array...)."""
    import numba

    return numba.typeof(value)  # type: ignore[no-untyped-call]


_COMPILED: dict[tuple[Callable[..., Any], Any], Callable[..., Any]] = {}
_LOCK = threading.Lock()


def compile_for(function: Callable[..., Any], arguments: Sequence[Any]) -> Callable[..., Any]:
    """``function`` compiled (or loaded from numba's cache) for the types of ``arguments``.

    The signature is derived from the arguments (:func:`signature_of`), never written by
    hand: adding an argument to a kernel is one edit, to the kernel and its call.  Each
    (function, signature) is compiled once per process.
    """
    signature = signature_of(arguments)
    key = (function, signature)
    with _LOCK:
        compiled = _COMPILED.get(key)
        if compiled is None:
            import numba

            compiled = numba.njit(signature, **OPTIONS)(function)
            _COMPILED[key] = compiled
    return compiled
