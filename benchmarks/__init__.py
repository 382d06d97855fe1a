"""Performance benchmarks of hybridlog (``make bench`` / ``python -m benchmarks.run``).

``python -m benchmarks.run`` imports this package first, so the thread limits below are in
place before numba (through hybridlog) is imported: every measurement runs on one core.  The
estimator kernels are plain sequential loops (no ``prange``), so this changes nothing for
them; it keeps numba's and BLAS's thread pools from adding noise.

The benchmarks' child processes get :func:`child_environment`: this environment as it is at
that point, before anything in this process imports polars, which writes its allocator's
settings into the environment when imported (``_RJEM_MALLOC_CONF``).  A child that inherits
them keeps freed pages resident as the console script does not
(:mod:`hybridlog.allocators`): ``analyze`` of 10^6 rows peaked 17 MiB higher (475 against
458 MiB, three runs each).
"""

import os

for _name in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_name] = "1"

_ENVIRONMENT = dict(os.environ)


def child_environment(**overrides: str) -> dict[str, str]:
    """The environment for a benchmark's child process (module docstring), with ``overrides``."""
    return {**_ENVIRONMENT, **overrides}
