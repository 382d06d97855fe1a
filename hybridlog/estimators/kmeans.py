"""Estimator ``kmeans``: paper 001's comparison, its pipeline with k-means centres.

Everything but the offline clustering is the ``chiu`` estimator's
(:func:`~hybridlog.estimators.chiu.run_clustering_observer`): regression vectors, labels
from the observer's prediction fit, nearest-centre decision (eqs. (2)-(3)), switched observer
(8) with gains from the LMI (15).  The centres are the best (least inertia) of ``restarts``
k-means++ runs (:func:`hybridlog.cluster.kmeans.kmeans_clustering`).
"""

from __future__ import annotations

from hybridlog.cluster.centers_file import CentersFile
from hybridlog.estimators.chiu import run_clustering_observer
from hybridlog.estimators.observer_options import KMeansOptions
from hybridlog.estimators.result import EstimationResult
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.signals import AlignedSignals

__all__ = ["KMeansOptions", "run_kmeans"]


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
