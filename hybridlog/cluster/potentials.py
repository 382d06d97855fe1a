r"""Potentials of subtractive clustering: exact (blocked, compiled) and grid-approximated.

The potential of data point :math:`\varphi(k)` is paper 001's eq. (5),

.. math::

    P_k = \sum_{l} \exp\!\left(-4\,\frac{\lVert\varphi(k) - \varphi(l)\rVert^2}{r_a^2}\right),

with the sum over all ``l`` when ``self_potential`` is true (MATLAB's ``subclust``, Chiu 1994)
or over ``l ≠ k`` (the paper's eq. (5): every potential is then 1 smaller).  Here the
coordinates are already divided by the radius ``r_a`` of each dimension, so the kernel is
``exp(-4‖Δ‖²)``.

Exact potentials
    :func:`exact_potentials`: all pairs, ``O(N²)`` time, ``O(N)`` memory.  The compiled kernel
    visits each unordered pair once (both potentials are updated), in blocks of ``_BLOCK``
    partners held in small buffers, and evaluates ``exp`` with a Cody–Waite range reduction
    and a degree-11 polynomial that LLVM vectorises (numba's ``math.exp`` is a scalar libm
    call, about 3x slower here); the relative error of that ``exp`` is below 1e-15.
    :func:`exact_potential_rows` runs the rows in steps of about :data:`PAIRS_PER_STEP`
    pairs (for a note with the expected time and a progress bar), optionally on several
    threads, each step cut into row ranges of equal pairs (the kernel releases the GIL).
Approximate potentials
    :func:`grid_potentials`: the data are deposited on a regular grid of ``(G+1)^d`` nodes
    spanning the unit box with multilinear (cloud-in-cell) weights, the node masses are
    convolved with the Gaussian kernel one axis at a time (a ``(G+1)×(G+1)`` matrix product
    per axis: the kernel is separable), and each point's potential is interpolated back with
    the same weights.  Deposit and interpolation each widen the kernel by a variance of
    ``h²/6`` per axis on average (``h = 1/G``); the kernel used on the grid is narrowed by
    ``h²/3`` (and rescaled to keep its mass) to cancel that on average.  The remaining error
    is of order ``(h/σ)²`` with ``σ = r_a/√8``; see :mod:`hybridlog.cluster.subtractive`
    for the measured tolerance.

References
----------
S. L. Chiu, "Fuzzy model identification based on cluster estimation", J. Intelligent and
Fuzzy Systems 2 (1994) 267-278.  Paper 001 (``papers/001_73b6a953d073a2d8.txt``), eq. (5).
"""

from __future__ import annotations

import contextlib
import itertools
import math
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from hybridlog.jit import jit
from hybridlog.signals import FloatArray, IntArray

__all__ = [
    "GRID_CELLS_MAX",
    "PAIRS_PER_STEP",
    "PAIR_TERM_FLOOR",
    "distinct_points",
    "exact_potential_rows",
    "exact_potentials",
    "grid_nodes_per_axis",
    "grid_potentials",
    "naive_potentials",
]

_BLOCK = 256
_LOG2E = 1.4426950408889634
_LN2_HI = 0.693147180369123816490
_LN2_LO = 1.90821492927058770002e-10
_MAGIC = 6755399441055744.0  # 1.5 * 2**52: adding it rounds to an integer held in the low bits
_MAGIC_BITS = int(np.array([_MAGIC]).view(np.int64)[0])
_EXP_FLOOR = -700.0  # exp(-700) ≈ 1e-304: still a normal number, so 2**n needs no special case

PAIR_TERM_FLOOR = math.exp(_EXP_FLOOR)
"""The least a pair of points adds to each other's exact potential: a term exp(−4 d²) that
underflows is counted as this (≈ 9.9e-305), so that the compiled exp needs no special case."""

PAIRS_PER_STEP = 1 << 27
"""Pairs of one step of :func:`exact_potential_rows` (about 0.1-0.2 s on one core)."""

GRID_CELLS_MAX = 1 << 22
"""Largest number of grid nodes ``(G+1)^d`` of the approximate potentials (32 MiB a grid)."""


