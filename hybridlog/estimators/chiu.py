r"""Estimator ``chiu``: clustering mode classifier + switched observer (paper 001).

Algorithm 1 of paper 001:

Offline
    Regression vectors ``φ(k) = [y(k), y(k−1), u(k−1)]`` (any lags: options ``output_lags``,
    ``input_lags``) are clustered, by Chiu's subtractive clustering (``chiu``, eqs. (5)–(7),
    :mod:`hybridlog.cluster.subtractive`) or by k-means (:mod:`hybridlog.estimators.kmeans`).
    By default the clusters are fitted on the analysed log itself; ``centers=FILE`` uses
    the centres (and labels) that ``hybridlog cluster`` wrote instead: the job running the
    estimator reads the file and passes it parsed (``centers=``); the estimator reads no file.
    The classifier itself is :class:`hybridlog.cluster.classifier.ModeClassifier`.  A φ(k)
    holding an output the log did not measure (bridged across a gap,
    ``AlignedSignals.unmeasured_outputs``) is left out of the fit and counted in the notes
    (:func:`hybridlog.cluster.regressors.measured_rows`); a log with none measured is refused.
Labelling
    Each cluster is given a mode from the data and the model alone (never from ground truth,
    :mod:`hybridlog.cluster.labels`): among the maps cluster → mode that give every mode a
    cluster, the one under which the switched observer (8) predicts the log best (least sum
    of squared one-step output prediction errors; the first 10 % of the log, at most 100
    samples, are left out as the observer's transient; so are outputs the log did not
    measure).  Surplus clusters thus join the mode
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

Outputs the log did not measure (``AlignedSignals.unmeasured_outputs``: the value there is
one the alignment took from the samples around a gap, or a slower output of a multi-rate
log) are read as :meth:`~hybridlog.signals.AlignedSignals.measured_outputs` gives them, NaN,
never as the stand-in value: the decision (2)–(3) of such a sample is over the outputs
measured there, held from the sample before where none was
(:meth:`~hybridlog.cluster.classifier.ModeClassifier.decide`), and the observer (8) leaves
the innovation of an unmeasured output out (open loop where none was measured,
:mod:`hybridlog.estimators.switched_observer`).  The timeline's ``vouched`` column is 0 at
those samples (1 elsewhere; no column when every output was measured) and the notes count
them.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from hybridlog.cluster.centers_file import CentersFile
from hybridlog.cluster.classifier import (
    ModeClassifier,
    fit_classifier,
    manual_labels,
    stored_classifier,
)
from hybridlog.cluster.labels import cluster_notes, decision_twins, label_clusters
from hybridlog.cluster.subtractive import ClusteringOptionError
from hybridlog.errors import DataShortError, LogError, ModelError, OptionError
from hybridlog.estimators.lmi import ObserverGains, observer_gains
from hybridlog.estimators.observer_options import ChiuOptions, check_centers
from hybridlog.estimators.options import options_dict, parse_options, shown
from hybridlog.estimators.result import EstimationResult, TimelineColumn
from hybridlog.estimators.switched_observer import LinearModes, linear_modes, run_observer
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.signals import AlignedSignals, IntArray

if TYPE_CHECKING:
    from hybridlog.estimators.kmeans import KMeansOptions

__all__ = [
    "ChiuOptions",
    "chiu_options",
    "design_observer",
    "mode_classifier",
    "run_chiu",
    "run_clustering_observer",
]

_BURN_IN_FRACTION = 0.1
_BURN_IN_MAX = 100


def design_observer(model: HybridModel, decay_rate: float) -> tuple[LinearModes, ObserverGains]:
    """The model's matrices and certified gains ``L_i`` from the LMI (15)."""
    linear = linear_modes(model)
    gains = observer_gains(
        linear.A,
        linear.C,
        model.mode_ids,
        decay_rate=decay_rate,
        model_name=model.origin or model.name,
    )
    return linear, gains


def _outputs_blind(linear: LinearModes) -> bool:
    """Whether no mode's outputs depend on the state and every mode's are the same map of u.

    Then the switched observer predicts the same outputs under every cluster -> mode map.
    """
    return (
        not np.any(linear.C)
        and bool(np.all(linear.D[0] == linear.D))
        and bool(np.all(linear.output_offsets == linear.output_offsets[0]))
    )


def _prediction_score(
    model: HybridModel,
    signals: AlignedSignals,
    linear: LinearModes,
    gains: ObserverGains,
    decided: IntArray,
) -> Callable[[IntArray], float]:
    """``score(labels)``: the switched observer's SSE of one-step predictions after burn-in.

    Over the outputs the log measured (``unmeasured_outputs`` left out): a value taken from
    the samples around a gap is no measurement for a labelling to be judged by.
    """
    n = signals.n_samples
    start = max(1, min(_BURN_IN_MAX, int(_BURN_IN_FRACTION * n)))
    measured = signals.measured_outputs()
    outputs = measured[start:]
    unmeasured = None if signals.unmeasured_outputs is None else signals.unmeasured_outputs[start:]

    def score(labels: IntArray) -> float:
        _, predictions = run_observer(
            linear,
            gains.gains,
            signals.inputs,
            measured,
            labels[decided],
            model.initial_state,
        )
        error = outputs - predictions[start:]
        if unmeasured is not None:  # a prediction that is not finite still shows
            error = np.where(unmeasured, 0.0, error)
        return float(np.sum(error * error))

    return score


