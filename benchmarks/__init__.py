"""Performance benchmarks of hybridlog (``make bench`` / ``python -m benchmarks.run``).

``python -m benchmarks.run`` imports this package first, so the thread limits below are in
place before numba (through hybridlog) is imported: every measurement runs on one core.  The
estimator kernels are plain sequential loops (no ``prange``), so this changes nothing for
them; it keeps numba's and BLAS's thread pools from adding noise.
"""

import os

for _name in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_name] = "1"