def _exact_steps(
    X: FloatArray, W: FloatArray | None, P: FloatArray, start: int, stop: int
) -> None:  # compiled below; W None (unweighted) is its own specialisation, pruned by numba
    d, n = X.shape
    squared = np.empty(_BLOCK)
    poly = np.empty(_BLOCK)
    scaled = np.empty(_BLOCK)
    bits = scaled.view(np.int64)
    row = np.empty(_BLOCK)
    for i in range(start, stop):
        # Pairs (i, j > i) in blocks: both P[i] and P[j] receive exp(-4 |X_i - X_j|^2).
        row[:] = 0.0
        for j0 in range(i + 1, n, _BLOCK):
            m = min(n, j0 + _BLOCK) - j0
            xi = X[0, i]
            column = X[0, j0 : j0 + m]
            for jj in range(m):
                t = column[jj] - xi
                squared[jj] = t * t
            for c in range(1, d):
                xi = X[c, i]
                column = X[c, j0 : j0 + m]
                for jj in range(m):
                    t = column[jj] - xi
                    squared[jj] += t * t
            # exp(x) = 2**n * p(r) with x = n ln2 + r, |r| <= ln2/2 (Cody-Waite); n sits in
            # the low bits of y = x log2(e) + 1.5*2**52 and is moved into the exponent field.
            for jj in range(m):
                x = max(-4.0 * squared[jj], _EXP_FLOOR)
                y = x * _LOG2E + _MAGIC
                nf = y - _MAGIC
                r = (x - nf * _LN2_HI) - nf * _LN2_LO
                p = 2.505210838544172e-08
                p = p * r + 2.755731922398589e-07
                p = p * r + 2.7557319223985893e-06
                p = p * r + 2.48015873015873e-05
                p = p * r + 0.0001984126984126984
                p = p * r + 0.001388888888888889
                p = p * r + 0.008333333333333333
                p = p * r + 0.041666666666666664
                p = p * r + 0.16666666666666666
                p = p * r + 0.5
                p = p * r + 1.0
                p = p * r + 1.0
                poly[jj] = p
                scaled[jj] = y
            for jj in range(m):
                bits[jj] = ((bits[jj] - _MAGIC_BITS) + 1023) << 52
            target = P[j0 : j0 + m]
            if W is None:
                for jj in range(m):
                    e = poly[jj] * scaled[jj]
                    row[jj] += e
                    target[jj] += e
            else:
                weights = W[j0 : j0 + m]
                wi = W[i]
                for jj in range(m):
                    e = poly[jj] * scaled[jj]
                    row[jj] += e * weights[jj]
                    target[jj] += e * wi
        total = 0.0
        for jj in range(_BLOCK):
            total += row[jj]
        P[i] += total


# hybridlog.jit's options plus fused multiply-add ("contract"), which lets LLVM vectorise the
# polynomial; no reassociation, so the integer-rounding trick of the exp stays exact.
_exact_kernel = jit(_exact_steps, fastmath={"contract"})


def exact_potential_rows(
    X: FloatArray,
    P: FloatArray,
    *,
    self_potential: bool = True,
    jit: bool = True,
    threads: int = 1,
    weights: FloatArray | None = None,
) -> Iterator[tuple[int, int]]:
    """Exact potentials (eq. (5)) into ``P`` in steps of about :data:`PAIRS_PER_STEP` pairs.

    Yields ``(pairs done, all pairs)`` after each step (``N(N-1)/2`` pairs in all), so a
    caller can time the first steps, say how long the rest will take and show progress;
    ``P`` (shape ``(N,)``, overwritten) is complete after the last step.  ``X``,
    ``self_potential`` and ``jit`` as in :func:`exact_potentials`.

    With ``threads > 1`` each step (``threads`` times as many pairs) is cut into ``threads``
    row ranges of as many pairs, run at once by the compiled kernel (which releases the
    GIL), each into its own ``(N,)`` sums (``8·threads·N`` bytes); the sums are added at
    the end, so ``P`` differs from one thread's only by rounding (a few units in the last
    place).

    ``weights`` (shape ``(N,)``): each point stands for that many identical points
    (:func:`distinct_points`); ``P`` is then the potential of each of them, as if every copy
    were there, and the pairs are those of the distinct points.
    """
    data = np.ascontiguousarray(X, dtype=np.float64)
    W = None if weights is None else np.ascontiguousarray(weights, dtype=np.float64)
    n = data.shape[1]
    kernel = _exact_kernel if jit else _exact_steps
    total = n * (n - 1) // 2
    threads = max(1, min(threads, n))
    # row i pairs with the n - 1 - i rows after it: cut the rows where the pairs so far
    # pass a multiple of the step
    done_after = np.cumsum(np.arange(n - 1, -1, -1, dtype=np.int64))
    step = PAIRS_PER_STEP * threads
    cuts = (np.searchsorted(done_after, np.arange(step, total, step)) + 1).tolist()
    sums = np.zeros((threads, n))
    # the self term, and the copies of a point (at distance 0) but the point itself
    sums[0] = (1.0 if self_potential else 0.0) + (0.0 if W is None else W - 1.0)
    with contextlib.ExitStack() as stack:
        pool = None
        if threads > 1:
            pool = stack.enter_context(ThreadPoolExecutor(threads, "hybridlog-potentials"))
        start = 0
        for stop in [*cuts, n]:
            if stop <= start:
                continue
            if pool is None:
                kernel(data, W, sums[0], start, stop)
            else:
                before = int(done_after[start - 1]) if start else 0
                shares = np.linspace(before, int(done_after[stop - 1]), threads + 1)[1:-1]
                inner = np.searchsorted(done_after, shares) + 1
                bounds = [start, *np.clip(inner, start, stop).tolist(), stop]
                futures = [
                    pool.submit(kernel, data, W, sums[t], bounds[t], bounds[t + 1])
                    for t in range(threads)
                    if bounds[t + 1] > bounds[t]
                ]
                for future in futures:
                    future.result()
            start = stop
            if stop == n:
                np.sum(sums, axis=0, out=P)
            yield int(done_after[stop - 1]), total
    if n == 0:
        yield 0, 0