def mode_classifier(
    model: HybridModel,
    signals: AlignedSignals,
    options: ChiuOptions | KMeansOptions,
    *,
    centers: CentersFile | None = None,
    observer: tuple[LinearModes, ObserverGains] | str | None = None,
) -> ModeClassifier:
    """Fit (or take from ``centers``) the clusters and label them as modes.

    The labels come, in this order of precedence, from ``cluster_modes``, from the centres
    file, from the switched observer's prediction fit (the module docstring), or not at all.

    Parameters
    ----------
    model, signals:
        The model and the log the clusters are fitted on (and labelled with).
    options:
        The estimator's options: ``chiu`` clusters by subtractive clustering, ``kmeans``
        by k-means.
    centers:
        A parsed ``centers.json`` to take the centres from instead of fitting them.
    observer:
        Matrices and gains for the automatic labelling; without them (``None``, or why
        there are none: a model not linear, an infeasible LMI) the clusters are unlabelled
        unless ``cluster_modes`` or the centres file gives labels, the note saying why.

    Raises
    ------
    LogError
        The log's regression vectors cannot be clustered: no more samples than the largest
        lag, or fewer distinct vectors than k-means clusters (naming the log,
        ``signals.source``, the algorithm and φ(k)); or every labelling of the clusters
        scores the same, so that none is the log's
        (:attr:`~hybridlog.cluster.labels.ClusterLabels.undecided`).
    OptionError
        Centres or ``cluster_modes`` that do not fit the model and these lags.
    """
    spec = options.regressor_spec()
    names = tuple(spec.names(model.outputs, model.inputs))
    algorithm = "chiu" if isinstance(options, ChiuOptions) else "kmeans"
    classifier: ModeClassifier
    if centers is not None:
        classifier = stored_classifier(
            centers,
            algorithm,
            spec,
            signals.measured_outputs(),
            names=names,
            mode_ids=model.mode_ids,
            source=options.centers or centers.path,
        )
    else:
        try:
            classifier = fit_classifier(
                signals.outputs,
                signals.inputs,
                spec,
                options.clustering(),
                names=names,
                n_modes=model.n_modes,
                unmeasured=signals.unmeasured_outputs,
            )
        except DataShortError as err:
            raise LogError(
                f"{signals.source}: {algorithm} cannot cluster its regression vectors "
                f"φ(k) = [{', '.join(names)}]: {err}"
            ) from err
    if options.cluster_modes:
        modes = manual_labels(
            options.cluster_modes,
            model.mode_ids,
            len(classifier.centers),
            decision_values=classifier.decision_values,
        )
        sizes = classifier.details["sizes"]
        return classifier.labelled(
            modes,
            (
                f"labels given by cluster_modes={options.cluster_modes}",
                *cluster_notes(
                    modes, sizes, model.mode_ids, twins=decision_twins(classifier.decision_values)
                ),
            ),
        )
    if classifier.cluster_modes is not None:
        return classifier
    if observer is not None and not isinstance(observer, str):
        decided = classifier.decide(signals.measured_outputs())
        score = _prediction_score(model, signals, *observer, decided)
        labels = label_clusters(
            len(classifier.centers),
            model.mode_ids,
            score,
            classifier.details["sizes"],
            what="one-step prediction SSE",
            samples=signals.n_samples,  # each map's score runs the observer over the log
            twins=decision_twins(classifier.decision_values),
        )
        populated = int(np.count_nonzero(np.asarray(classifier.details["sizes"]) > 0))
        if labels.undecided and len(labels.undecided) == populated:
            # every cluster's mode was the search's first: kmeans refused such a log (one
            # distinct point), chiu reported a mode accuracy of its labelling's order
            linear = observer[0]
            if _outputs_blind(linear):
                # the model's, not the log's: a sensor gain set to 0 (--set g=0) blamed a
                # "plant at rest" on a log that moved
                raise ModelError(
                    f"{model.origin or model.name}: {algorithm} cannot label its clusters as "
                    "modes: the outputs read no state in any mode (every C_i is 0) and every "
                    "mode adds the same D_i u + d_i, so every labelling predicts the same "
                    "outputs whatever the log; the estimator option cluster_modes (analyze "
                    "--set cluster_modes=2,1) sets the labels by hand"
                )
            raise LogError(
                f"{signals.source}: {algorithm} cannot label its clusters as modes: every "
                f"labelling scores the same one-step prediction SSE ({labels.score:.4g}), so "
                "the log does not tell the modes apart (a plant at rest, or errors whose "
                "squares leave float64's range); the estimator option cluster_modes "
                "(analyze --set cluster_modes=2,1) sets the labels by hand"
            )
        return classifier.labelled(labels.modes, labels.notes, labelling_scores=labels.alternatives)
    # the reason given: a linear model whose LMI (15) is infeasible was said "not linear"
    why = observer if isinstance(observer, str) else "no observer to score labellings by"
    return classifier.labelled(None, (f"clusters not labelled as modes: {why}",))


