"""The ``smoothing`` part of a report: the filter's own estimates beside the offline pass's.

:class:`OfflineSides` takes a run with an offline pass (``post_processing``: ``--smooth``,
``--mode-sequence``) a chunk at a time, like the rest of the report, and gives both sides'
mode, state and output metrics; :func:`state_reports` and :func:`output_mean` make the
report's own state RMSEs and mean output metrics too.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import TYPE_CHECKING

import numpy as np

from hybridlog.estimators.explained import explained_outputs
from hybridlog.estimators.result import EstimationResult
from hybridlog.report import metrics, mode_metrics, state_error
from hybridlog.report.mode_scores import ComponentModes, finite_or_none, where_known
from hybridlog.report.report_parts import (
    ComponentSide,
    ModeReport,
    OutputReport,
    Smoothing,
    SmoothingMetrics,
    StateReport,
)
from hybridlog.signals import NO_TRUE_MODE, AlignedSignals, IntArray

if TYPE_CHECKING:
    from hybridlog.model.hybrid_model import HybridModel

__all__ = ["OfflineSides", "output_mean", "state_reports"]


def output_mean(per_output: Iterable[metrics.OutputMetrics], name: str) -> float | None:
    """The top-level ``mse``, ``vaf`` or ``fit``: the mean over the outputs where it is defined.

    ``None`` when no output's is, and when one output's is a number float64 cannot hold
    (:attr:`~hybridlog.report.metrics.OutputMetrics.out_of_range`) or infinite (a
    prediction that diverged): the worst output is never left out of the mean.
    """
    per_output = list(per_output)
    if any(name in m.out_of_range for m in per_output):
        return None
    return finite_or_none(metrics.mean_where_defined([getattr(m, name) for m in per_output]))


def state_reports(
    names: tuple[str, ...], accumulator: state_error.StateAccumulator | None
) -> dict[str, StateReport]:
    """Each state's RMSE and the rows it is over (``accumulator``: ``None`` without truth)."""
    if accumulator is None:
        return {x: StateReport(rmse=None, samples=0) for x in names}
    rmse, samples = accumulator.result(), accumulator.samples()
    return {
        x: StateReport(rmse=finite_or_none(float(r)), samples=k)
        for x, r, k in zip(names, rmse, samples, strict=True)
    }


def _side(
    ids: tuple[str, ...],
    signals: AlignedSignals,
    dt: float,
    modes: IntArray,
    states: Mapping[str, StateReport],
    output_names: tuple[str, ...],
    explained: metrics.OutputAccumulator | None,
    component_accuracy: float | None = None,
    components: Mapping[str, ModeReport] | None = None,
) -> SmoothingMetrics:
    """The metrics of one side (filtered or offline) of a run with an offline pass.

    ``dt`` the step of the signals' grid, ``modes`` of every sample, ``states`` the RMSE
    of each state, ``explained`` the errors of the outputs its estimates explain,
    accumulated over the run (``None``: not evaluated).  ``component_accuracy``: for a
    ``[components]`` model, the fraction of samples where this side has every component's
    mode right (the log's truth is per component, so it is the side's mode accuracy; its
    switches are not scored jointly), ``components`` the side's report of each component
    with a true mode.
    """
    outputs: dict[str, OutputReport] | None = None
    fit: float | None = None
    if explained is not None:
        per_output = explained.result()
        outputs = {
            y: OutputReport(
                mse=finite_or_none(m.mse),
                vaf=finite_or_none(m.vaf),
                fit=finite_or_none(m.fit),
                samples=m.samples,
            )
            for y, m in zip(output_names, per_output, strict=True)
        }
        fit = output_mean(per_output, "fit")
    switches = int(np.count_nonzero(modes[1:] != modes[:-1]))
    sides = {c: ComponentSide.of(m) for c, m in (components or {}).items()}
    truth = signals.truth_modes
    if truth is None:
        return SmoothingMetrics(
            mode_accuracy=finite_or_none(component_accuracy)
            if component_accuracy is not None
            else None,
            confusion=None,
            detection_delay_s=None,
            detection_max_s=None,
            detected=None,
            missed=None,
            estimated_switches=switches,
            states=states,
            outputs=outputs,
            fit=fit,
            components=sides,
        )
    known = truth != NO_TRUE_MODE  # a true mode's gaps and late start are not scored
    scored = int(np.count_nonzero(known))
    estimated, true = where_known(modes, truth, known, scored)
    counts = mode_metrics.confusion_matrix(estimated, true, len(ids))
    det = mode_metrics.detection_delays(signals.time, modes, truth, ids, dt, known=known)
    return SmoothingMetrics(
        mode_accuracy=finite_or_none(mode_metrics.mode_accuracy(estimated, true))
        if scored
        else None,
        confusion={
            t_id: {e_id: int(counts[i, j]) for j, e_id in enumerate(ids)}
            for i, t_id in enumerate(ids)
        },
        detection_delay_s=finite_or_none(det.mean_s),
        detection_max_s=finite_or_none(det.max_s),
        detected=det.detected,
        missed=det.missed,
        undetermined=det.undetermined,
        estimated_switches=switches,
        states=states,
        outputs=outputs,
        fit=fit,
        components=sides,
    )