def distinct_points(X: FloatArray) -> tuple[FloatArray, FloatArray, IntArray]:
    """The distinct columns of ``X`` ``(d, N)``, how often each occurs, and where each point went.

    Returns
    -------
    tuple
        ``(distinct (d, M), counts (M,) as floats, index (N,) of each point's column)``.
    """
    distinct, index, counts = np.unique(
        np.asarray(X).T, axis=0, return_inverse=True, return_counts=True
    )
    return (
        np.ascontiguousarray(distinct.T),
        counts.astype(np.float64),
        index.reshape(-1).astype(np.int64),
    )


def exact_potentials(X: FloatArray, *, self_potential: bool = True, jit: bool = True) -> FloatArray:
    """Exact potentials (eq. (5)) of points given in radius units.

    Parameters
    ----------
    X:
        Coordinates divided by the radius of each dimension, shape ``(d, N)``.
    self_potential:
        Include the ``l = k`` term (1) as MATLAB's ``subclust`` does; false is eq. (5).
    jit:
        Use the compiled kernel; false runs the same code as plain Python (slow: tests only).

    Returns
    -------
    FloatArray
        ``P``, shape ``(N,)``.
    """
    P = np.empty(np.shape(X)[1])
    for _ in exact_potential_rows(X, P, self_potential=self_potential, jit=jit):
        pass
    return P


def naive_potentials(X: FloatArray, *, self_potential: bool = True) -> FloatArray:
    """All-pairs NumPy reference of :func:`exact_potentials`: ``O(N²)`` memory (8·N² bytes)."""
    from scipy.spatial.distance import cdist

    points = np.ascontiguousarray(np.asarray(X, dtype=np.float64).T)
    potentials: FloatArray = np.exp(-4.0 * cdist(points, points, "sqeuclidean")).sum(axis=1)
    return potentials if self_potential else potentials - 1.0


def grid_nodes_per_axis(d: int, requested: int | None = None) -> int:
    """Grid intervals ``G`` per axis: ``requested``, else the largest ≤ 128 that fits.

    ``(G+1)^d`` nodes must not exceed :data:`GRID_CELLS_MAX`.
    """
    if requested is not None:
        return requested
    fits = int(math.floor(float(GRID_CELLS_MAX) ** (1.0 / d) + 1e-9)) - 1  # noqa: RUF046
    return max(1, min(128, fits))


def _corner(
    base: IntArray, frac: FloatArray, corner: tuple[int, ...], nodes: int
) -> tuple[IntArray, FloatArray]:
    """Flat node index and multilinear weight of one corner of every point's cell."""
    n, d = base.shape
    flat = np.zeros(n, dtype=np.int64)
    weight = np.ones(n)
    for c in range(d):
        flat *= nodes
        flat += base[:, c] + corner[c]
        weight *= frac[:, c] if corner[c] else 1.0 - frac[:, c]
    return flat, weight


def grid_potentials(
    unit: FloatArray, radii: FloatArray, intervals: int, *, self_potential: bool = True
) -> FloatArray:
    """Approximate potentials (eq. (5)): multilinear deposit, separable convolution, interpolation.

    Parameters
    ----------
    unit:
        Points in the unit box, shape ``(N, d)``.
    radii:
        ``r_a`` of each dimension in unit-box units, shape ``(d,)``.
    intervals:
        ``G``: grid intervals per axis (nodes at ``i/G``, ``i = 0..G``).
    self_potential:
        As in :func:`exact_potentials`.

    Returns
    -------
    FloatArray
        Approximate ``P``, shape ``(N,)``.
    """
    n, d = unit.shape
    nodes = intervals + 1
    h = 1.0 / intervals
    position = np.clip(unit, 0.0, 1.0) * intervals
    base = np.minimum(np.floor(position).astype(np.int64), intervals - 1)
    frac = position - base
    del position
    corners = list(itertools.product((0, 1), repeat=d))
    grid = np.zeros(nodes**d)
    for corner in corners:
        flat, weight = _corner(base, frac, corner, nodes)
        grid += np.bincount(flat, weights=weight, minlength=nodes**d)
    offsets = np.arange(nodes) * h
    field = grid.reshape((nodes,) * d)
    for axis in range(d):
        variance = float(radii[axis]) ** 2 / 8.0
        narrowed = variance - h * h / 3.0
        kernel = math.sqrt(variance / narrowed) * np.exp(
            -((offsets[:, None] - offsets[None, :]) ** 2) / (2.0 * narrowed)
        )
        field = np.moveaxis(np.tensordot(kernel, field, axes=([1], [axis])), 0, axis)
    values = np.ascontiguousarray(field).reshape(-1)
    potentials = np.zeros(n)
    for corner in corners:
        flat, weight = _corner(base, frac, corner, nodes)
        potentials += weight * values[flat]
    if not self_potential:
        potentials -= 1.0
    clipped: FloatArray = np.maximum(potentials, 0.0)
    return clipped
