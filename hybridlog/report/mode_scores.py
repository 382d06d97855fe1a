"""The mode part of a report, scored against the log's true mode.

:func:`mode_report`: the estimated switches and dwell times, and where the log has a true
mode the accuracy, confusion and detection delays over the samples that have one
(:func:`where_known`); :class:`ComponentModes`: the estimated mode of each component of a
``[components]`` result, gathered chunk by chunk and scored against each component's true
mode.  :func:`finite_or_none`: a number report.json holds, ``None`` for NaN and infinities.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

import numpy as np

from hybridlog.estimators.result import EstimationResult
from hybridlog.report import mode_metrics
from hybridlog.report.plot_data import COMPONENT_PREFIX
from hybridlog.report.report_parts import Detection, ModeReport, ModeSwitch
from hybridlog.signals import NO_TRUE_MODE, BoolArray, ComponentTruth, FloatArray, IntArray

__all__ = ["ComponentModes", "finite_or_none", "mode_report", "where_known"]


def finite_or_none(x: float) -> float | None:
    """``x``, or ``None`` where it is NaN or infinite (report.json's ``null``)."""
    return x if math.isfinite(x) else None


def where_known(
    modes: IntArray, truth: IntArray, known: BoolArray, scored: int
) -> tuple[IntArray, IntArray]:
    """The estimated and true modes of the samples with a true mode (``scored`` of them).

    The arrays themselves where every sample has one: each selection copied the 10^6 modes
    of a long log, twice for the confusion matrix and twice for the accuracy.
    """
    if scored == truth.size:
        return modes, truth
    return modes[known], truth[known]


def mode_report(
    ids: tuple[str, ...], time: FloatArray, modes: IntArray, truth: IntArray | None, dt: float
) -> ModeReport:
    """The mode part of a report: switches and dwell, and against the truth when known."""
    dwell = mode_metrics.dwell_times(time, modes, len(ids), dt, on_grid=True)
    report = ModeReport(
        labels=ids,
        switches=tuple(
            ModeSwitch(t=s["t"], from_mode=s["from"], to_mode=s["to"])
            for s in mode_metrics.mode_switches(time, modes, ids)
        ),
        dwell_s={m: finite_or_none(float(d)) for m, d in zip(ids, dwell, strict=True)},
    )
    if truth is None:
        return report
    known = truth != NO_TRUE_MODE
    scored = int(np.count_nonzero(known))
    if scored == 0:  # the true mode starts after the last sample
        return dataclasses.replace(report, samples=0)
    estimated, true = where_known(modes, truth, known, scored)
    counts = mode_metrics.confusion_matrix(estimated, true, len(ids))
    det = mode_metrics.detection_delays(time, modes, truth, ids, dt, known=known)
    return ModeReport(
        labels=report.labels,
        switches=report.switches,
        dwell_s=report.dwell_s,
        accuracy=finite_or_none(mode_metrics.mode_accuracy(estimated, true)),
        samples=scored,
        confusion={
            t_id: {e_id: int(counts[i, j]) for j, e_id in enumerate(ids)}
            for i, t_id in enumerate(ids)
        },
        detection=Detection(
            mean_s=finite_or_none(det.mean_s), max_s=finite_or_none(det.max_s), events=det.events
        ),
    )


class ComponentModes:
    """The estimated mode of each component with ground truth, gathered chunk by chunk.

    A ``[components]`` result carries each component's mode as a timeline column
    ``mode.<component>`` (labels); the log may carry each component's true mode
    (``AlignedSignals.truth_components``).  Both are scored per component on the union of
    their labels (the estimate may say ``unknown``), and jointly: a sample is right when
    every component is.
    """

    def __init__(self, n: int, truth: Mapping[str, ComponentTruth]) -> None:
        self._n = n
        self._truth = truth
        self._labels: dict[str, tuple[str, ...]] = {}
        self._codes: dict[str, IntArray] = {}
        self._components: dict[str, None] = {}  # every component, in the result's order

    def add(self, chunk: EstimationResult, start: int) -> None:
        """Take a chunk's component modes, its rows from row ``start`` of the run."""
        for column in chunk.timeline_columns:
            name = column.name.removeprefix(COMPONENT_PREFIX)
            if not column.name.startswith(COMPONENT_PREFIX) or not column.labels:
                continue
            self._components[name] = None
            if name not in self._truth:
                continue
            if self._labels.setdefault(name, column.labels) != column.labels:
                raise ValueError(f"{chunk.estimator}: the labels of {column.name} changed")
            codes = self._codes.setdefault(name, np.empty(self._n, dtype=np.int64))
            codes[start : start + chunk.n_samples] = column.values

    def reports(self, time: FloatArray, dt: float) -> dict[str, ModeReport]:
        """Per component with truth: its :class:`ModeReport` against the truth."""
        reports = {}
        for name, labels in self._labels.items():
            truth = self._truth[name]
            ids = tuple(dict.fromkeys((*truth.labels, *labels)))
            where = {label: i for i, label in enumerate(ids)}
            estimated = np.array([where[label] for label in labels], dtype=np.int64)
            true = np.array([where[label] for label in truth.labels], dtype=np.int64)
            # NO_TRUE_MODE stays so: as an index it would pick the last label
            codes = np.where(truth.codes == NO_TRUE_MODE, NO_TRUE_MODE, true[truth.codes])
            reports[name] = mode_report(ids, time, estimated[self._codes[name]], codes, dt)
        return reports

    def without_truth(self) -> tuple[str, ...]:
        """The components whose true mode the log does not have, in the result's order."""
        return tuple(name for name in self._components if name not in self._labels)

    def joint_samples(self) -> int | None:
        """How many samples :meth:`joint_accuracy` scores; ``None`` when it scores none."""
        if not self._components or set(self._labels) != set(self._components):
            return None
        known = np.ones(self._n, dtype=bool)
        for name in self._labels:
            known &= self._truth[name].codes != NO_TRUE_MODE
        return int(np.count_nonzero(known))

    def joint_accuracy(self) -> float | None:
        """Fraction of samples where every component's mode is right.

        Over the samples where every component has a true mode (one that starts late leaves
        those before it out); ``None`` unless the log has every component's true mode.
        """
        if not self._components or set(self._labels) != set(self._components):
            return None
        right = np.ones(self._n, dtype=bool)
        known = np.ones(self._n, dtype=bool)  # every component has a true mode
        for name, labels in self._labels.items():
            truth = self._truth[name]
            estimated = np.asarray(labels, dtype=object)[self._codes[name]]
            right &= estimated == np.asarray(truth.labels, dtype=object)[truth.codes]
            known &= truth.codes != NO_TRUE_MODE
        return float(right[known].mean()) if known.any() else None