def run_clustering_observer(
    name: str,
    model: HybridModel,
    signals: AlignedSignals,
    options: ChiuOptions | KMeansOptions,
    *,
    centers: CentersFile | None,
    jit: bool,
) -> EstimationResult:
    """Algorithm 1 of paper 001 (module docstring) with the centres of ``name``.

    Raises
    ------
    OptionError
        ``options.centers`` names a file but ``centers`` (its parsed content) is missing:
        the estimator reads no file, the job running it does; or the centres were fitted
        for another model, modes or regressors, or with another value of a clustering
        option (``radius``, ``clusters`` ...) set here
        (:func:`~hybridlog.estimators.observer_options.check_centers`, which the jobs also
        run before reading the log); or the clustering options do not suit this log (the
        grid of ``method = approximate``, chosen on the data, is too coarse).
    """
    fitted_with = check_centers(model, options, centers=centers)
    start = time.perf_counter()
    linear, gains = design_observer(model, options.decay_rate)
    try:
        classifier = mode_classifier(
            model, signals, options, centers=centers, observer=(linear, gains)
        )
    except ClusteringOptionError as err:
        # a plain OptionError naming the values: the subclass's (keys, message) signature
        # broke compare's re-raise with the estimator's name (an unexpected TypeError)
        values = ", ".join(f"{key}={shown(getattr(options, key))}" for key in err.keys)
        raise OptionError(f"{name} option {values}: {err.reason}") from None
    assert classifier.cluster_modes is not None
    measured = signals.measured_outputs()
    decided = classifier.decide(measured)
    modes = classifier.cluster_modes[decided]
    means, predictions = run_observer(
        linear,
        gains.gains,
        signals.inputs,
        measured,
        modes,
        model.initial_state,
        jit=jit,
    )
    runtime = time.perf_counter() - start
    probabilities = np.zeros((signals.n_samples, model.n_modes))
    probabilities[np.arange(signals.n_samples), modes] = 1.0
    used = {**options_dict(options), **fitted_with}  # loaded centres: as the file was fitted
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
    vouched, unvouched_note = _decided_on_measurements(signals)
    notes = (
        *classifier.notes,
        *classifier.labelling,
        *unvouched_note,
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
        timeline_columns=vouched,
    )


def _decided_on_measurements(
    signals: AlignedSignals,
) -> tuple[tuple[TimelineColumn, ...], tuple[str, ...]]:
    """timeline.csv's ``vouched`` column and report.md's note, where an output was not measured.

    The nearest-centre decision of sample ``k`` reads ``y(k)`` alone (eqs. (2)–(3)); where
    the log did not measure all of it (``unmeasured_outputs``) the mode is decided over the
    outputs it did measure, or held from the sample before where it measured none
    (:meth:`~hybridlog.cluster.classifier.ModeClassifier.decide`): less than eq. (3) asks
    for.  As ``sliding-mode`` marks the σ̂ Lemma 1 cannot vouch for, the timeline gets
    ``vouched``, 1 where every output of the sample was measured and 0 there, and the notes
    say how many; the mode metrics score the decision there as they score every other
    sample.  Nothing when every output was measured.
    """
    if signals.unmeasured_outputs is None:
        return (), ()
    bridged = np.any(signals.unmeasured_outputs, axis=1)
    count = int(np.count_nonzero(bridged))
    if count == 0:
        return (), ()
    n = signals.n_samples
    note = (
        f"the mode of {count:,} of {n:,} samples ({100 * count / n:.1f} %) was decided without "
        "an output the log did not measure there: over the outputs it measured, held from the "
        "sample before where it measured none (the observer leaves an unmeasured output's "
        "innovation out); timeline.csv's vouched is 0 there; the mode metrics score those "
        "samples too"
    )
    return (TimelineColumn("vouched", np.where(bridged, 0.0, 1.0)),), (note,)


def run_chiu(
    model: HybridModel,
    signals: AlignedSignals,
    options: ChiuOptions,
    *,
    centers: CentersFile | None = None,
    jit: bool = True,
) -> EstimationResult:
    """Paper 001 with Chiu's subtractive clustering (see the module docstring).

    ``centers``: the parsed file ``options.centers`` names (read by the job).
    """
    return run_clustering_observer("chiu", model, signals, options, centers=centers, jit=jit)


def chiu_options(values: dict[str, object]) -> ChiuOptions:
    """Validated ``chiu`` options from a name → value mapping."""
    return parse_options(ChiuOptions, values, estimator="chiu")
