r"""Estimator ``chiu``: clustering mode classifier + switched observer (paper 001).

Algorithm 1 of paper 001:

Offline
    Regression vectors ``φ(k) = [y(k), y(k−1), u(k−1)]`` (any lags: options ``output_lags``,
    ``input_lags``) are clustered, by Chiu's subtractive clustering (``chiu``, eqs. (5)–(7),
    :mod:`hybridlog.cluster.subtractive`) or by k-means (:mod:`hybridlog.estimators.kmeans`).
    By default the clusters are fitted on the analysed log itself; ``centers=FILE`` loads
    the centres (and labels) that ``hybridlog cluster`` wrote instead.
Labelling
    Each cluster is given a mode from the data and the model alone (never from ground truth,
    :mod:`hybridlog.cluster.labels`): among the maps cluster → mode that give every mode a
    cluster, the one under which the switched observer (8) predicts the log best (least sum
    of squared one-step output prediction errors; the first 10 % of the log, at most 100
    samples, are left out as the observer's transient).  Surplus clusters thus join the mode
    that explains their samples best.  ``cluster_modes="2,1"`` sets the labels by hand.
Online
    ``q̂(k) = argmin_i |y(k) − y_i*|²`` (eqs. (2)–(3)) and the switched observer (8) with gains
    from the LMI (15) (:mod:`hybridlog.estimators.lmi`,
    :mod:`hybridlog.estimators.switched_observer`).

Result: ``mode_probabilities`` are one-hot (the nearest-centre decision gives no
probabilities); ``state_variances`` are NaN (a Luenberger observer has no covariance);
``state_means[k] = x̂(k)`` from ``y(0..k−1)``; ``output_predictions[k]`` is made with
``q̂(k−1)`` before ``y(k)`` is used (row 0 NaN).  The report's ``options`` hold the centres,
the labels, the gains and the LMI certificate; its ``notes`` say how each cluster was
labelled and what happened to surplus clusters.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from hybridlog.cluster.centers_file import read_centers
from hybridlog.cluster.kmeans import kmeans_clustering
from hybridlog.cluster.labels import decide_clusters, label_clusters
from hybridlog.cluster.regressors import RegressorSpec, parse_lags, regression_vectors
from hybridlog.cluster.subtractive import SubtractiveOptions, subtractive_clustering
from hybridlog.errors import OptionError
from hybridlog.estimators.lmi import ObserverGains, observer_gains
from hybridlog.estimators.options import option, options_dict, parse_options
from hybridlog.estimators.result import EstimationResult
from hybridlog.estimators.switched_observer import LinearModes, linear_modes, run_observer
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.signals import AlignedSignals, FloatArray, IntArray

if TYPE_CHECKING:
    from hybridlog.estimators.kmeans import KMeansOptions

__all__ = [
    "ChiuOptions",
    "ModeClassifier",
    "ObserverOptions",
    "chiu_options",
    "design_observer",
    "fit_classifier",
    "run_chiu",
    "run_clustering_observer",
]

_BURN_IN_FRACTION = 0.1
_BURN_IN_MAX = 100


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


@dataclass(frozen=True)
class ModeClassifier:
    """Fitted centres and their modes: the classifier of eqs. (2)–(3).

    Attributes
    ----------
    algorithm:
        ``"chiu"`` or ``"kmeans"``.
    spec:
        The regression-vector lags.
    regressors:
        Names of the components of φ(k).
    decision_columns:
        Columns of φ holding ``y_j(k)``: the decision variables.
    centers:
        Cluster centres in data units, shape ``(c, d)``.
    lower, upper:
        Unit-box scaling of φ.
    cluster_modes:
        Mode index of each cluster, or ``None`` when not labelled.
    labelling:
        How the clusters were labelled (one line each).
    notes:
        How the centres were obtained.
    details:
        Algorithm-specific values for ``centers.json`` (potentials, radii, sizes …).
    """

    algorithm: str
    spec: RegressorSpec
    regressors: tuple[str, ...]
    decision_columns: tuple[int, ...]
    centers: FloatArray
    lower: FloatArray
    upper: FloatArray
    cluster_modes: IntArray | None
    labelling: tuple[str, ...]
    notes: tuple[str, ...]
    details: dict[str, Any]

    @property
    def decision_values(self) -> FloatArray:
        """``y_i*``: the ``y(k)`` components of every centre, shape ``(c, n_y)``."""
        values: FloatArray = self.centers[:, list(self.decision_columns)]
        return values

    def decide(self, outputs: FloatArray) -> IntArray:
        """Cluster of every sample by the nearest decision variable (eqs. (2)–(3))."""
        span = (self.upper - self.lower)[list(self.decision_columns)]
        return decide_clusters(outputs, self.decision_values, span)


def _spec(options: ObserverOptions) -> RegressorSpec:
    return RegressorSpec(
        output_lags=parse_lags(options.output_lags, "output_lags"),
        input_lags=parse_lags(options.input_lags, "input_lags"),
    )


def _manual_labels(text: str, model: HybridModel, n_clusters: int) -> IntArray:
    ids = [part.strip() for part in text.split(",") if part.strip()]
    if len(ids) != n_clusters:
        raise OptionError(
            f"cluster_modes: {len(ids)} mode ids for {n_clusters} clusters ('{text}')"
        )
    for mode in ids:
        if mode not in model.mode_ids:
            raise OptionError(
                f"cluster_modes: unknown mode '{mode}' (modes: {', '.join(model.mode_ids)})"
            )
    return np.array([model.mode_index(m) for m in ids], dtype=np.int64)


def design_observer(model: HybridModel, decay_rate: float) -> tuple[LinearModes, ObserverGains]:
    """The model's matrices and certified gains ``L_i`` from the LMI (15)."""
    linear = linear_modes(model)
    gains = observer_gains(
        linear.A, linear.C, model.mode_ids, decay_rate=decay_rate, model_name=model.name
    )
    return linear, gains


