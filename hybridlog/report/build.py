"""Compute the :class:`~hybridlog.report.document.Report` of one run from its result and log.

Every metric comes from :mod:`hybridlog.report.metrics` and
:mod:`hybridlog.report.state_error`; this module assembles them into the typed report and
turns numbers that are not finite into ``None``.  Its parts: the mode part
:mod:`hybridlog.report.mode_scores`, the ``smoothing`` part
:mod:`hybridlog.report.offline_sides`, why each gate metric that is ``None`` is undefined
:mod:`hybridlog.report.null_reasons`, and the notes: the model's
(:mod:`hybridlog.report.model_notes`), of metrics over too few samples
(:mod:`hybridlog.report.few_samples`) and of how the log was read
(:mod:`hybridlog.report.reading_notes`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from hybridlog import __version__
from hybridlog.errors import LogError
from hybridlog.estimators.consistency import ConsistencyAccumulator
from hybridlog.estimators.result import EstimationResult
from hybridlog.report import metrics, state_error
from hybridlog.report.chance_level import chance_level_warning
from hybridlog.report.document import Report
from hybridlog.report.few_samples import few_samples_warning
from hybridlog.report.markdown import plural
from hybridlog.report.mode_scores import ComponentModes, finite_or_none, mode_report
from hybridlog.report.model_notes import model_notes
from hybridlog.report.null_reasons import null_reasons
from hybridlog.report.offline_sides import OfflineSides, output_mean, state_reports
from hybridlog.report.reading_notes import report_reading_notes
from hybridlog.report.report_json import JsonObject
from hybridlog.report.report_parts import OutputReport
from hybridlog.signals import AlignedSignals, IntArray

if TYPE_CHECKING:
    from hybridlog.model.hybrid_model import HybridModel

__all__ = [
    "MIN_SAMPLES",
    "ReportBuilder",
    "build_report",
    "check_compatible",
    "jsonable",
]

MIN_SAMPLES = 3
"""Fewest samples a run must have to be reported: row 0 is the estimators' prior (no
prediction), and VAF and fit compare spreads, which a single predicted sample does not have."""


def jsonable(value: Any) -> Any:
    """Convert a value to plain JSON types, with ``None`` for NaN and infinities.

    Parameters
    ----------
    value:
        Nested dicts, lists, tuples, NumPy scalars and arrays, numbers, strings.

    Returns
    -------
    Any
        The same structure made of ``dict``, ``list``, ``str``, ``int``, ``float``,
        ``bool`` and ``None``; any other object becomes its ``str``.

    """
    if value is None or isinstance(value, bool | str):
        return value
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, int | np.integer):
        return int(value)
    if isinstance(value, float | np.floating):
        f = float(value)
        return f if math.isfinite(f) else None
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, Mapping):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple | set | frozenset):
        return [jsonable(v) for v in value]
    return str(value)


def check_compatible(result: EstimationResult, signals: AlignedSignals) -> None:
    """Check that a result and the signals it was computed from line up row by row.

    The result's own arrays are checked when it is built
    (:class:`~hybridlog.estimators.result.EstimationResult`); this checks the signals
    against it.

    Parameters
    ----------
    result:
        The estimation result.
    signals:
        The aligned signals it was computed from.

    Raises
    ------
    ValueError
        When sample counts, outputs or truth shapes disagree (a programming error, not a
        user error).

    """
    n = result.n_samples
    if signals.n_samples != n:
        raise ValueError(f"result has {n} samples but the signals have {signals.n_samples}")
    if tuple(signals.output_names) != tuple(result.output_names):
        raise ValueError(
            f"the result predicts outputs {result.output_names} but the signals hold "
            f"{signals.output_names}"
        )
    n_y, n_x = len(result.output_names), len(result.state_names)
    if signals.outputs.shape != (n, n_y):
        raise ValueError(f"outputs have shape {signals.outputs.shape}; expected {(n, n_y)}")
    if signals.truth_modes is not None and signals.truth_modes.shape != (n,):
        raise ValueError(f"truth modes have shape {signals.truth_modes.shape}; expected {(n,)}")
    if signals.truth_states is not None and signals.truth_states.shape != (n, n_x):
        raise ValueError(
            f"truth states have shape {signals.truth_states.shape}; expected {(n, n_x)}"
        )


def _same_run(first: EstimationResult, chunk: EstimationResult) -> bool:
    """Whether a chunk belongs to the run whose first chunk is ``first`` (names, options)."""
    return (
        chunk.estimator == first.estimator
        and chunk.mode_ids == first.mode_ids
        and chunk.state_names == first.state_names
        and chunk.output_names == first.output_names
        and _same_value(chunk.options, first.options)
    )


def _same_value(a: object, b: object) -> bool:
    """``a == b`` for option values, which may hold NumPy arrays (``chiu``'s centres).

    An array's ``==`` is elementwise and has no truth value.
    """
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return isinstance(a, np.ndarray) and isinstance(b, np.ndarray) and np.array_equal(a, b)
    if isinstance(a, Mapping) and isinstance(b, Mapping):
        return a.keys() == b.keys() and all(_same_value(a[k], b[k]) for k in a)
    if isinstance(a, list | tuple) and isinstance(b, list | tuple):
        return type(a) is type(b) and len(a) == len(b) and all(map(_same_value, a, b))
    return bool(a == b)


class ReportBuilder:
    """The report of one run, its result taken a chunk of rows at a time.

    An estimator may give its result in consecutive chunks whose arrays the next chunk
    overwrites (:meth:`hybridlog.estimators.Prepared.stream`): each :meth:`add` takes what
    the report needs of a chunk and keeps none of its arrays.  The output and state metrics
    are accumulated (:class:`~hybridlog.report.metrics.OutputAccumulator`,
    :class:`~hybridlog.report.state_error.StateAccumulator`: the same numbers however the rows
    were split); the estimated modes, one index a sample (8 bytes, where the whole result
    holds about a hundred), are kept for the mode metrics, which follow switches across the
    run.  A result with an offline pass (``post_processing``) also gets the ``smoothing``
    part, its chunks taken alike (:class:`~hybridlog.report.offline_sides.OfflineSides`).
    A whole result is one chunk (:func:`build_report`).

    Parameters
    ----------
    signals:
        The aligned signals of the whole run.
    log:
        Path or name of the log, as the user gave it.
    dt:
        The model's sample time in seconds.
    model:
        The model the result was estimated with (for the outputs a smoothed result's
        estimates explain, where its chunks do not carry them:
        :class:`~hybridlog.report.offline_sides.OfflineSides`); ``None`` when not given.

    Raises
    ------
    LogError
        When the run has fewer than :data:`MIN_SAMPLES` samples (naming ``log``, and the
        piece of it ``--split-gaps`` kept, :attr:`~hybridlog.signals.AlignedSignals.piece`):
        before any estimate is taken, so a run too short to report is refused before it
        runs.

    """

    def __init__(
        self, signals: AlignedSignals, *, log: str, dt: float, model: HybridModel | None = None
    ) -> None:
        n = signals.n_samples
        if n < MIN_SAMPLES:
            where = f"{log} ({signals.piece})" if signals.piece else log  # which piece of it
            raise LogError(
                f"{where}: too short: {plural(n, 'sample')} on the model's grid (dt = {dt:g} s); "
                f"a report needs at least {MIN_SAMPLES}: the first sample is the prior, and "
                "VAF and fit need the spread of at least two predicted samples"
            )
        self._signals = signals
        self._log = str(log)
        self._dt = float(dt)
        self._model = model
        self._rows = 0
        self._modes: IntArray = np.empty(n, dtype=np.int64)
        self._outputs = metrics.OutputAccumulator(len(signals.output_names))
        self._states: state_error.StateAccumulator | None = None
        # per state, the samples with a true value the estimator did not estimate it on
        self._held: IntArray = np.zeros(0, dtype=np.int64)
        self._first: EstimationResult | None = None
        self._last: EstimationResult | None = None
        self._offline: OfflineSides | None = None
        self._components = ComponentModes(n, signals.truth_components)
        self._consistency: ConsistencyAccumulator | None = None

    @property
    def rows(self) -> int:
        """Rows taken so far: the first row of the next chunk."""
        return self._rows

    def add(self, chunk: EstimationResult) -> None:
        """Take the next rows of the run's result (a chunk, or the whole result).

        Raises
        ------
        ValueError
            When the chunk does not line up with the signals' next rows or with the run's
            earlier chunks (its names, options, whether it has ``post_processing``, or
            its filter's result): programming errors of the estimator, not user errors.

        """
        start, stop = self._rows, self._rows + chunk.n_samples
        if stop > self._signals.n_samples:
            raise ValueError(
                f"{chunk.estimator}: rows {start}:{stop} past the run's "
                f"{self._signals.n_samples} samples"
            )
        part = self._signals.rows(start, stop)
        check_compatible(chunk, part)
        if self._first is None:
            self._first = chunk
            if part.truth_states is not None:
                self._states = state_error.StateAccumulator(len(chunk.state_names))
                self._held = np.zeros(len(chunk.state_names), dtype=np.int64)
            if chunk.post_processing is not None:
                self._offline = OfflineSides(chunk, self._signals, self._model)
        elif not _same_run(self._first, chunk) or (chunk.post_processing is None) != (
            self._offline is None
        ):
            raise ValueError(
                f"{chunk.estimator}: a chunk of another run (names, options or offline pass)"
            )
        self._outputs.add(part.measured_outputs(), chunk.output_predictions)
        if self._states is not None and part.truth_states is not None:
            self._states.add(chunk.estimated_state_means(), part.truth_states)
            if chunk.states_not_estimated is not None:  # held where there is a true value
                truth = np.isfinite(part.truth_states)
                self._held += np.count_nonzero(chunk.states_not_estimated & truth, axis=0)
        self._modes[start:stop] = chunk.modes
        self._components.add(chunk, start)
        if chunk.whitened_innovations is not None:  # the innovations' test (consistency.py)
            if self._consistency is None:
                self._consistency = ConsistencyAccumulator(chunk.output_names)
            whitened = chunk.whitened_innovations
            if part.unmeasured_outputs is not None:  # an innovation of a value not measured
                # (the filter updated on the others: their L⁻¹ γ is tested, consistency.py)
                whitened = np.where(part.unmeasured_outputs, np.nan, whitened)
            # settled by the filter's own mode probabilities: the innovations are the filter's,
            # and an offline pass's (smoothed) probabilities settle at other samples
            post = chunk.post_processing
            own = chunk if post is None else post.filtered
            self._consistency.add(whitened, own.mode_probabilities)
        if self._offline is not None:
            self._offline.add(chunk, part, start)
        self._last = chunk
        self._rows = stop

    def report(
        self,
        *,
        model_name: str,
        reading: Mapping[str, Any] | None = None,
        extra: Mapping[str, Any] | None = None,
    ) -> Report:
        """The report of every row taken (they must be the whole run).

        Parameters
        ----------
        model_name:
            Name of the model.
        reading:
            What reading the log did (the ``notes`` of :func:`hybridlog.io.load_signals`).
        extra:
            Further top-level keys of ``report.json``; a key naming a report attribute
            replaces the computed value (checked like a key of a ``report.json``).

        Raises
        ------
        ValueError
            When rows of the run were not taken.

        """
        signals, first, last = self._signals, self._first, self._last
        if first is None or last is None or self._rows != signals.n_samples:
            raise ValueError(f"{self._rows} of the run's {signals.n_samples} rows were taken")
        n = signals.n_samples
        per_output = dict(zip(first.output_names, self._outputs.result(), strict=True))
        runtime = float(last.runtime_s)
        ids = tuple(str(m) for m in first.mode_ids)
        truth = None if first.modes_given else signals.truth_modes  # given: nothing to score
        modes = mode_report(ids, signals.time, self._modes, truth, self._dt)
        components = self._components.reports(signals.time, self._dt)
        if components:
            joint = self._components.joint_accuracy()
            modes = dataclasses.replace(
                modes,
                components=components,
                accuracy=None if joint is None else finite_or_none(joint),
                samples=self._components.joint_samples(),
                components_without_truth=self._components.without_truth(),
            )
        states = state_reports(first.state_names, self._states)
        means = {name: output_mean(per_output.values(), name) for name in ("mse", "vaf", "fit")}
        samples_per_s = finite_or_none(n / runtime) if runtime > 0.0 else None
        report = Report(
            hybridlog_version=__version__,
            log=self._log,
            model=model_name,
            estimator=first.estimator,
            options=_json_object(first.options),
            samples=n,
            dt=self._dt,
            t_start=finite_or_none(float(signals.time[0])),
            t_end=finite_or_none(float(signals.time[-1])),
            outputs={
                y: OutputReport(
                    mse=finite_or_none(m.mse),
                    vaf=finite_or_none(m.vaf),
                    fit=finite_or_none(m.fit),
                    samples=m.samples,
                )
                for y, m in per_output.items()
            },
            mse=means["mse"],
            vaf=means["vaf"],
            fit=means["fit"],
            modes=modes,
            states=states,
            runtime_s=finite_or_none(runtime),
            compile_s=finite_or_none(float(last.compile_s)),
            samples_per_s=samples_per_s,
            notes=(
                *(str(note) for note in last.notes),
                *model_notes(self._model),
                *report_reading_notes(reading),
            ),
            null_reasons=null_reasons(
                per_output,
                means,
                modes,
                states,
                signals,
                samples_per_s,
                {}
                if self._states is None
                else dict(zip(states, self._states.undefined(), strict=True)),
                modes_given=first.modes_given,
                held=dict(zip(states, self._held.tolist(), strict=False)),
            ),
            smoothing=(
                None
                if self._offline is None
                else self._offline.smoothing(
                    first, signals, self._modes, states, self._components, self._dt
                )
            ),
            reading=None if reading is None else _json_object(reading),
        )
        consistency = None if self._consistency is None else self._consistency.result()
        if consistency is not None:  # report.json's "consistency"; a failed test warns
            report = dataclasses.replace(
                report,
                notes=(*report.notes, *(f"WARNING: {w}" for w in consistency.warnings())),
                extra={"consistency": _json_object(consistency.to_dict())},
            )
        elif self._consistency is not None and (why := self._consistency.untested()):
            report = dataclasses.replace(report, notes=(*report.notes, why))
        for warning in (chance_level_warning(report), few_samples_warning(report)):
            if warning is not None:
                report = dataclasses.replace(report, notes=(*report.notes, warning))
        if extra:
            report = report.with_extra(_json_object(extra), source=self._log)
        return report


def build_report(
    result: EstimationResult,
    signals: AlignedSignals,
    *,
    log: str,
    model_name: str,
    dt: float,
    reading: Mapping[str, Any] | None = None,
    extra: Mapping[str, Any] | None = None,
    model: HybridModel | None = None,
) -> Report:
    """Compute every metric of a run into a :class:`~hybridlog.report.document.Report`.

    A result whose estimates are not the causal filter's own (``result.post_processing``:
    ``--smooth``, ``--mode-sequence viterbi``) is reported as it is (modes, states and the
    tables hold the smoothed values; the output metrics stay the filter's one-step-ahead
    prediction, which ``output_predictions`` holds either way), and its ``smoothing`` holds
    the mode, state and output metrics of the filter's estimates and of the smoothed ones
    (:class:`~hybridlog.report.offline_sides.OfflineSides`).  The whole result as one chunk
    of a :class:`ReportBuilder`.

    Parameters
    ----------
    result:
        What the estimator returned.
    signals:
        The aligned signals it ran on (measured outputs, ground truth if any).
    log:
        Path or name of the log, as the user gave it.
    model_name:
        Name of the model.
    dt:
        The model's sample time in seconds.
    reading:
        What reading the log did (the ``notes`` of :func:`hybridlog.io.load_signals`).
    extra:
        Further top-level keys of ``report.json``; a key naming a report attribute
        replaces the computed value (checked like a key of a ``report.json``).
    model:
        The model the result was estimated with: for a smoothed result that does not carry
        the outputs its estimates explain, they are computed through the model's ``h``
        (:func:`~hybridlog.estimators.explained.explained_outputs`); ``None`` when not
        given.

    Returns
    -------
    Report
        The report; ``report.to_json()`` is ``report.json``.

    Raises
    ------
    LogError
        When the run has fewer than :data:`MIN_SAMPLES` samples (naming ``log``).

    """
    check_compatible(result, signals)
    builder = ReportBuilder(signals, log=log, dt=dt, model=model)
    builder.add(result)
    return builder.report(model_name=model_name, reading=reading, extra=extra)


def _json_object(value: Mapping[str, Any]) -> JsonObject:
    converted: JsonObject = jsonable(value)
    return converted
