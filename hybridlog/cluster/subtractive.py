r"""Chiu's subtractive clustering (paper 001, eqs. (5)–(7) and the acceptance rules).

.. math::

    P_k = \sum_l e^{-4\lVert\varphi_k-\varphi_l\rVert^2/r_a^2}                \quad (5)

    P_k \leftarrow P_k - P_c^*\, e^{-4\lVert\varphi_k-\varphi_c^*\rVert^2/r_b^2},
    \qquad r_b = \eta\, r_a                                                    \quad (6),(7)

The data are first scaled into the unit hyper-box (per dimension, by the data's own minimum
and maximum unless bounds are given); radii are in unit-box units.  The point of highest
potential is the first centre; after each accepted centre every potential is revised by
(6)–(7) and clipped at 0.  The next candidate, of revised potential ``P_c*``, is

- accepted when ``P_c*/P_1* > accept`` (ε₁);
- the end of the search when ``P_c*/P_1* ≤ reject`` (ε₂);
- otherwise accepted only if ``d_min/r_a + P_c*/P_1* ≥ 1``, with ``d_min`` its distance to
  the nearest centre; if not, its potential is set to 0 and the next candidate is tried.

Reading choice: the paper prints the grey-zone test as ``d_min/r_a ≤ 1 − P_c*/P_1*``; with
``≤`` it would accept candidates *close* to existing centres, the opposite of the rule's
purpose.  This module uses Chiu's (1994) and MATLAB's ``d_min/r_a + P_c*/P_1* ≥ 1``.

Defaults are MATLAB's ``subclust``: squash ``η = 1.25``, accept 0.5, reject 0.15, the
self term included in (5).  The paper's choices are selectable: ``self_potential=False`` is
eq. (5) as printed (``l ≠ k``), and ``squash`` sets ``r_b/r_a`` (Chiu 1994 suggests 1.5).

Two ways to compute the potentials (5) (:mod:`hybridlog.cluster.potentials`):

``exact``
    All pairs, compiled and blocked: ``O(N²)`` time, ``O(N)`` memory; long work on every
    usable core (:func:`exact_threads`), announced with its expected time and followed by a
    progress bar where a command installed a reporter (:mod:`hybridlog.cluster.progress`).
    Dimensions in which every point sits at the same place are left out (they add 0 to
    every distance).
``approximate``
    Multilinear deposit on a ``(G+1)^d`` grid, separable Gaussian convolution, interpolation
    back to the points: ``O(N·2^d + d·G^{d+1})``.  The selection and the revisions (6)–(7)
    are then done exactly on the data points, so approximate centres are data points too.
    Documented tolerance, tested on 10,000 points of six shapes (Gaussian blobs in 2-D,
    anisotropic and unequal blobs in 3-D, a noisy helix, the double cart's φ(k), a blob on a
    uniform background) at ``r_a = 0.5`` and ``0.3`` with the default ``G = 128``:
    potentials within :data:`POTENTIAL_TOLERANCE` ``· P_max`` of the exact ones (measured
    ≤ 9.4e-4), the same number of centres, each within :data:`CENTRE_TOLERANCE` ``· r_a``
    (unit-box distance) of the exact centre of the same rank (measured ≤ 0.013).  Not covered:
    data whose potential has a ridge of near-equal values (the helix at ``r_a = 0.3``), where
    even the exact centres depend on differences far below the grid's error.
``auto`` (default)
    ``exact`` up to :data:`AUTO_EXACT_MAX` points, ``approximate`` above when the grid is
    fine enough (``h/σ ≤`` :data:`GRID_H_OVER_SIGMA_MAX` with ``h = 1/G`` and
    ``σ = r_a/√8``), else ``exact``; the result says which ran and why.  The grid's error
    grows as ``(h/σ)²``: over the six shapes above at ``r_a`` = 0.5, 0.3 and 0.2 it was at
    most 1.9e-3 ``· P_max`` at ``h/σ = 0.1``, 4.4e-3 at 0.15 and 4.7e-2 at 0.5, so the grid
    runs only where the documented tolerance holds: in practice up to three dimensions,
    ``G = 128`` at ``r_a ≥ 0.22``, below that the coarsest finer grid that is fine enough
    while its ``(G+1)^d`` nodes fit :data:`GRID_CELLS_MAX` (3-D: ``r_a ≥ 0.18``, 161^3
    nodes; 2-D: ``r_a ≥ 0.014``), where its convolutions cost less than the exact pairs;
    with more dimensions, ``(G+1)^d`` nodes fine enough do not fit.

References
----------
S. L. Chiu, "Fuzzy model identification based on cluster estimation", J. Intelligent and
Fuzzy Systems 2 (1994) 267-278.  MATLAB Fuzzy Logic Toolbox, ``subclust``.
Paper 001 (``papers/001_73b6a953d073a2d8.txt``), §4.A, eqs. (5)–(7).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numba
import numpy as np

from hybridlog.cluster.potentials import (
    GRID_CELLS_MAX,
    PAIR_TERM_FLOOR,
    PAIRS_PER_STEP,
    distinct_points,
    exact_potential_rows,
    grid_nodes_per_axis,
    grid_potentials,
)
from hybridlog.cluster.progress import (  # the exact potentials announce long work
    LONG_WORK_S,
    current_reporter,
    duration_text,
)
from hybridlog.environment import usable_cores
from hybridlog.errors import DataShortError, OptionError
from hybridlog.jit import jit
from hybridlog.signals import FloatArray, IntArray

__all__ = [
    "AUTO_EXACT_MAX",
    "CENTRE_TOLERANCE",
    "DISTINCT_SHARE_MAX",
    "GRID_H_OVER_SIGMA_MAX",
    "LONG_WORK_S",
    "METHODS",
    "POTENTIAL_TOLERANCE",
    "ClusteringOptionError",
    "SubtractiveClusters",
    "SubtractiveOptions",
    "duration_text",
    "exact_threads",
    "select_centres",
    "subtractive_clustering",
    "unit_box",
]

AUTO_EXACT_MAX = 20_000
"""``method="auto"`` runs the exact potentials up to this many points (about 0.2 s)."""

CENTRE_TOLERANCE = 0.1
"""Documented agreement of approximate and exact centres, in units of ``r_a`` (unit box)."""

POTENTIAL_TOLERANCE = 2e-3
"""Documented agreement of approximate and exact potentials, relative to the largest."""

METHODS = ("auto", "exact", "approximate")

_CALIBRATION_S = 1.0

DISTINCT_SHARE_MAX = 0.9
"""Long exact work pairs only the distinct points when at most this share of them is."""

GRID_H_OVER_SIGMA_MAX = 0.1
"""Coarsest grid of the approximate potentials, as grid spacing ``h = 1/G`` over the kernel's
``σ = r_a/√8`` in the finest dimension: the largest at which the potentials were measured
within :data:`POTENTIAL_TOLERANCE` (at 0.5 they were up to 5 % off)."""


class ClusteringOptionError(OptionError):
    """A value of :class:`SubtractiveOptions` out of its bounds; ``keys`` names the options.

    The algorithm knows no flag or file: whoever knows where each value came from
    (``--squash``, a model file's ``estimators.chiu.squash``) names it
    (:func:`hybridlog.jobs.cluster.discover_modes`).
    """

    def __init__(self, keys: tuple[str, ...], message: str) -> None:
        super().__init__(message)
        self.keys = keys
        self.reason = message.partition(": ")[2]

    def __reduce__(self) -> tuple[Any, ...]:
        """Pickle with both arguments: analyze runs chiu in a worker and gets its errors back.

        The default pickles ``args`` (the message alone), and unpickling called
        ``__init__(message)``: the worker's "approximate potentials need a grid ..." arrived as
        an unexpected TypeError.
        """
        return (type(self), (self.keys, str(self)))


@dataclass(frozen=True)
class SubtractiveOptions:
    """Parameters of subtractive clustering (defaults: MATLAB ``subclust``).

    Attributes
    ----------
    radius:
        ``r_a`` in unit-box units: one value for every dimension or one per dimension.
    squash:
        ``η = r_b/r_a`` of the revision (6)–(7); must exceed 1.
    accept, reject:
        ε₁ and ε₂ of the acceptance rules (``0 < reject < accept ≤ 1``).
    self_potential:
        Include the ``l = k`` term in (5) (MATLAB); false is the paper's eq. (5).
    method:
        ``"auto"``, ``"exact"`` or ``"approximate"``.
    grid:
        Grid intervals per axis ``G`` of the approximate potentials; ``None`` picks the
        largest ``G ≤ 128`` with ``(G+1)^d ≤ 2^22`` nodes, or a finer one that fits when
        that is too coarse for the radius (:func:`_choose_method`).
    max_centres:
        Stop after this many centres (``None``: no limit).
    """

    radius: float | tuple[float, ...] = 0.5
    squash: float = 1.25
    accept: float = 0.5
    reject: float = 0.15
    self_potential: bool = True
    method: str = "auto"
    grid: int | None = None
    max_centres: int | None = None

    def validate(self, dimensions: int) -> FloatArray:
        """Check every value; return ``r_a`` per dimension, shape ``(dimensions,)``."""
        radii = np.atleast_1d(np.asarray(self.radius, dtype=float))
        if radii.ndim != 1 or radii.shape[0] not in (1, dimensions):
            raise ClusteringOptionError(
                ("radius",),
                f"radius: expected one value or {dimensions} values, got {radii.shape[0]}",
            )
        if not np.all(np.isfinite(radii)) or np.any(radii <= 0.0):
            raise ClusteringOptionError(
                ("radius",), f"radius: must be positive, got {self.radius!r}"
            )
        if not (math.isfinite(self.squash) and self.squash > 1.0):
            raise ClusteringOptionError(
                ("squash",), f"squash: r_b/r_a must be greater than 1, got {self.squash!r}"
            )
        if not 0.0 < self.reject < self.accept <= 1.0:
            raise ClusteringOptionError(
                ("accept", "reject"),
                f"accept, reject: need 0 < reject < accept <= 1, got accept={self.accept!r}, "
                f"reject={self.reject!r}",
            )
        if self.method not in METHODS:
            raise ClusteringOptionError(
                ("method",), f"method: {self.method!r} is not one of {', '.join(METHODS)}"
            )
        if self.grid is not None and not 2 <= self.grid <= 4096:
            raise ClusteringOptionError(
                ("grid",), f"grid: must be between 2 and 4096 intervals, got {self.grid!r}"
            )
        if self.max_centres is not None and self.max_centres < 1:
            raise ClusteringOptionError(
                ("max_centres",), f"max_centres: must be at least 1, got {self.max_centres!r}"
            )
        return np.broadcast_to(radii, (dimensions,)).copy()


@dataclass(frozen=True)
class SubtractiveClusters:
    """Result of :func:`subtractive_clustering`.

    Attributes
    ----------
    centers:
        Cluster centres in data units, shape ``(c, d)``, in the order found.
    centers_unit:
        The same in unit-box coordinates.
    center_indices:
        Row of the data point each centre is, shape ``(c,)``.
    potentials:
        Revised potential ``P_c*`` of each centre when it was accepted, shape ``(c,)``.
    potential_ratios:
        ``P_c*/P_1*``.
    radii:
        ``r_a`` of each dimension in data units (``r_a`` × range), shape ``(d,)``.
    sigmas:
        ``radii/√8``: the standard deviations of the Gaussian memberships (MATLAB's output).
    lower, upper:
        Bounds of the unit-box scaling, shape ``(d,)``.
    method:
        ``"exact"`` or ``"approximate"``: what computed the potentials.
    grid:
        ``G`` of the approximate potentials, ``None`` for exact.
    initial_potentials:
        Potentials (5) of every data point before any revision, shape ``(N,)``.
    final_potentials:
        Potentials after the last revision (and rejections), clipped at 0, shape ``(N,)``.
    options:
        The options used.
    notes:
        Why the method was chosen, for reports.
    """

    centers: FloatArray
    centers_unit: FloatArray
    center_indices: IntArray
    potentials: FloatArray
    potential_ratios: FloatArray
    radii: FloatArray
    sigmas: FloatArray
    lower: FloatArray
    upper: FloatArray
    method: str
    grid: int | None
    initial_potentials: FloatArray
    final_potentials: FloatArray
    options: SubtractiveOptions
    notes: tuple[str, ...] = field(default=())

    @property
    def n_clusters(self) -> int:
        """Number of centres found."""
        return int(self.centers.shape[0])


def unit_box(
    data: FloatArray, bounds: tuple[Sequence[float], Sequence[float]] | None = None
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Scale ``data`` ``(N, d)`` into the unit hyper-box (clipped), as ``subclust`` does.

    A dimension whose range is zero maps to 0 (its range is taken as 1).

    Returns
    -------
    tuple
        ``(unit data, lower, upper)``.
    """
    if bounds is None:
        lower = data.min(axis=0)
        upper = data.max(axis=0)
    else:
        lower = np.asarray(bounds[0], dtype=float)
        upper = np.asarray(bounds[1], dtype=float)
        if lower.shape != (data.shape[1],) or upper.shape != (data.shape[1],):
            raise OptionError(f"bounds: expected {data.shape[1]} lower and upper values")
        if np.any(upper < lower):
            raise OptionError("bounds: every upper bound must be at least the lower one")
    span = np.where(upper > lower, upper - lower, 1.0)
    unit: FloatArray = np.clip((data - lower) / span, 0.0, 1.0)
    return unit, lower.astype(float), upper.astype(float)


def _select_steps(
    X: FloatArray,
    P: FloatArray,
    squash: float,
    accept: float,
    reject: float,
    max_centres: int,
    centres_out: IntArray,
    potentials_out: FloatArray,
) -> int:  # compiled as select_centres
    d, n = X.shape
    count = 0
    best = 0
    for k in range(n):
        if P[k] > P[best]:
            best = k
    reference = P[best]
    if not reference > 0.0:
        return 0
    revise = 4.0 / (squash * squash)
    order = np.empty(0, dtype=np.int64)
    position = 0
    walking = False
    while count < max_centres:
        if walking:
            # Successive maxima after rejections: walk the candidates in descending order.
            while position < order.shape[0] and P[order[position]] <= 0.0:
                position += 1
            if position == order.shape[0]:
                break
            best = order[position]
        peak = P[best]
        if not peak > 0.0:
            break
        ratio = peak / reference
        take = ratio > accept
        if not take:
            if not ratio > reject:
                break
            nearest = np.inf
            for c in range(count):
                other = centres_out[c]
                squared = 0.0
                for a in range(d):
                    t = X[a, best] - X[a, other]
                    squared += t * t
                nearest = min(nearest, squared)
            take = ratio + math.sqrt(nearest) >= 1.0
        if not take:
            P[best] = 0.0
            if not walking:
                threshold = reject * reference
                candidates = np.flatnonzero(threshold < P)
                order = candidates[np.argsort(-P[candidates], kind="mergesort")]
                position = 0
                walking = True
            continue
        centres_out[count] = best
        potentials_out[count] = peak
        count += 1
        for k in range(n):
            squared = 0.0
            for a in range(d):
                t = X[a, k] - X[a, best]
                squared += t * t
            value = P[k] - peak * math.exp(-revise * squared)
            P[k] = value if value > 0.0 else 0.0
        walking = False
        best = 0
        for k in range(n):
            if P[k] > P[best]:
                best = k
    return count


_select_loop = jit(_select_steps)


def select_centres(
    X: FloatArray,
    potentials: FloatArray,
    options: SubtractiveOptions,
    *,
    jit: bool = True,
) -> tuple[IntArray, FloatArray, FloatArray]:
    """Centres from potentials by the revisions (6)–(7) and the acceptance rules.

    Parameters
    ----------
    X:
        Unit-box coordinates divided by ``r_a`` per dimension, shape ``(d, N)``.
    potentials:
        Potentials (5) of the points, shape ``(N,)`` (not modified).
    options:
        ``squash``, ``accept``, ``reject``, ``max_centres``.
    jit:
        Compiled loop (default) or the same code as plain Python.

    Returns
    -------
    tuple
        ``(centre indices, their potentials P_c*, the final revised potentials)``.
    """
    P = np.array(potentials, dtype=np.float64)
    n = P.shape[0]
    limit = n if options.max_centres is None else min(n, options.max_centres)
    indices = np.zeros(max(limit, 1), dtype=np.int64)
    peaks = np.zeros(max(limit, 1))
    loop = _select_loop if jit else _select_steps
    count = loop(
        np.ascontiguousarray(X, dtype=np.float64),
        P,
        float(options.squash),
        float(options.accept),
        float(options.reject),
        limit,
        indices,
        peaks,
    )
    return indices[:count].copy(), peaks[:count].copy(), P


def _choose_method(
    options: SubtractiveOptions, n: int, radii: FloatArray
) -> tuple[str, int | None, str, str]:
    """The method to run, the grid size, a note saying why, and the way to the grid.

    The last is for the exact potentials, which a long log makes long: what would take the
    approximate ones instead (``method=approximate``, or the radius at which the finest
    grid that fits is fine enough), or ``""``.
    """
    d = radii.shape[0]
    intervals = grid_nodes_per_axis(d, options.grid)
    finer = options.grid is None and _h_over_sigma(intervals, radii) > GRID_H_OVER_SIGMA_MAX
    if finer:  # the finest grid that fits, no finer than the tolerance needs
        wanted = math.ceil(math.sqrt(8.0) / (float(radii.min()) * GRID_H_OVER_SIGMA_MAX))
        intervals = max(intervals, min(wanted, _finest_intervals(d)))
    h_over_sigma = _h_over_sigma(intervals, radii)
    grid_ok = (intervals + 1) ** d <= GRID_CELLS_MAX or options.grid is not None
    grid_fine = h_over_sigma <= GRID_H_OVER_SIGMA_MAX
    grid_text = f"{intervals + 1}^{d} grid nodes, h/σ = {h_over_sigma:.3f}"
    # h/σ = √8 / (G r_a): the radius at which the finest grid that fits is fine enough
    finest = intervals if options.grid is not None else _finest_intervals(d)
    needed = math.ceil(math.sqrt(8.0) / (finest * GRID_H_OVER_SIGMA_MAX) * 100) / 100
    if grid_ok and grid_fine:
        way_out = "method=approximate takes the grid's approximate potentials instead"
    else:
        way_out = (
            f"method=approximate with radius >= {needed:g} or fewer lags takes the grid's "
            "approximate potentials instead"
        )
    points = "1 point" if n == 1 else f"{n} points"  # "approximate potentials (1 points"
    if options.method == "exact":
        return "exact", None, f"exact potentials ({points}, requested)", way_out
    if options.method == "approximate":
        if not (grid_ok and grid_fine):
            raise ClusteringOptionError(
                ("method", "radius"),
                f"method: the approximate potentials need a grid with h/σ <= "
                f"{GRID_H_OVER_SIGMA_MAX} to stay within {POTENTIAL_TOLERANCE:g} of the exact "
                f"ones; {d} varying dimensions at r_a = {float(radii.min()):g} give "
                f"{grid_text}: use method=exact (O(N²)), fewer lags, or radius >= {needed:g}",
            )
        return "approximate", intervals, f"approximate potentials ({points}, {grid_text})", ""
    if n <= AUTO_EXACT_MAX:
        note = f"exact potentials (auto: {points} <= {AUTO_EXACT_MAX})"
        return "exact", None, note, way_out
    if grid_ok and grid_fine:
        # a grid finer than the default costs d·(G+1)^(d+1) in its convolutions: run where
        # that is below the exact pairs' cost (a pair's exp about 10 multiply-adds)
        if finer and d * (intervals + 1) ** (d + 1) > _PAIR_COST * (n * (n - 1) // 2):
            return (
                "exact",
                None,
                f"exact potentials (auto: {n} points; fewer pairs than work on the "
                f"{grid_text} fine enough)",
                "",  # the grid would take longer
            )
        return (
            "approximate",
            intervals,
            f"approximate potentials (auto: {n} points > {AUTO_EXACT_MAX}; {grid_text})",
            "",
        )
    way_out = f"radius >= {needed:g} or fewer lags take the grid's approximate potentials instead"
    return (
        "exact",
        None,
        f"exact potentials (auto: {n} points, but the grid would be too coarse: {grid_text} "
        f"> {GRID_H_OVER_SIGMA_MAX})",
        way_out,
    )


_PAIR_COST = 10
"""Multiply-adds of the grid's convolutions counted as one pair of the exact potentials, when
:func:`_choose_method` weighs a grid finer than the default against the exact pairs (one
pair's compiled ``exp`` and distance cost about that many)."""


def _h_over_sigma(intervals: int, radii: FloatArray) -> float:
    """``h/σ`` of a grid of ``intervals`` per axis: ``h = 1/G``, ``σ = r_a/√8`` (finest)."""
    return (1.0 / intervals) / (float(radii.min()) / math.sqrt(8.0))


def _finest_intervals(d: int) -> int:
    """The most grid intervals per axis that fit :data:`GRID_CELLS_MAX`.

    Both the ``(G+1)^d`` nodes and each axis's ``(G+1)×(G+1)`` convolution kernel must fit.

    :func:`~hybridlog.cluster.potentials.grid_nodes_per_axis` stops at 128 (fine enough at
    ``r_a`` ≥ 0.22); a smaller radius in up to three dimensions takes a finer grid that still
    fits: at ``r_a = 0.2`` in 3-D (143^3 nodes) auto ran the exact potentials instead, 1.8 h
    for 10^6 regression vectors on 2 cores where the grid takes seconds.
    """
    fits = int(math.floor(float(GRID_CELLS_MAX) ** (1.0 / d) + 1e-9)) - 1  # noqa: RUF046
    fits = min(fits, math.isqrt(GRID_CELLS_MAX) - 1)  # the kernel: 2048 x 2048 at most
    while (fits + 1) ** d > GRID_CELLS_MAX:
        fits -= 1
    return max(1, fits)


def _long_work(n: int) -> bool:
    """``n`` points have at least ``4·PAIRS_PER_STEP`` pairs (about half a second)."""
    return n * (n - 1) // 2 >= 4 * PAIRS_PER_STEP


def exact_threads(n: int) -> int:
    """Threads of the exact potentials of ``n`` points: the usable cores for long work.

    One below ``4·PAIRS_PER_STEP`` pairs (about half a second: small logs give the same
    potentials, bit for bit, on every machine); else the cores this process may run on,
    at most numba's thread count (``NUMBA_NUM_THREADS``, which the benchmarks set to 1).
    """
    if not _long_work(n):
        return 1
    return max(1, min(usable_cores(), int(getattr(numba.config, "NUMBA_NUM_THREADS", 1))))


def _reported_exact_potentials(
    scaled: FloatArray, options: SubtractiveOptions, *, jit: bool, why: str, way_out: str = ""
) -> tuple[FloatArray, str]:
    """Exact potentials; when long, a note with the expected time and a progress bar first.

    Long work (:func:`exact_threads`) pairs the distinct points only, each weighted by its
    copies, when at most :data:`DISTINCT_SHARE_MAX` of the points are distinct (quantised
    sensors, a plant at rest): the same potentials up to rounding, in ``(M/N)²`` of the
    time.  The first steps are timed (after the first, which may load the compiled kernel);
    when the whole would take more than :data:`LONG_WORK_S`, the installed reporter gets
    one line (points, dimensions, pairs, expected time, ``why`` the exact path runs and the
    ``way_out`` to the grid) and a bar.

    Returns
    -------
    tuple
        ``(P, a note on the distinct points or "")``.
    """
    reporter = current_reporter()
    d, n = scaled.shape
    points, weights, index, said = scaled, None, None, ""
    if _long_work(n):
        distinct, counts, where = distinct_points(scaled)
        if distinct.shape[1] <= DISTINCT_SHARE_MAX * n:
            points, weights, index = distinct, counts, where
            said = f"{distinct.shape[1]:,} distinct of {n:,} points, weighted by their copies"
    m = points.shape[1]
    P = np.empty(m)
    threads = exact_threads(m)
    steps = exact_potential_rows(
        points,
        P,
        self_potential=options.self_potential,
        jit=jit,
        threads=threads,
        weights=weights,
    )
    first, total = next(steps)
    done = first
    if reporter is not None and first < total:
        started = time.perf_counter()
        for done, _ in steps:
            elapsed = time.perf_counter() - started
            if done == total or elapsed >= _CALIBRATION_S:
                break
        expected = elapsed * (total - first) / (done - first)
        if done < total and expected > LONG_WORK_S:
            reporter.note(
                f"exact potentials of {n:,} points{f' ({said})' if said else ''} in {d} "
                f"dimensions ({total:.2g} pairs, O(N²)): about {duration_text(expected)} on this "
                f"machine with {threads} thread{'s' if threads > 1 else ''} "
                f"{why.removeprefix('exact potentials ')}{f'; {way_out}' if way_out else ''}"
            )
            with reporter.bar(total, "cluster potentials") as advance:
                advance(done)
                for now, _ in steps:
                    advance(now - done)
                    done = now
    for _ in steps:
        pass
    return (P if index is None else P[index]), said


def subtractive_clustering(
    data: FloatArray,
    options: SubtractiveOptions | None = None,
    *,
    bounds: tuple[Sequence[float], Sequence[float]] | None = None,
    jit: bool = True,
) -> SubtractiveClusters:
    """Cluster ``data`` by Chiu's subtractive clustering (paper 001, eqs. (5)–(7)).

    Parameters
    ----------
    data:
        Points, shape ``(N, d)`` (e.g. regression vectors φ(k)); rows must be finite.
    options:
        :class:`SubtractiveOptions` (defaults: MATLAB ``subclust``).
    bounds:
        ``(lower, upper)`` of the unit-box scaling; default: the data's min and max.
    jit:
        Compiled kernels (default) or plain Python (tests, small data).

    Returns
    -------
    SubtractiveClusters
        Centres (data points), their potentials, radii, scaling and the method used.

    Raises
    ------
    OptionError
        On invalid options, an empty or non-finite data set.
    DataShortError
        Without the self term, when no two points lie within reach of each other: every
        potential is zero (the message names no file: the caller knows the data).
    """
    options = options or SubtractiveOptions()
    points = np.asarray(data, dtype=np.float64)
    if points.ndim != 2 or points.shape[0] == 0 or points.shape[1] == 0:
        raise OptionError(f"data: expected a non-empty (N, d) array, got shape {points.shape}")
    if not np.all(np.isfinite(points)):
        row = int(np.argmax(~np.all(np.isfinite(points), axis=1)))
        raise OptionError(f"data: row {row} is not finite")
    n, d = points.shape
    radii = options.validate(d)
    unit, lower, upper = unit_box(points, bounds)
    # a dimension in which every point sits at the same place adds 0 to every distance: left
    # out, it no longer makes the grid too coarse (u(k-1) of a log with a constant input)
    varying = unit.max(axis=0) > unit.min(axis=0)
    constant = not varying.any()
    varying[0] |= constant
    method, intervals, note, way_out = _choose_method(options, n, radii[varying])
    if constant:  # the one dimension kept above is constant too
        which = "the only dimension" if d == 1 else f"all {d} dimensions"
        note += f"; {which} constant: every point the same"
    elif not varying.all():
        note += f"; {int(np.sum(~varying))} of {d} dimensions constant, left out"
    scaled = np.ascontiguousarray((unit[:, varying] / radii[varying]).T)
    if method == "exact":
        initial, said = _reported_exact_potentials(
            scaled, options, jit=jit, why=note, way_out=way_out
        )
        note += f"; {said}" if said else ""
    else:
        assert intervals is not None
        initial = grid_potentials(
            unit[:, varying],
            radii[varying],
            intervals,
            self_potential=options.self_potential,
        )
    if not options.self_potential and not initial.max() > 2.0 * (n - 1) * PAIR_TERM_FLOOR:
        # every potential is the floor of underflowed terms (or, for one point, zero): their
        # ratios would pick "centres" from rounding, and one point gave none at all
        radius = ", ".join(f"{r:g}" for r in np.unique(radii))
        alone = "one point alone" if n == 1 else f"no two of the {n} points within reach"
        raise DataShortError(
            f"radius: {alone} at r_a = {radius}: without the self term (self_potential = "
            "false, eq. (5) as printed) every potential is zero; use a larger radius or "
            "self_potential = true"
        )
    indices, peaks, final = select_centres(scaled, initial, options, jit=jit)
    span = upper - lower
    ratios = peaks / peaks[0] if peaks.shape[0] else peaks
    return SubtractiveClusters(
        centers=points[indices].copy(),
        centers_unit=unit[indices].copy(),
        center_indices=indices,
        potentials=peaks,
        potential_ratios=ratios,
        radii=radii * span,
        sigmas=radii * span / math.sqrt(8.0),
        lower=lower,
        upper=upper,
        method=method,
        grid=intervals,
        initial_potentials=initial,
        final_potentials=final,
        options=options,
        notes=(note,),
    )
