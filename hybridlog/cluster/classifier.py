r"""The mode classifier of paper 001: cluster centres, their decision rule and their modes.

Offline, the regression vectors ``φ(k)`` of a log are clustered (Chiu's subtractive
clustering, eqs. (5)–(7), or k-means, the paper's comparison); online, every sample goes to
the cluster whose decision variable is nearest (eqs. (2)–(3)),

.. math::

    \hat c(k) = \arg\min_i \lVert y(k) - y_i^*\rVert^2 ,

and the cluster's mode is the estimated mode.  This module holds the classifier and the ways
to obtain one without ground truth or files: :func:`fit_classifier` clusters arrays,
:func:`stored_classifier` takes the centres of a parsed ``centers.json``
(:mod:`hybridlog.cluster.centers_file`), :func:`manual_labels` reads ``cluster_modes="2,1"``.
Labelling clusters by how well a model predicts the log needs the switched observer and
lives with it (:func:`hybridlog.estimators.chiu.mode_classifier`), which calls
:func:`hybridlog.cluster.labels.label_clusters` with that score.

References
----------
Paper 001 (``papers/001_73b6a953d073a2d8.txt``), §4.A, eqs. (2)–(7).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

import numpy as np

from hybridlog.cluster.centers_file import CentersFile
from hybridlog.cluster.kmeans import KMeansParameters, kmeans_clustering
from hybridlog.cluster.labels import (
    NO_CLUSTER,
    cluster_notes,
    decide_clusters,
    decision_twins,
    twin_conflict,
)
from hybridlog.cluster.regressors import RegressorSpec, measured_rows, regression_vectors
from hybridlog.cluster.subtractive import SubtractiveOptions, subtractive_clustering
from hybridlog.errors import DataShortError, OptionError, as_text
from hybridlog.numbers import comma_items
from hybridlog.signals import BoolArray, FloatArray, IntArray

__all__ = [
    "ModeClassifier",
    "fit_classifier",
    "manual_labels",
    "stored_classifier",
]


@dataclass(frozen=True)
class ModeClassifier:
    """Fitted centres and their modes: the classifier of eqs. (2)–(3).

    Immutable: :meth:`labelled` returns a new classifier with the clusters' modes.

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
        Algorithm-specific values for ``centers.json`` (potentials, radii, ``sizes``: samples
        decided for each cluster on the log it was fitted or applied to, ...); read-only.
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
    details: Mapping[str, Any]

    @property
    def decision_values(self) -> FloatArray:
        """``y_i*``: the ``y(k)`` components of every centre, shape ``(c, n_y)``."""
        values: FloatArray = self.centers[:, list(self.decision_columns)]
        return values

    def decide(self, outputs: FloatArray) -> IntArray:
        """Cluster of every sample by the nearest decision variable (eqs. (2)–(3)).

        ``outputs`` holds NaN where the log did not measure an output
        (``AlignedSignals.measured_outputs()``): the decision of such a sample is over its
        measured outputs, and a sample with none keeps the cluster of the sample before
        (the first decided one's, before it): no measurement, nothing to move the decision.
        (The value the alignment takes from the samples around a gap decided such a sample
        as if it were measured: at half the model's rate every other mode came from
        ``y(k) = y(k−1)``.)

        Raises
        ------
        DataShortError
            No sample has a measured output.
        """
        span = (self.upper - self.lower)[list(self.decision_columns)]
        decided = decide_clusters(outputs, self.decision_values, span)
        undecided = decided == NO_CLUSTER
        if not undecided.any():
            return decided
        rows = np.flatnonzero(~undecided)
        if not rows.size:
            raise DataShortError("no sample has a measured output to decide its mode on")
        last = np.where(undecided, -1, np.arange(decided.size))
        held: IntArray = decided[np.maximum(np.maximum.accumulate(last), rows[0])]
        return held

    def labelled(
        self, cluster_modes: IntArray | None, labelling: Sequence[str], **details: Any
    ) -> ModeClassifier:
        """The same centres with ``cluster_modes``; ``details`` are added to :attr:`details`."""
        return dataclasses.replace(
            self,
            cluster_modes=cluster_modes,
            labelling=tuple(labelling),
            details=MappingProxyType({**self.details, **details}),
        )


