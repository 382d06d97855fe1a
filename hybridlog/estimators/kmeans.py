"""Estimator ``kmeans``: paper 001's comparison, its pipeline with k-means centres.

Everything but the offline clustering is the ``chiu`` estimator's
(:func:`~hybridlog.estimators.chiu.run_clustering_observer`): regression vectors, labels
from the observer's prediction fit, nearest-centre decision (eqs. (2)-(3)), switched observer
(8) with gains from the LMI (15).  The centres are the best (least inertia) of ``restarts``
k-means++ runs (:func:`hybridlog.cluster.kmeans.kmeans_clustering`).
"""

from __future__ import annotations

from dataclasses import dataclass

from hybridlog.cluster.centers_file import CentersFile
from hybridlog.cluster.kmeans import KMeansParameters
from hybridlog.estimators.chiu import ObserverOptions, run_clustering_observer
from hybridlog.estimators.options import option
from hybridlog.estimators.result import EstimationResult
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.signals import AlignedSignals

__all__ = ["KMeansOptions", "run_kmeans"]


@dataclass(frozen=True)
class KMeansOptions(ObserverOptions):
    """Options of the ``kmeans`` estimator; the lags, centres and labels are as for ``chiu``."""

    clusters: int | None = option(
        None, "number of k-means centres (none: the number of modes)", range=(1, 1000)
    )
    restarts: int = option(10, "k-means++ runs; the one of least inertia is kept", range=(1, 1000))
    seed: int = option(0, "seed of the first run (then seed+1, ...)", range=(0, 2**31))

    def clustering(self) -> KMeansParameters:
        """The k-means part of the options."""
        return KMeansParameters(clusters=self.clusters, restarts=self.restarts, seed=self.seed)


def run_kmeans(
    model: HybridModel,
    signals: AlignedSignals,
    options: KMeansOptions,
    *,
    centers: CentersFile | None = None,
    jit: bool = True,
) -> EstimationResult:
    """Paper 001's k-means comparison: the same pipeline with k-means centres.

    ``centers``: the parsed file ``options.centers`` names (read by the job).
    """
    return run_clustering_observer("kmeans", model, signals, options, centers=centers, jit=jit)
