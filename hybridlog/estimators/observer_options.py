"""Options of paper 001's estimators ``chiu`` and ``kmeans`` (a light module).

The options dataclasses live apart from the estimators, which import numba, scipy and cvxpy,
so that the registry, ``--help`` and ``hybridlog cluster``'s generated options can read them
without loading those libraries; the clustering types they convert to are imported when a
conversion is asked for.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

from hybridlog.estimators.options import option

if TYPE_CHECKING:
    from hybridlog.cluster.kmeans import KMeansParameters
    from hybridlog.cluster.regressors import RegressorSpec
    from hybridlog.cluster.subtractive import SubtractiveOptions

__all__ = ["ChiuOptions", "KMeansOptions", "ObserverOptions"]


@dataclass(frozen=True)
class ObserverOptions:
    """Options of paper 001's pipeline shared by ``chiu`` and ``kmeans``."""

    output_lags: str = option("0,1", "lags of every output in φ(k), e.g. 0,1; must contain 0")
    input_lags: str = option("1", "lags of every input in φ(k), e.g. 1")
    centers: str = option("", "centers.json of hybridlog cluster to load instead of fitting")
    cluster_modes: str = option(
        "", "mode ids of the clusters in order, e.g. 2,1 (empty: automatic labelling)"
    )
    decay_rate: float = option(
        1.0, "decay rate ρ of the LMI (15) (1: the paper's condition)", range=(1e-6, 1.0)
    )

    def regressor_spec(self) -> RegressorSpec:
        """The lags of φ(k) (``output_lags``, ``input_lags``)."""
        from hybridlog.cluster.regressors import RegressorSpec, parse_lags

        return RegressorSpec(
            output_lags=parse_lags(self.output_lags, "output_lags"),
            input_lags=parse_lags(self.input_lags, "input_lags"),
        )


@dataclass(frozen=True)
class ChiuOptions(ObserverOptions):
    """Options of the ``chiu`` estimator (clustering defaults: MATLAB ``subclust``)."""

    radius: float = option(
        0.5, "cluster radius r_a of eq. (5), in unit-box units", range=(1e-3, 100.0)
    )
    squash: float = option(1.25, "r_b/r_a of the revision eqs. (6)-(7)", range=(1.0, 100.0))
    accept: float = option(0.5, "acceptance ratio ε₁ of a new centre", range=(0.0, 1.0))
    reject: float = option(0.15, "rejection ratio ε₂ of a new centre", range=(0.0, 1.0))
    self_potential: bool = option(
        True, "count each point in its own potential (false: eq. (5) as printed)"
    )
    method: Literal["auto", "exact", "approximate"] = option(
        "auto", "potentials: exact all-pairs, approximate on a grid, or auto by size"
    )

    def clustering(self) -> SubtractiveOptions:
        """The subtractive-clustering part of the options."""
        from hybridlog.cluster.subtractive import SubtractiveOptions

        return SubtractiveOptions(
            radius=self.radius,
            squash=self.squash,
            accept=self.accept,
            reject=self.reject,
            self_potential=self.self_potential,
            method=self.method,
        )


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
        from hybridlog.cluster.kmeans import KMeansParameters

        return KMeansParameters(clusters=self.clusters, restarts=self.restarts, seed=self.seed)