def _count(count: int, noun: str) -> str:
    """``"1 centre"``, ``"3 centres"``: a count with its (regular) noun in agreement."""
    return f"{count} {noun}" if count == 1 else f"{count} {noun}s"


def _unlabelled(
    algorithm: str,
    spec: RegressorSpec,
    names: tuple[str, ...],
    centers: FloatArray,
    lower: FloatArray,
    upper: FloatArray,
    notes: tuple[str, ...],
    details: Mapping[str, Any],
    outputs: FloatArray,
) -> ModeClassifier:
    """A classifier without modes; ``details`` gain the cluster sizes on ``outputs``."""
    classifier = ModeClassifier(
        algorithm=algorithm,
        spec=spec,
        regressors=names,
        decision_columns=tuple(spec.decision_columns(outputs.shape[1])),
        centers=np.asarray(centers, dtype=np.float64),
        lower=np.asarray(lower, dtype=np.float64),
        upper=np.asarray(upper, dtype=np.float64),
        cluster_modes=None,
        labelling=(),
        notes=notes,
        details=MappingProxyType({}),
    )
    sizes = np.bincount(classifier.decide(outputs), minlength=len(classifier.centers))
    return dataclasses.replace(classifier, details=MappingProxyType({**details, "sizes": sizes}))


def fit_classifier(
    outputs: FloatArray,
    inputs: FloatArray,
    spec: RegressorSpec,
    clustering: SubtractiveOptions | KMeansParameters,
    *,
    names: Sequence[str],
    n_modes: int,
    unmeasured: BoolArray | None = None,
) -> ModeClassifier:
    """Cluster the regression vectors of a log; the clusters get no modes yet.

    Only the vectors built from measured outputs are clustered (:func:`measured_rows`): one
    holding a value the alignment took from the samples around a gap is a point no
    measurement gave (a log at half the model's rate fitted centres with ``y(k) = y(k−1)``).
    The notes say how many were left out.

    Parameters
    ----------
    outputs, inputs:
        ``y`` ``(N, n_y)`` and ``u`` ``(N, n_u)`` of the log.
    spec:
        The lags making up φ(k).
    clustering:
        :class:`~hybridlog.cluster.subtractive.SubtractiveOptions` for Chiu's subtractive
        clustering (``algorithm = "chiu"``) or
        :class:`~hybridlog.cluster.kmeans.KMeansParameters` for k-means (``"kmeans"``).
    names:
        Names of the components of φ(k) (:meth:`RegressorSpec.names`).
    n_modes:
        Number of modes: the number of k-means centres unless ``clustering.clusters`` says.
    unmeasured:
        ``True`` where the log did not measure an output (``AlignedSignals.
        unmeasured_outputs``), shape ``(N, n_y)``; ``None``: every output was measured.

    Raises
    ------
    DataShortError
        No more samples than the largest lag, every regression vector holding an output the
        log did not measure, fewer distinct regression vectors than k-means centres, or
        (eq. (5) without the self term) none within reach of another (the message names no
        file: the caller knows the log).
    """
    names = tuple(names)
    every = regression_vectors(outputs, inputs, spec)
    kept = measured_rows(unmeasured, spec, every.shape[0] + spec.max_lag)
    left_out = int(every.shape[0] - np.count_nonzero(kept))
    text = ", ".join(names)
    if left_out == every.shape[0]:
        raise DataShortError(
            f"every one of its {_count(left_out, 'regression vector')} holds an output value "
            "the log did not measure (taken from the samples around a gap): no centre can be "
            "fitted on measurements (an output sampled less often than every dt leaves no "
            "φ(k) whole; or is the model's dt not the log's?)"
        )
    phi = every[kept] if left_out else every
    rows = np.flatnonzero(kept) + spec.max_lag  # the sample k of each clustered φ(k)
    without = (
        f" ({_count(left_out, 'regression vector')} left out: "
        f"{'it holds' if left_out == 1 else 'each holds'} an output value the log did not "
        "measure, taken from the samples around a gap)"
        if left_out
        else ""
    )
    details: dict[str, Any]
    if isinstance(clustering, SubtractiveOptions):
        algorithm = "chiu"
        found = subtractive_clustering(phi, clustering)
        centers, lower, upper = found.centers, found.lower, found.upper
        details = {
            "method": found.method,
            "grid": found.grid,
            "potentials": found.potentials,
            "potential_ratios": found.potential_ratios,
            "radii": found.radii,
            "sigmas": found.sigmas,
            "center_rows": rows[found.center_indices],
        }
        self_term = "included" if clustering.self_potential else "excluded (eq. (5) as printed)"
        radius = np.atleast_1d(np.asarray(clustering.radius, dtype=float))
        notes = (
            f"chiu: {_count(found.n_clusters, 'centre')} from "
            f"{_count(phi.shape[0], 'regression vector')} φ(k) = [{text}]{without}; "
            f"{found.notes[0]}; "
            f"r_a = {', '.join(f'{r:g}' for r in radius)}, "
            f"squash {clustering.squash:g}, accept {clustering.accept:g}, reject "
            f"{clustering.reject:g}, self term {self_term}",
        )
    else:
        algorithm = "kmeans"
        k = n_modes if clustering.clusters is None else clustering.clusters
        km = kmeans_clustering(phi, k, restarts=clustering.restarts, seed=clustering.seed)
        centers, lower, upper = km.centers, km.lower, km.upper
        details = {"inertia": km.inertia, "seed": km.seed, "restarts": km.restarts}
        notes = (
            f"kmeans: {_count(k, 'centre')} from {_count(phi.shape[0], 'regression vector')} "
            f"φ(k) = [{text}]{without} "
            f"(scipy kmeans2, k-means++, best of {km.restarts} runs from seed {km.seed}, "
            f"inertia {km.inertia:.4g})",
        )
    measured = outputs if unmeasured is None else np.where(unmeasured, np.nan, outputs)
    return _unlabelled(algorithm, spec, names, centers, lower, upper, notes, details, measured)


