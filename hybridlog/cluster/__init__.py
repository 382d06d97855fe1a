"""Mode discovery by clustering (paper 001): pure algorithms over arrays.

Nothing here reads or writes a file (the jobs do: :mod:`hybridlog.jobs.cluster`,
:mod:`hybridlog.jobs.centers`), and nothing imports :mod:`hybridlog.estimators`.

- :mod:`~hybridlog.cluster.regressors`: regression vectors φ(k) = [y(k), y(k−1), u(k−1)] and
  their generalisation to any lags, outputs and inputs.
- :mod:`~hybridlog.cluster.subtractive`: Chiu's subtractive clustering, eqs. (5)–(7), exact
  (compiled, blocked) or approximate (grid) potentials
  (:mod:`~hybridlog.cluster.potentials`).
- :mod:`~hybridlog.cluster.kmeans`: the k-means baseline.
- :mod:`~hybridlog.cluster.labels`: the decision rule (2)–(3) and labelling clusters as modes.
- :mod:`~hybridlog.cluster.classifier`: the mode classifier (centres, decision rule, modes),
  fitted on arrays or taken from a parsed centres file.
- :mod:`~hybridlog.cluster.centers_file`: the ``centers.json`` format (text ↔ values).
- :mod:`~hybridlog.cluster.reference`: a naive all-pairs port of MATLAB's ``subclust``.

The names below are imported on first use (:mod:`hybridlog.lazy`): importing the package, or
one light module of it, loads no numba or scipy.
"""

from typing import TYPE_CHECKING

from hybridlog.lazy import lazy_exports

if TYPE_CHECKING:
    from hybridlog.cluster.kmeans import KMeansClusters, kmeans_clustering
    from hybridlog.cluster.labels import ClusterLabels, decide_clusters, label_clusters
    from hybridlog.cluster.regressors import RegressorSpec, parse_lags, regression_vectors
    from hybridlog.cluster.subtractive import (
        SubtractiveClusters,
        SubtractiveOptions,
        subtractive_clustering,
    )

__all__ = [
    "ClusterLabels",
    "KMeansClusters",
    "RegressorSpec",
    "SubtractiveClusters",
    "SubtractiveOptions",
    "decide_clusters",
    "kmeans_clustering",
    "label_clusters",
    "parse_lags",
    "regression_vectors",
    "subtractive_clustering",
]

__getattr__, __dir__ = lazy_exports(
    __name__,
    {
        ".kmeans": ["KMeansClusters", "kmeans_clustering"],
        ".labels": ["ClusterLabels", "decide_clusters", "label_clusters"],
        ".regressors": ["RegressorSpec", "parse_lags", "regression_vectors"],
        ".subtractive": ["SubtractiveClusters", "SubtractiveOptions", "subtractive_clustering"],
    },
)