def _prediction_score(
    model: HybridModel,
    signals: AlignedSignals,
    linear: LinearModes,
    gains: ObserverGains,
    decided: IntArray,
) -> Callable[[IntArray], float]:
    """``score(labels)``: the switched observer's SSE of one-step predictions after burn-in."""
    n = signals.n_samples
    start = max(1, min(_BURN_IN_MAX, int(_BURN_IN_FRACTION * n)))

    def score(labels: IntArray) -> float:
        _, predictions = run_observer(
            linear,
            gains.gains,
            signals.inputs,
            signals.outputs,
            labels[decided],
            model.initial_state,
        )
        error = signals.outputs[start:] - predictions[start:]
        return float(np.sum(error * error))

    return score


def fit_classifier(
    model: HybridModel,
    signals: AlignedSignals,
    algorithm: str,
    options: ChiuOptions | KMeansOptions,
    *,
    observer: tuple[LinearModes, ObserverGains] | None = None,
) -> ModeClassifier:
    """Fit (or load) the centres and label the clusters as modes.

    Parameters
    ----------
    model, signals:
        The model and the log the clusters are fitted on (and labelled with).
    algorithm:
        ``"chiu"`` or ``"kmeans"``.
    options:
        The estimator's options.
    observer:
        Matrices and gains for the automatic labelling; ``None`` leaves the clusters
        unlabelled unless ``cluster_modes`` or the centres file gives labels.
    """
    spec = _spec(options)
    names = tuple(spec.names(model.outputs, model.inputs))
    columns = spec.decision_columns(model.n_outputs)
    stored_modes: tuple[str, ...] | None = None
    labelling: tuple[str, ...] = ()
    details: dict[str, Any] = {}
    if options.centers:
        stored = read_centers(options.centers)
        if stored.regressors != names:
            raise OptionError(
                f"{options.centers}: regressors {list(stored.regressors)} do not match this "
                f"model and these lags ({list(names)})"
            )
        if algorithm not in stored.clusters:
            raise OptionError(
                f"{options.centers}: {algorithm}: no {algorithm} centres in the file"
                + (" (run hybridlog cluster --compare-kmeans)" if algorithm == "kmeans" else "")
            )
        entry = stored.clusters[algorithm]
        centers, lower, upper = entry.centers, stored.lower, stored.upper
        notes = (f"{algorithm}: {len(centers)} centres loaded from {options.centers}",)
        if entry.modes is not None and set(entry.modes) <= set(model.mode_ids):
            stored_modes = entry.modes
            labelling = (f"labels loaded from {options.centers}", *entry.labelling)
    else:
        phi = regression_vectors(signals.outputs, signals.inputs, spec)
        text = ", ".join(names)
        if algorithm == "chiu":
            assert isinstance(options, ChiuOptions)
            found = subtractive_clustering(
                phi,
                SubtractiveOptions(
                    radius=options.radius,
                    squash=options.squash,
                    accept=options.accept,
                    reject=options.reject,
                    self_potential=options.self_potential,
                    method=options.method,
                ),
            )
            centers, lower, upper = found.centers, found.lower, found.upper
            details.update(
                method=found.method,
                grid=found.grid,
                potentials=found.potentials,
                potential_ratios=found.potential_ratios,
                radii=found.radii,
                sigmas=found.sigmas,
                center_rows=found.center_indices + spec.max_lag,
            )
            self_term = "included" if options.self_potential else "excluded (eq. (5) as printed)"
            notes = (
                f"chiu: {found.n_clusters} centres from {phi.shape[0]} regression vectors "
                f"φ(k) = [{text}]; {found.notes[0]}; r_a = {options.radius:g}, "
                f"squash {options.squash:g}, accept {options.accept:g}, reject "
                f"{options.reject:g}, self term {self_term}",
            )
        else:
            assert not isinstance(options, ChiuOptions)
            k = model.n_modes if options.clusters is None else options.clusters
            km = kmeans_clustering(phi, k, restarts=options.restarts, seed=options.seed)
            centers, lower, upper = km.centers, km.lower, km.upper
            details.update(inertia=km.inertia, seed=km.seed, restarts=km.restarts)
            notes = (
                f"kmeans: {k} centres from {phi.shape[0]} regression vectors φ(k) = [{text}] "
                f"(scipy kmeans2, k-means++, best of {km.restarts} runs from seed {km.seed}, "
                f"inertia {km.inertia:.4g})",
            )
    classifier = ModeClassifier(
        algorithm=algorithm,
        spec=spec,
        regressors=names,
        decision_columns=tuple(columns),
        centers=np.asarray(centers, dtype=np.float64),
        lower=np.asarray(lower, dtype=np.float64),
        upper=np.asarray(upper, dtype=np.float64),
        cluster_modes=None,
        labelling=(),
        notes=notes,
        details=details,
    )
    decided = classifier.decide(signals.outputs)
    sizes = np.bincount(decided, minlength=len(classifier.centers))
    details["sizes"] = sizes
    cluster_modes: IntArray | None
    if options.cluster_modes:
        cluster_modes = _manual_labels(options.cluster_modes, model, len(classifier.centers))
        labelling = (f"labels given by cluster_modes={options.cluster_modes}",)
    elif stored_modes is not None:
        cluster_modes = np.array([model.mode_index(m) for m in stored_modes], dtype=np.int64)
    elif observer is not None:
        score = _prediction_score(model, signals, *observer, decided)
        labels = label_clusters(
            len(classifier.centers),
            model.mode_ids,
            score,
            sizes,
            what="one-step prediction SSE",
        )
        cluster_modes = labels.modes
        labelling = labels.notes
        details["labelling_scores"] = labels.alternatives
    else:
        cluster_modes = None
        labelling = ("clusters not labelled (the model is not linear)",)
    return ModeClassifier(
        algorithm=algorithm,
        spec=spec,
        regressors=names,
        decision_columns=tuple(columns),
        centers=classifier.centers,
        lower=classifier.lower,
        upper=classifier.upper,
        cluster_modes=cluster_modes,
        labelling=labelling,
        notes=notes,
        details=details,
    )