def stored_classifier(
    stored: CentersFile,
    algorithm: str,
    spec: RegressorSpec,
    outputs: FloatArray,
    *,
    names: Sequence[str],
    mode_ids: Sequence[str],
    source: str,
) -> ModeClassifier:
    """The classifier of ``algorithm`` in a parsed ``centers.json``, applied to ``outputs``.

    ``outputs``: NaN where the log did not measure them (:meth:`ModeClassifier.decide`).

    Labelled with the file's modes when it has them; the notes say what each cluster decides
    on ``outputs`` (the file's own notes describe the log it was fitted on).

    Raises
    ------
    OptionError
        The file's modes are not the model's, its regressors are not φ(k) of this model and
        these lags, or it holds no centres of ``algorithm`` (the message starts with
        ``source``, the file's name).
    """
    names = tuple(names)
    lags = {"output_lags": spec.output_lags, "input_lags": spec.input_lags}
    entry = stored.entry(algorithm, names, lags, mode_ids, source)
    named = as_text(source)  # a name that is not UTF-8: no report could hold its note
    notes = (
        f"{algorithm}: {_count(len(entry.centers), 'centre')} loaded from {named}",
        *(f"WARNING: {named} says: {warning}" for warning in entry.warnings),
    )
    classifier = _unlabelled(
        algorithm, spec, names, entry.centers, stored.lower, stored.upper, notes, {}, outputs
    )
    beyond = _beyond_the_fitted_range(classifier, outputs, named)
    classifier = dataclasses.replace(classifier, notes=(*classifier.notes, *beyond))
    if entry.modes is None:
        return classifier
    modes = np.array([list(mode_ids).index(m) for m in entry.modes], dtype=np.int64)
    conflict = twin_conflict(modes, classifier.decision_values, mode_ids)
    if conflict is not None:
        raise OptionError(f"{source}: {algorithm}.modes: {conflict}")
    sizes = classifier.details["sizes"]
    return classifier.labelled(
        modes,
        (
            f"labels loaded from {named}",
            *cluster_notes(
                modes, sizes, mode_ids, twins=decision_twins(classifier.decision_values)
            ),
        ),
    )


