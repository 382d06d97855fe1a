"""A naive all-pairs NumPy port of MATLAB's ``subclust``: the reference for tests and benchmarks.

It follows the MATLAB code line by line (potentials from the full ``N × N`` matrix of squared
distances, one ``argmax`` per accepted or rejected candidate), so it needs ``8·N²`` bytes
(12 GB at 40,000 points) and is independent of :mod:`hybridlog.cluster.subtractive`'s
blocked kernel, grid and candidate walk.  Not for production use.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial.distance import cdist

from hybridlog.signals import FloatArray, IntArray

__all__ = ["naive_subtractive_clustering"]


def naive_subtractive_clustering(
    data: FloatArray,
    radius: float = 0.5,
    *,
    squash: float = 1.25,
    accept: float = 0.5,
    reject: float = 0.15,
    self_potential: bool = True,
) -> tuple[IntArray, FloatArray]:
    """Centre row indices and their potentials ``P_c*``, as MATLAB's ``subclust`` finds them."""
    x = np.asarray(data, dtype=np.float64)
    lower, upper = x.min(axis=0), x.max(axis=0)
    span = np.where(upper > lower, upper - lower, 1.0)
    unit = np.clip((x - lower) / span, 0.0, 1.0) / radius
    kernel = np.exp(-4.0 * cdist(unit, unit, "sqeuclidean"))
    if not self_potential:  # eq. (5) as printed, l ≠ k: dropped, not subtracted (1 + 1e-21 - 1 = 0)
        np.fill_diagonal(kernel, 0.0)
    potentials = kernel.sum(axis=1)
    best = int(np.argmax(potentials))
    reference = potentials[best]
    peak = reference
    centres: list[int] = []
    peaks: list[float] = []
    while peak > 0.0:
        ratio = peak / reference
        if ratio > accept:
            take = True
        elif ratio > reject:
            # no centre yet (accept = 1): none is near, as in the production walk (MATLAB's
            # min over none is empty, and every candidate would be rejected: no centre at all)
            nearest = min((math.dist(unit[best], unit[c]) for c in centres), default=math.inf)
            take = ratio + nearest >= 1.0
        else:
            break
        if take:
            centres.append(best)
            peaks.append(float(peak))
            squared = ((unit - unit[best]) ** 2).sum(axis=1)
            potentials = np.maximum(potentials - peak * np.exp(-4.0 * squared / squash**2), 0.0)
        else:
            potentials[best] = 0.0
        best = int(np.argmax(potentials))
        peak = potentials[best]
    return np.asarray(centres, dtype=np.int64), np.asarray(peaks)
