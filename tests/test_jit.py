"""``hybridlog.jit.set_up``: numba's CPU target set up without SciPy's BLAS probe."""

from __future__ import annotations

import subprocess
import sys

SET_UP = """
import sys
from hybridlog.jit import BLAS_PROBE, set_up
set_up()
loaded = "scipy.linalg" in sys.modules
import numba
import numpy as np

@numba.njit
def product(a, b):
    return np.dot(a, b)

# a kernel that calls BLAS still gets it: SciPy is imported when it is compiled
value = product(np.arange(3.0), np.arange(3.0))
print(loaded, BLAS_PROBE in sys.modules and sys.modules[BLAS_PROBE] is not None, value)
"""


def test_set_up_skips_the_blas_probe_and_blas_kernels_still_compile() -> None:
    done = subprocess.run(
        [sys.executable, "-c", SET_UP], capture_output=True, text=True, check=True
    )
    assert done.stdout.split() == ["False", "True", "5.0"]
