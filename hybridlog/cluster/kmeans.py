"""The k-means baseline of paper 001's comparison (Tables 1–4).

SciPy's :func:`scipy.cluster.vq.kmeans2` (Lloyd's algorithm, k-means++ seeding) on the same
unit-box-scaled regression vectors as the subtractive clustering, restarted ``restarts``
times with seeds ``seed, seed+1, …``; the run with the smallest within-cluster sum of squares
wins.  SciPy is already a dependency and its ``kmeans2`` is enough for ``k`` = the number of
modes; scikit-learn's ``KMeans`` (the usual choice) would add a large dependency for the same
algorithm.  Results are deterministic for a given seed.

``kmeans2`` always runs all its ``iter`` iterations (100 here: two and a half minutes of
restarts on 10^6 six-dimensional points).  :func:`_lloyd` runs it one iteration at a time
and stops at the fixed point, where the labels repeat: the same labels give the same means,
so every later iteration would repeat too, and the result is ``kmeans2``'s bit for bit.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.cluster.vq import kmeans2

from hybridlog.cluster.subtractive import unit_box
from hybridlog.errors import DataShortError, OptionError
from hybridlog.signals import FloatArray, IntArray

__all__ = ["KMeansClusters", "KMeansParameters", "kmeans_clustering"]


@dataclass(frozen=True)
class KMeansParameters:
    """Parameters of the k-means baseline as the mode classifier uses them.

    Attributes
    ----------
    clusters:
        Number of centres ``k``; ``None``: the number of the model's modes.
    restarts:
        k-means++ runs; the one of least inertia is kept.
    seed:
        Seed of the first run (then ``seed + 1``, ...).
    """

    clusters: int | None = None
    restarts: int = 10
    seed: int = 0


@dataclass(frozen=True)
class KMeansClusters:
    """Result of :func:`kmeans_clustering`.

    Attributes
    ----------
    centers, centers_unit:
        Centres in data units and in unit-box coordinates, shape ``(k, d)``.
    sizes:
        Points assigned to each centre (nearest centre in the unit box), shape ``(k,)``.
    inertia:
        Within-cluster sum of squared unit-box distances of the winning run.
    lower, upper:
        Bounds of the unit-box scaling.
    seed, restarts, iterations:
        The settings used.
    """

    centers: FloatArray
    centers_unit: FloatArray
    sizes: IntArray
    inertia: float
    lower: FloatArray
    upper: FloatArray
    seed: int
    restarts: int
    iterations: int

    @property
    def n_clusters(self) -> int:
        """Number of centres."""
        return int(self.centers.shape[0])


def _lloyd(
    unit: FloatArray, n_clusters: int, iterations: int, seed: int
) -> tuple[FloatArray, IntArray]:
    """``kmeans2(unit, n_clusters, iter=iterations, minit="++", rng=seed)``, stopped early.

    Each call after the first continues from the centres of the last (``minit="matrix"``)
    for one more iteration; when it gives the labels of the iteration before, the centres
    it computes from them are the ones it started from, and so are all later ones.
    """
    centres, labels = kmeans2(unit, n_clusters, iter=1, minit="++", rng=seed)
    for _ in range(1, iterations):
        following, relabelled = kmeans2(unit, centres, iter=1, minit="matrix", check_finite=False)
        if np.array_equal(relabelled, labels):
            break
        centres, labels = following, relabelled
    return centres, labels


def kmeans_clustering(
    data: FloatArray,
    n_clusters: int,
    *,
    restarts: int = 10,
    seed: int = 0,
    iterations: int = 100,
    bounds: tuple[Sequence[float], Sequence[float]] | None = None,
) -> KMeansClusters:
    """k-means on unit-box-scaled ``data`` ``(N, d)``; the best of ``restarts`` runs.

    Raises
    ------
    OptionError
        When a setting is out of range.
    DataShortError
        When the data have fewer distinct points than clusters, or every run leaves a
        cluster empty (the message names no file: the caller knows where the data came from).
    ValueError
        When ``data`` is not a 2-D array.
    """
    points = np.asarray(data, dtype=np.float64)
    if n_clusters < 1:
        raise OptionError(f"clusters: must be at least 1, got {n_clusters}")
    if restarts < 1:
        raise OptionError(f"restarts: must be at least 1, got {restarts}")
    if points.ndim != 2:
        raise ValueError(f"data: expected an (N, d) array, got shape {points.shape}")
    distinct = np.unique(points, axis=0).shape[0]
    if distinct < n_clusters:
        raise DataShortError(
            f"clusters: the data have fewer than {n_clusters} distinct points "
            f"({distinct} among {points.shape[0]})"
        )
    unit, lower, upper = unit_box(points, bounds)
    best: tuple[float, FloatArray, IntArray] | None = None
    for run in range(restarts):
        with warnings.catch_warnings():
            # An empty cluster is reported by a warning; such a run simply loses below.
            warnings.simplefilter("ignore", UserWarning)
            centres, labels = _lloyd(unit, n_clusters, iterations, seed + run)
        counts = np.bincount(labels, minlength=n_clusters)
        if np.any(counts == 0):
            continue
        inertia = float(((unit - centres[labels]) ** 2).sum())
        if best is None or inertia < best[0]:
            best = (inertia, np.asarray(centres, dtype=np.float64), counts.astype(np.int64))
    if best is None:
        raise DataShortError(f"clusters: every k-means run left one of {n_clusters} clusters empty")
    inertia, centres_unit, sizes = best
    span = np.where(upper > lower, upper - lower, 1.0)
    return KMeansClusters(
        centers=lower + centres_unit * span,
        centers_unit=centres_unit,
        sizes=sizes,
        inertia=inertia,
        lower=lower,
        upper=upper,
        seed=seed,
        restarts=restarts,
        iterations=iterations,
    )