_FAR = 1.0
"""How far beyond the fitted range, in widths of that range, a decision is a WARNING."""


def _beyond_the_fitted_range(
    classifier: ModeClassifier, outputs: FloatArray, source: str
) -> tuple[str, ...]:
    """A note where ``outputs`` leave the range of ``y(k)`` the stored centres were fitted on.

    The centres of a file hold only the box (``scaling``) of the log they were fitted on;
    eqs. (2)-(3) decide every sample by its nearest centre however far from that box it
    lies (centres fitted on a cart moving ±1 m decided a log in micrometres, 10^6 times
    larger, without a word).  The note counts the samples with a measured ``y(k)`` outside
    the box and names the farthest; it is a WARNING where that one lies more than the box's
    own width beyond it (:data:`_FAR`; 1 where the box is one value, which the decision
    does not scale): the decision there is an extrapolation.  Nothing
    when every measured ``y(k)`` is inside.
    """
    columns = list(classifier.decision_columns)
    lower, upper = classifier.lower[columns], classifier.upper[columns]
    span = upper - lower
    with np.errstate(invalid="ignore"):  # NaN: not measured, never outside
        excess = np.maximum(np.maximum(lower - outputs, outputs - upper), 0.0)
        excess = np.where(np.isnan(outputs), 0.0, excess)
    outside = np.any(excess > 0.0, axis=1)
    count = int(np.count_nonzero(outside))
    if count == 0:
        return ()
    # in the decision's own units (decide_clusters): the width, or 1 where the file's range
    # is one value (an infinite 'width' there named a nanometre off it, over a log 10^6
    # times larger in another output, as the farthest, and warned of it)
    widths = excess / np.where(span > 0, span, 1.0)
    row, column = np.unravel_index(int(np.argmax(widths)), widths.shape)
    far = float(widths[row, column])
    name = classifier.regressors[columns[column]]
    measured = int(np.count_nonzero(np.any(~np.isnan(outputs), axis=1)))
    times = (
        f"{far:.3g} times its width"
        if span[column] > 0
        else f"{far:.3g} (one value in the file: compared unscaled, as the decision is)"
    )
    note = (
        f"{count:,} of {measured:,} samples have y(k) outside the range the centres of "
        f"{source} were fitted on (its scaling); farthest {name} = "
        f"{float(outputs[row, column]):.6g} at sample {int(row):,}, beyond "
        f"[{float(lower[column]):.6g}, {float(upper[column]):.6g}] by {times}: the "
        "nearest-centre decision (eqs. (2)-(3)) extrapolates there (another sensor scale, "
        "operating point or plant than the centres'?)"
    )
    return (f"WARNING: {note}" if far > _FAR else note,)


def manual_labels(
    text: str,
    mode_ids: Sequence[str],
    n_clusters: int,
    *,
    decision_values: FloatArray | None = None,
) -> IntArray:
    """Mode index of each cluster from ``cluster_modes="2,1"`` (mode ids in cluster order).

    ``decision_values``: the clusters' ``y_i*``, against which two clusters of the same
    decision values given different modes are refused
    (:func:`~hybridlog.cluster.labels.twin_conflict`).

    Raises
    ------
    OptionError
        Not one known mode id per cluster, or twins given different modes.
    """
    try:
        ids = comma_items(text, "mode ids")
    except ValueError as err:
        raise OptionError(f"cluster_modes: {err}") from None
    if len(ids) != n_clusters:
        raise OptionError(
            f"cluster_modes: {len(ids)} mode ids for {n_clusters} clusters ('{text}')"
        )
    for mode in ids:
        if mode not in mode_ids:
            raise OptionError(
                f"cluster_modes: unknown mode '{mode}' (modes: {', '.join(mode_ids)})"
            )
    modes = np.array([list(mode_ids).index(m) for m in ids], dtype=np.int64)
    conflict = None if decision_values is None else twin_conflict(modes, decision_values, mode_ids)
    if conflict is not None:
        raise OptionError(f"cluster_modes={text}: {conflict}")
    return modes
