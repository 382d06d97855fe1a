"""A run's result, a chunk of rows at a time, reduced to the :class:`PlotData` its plots draw.

:class:`PlotReducer` takes the estimator's result in consecutive chunks of rows, as a
streamed analysis yields it (a chunk's arrays may be overwritten by the next chunk: whatever
is kept is copied), beside the aligned signals of the whole run; :func:`reduce_result` is
the same for a whole result.  NumPy only, no matplotlib: the drawing is left to another
process, which receives only the reduced data (:mod:`hybridlog.report.plot_data`).

Chunks are reduced exactly as the whole run is: the bins are cut once, from the whole run's
sample times (:class:`~hybridlog.report.pixel_bins.PixelBins`); a bin cut by a chunk's
boundary gets the minimum and maximum of both parts, its first sample from the earlier
chunk and its last from the later one (:class:`~hybridlog.report.curve_envelopes.CurveReducer`,
:class:`~hybridlog.report.curve_envelopes.BandReducer`); a mode's pixel columns in one chunk
are joined to those of the chunks before where they touch, as the run that continues across
the boundary joins them (:class:`~hybridlog.report.timeline_bars.BarsReducer`).  A curve
short enough not to be reduced is kept whole.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from hybridlog.estimators.result import EstimationResult, TimelineColumn
from hybridlog.report.curve_envelopes import BandReducer, CurveReducer
from hybridlog.report.pixel_bins import PixelBins
from hybridlog.report.plot_data import (
    COMPONENT_PREFIX,
    MAX_PANELS,
    Components,
    ComponentTimeline,
    ModeTimelines,
    OutputCurves,
    PlotData,
    StateCurves,
)
from hybridlog.report.timeline_bars import BarsReducer
from hybridlog.signals import NO_TRUE_MODE, AlignedSignals, ComponentTruth, IntArray

__all__ = ["PlotReducer", "reduce_result"]


def _mode_label(result: EstimationResult) -> str:
    """The legend of the estimated mode: ``estimated``, ``smoothed``, ``viterbi`` or ``kbest``."""
    post = result.post_processing
    if post is None:
        return "estimated"
    return "smoothed" if post.mode_sequence == "argmax" else post.mode_sequence


class _FilteredReducers:
    """The reductions of a smoothed result's causal filter (``post_processing.filtered``).

    A pass may leave some of the filter's estimates as they were: the Viterbi path changes
    only the modes, ``kbest`` without ``smooth`` keeps the filter's mode probabilities.  Such
    a curve would be drawn twice, once labelled as the filter's, as if the pass had changed
    it; ``states_differ`` and ``probabilities_differ`` record whether any row of the filter's
    differs from the estimate's, and only those curves are overlaid (:meth:`PlotReducer.finish`).
    """

    def __init__(self, bins: PixelBins, n_modes: int, n_states: int, timelines: bool) -> None:
        self.modes = BarsReducer(bins, n_modes)  # or, of a [components] result, the joint ones
        self.probabilities = [CurveReducer(bins) for _ in range(n_modes if timelines else 0)]
        self.means = [CurveReducer(bins) for _ in range(n_states)]
        self.states_differ = [False] * n_states
        self.probabilities_differ = False

    def add(self, filtered: EstimationResult, estimate: EstimationResult, start: int) -> None:
        """Take the filter's rows ``start .. start + filtered.n_samples - 1``.

        ``estimate``: the offline estimate's same rows, against which each curve of the
        filter's is compared.
        """
        self.modes.add(filtered.modes, start)
        for j, curve in enumerate(self.probabilities):
            curve.add(filtered.mode_probabilities[:, j], start)
        if self.probabilities and not self.probabilities_differ:
            self.probabilities_differ = not np.array_equal(
                filtered.mode_probabilities, estimate.mode_probabilities, equal_nan=True
            )
        filtered_means = filtered.estimated_state_means()  # NaN where not estimated
        means = estimate.estimated_state_means()
        for i, curve in enumerate(self.means):
            curve.add(filtered_means[:, i], start)
            if not self.states_differ[i]:
                self.states_differ[i] = not np.array_equal(
                    filtered_means[:, i], means[:, i], equal_nan=True
                )


class _ComponentReducers:
    """The bars of one component of a ``[components]`` result: estimated, true and filtered.

    Rows are the column's labels, then the true ones it lacks (:class:`ComponentTimeline`);
    ``truth_rows`` and ``filtered_rows`` take the truth's and the filter's label codes there.
    """

    def __init__(
        self,
        bins: PixelBins,
        column: TimelineColumn,
        truth: ComponentTruth | None,
        filtered: TimelineColumn | None,
    ) -> None:
        self.column = column.name
        self.labels = tuple(dict.fromkeys((*column.labels, *(truth.labels if truth else ()))))
        row = {label: i for i, label in enumerate(self.labels)}
        self.estimated = BarsReducer(bins, len(self.labels))
        self.truth = None if truth is None else BarsReducer(bins, len(self.labels))
        self.truth_rows = np.array([row[label] for label in truth.labels] if truth else [])
        self.filtered = None
        self.filtered_rows = np.zeros(0, dtype=np.int64)
        if filtered is not None and all(label in row for label in filtered.labels):
            self.filtered = BarsReducer(bins, len(self.labels))
            self.filtered_rows = np.array([row[label] for label in filtered.labels])

    def finish(self) -> ComponentTimeline:
        return ComponentTimeline(
            self.column.removeprefix(COMPONENT_PREFIX),
            self.labels,
            self.estimated.finish(),
            None if self.truth is None else self.truth.finish(),
            None if self.filtered is None else self.filtered.finish(),
        )


class PlotReducer:
    """Reduce a run's result, given in consecutive chunks of rows, to its :class:`PlotData`.

    The result's arrays are taken a chunk at a time (:meth:`add`; only their reductions are
    kept, so a chunk's arrays may be reused for the next one), and with each chunk the same
    rows of the aligned signals (measured outputs, truth): :meth:`finish` only assembles
    the data, so the drawing that waits for it starts at once.
    The first chunk says whether the result has ``post_processing`` (the filter's curves are
    then reduced too, from each chunk's ``post_processing.filtered`` over the same rows) and
    per-component mode columns (``unknown-mode``: its timelines replace the modes'); a result
    that has them may come as one chunk, the whole result.

    Parameters
    ----------
    signals:
        The aligned signals of the whole run: the bins are cut from their ``time``.
    mode_ids, state_names, output_names:
        The result's modes, states and outputs.
    """

    def __init__(
        self,
        signals: AlignedSignals,
        mode_ids: Sequence[str],
        state_names: Sequence[str],
        output_names: Sequence[str],
    ) -> None:
        self._signals = signals
        self._bins = PixelBins.of_run(signals.time)
        self._mode_ids = tuple(mode_ids)
        self._state_names = tuple(state_names)
        self._output_names = tuple(output_names)
        n_outputs = min(len(self._output_names), MAX_PANELS)
        n_states = min(len(self._state_names), MAX_PANELS)
        self._predicted = [CurveReducer(self._bins) for _ in range(n_outputs)]
        self._means = [CurveReducer(self._bins) for _ in range(n_states)]
        self._bands = [BandReducer(self._bins) for _ in range(n_states)]
        self._modes = BarsReducer(self._bins, len(self._mode_ids))
        # The signals' curves are reduced with the result's rows, not all at once in finish:
        # the drawing waits for finish, and the chunks come slower than they are reduced.
        self._measured = [CurveReducer(self._bins) for _ in range(n_outputs)]
        truth = signals.truth_states
        self._truth = [] if truth is None else [CurveReducer(self._bins) for _ in range(n_states)]
        self._truth_seen = [False] * len(self._truth)
        self._truth_modes: BarsReducer | None = None
        # Set by the first chunk (:meth:`_begin`).
        self._begun = False
        self._mode_label = "estimated"
        self._state_label = "estimate"
        self._explained: list[CurveReducer] = []
        self._explained_label = ""
        self._probabilities: list[CurveReducer] = []
        self._components: list[_ComponentReducers] = []
        self._filtered: _FilteredReducers | None = None
        self._next = 0

    def _begin(self, first: EstimationResult) -> None:
        """Set up what depends on the kind of result: the labels, components, filter."""
        self._begun = True
        post = first.post_processing
        self._mode_label = _mode_label(first)
        self._state_label = "smoothed" if post is not None and post.smoothing else "estimate"
        filtered = {} if post is None else {c.name: c for c in post.filtered.timeline_columns}
        self._components = [
            _ComponentReducers(
                self._bins,
                column,
                self._signals.truth_components.get(column.name.removeprefix(COMPONENT_PREFIX)),
                filtered.get(column.name),
            )
            for column in first.timeline_columns
            if column.name.startswith(COMPONENT_PREFIX) and column.labels
        ]
        timelines = not self._components  # the figure of the modes, not of the components
        n_modes = len(self._mode_ids)
        self._probabilities = [CurveReducer(self._bins) for _ in range(n_modes if timelines else 0)]
        if post is not None:
            self._filtered = _FilteredReducers(self._bins, n_modes, len(self._means), timelines)
            if post.explained is not None:
                self._explained = [CurveReducer(self._bins) for _ in self._predicted]
                self._explained_label = "smoothed" if post.smoothing else self._mode_label
        if timelines and self._signals.truth_modes is not None:
            self._truth_modes = BarsReducer(self._bins, n_modes)

    def add(self, chunk: EstimationResult, start: int) -> None:
        """Reduce ``chunk``: the result's rows ``start .. start + chunk.n_samples - 1``.

        Raises
        ------
        ValueError
            When ``chunk`` does not continue the rows added before, runs past the signals'
            end, or has ``post_processing`` (or its filter's rows) where the first chunk did
            not, or the other way round.
        """
        stop = start + chunk.n_samples
        if start != self._next or stop > self._signals.n_samples:
            raise ValueError(
                f"plots: chunk of rows [{start}, {stop}) added where row {self._next} of "
                f"{self._signals.n_samples} was expected"
            )
        if not self._begun:
            self._begin(chunk)
        post = chunk.post_processing
        if (
            (post is None) != (self._filtered is None)
            or (post is not None and post.filtered.n_samples != chunk.n_samples)
            or (post is not None and (post.explained is None) == bool(self._explained))
        ):
            raise ValueError(
                f"plots: rows [{start}, {stop}) have post-processing where the first chunk "
                "had none, or none where it had, or a filter's result of other rows, or "
                "explained outputs where the first chunk had none, or none where it had"
            )
        for j, curve in enumerate(self._predicted):
            curve.add(chunk.output_predictions[:, j], start)
        if post is not None and post.explained is not None:
            for j, curve in enumerate(self._explained):
                curve.add(post.explained[:, j], start)
        means = chunk.estimated_state_means()  # NaN (no curve, no band) where not estimated
        for i, (curve, band) in enumerate(zip(self._means, self._bands, strict=True)):
            curve.add(means[:, i], start)
            band.add(means[:, i], chunk.state_variances[:, i], start)
        self._modes.add(chunk.modes, start)
        for j, curve in enumerate(self._probabilities):
            curve.add(chunk.mode_probabilities[:, j], start)
        if self._components:
            columns = {column.name: column for column in chunk.timeline_columns}
            filtered = {} if post is None else {c.name: c for c in post.filtered.timeline_columns}
            for component in self._components:
                values = columns[component.column].values
                component.estimated.add(np.asarray(values, dtype=np.int64), start)
                if component.filtered is not None:
                    codes = np.asarray(filtered[component.column].values, dtype=np.int64)
                    component.filtered.add(component.filtered_rows[codes], start)
        if post is not None and self._filtered is not None:
            self._filtered.add(post.filtered, chunk, start)
        self._add_signals(start, stop)
        self._next = stop

    def _add_signals(self, start: int, stop: int) -> None:
        """Reduce the signals' rows ``start .. stop - 1``: measured outputs and the truth."""
        signals = self._signals
        measured = signals.rows(start, stop).measured_outputs()  # no line across a gap bridged
        for j, curve in enumerate(self._measured):
            curve.add(measured[:, j], start)
        truth = signals.truth_states
        if truth is not None:
            for i, curve in enumerate(self._truth):
                rows = truth[start:stop, i]
                curve.add(rows, start)
                self._truth_seen[i] = self._truth_seen[i] or bool(np.isfinite(rows).any())
        if self._truth_modes is not None and signals.truth_modes is not None:
            self._truth_modes.add(signals.truth_modes[start:stop], start)
        for component in self._components:
            name = component.column.removeprefix(COMPONENT_PREFIX)
            if component.truth is not None:
                codes = signals.truth_components[name].codes[start:stop]
                known = codes != NO_TRUE_MODE
                true_rows: IntArray = np.full(codes.shape, NO_TRUE_MODE, dtype=np.int64)
                true_rows[known] = component.truth_rows[codes[known]]
                component.truth.add(true_rows, start)  # mode_bars draws no NO_TRUE_MODE bar

    def finish(self) -> PlotData:
        """The run's :class:`PlotData`, once every row was added.

        Raises
        ------
        ValueError
            When rows of the run were not added.
        """
        bins = self._bins
        n = self._signals.n_samples
        if self._next != n:
            raise ValueError(f"plots: rows [{self._next}, {n}) of the result were not added")
        outputs = tuple(
            OutputCurves(
                name,
                measured.finish(),
                curve.finish(),
                self._explained[j].finish() if self._explained else None,
            )
            for j, (name, measured, curve) in enumerate(
                zip(self._output_names, self._measured, self._predicted, strict=False)
            )
        )
        filtered = self._filtered
        states = tuple(
            StateCurves(
                name,
                band.finish(),
                self._truth[i].finish() if self._truth and self._truth_seen[i] else None,
                curve.finish(),
                filtered.means[i].finish()
                if filtered is not None and filtered.states_differ[i]
                else None,
            )
            for i, (name, curve, band) in enumerate(
                zip(self._state_names, self._means, self._bands, strict=False)
            )
        )
        return PlotData(
            n_samples=n,
            time_origin=bins.origin,
            span=bins.span,
            edges=bins.edges,
            output_names=self._output_names,
            outputs=outputs,
            state_names=self._state_names,
            state_label=self._state_label,
            states=states,
            modes=self._finish_modes() if n else None,
            explained_label=self._explained_label,
        )

    def _finish_modes(self) -> ModeTimelines | Components:
        """The mode timelines, or the per-component ones of a ``[components]`` result."""
        estimated = self._modes.finish()
        filtered = self._filtered
        if self._components:
            joint_filtered = None if filtered is None else filtered.modes.finish()
            visited = [
                m
                for m, (first, _) in enumerate(estimated)
                if first.size or (joint_filtered is not None and joint_filtered[m][0].size)
            ]
            return Components(
                columns=tuple(component.finish() for component in self._components),
                joint_ids=tuple(self._mode_ids[m] for m in visited),
                joint=tuple(estimated[m] for m in visited),
                joint_filtered=None
                if joint_filtered is None
                else tuple(joint_filtered[m] for m in visited),
                label=self._mode_label,
            )
        truth = self._truth_modes
        return ModeTimelines(
            mode_ids=self._mode_ids,
            label=self._mode_label,
            estimated=estimated,
            truth=None if truth is None else truth.finish(),
            filtered=None if filtered is None else filtered.modes.finish(),
            probabilities=tuple(curve.finish() for curve in self._probabilities),
            filtered_probabilities=tuple(curve.finish() for curve in filtered.probabilities)
            if filtered is not None and filtered.probabilities_differ
            else None,
        )


def reduce_result(result: EstimationResult, signals: AlignedSignals) -> PlotData:
    """The :class:`PlotData` of a whole result (one chunk of a :class:`PlotReducer`)."""
    reducer = PlotReducer(signals, result.mode_ids, result.state_names, result.output_names)
    reducer.add(result, 0)
    return reducer.finish()