def run_clustering_observer(
    name: str,
    model: HybridModel,
    signals: AlignedSignals,
    options: ChiuOptions | KMeansOptions,
    *,
    jit: bool,
) -> EstimationResult:
    """Algorithm 1 of paper 001 (module docstring) with the centres of ``name``."""
    start = time.perf_counter()
    linear, gains = design_observer(model, options.decay_rate)
    classifier = fit_classifier(model, signals, name, options, observer=(linear, gains))
    assert classifier.cluster_modes is not None
    decided = classifier.decide(signals.outputs)
    modes = classifier.cluster_modes[decided]
    means, predictions = run_observer(
        linear,
        gains.gains,
        signals.inputs,
        signals.outputs,
        modes,
        model.initial_state,
        jit=jit,
    )
    runtime = time.perf_counter() - start
    probabilities = np.zeros((signals.n_samples, model.n_modes))
    probabilities[np.arange(signals.n_samples), modes] = 1.0
    used = options_dict(options)
    used["classifier"] = {
        "regressors": list(classifier.regressors),
        "centers": classifier.centers,
        "decision_values": classifier.decision_values,
        "cluster_modes": [model.mode_ids[m] for m in classifier.cluster_modes],
        "sizes": classifier.details.get("sizes"),
        "scaling": {"lower": classifier.lower, "upper": classifier.upper},
    }
    used["observer"] = {
        "gains": gains.gains,
        "lmi_margin": gains.margin,
        "decay_bound": gains.decay_bound,
        "spectral_radii": gains.spectral_radii,
        "solver": gains.solver,
    }
    radii = ", ".join(f"{r:.3f}" for r in gains.spectral_radii)
    notes = (
        *classifier.notes,
        *classifier.labelling,
        f"observer gains from LMI (15) ({gains.solver}, decay rate {gains.decay_rate:g}): "
        f"certificate margin {gains.margin:.3g}, √V shrinks by ≤ {gains.decay_bound:.4f} per "
        f"step; spectral radii of A_i − L_i C_i: {radii}",
        "mode probabilities are one-hot: the nearest-centre decision (eqs. (2)-(3)) gives "
        "no probabilities; state variances are undefined (NaN) for a Luenberger observer",
    )
    return EstimationResult(
        estimator=name,
        options=used,
        time=signals.time,
        mode_ids=model.mode_ids,
        state_names=model.states,
        output_names=model.outputs,
        modes=np.ascontiguousarray(modes, dtype=np.int64),
        mode_probabilities=probabilities,
        state_means=means,
        state_variances=np.full_like(means, np.nan),
        output_predictions=predictions,
        runtime_s=runtime,
        compile_s=0.0,
        notes=notes,
    )


def run_chiu(
    model: HybridModel, signals: AlignedSignals, options: ChiuOptions, *, jit: bool = True
) -> EstimationResult:
    """Paper 001 with Chiu's subtractive clustering (see the module docstring)."""
    return run_clustering_observer("chiu", model, signals, options, jit=jit)


def chiu_options(values: dict[str, object]) -> ChiuOptions:
    """Validated ``chiu`` options from a name → value mapping."""
    return parse_options(ChiuOptions, values, estimator="chiu")