class OfflineSides:
    """The ``smoothing`` part of a report, a chunk of a run with an offline pass at a time.

    What the report does not keep of its own estimates (which are the offline ones): the
    filter's modes (8 bytes a sample) and state errors, and for both sides the errors of the
    outputs their estimates explain (``ŷ = h_q̂(x̂, u)``), all accumulated like the report's
    own metrics, so the numbers do not depend on how the rows were split.  The explained
    outputs are those the chunk carries (``post_processing.explained``,
    ``filtered_explained``), else computed here through ``model``
    (:func:`~hybridlog.estimators.explained.explained_outputs`); a side without them has no
    output metrics.
    """

    def __init__(
        self, first: EstimationResult, signals: AlignedSignals, model: HybridModel | None
    ) -> None:
        post = first.post_processing
        assert post is not None  # the caller's check
        self._how = (post.smoothing, post.mode_sequence, post.description)
        self._fallbacks = post.fallbacks  # the whole run's, in every chunk
        self._model = model
        self._filtered_modes: IntArray = np.empty(signals.n_samples, dtype=np.int64)
        self._filtered_components = ComponentModes(signals.n_samples, signals.truth_components)
        self._filtered_states = (
            None
            if signals.truth_states is None
            else state_error.StateAccumulator(len(first.state_names))
        )
        n_y = len(first.output_names)
        self._explained: list[metrics.OutputAccumulator | None] = [
            metrics.OutputAccumulator(n_y),
            metrics.OutputAccumulator(n_y),
        ]

    def add(self, chunk: EstimationResult, part: AlignedSignals, start: int) -> None:
        """Take a chunk's rows of both sides (``part``: the signals' rows from ``start``)."""
        post = chunk.post_processing
        assert post is not None  # the caller's check
        filtered = post.filtered
        if not (
            filtered.n_samples == chunk.n_samples
            and filtered.mode_ids == chunk.mode_ids
            and filtered.state_names == chunk.state_names
            and filtered.output_names == chunk.output_names
        ):
            raise ValueError(
                f"{chunk.estimator}: the filtered result does not line up with the smoothed one "
                f"({filtered.n_samples} against {chunk.n_samples} samples, or other modes, "
                "states or outputs)"
            )
        self._filtered_modes[start : start + chunk.n_samples] = filtered.modes
        self._filtered_components.add(filtered, start)
        if self._filtered_states is not None and part.truth_states is not None:
            self._filtered_states.add(filtered.estimated_state_means(), part.truth_states)
        sides = ((filtered, post.filtered_explained), (chunk, post.explained))
        for index, (side, carried) in enumerate(sides):
            accumulator = self._explained[index]
            if accumulator is None:
                continue
            explained = carried
            if explained is None and self._model is not None:
                explained = explained_outputs(self._model, side, part)
            if explained is None:
                self._explained[index] = None
            else:
                accumulator.add(part.measured_outputs(), explained)

    def smoothing(
        self,
        first: EstimationResult,
        signals: AlignedSignals,
        modes: IntArray,
        states: Mapping[str, StateReport],
        components: ComponentModes,
        dt: float,
    ) -> Smoothing:
        """Both sides' metrics.

        ``modes``, ``states`` and ``components`` (each component's modes) are the report's
        own (the offline ones).
        """
        ids = tuple(str(m) for m in first.mode_ids)
        filtered_states = state_reports(first.state_names, self._filtered_states)
        method, mode_sequence, description = self._how
        return Smoothing(
            method=method,
            mode_sequence=mode_sequence,
            description=description,
            fallbacks=self._fallbacks,
            filtered=_side(
                ids,
                signals,
                dt,
                self._filtered_modes,
                filtered_states,
                first.output_names,
                self._explained[0],
                self._filtered_components.joint_accuracy(),
                self._filtered_components.reports(signals.time, dt),
            ),
            smoothed=_side(
                ids,
                signals,
                dt,
                modes,
                states,
                first.output_names,
                self._explained[1],
                components.joint_accuracy(),
                components.reports(signals.time, dt),
            ),
        )
