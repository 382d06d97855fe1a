"""Compute the :class:`~hybridlog.report.document.Report` of one run from its result and log.

Every metric comes from :mod:`hybridlog.report.metrics`; this module assembles them into the
typed report, turns numbers that are not finite into ``None`` and says why each gate metric
that is ``None`` is undefined (``null_reasons``); its notes of how the log was read are
:mod:`hybridlog.report.reading_notes`'.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from hybridlog import __version__
from hybridlog.errors import LogError
from hybridlog.estimators.consistency import ConsistencyAccumulator
from hybridlog.estimators.explained import explained_outputs
from hybridlog.estimators.result import EstimationResult
from hybridlog.report import metrics, mode_metrics
from hybridlog.report.document import Report
from hybridlog.report.markdown import (
    NO_TRUE_MODE_REASON,
    NO_TRUE_STATE_REASON,
    WARNING_PREFIX,
    plural,
)
from hybridlog.report.plot_data import COMPONENT_PREFIX
from hybridlog.report.reading_notes import report_reading_notes
from hybridlog.report.report_json import JsonObject
from hybridlog.report.report_parts import (
    ComponentSide,
    Detection,
    ModeReport,
    ModeSwitch,
    OutputReport,
    Smoothing,
    SmoothingMetrics,
    StateReport,
)
from hybridlog.signals import (
    NO_TRUE_MODE,
    AlignedSignals,
    BoolArray,
    ComponentTruth,
    FloatArray,
    IntArray,
)

if TYPE_CHECKING:
    from hybridlog.model.hybrid_model import HybridModel

__all__ = [
    "FEW_SAMPLES",
    "MIN_SAMPLES",
    "ReportBuilder",
    "build_report",
    "check_compatible",
    "jsonable",
]

MIN_SAMPLES = 3
"""Fewest samples a run must have to be reported: row 0 is the estimators' prior (no
prediction), and VAF and fit compare spreads, which a single predicted sample does not have."""

FEW_SAMPLES = 30
"""Fewest samples a metric is taken over without a warning that it describes those samples,
not the estimator (:func:`few_samples_warning`): the variance of ``n`` samples of Gaussian
noise is off from the noise's by ``sqrt(2/(n-1))`` of itself (one standard deviation: 82 %
at 4 samples, 26 % at 30), and MSE, VAF and fit are built of such sums; over a short log
the filter's start (its prior, and the samples it takes to find the mode) weighs as much
as the rest (``sample_logs/three_tank_hstf.csv``'s first 5 samples: hstf's VAF 5.2 % and
mode accuracy 0 against 301 samples' 87 % and 99 %).  The threshold of the innovations'
test (:data:`hybridlog.estimators.consistency.MIN_SAMPLES`) for the same reason."""


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


def _num(x: float) -> float | None:
    return x if math.isfinite(x) else None


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


def _where_known(
    modes: IntArray, truth: IntArray, known: BoolArray, scored: int
) -> tuple[IntArray, IntArray]:
    """The estimated and true modes of the samples with a true mode (``scored`` of them).

    The arrays themselves where every sample has one: each selection copied the 10^6 modes
    of a long log, twice for the confusion matrix and twice for the accuracy.
    """
    if scored == truth.size:
        return modes, truth
    return modes[known], truth[known]


def _modes(
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
        dwell_s={m: _num(float(d)) for m, d in zip(ids, dwell, strict=True)},
    )
    if truth is None:
        return report
    known = truth != NO_TRUE_MODE
    scored = int(np.count_nonzero(known))
    if scored == 0:  # the true mode starts after the last sample
        return dataclasses.replace(report, samples=0)
    estimated, true = _where_known(modes, truth, known, scored)
    counts = mode_metrics.confusion_matrix(estimated, true, len(ids))
    det = mode_metrics.detection_delays(time, modes, truth, ids, dt, known=known)
    return ModeReport(
        labels=report.labels,
        switches=report.switches,
        dwell_s=report.dwell_s,
        accuracy=_num(mode_metrics.mode_accuracy(estimated, true)),
        samples=scored,
        confusion={
            t_id: {e_id: int(counts[i, j]) for j, e_id in enumerate(ids)}
            for i, t_id in enumerate(ids)
        },
        detection=Detection(mean_s=_num(det.mean_s), max_s=_num(det.max_s), events=det.events),
    )


class _ComponentModes:
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
            reports[name] = _modes(ids, time, estimated[self._codes[name]], codes, dt)
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
    :class:`~hybridlog.report.metrics.StateAccumulator`: the same numbers however the rows
    were split); the estimated modes, one index a sample (8 bytes, where the whole result
    holds about a hundred), are kept for the mode metrics, which follow switches across the
    run.  A result with an offline pass (``post_processing``) also gets the ``smoothing``
    part, its chunks taken alike (:class:`_OfflineSides`).  A whole result is one chunk
    (:func:`build_report`).

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
        estimates explain, where its chunks do not carry them: :class:`_OfflineSides`);
        ``None`` when not given.

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
        self._states: metrics.StateAccumulator | None = None
        # per state, the samples with a true value the estimator did not estimate it on
        self._held: IntArray = np.zeros(0, dtype=np.int64)
        self._first: EstimationResult | None = None
        self._last: EstimationResult | None = None
        self._offline: _OfflineSides | None = None
        self._components = _ComponentModes(n, signals.truth_components)
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
                self._states = metrics.StateAccumulator(len(chunk.state_names))
                self._held = np.zeros(len(chunk.state_names), dtype=np.int64)
            if chunk.post_processing is not None:
                self._offline = _OfflineSides(chunk, self._signals, self._model)
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
        modes = _modes(ids, signals.time, self._modes, truth, self._dt)
        components = self._components.reports(signals.time, self._dt)
        if components:
            joint = self._components.joint_accuracy()
            modes = dataclasses.replace(
                modes,
                components=components,
                accuracy=None if joint is None else _num(joint),
                samples=self._components.joint_samples(),
                components_without_truth=self._components.without_truth(),
            )
        states = _state_reports(first.state_names, self._states)
        means = {name: _output_mean(per_output.values(), name) for name in ("mse", "vaf", "fit")}
        samples_per_s = _num(n / runtime) if runtime > 0.0 else None
        report = Report(
            hybridlog_version=__version__,
            log=self._log,
            model=model_name,
            estimator=first.estimator,
            options=_json_object(first.options),
            samples=n,
            dt=self._dt,
            t_start=_num(float(signals.time[0])),
            t_end=_num(float(signals.time[-1])),
            outputs={
                y: OutputReport(
                    mse=_num(m.mse), vaf=_num(m.vaf), fit=_num(m.fit), samples=m.samples
                )
                for y, m in per_output.items()
            },
            mse=means["mse"],
            vaf=means["vaf"],
            fit=means["fit"],
            modes=modes,
            states=states,
            runtime_s=_num(runtime),
            compile_s=_num(float(last.compile_s)),
            samples_per_s=samples_per_s,
            notes=(
                *(str(note) for note in last.notes),
                *_model_notes(self._model),
                *report_reading_notes(reading),
            ),
            null_reasons=_null_reasons(
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
        few = few_samples_warning(report)
        if few is not None:
            report = dataclasses.replace(report, notes=(*report.notes, few))
        if extra:
            report = report.with_extra(_json_object(extra), source=self._log)
        return report


def _sample_counts(samples: Mapping[str, int | None]) -> str:
    """``4 samples`` when every named count is that, else ``4 (y1), 3 (y2)``."""
    counts = {n for n in samples.values() if n is not None}
    if len(counts) == 1:
        return plural(counts.pop(), "sample")
    return ", ".join(f"{n:,} ({name})" for name, n in samples.items() if n is not None)


FEW_SAMPLES_REMEDY = (
    f"judge the estimator on a log that gives each metric at least {FEW_SAMPLES} samples"
)
"""What to do, ending :func:`few_samples_warning`'s text (so report.md, report.json, the
terminal, comparison.md, the summaries and JUnit, which all carry the note whole)."""


def few_samples_warning(report: Report) -> str | None:
    """The warning that metrics are over fewer than :data:`FEW_SAMPLES` samples, or ``None``.

    A metric counts when it is over at least one sample (a metric over none is ``null`` and
    says why): the output metrics per output, the mode metrics (a ``[components]`` model's
    joint accuracy, and each component's over other samples than the joint one: without
    every component's true mode there is no joint accuracy, and a component's own is over
    the samples its true mode covers), the state RMSE per state.
    """
    outputs = {
        y: o.samples for y, o in report.outputs.items() if o.samples and o.samples < FEW_SAMPLES
    }
    states = {
        x: s.samples for x, s in report.states.items() if s.samples and s.samples < FEW_SAMPLES
    }
    joint = report.modes.samples
    modes = joint if joint and joint < FEW_SAMPLES and report.modes.accuracy is not None else None
    components = {
        c: m.samples
        for c, m in report.modes.components.items()
        if m.accuracy is not None and m.samples and m.samples < FEW_SAMPLES and m.samples != modes
    }
    parts = []
    if outputs:
        every = "" if len(outputs) == len(report.outputs) else f" of {', '.join(outputs)}"
        parts.append(f"MSE, VAF and fit{every} over {_sample_counts(outputs)}")
    if modes:
        parts.append(f"mode accuracy over {plural(modes, 'sample')}")
    if components:
        named = "component" if len(components) == 1 else "components"
        parts.append(
            f"mode accuracy of {named} {', '.join(components)} over {_sample_counts(components)}"
        )
    if states:
        every = "" if len(states) == len(report.states) else f" of {', '.join(states)}"
        parts.append(f"state RMSE{every} over {_sample_counts(states)}")
    if not parts:
        return None
    counted = [
        *outputs.values(),
        *components.values(),
        *states.values(),
        *([modes] if modes else []),
    ]
    least = min(counted, default=0)
    off = math.sqrt(2.0 / (least - 1)) if least > 1 else math.inf
    spread = f" ({off:.0%} at {least})" if math.isfinite(off) else ""
    return (
        f"{WARNING_PREFIX}{'; '.join(parts)}: fewer than {FEW_SAMPLES} samples, they describe "
        "these samples, not the estimator: the filter's start weighs as much as the rest, and "
        f"a variance over n samples is off by sqrt(2/(n-1)) of itself{spread}; {FEW_SAMPLES_REMEDY}"
    )


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
    (:class:`_OfflineSides`).  The whole result as one chunk of a :class:`ReportBuilder`.

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


def _output_mean(per_output: Iterable[metrics.OutputMetrics], name: str) -> float | None:
    """The top-level ``mse``, ``vaf`` or ``fit``: the mean over the outputs where it is defined.

    ``None`` when no output's is, and when one output's is a number float64 cannot hold
    (:attr:`~hybridlog.report.metrics.OutputMetrics.out_of_range`) or infinite (a
    prediction that diverged): the worst output is never left out of the mean.
    """
    per_output = list(per_output)
    if any(name in m.out_of_range for m in per_output):
        return None
    return _num(metrics.mean_where_defined([getattr(m, name) for m in per_output]))


def _state_reports(
    names: tuple[str, ...], accumulator: metrics.StateAccumulator | None
) -> dict[str, StateReport]:
    """Each state's RMSE and the rows it is over (``accumulator``: ``None`` without truth)."""
    if accumulator is None:
        return {x: StateReport(rmse=None, samples=0) for x in names}
    rmse, samples = accumulator.result(), accumulator.samples()
    return {
        x: StateReport(rmse=_num(float(r)), samples=k)
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
            y: OutputReport(mse=_num(m.mse), vaf=_num(m.vaf), fit=_num(m.fit), samples=m.samples)
            for y, m in zip(output_names, per_output, strict=True)
        }
        fit = _output_mean(per_output, "fit")
    switches = int(np.count_nonzero(modes[1:] != modes[:-1]))
    sides = {c: ComponentSide.of(m) for c, m in (components or {}).items()}
    truth = signals.truth_modes
    if truth is None:
        return SmoothingMetrics(
            mode_accuracy=_num(component_accuracy) if component_accuracy is not None else None,
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
    estimated, true = _where_known(modes, truth, known, scored)
    counts = mode_metrics.confusion_matrix(estimated, true, len(ids))
    det = mode_metrics.detection_delays(signals.time, modes, truth, ids, dt, known=known)
    detected = sum(1 for e in det.events if e.detected)
    return SmoothingMetrics(
        mode_accuracy=_num(mode_metrics.mode_accuracy(estimated, true)) if scored else None,
        confusion={
            t_id: {e_id: int(counts[i, j]) for j, e_id in enumerate(ids)}
            for i, t_id in enumerate(ids)
        },
        detection_delay_s=_num(det.mean_s),
        detection_max_s=_num(det.max_s),
        detected=detected,
        missed=len(det.events) - detected,
        estimated_switches=switches,
        states=states,
        outputs=outputs,
        fit=fit,
        components=sides,
    )


class _OfflineSides:
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
        self._filtered_components = _ComponentModes(signals.n_samples, signals.truth_components)
        self._filtered_states = (
            None
            if signals.truth_states is None
            else metrics.StateAccumulator(len(first.state_names))
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
        components: _ComponentModes,
        dt: float,
    ) -> Smoothing:
        """Both sides' metrics.

        ``modes``, ``states`` and ``components`` (each component's modes) are the report's
        own (the offline ones).
        """
        ids = tuple(str(m) for m in first.mode_ids)
        filtered_states = _state_reports(first.state_names, self._filtered_states)
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


def _json_object(value: Mapping[str, Any]) -> JsonObject:
    converted: JsonObject = jsonable(value)
    return converted


_MOST_TWINS_NAMED = 10
"""Most modes of one group of twins a note names (the rest counted)."""


def _model_notes(model: HybridModel | None) -> tuple[str, ...]:
    """What report.md must say of the model: modes no log can tell apart, and its warnings.

    Twin modes (``twin_modes``) give the same log, so an estimate picks among them by their
    order or their Markov rows, never by the data, and the mode metrics score the log's
    samples of the one not picked as errors; said in every report of such a model, whatever
    the estimator.  The warnings of the model's diagnoses (``diagnoses``: states no output
    determines, a mode whose outputs read no state, a continuous mode too stiff for its
    step) follow: after them the state estimates are not what they seem.
    """
    if model is None:
        return ()
    notes = []
    for twins in model.twin_modes:
        quoted = [f"'{m}'" for m in twins]
        if len(twins) <= _MOST_TWINS_NAMED:
            names = ", ".join(quoted[:-1]) + f" and {quoted[-1]}"
        else:  # many twins (booleans no equation uses): the first and the last named
            shown = ", ".join(quoted[: _MOST_TWINS_NAMED - 1])
            names = f"{shown}, ... and {quoted[-1]} ({len(twins)} modes)"
        notes.append(
            f"NOTE: modes {names} have the same equations and noise (f, h, process and "
            "measurement noise; guards and jump maps alike): no log can tell them apart"
            + (
                ""
                if _interchangeable(model, twins)
                else " (their [transitions] rows or initial probabilities differ: only the "
                "estimators' priors on the switches set them apart)"
            )
            + ". Between them the estimate follows the modes' order and Markov rows, not the "
            f"data (where their probabilities or errors tie, '{twins[0]}', the first listed, "
            "is taken), so the mode accuracy, confusion and detection delays count "
            "the log's samples of the one not picked as errors; merge them, or give them "
            "different equations or noise if they are to be told apart"
        )
    for component, twins in model.component_twin_modes:
        quoted = [f"'{m}'" for m in twins]
        notes.append(
            f"NOTE: component '{component}': modes {', '.join(quoted[:-1])} and {quoted[-1]} "
            "have the same equations and noise (process and measurement): no log can tell "
            "them apart. Between them the estimate follows the modes' order, initial and "
            "transition probabilities, not the data, so the mode accuracy, confusion and "
            f"detection delays of component '{component}' count the log's samples of the one "
            "not picked as errors; merge them, or give them different equations or noise if they "
            "are to be told apart"
        )
    notes += [line for line in model.diagnoses if line.startswith(WARNING_PREFIX)]
    return tuple(notes)


def _interchangeable(model: HybridModel, twins: tuple[str, ...]) -> bool:
    """Whether swapping the first twin with any other leaves the priors as they are.

    The priors: ``[transitions]`` and ``[initial]``; when they are symmetric in the twins,
    nothing at all sets the twins apart.
    """
    first = model.mode_index(twins[0])
    markov, prior = model.transitions, model.initial_mode_probabilities
    for twin in twins[1:]:
        order = np.arange(model.n_modes)
        other = model.mode_index(twin)
        order[[first, other]] = order[[other, first]]
        if not np.array_equal(prior[order], prior):
            return False
        if markov is not None and not np.array_equal(markov[np.ix_(order, order)], markov):
            return False
    return True


def _no_delay(modes: ModeReport, of: str = "", *, partial: bool = False) -> str | None:
    """Why a report with a true mode (``of`` a component) has no detection delay, or None.

    ``partial``: some samples have no true mode (a late start, a gap), where a switch may
    have gone unseen.
    """
    if modes.detection is None or modes.detection_delay_s is not None:
        return None
    events = modes.detection.events
    if not events:
        if partial:
            return f"the true mode{of} never switches between two samples that have one"
        return f"the true mode{of} never switches"
    return f"every true switch{of} ({len(events)}) was missed"


def _each_why(per_output: Mapping[str, metrics.OutputMetrics], name: str) -> str:
    """Why ``name`` is undefined for each output, outputs with the same reason named together.

    ``y1, y2, y3: ‖y − mean(y)‖ = 0: ...`` where every output has one reason, else a part per
    reason (``y1: ...; y2, y3: ...``): naming the first output alone read as if the others
    had a value.
    """
    grouped: dict[str | None, list[str]] = {}
    for y, m in per_output.items():
        grouped.setdefault(m.undefined.get(name), []).append(y)
    return "; ".join(f"{', '.join(ys)}: {why}" for why, ys in grouped.items())


def _null_reasons(
    per_output: Mapping[str, metrics.OutputMetrics],
    means: Mapping[str, float | None],
    modes: ModeReport,
    states: Mapping[str, StateReport],
    signals: AlignedSignals,
    samples_per_s: float | None,
    state_reasons: Mapping[str, str | None],
    *,
    modes_given: str = "",
    held: Mapping[str, int] | None = None,
) -> dict[str, str]:
    """Why each gate metric that is ``None`` in the report is (keys as in the gates).

    ``state_reasons``: why a state's RMSE over some rows is not a number
    (:meth:`~hybridlog.report.metrics.StateAccumulator.undefined`); ``held``: per state, the
    samples with a true value where the estimator did not estimate it
    (:attr:`~hybridlog.estimators.result.EstimationResult.states_not_estimated`).
    """
    reasons: dict[str, str] = {}
    for name in ("mse", "vaf", "fit"):
        for y, m in per_output.items():
            if name in m.undefined:
                reasons[f"{name}.{y}"] = m.undefined[name]
        if means[name] is None and per_output:
            beyond = [y for y, m in per_output.items() if name in m.out_of_range]
            diverged = [y for y, m in per_output.items() if math.isinf(getattr(m, name))]
            if beyond:
                y = beyond[0]
                reasons[name] = (
                    f"a mean over the outputs cannot leave out {name}.{y}, which float64 "
                    f"cannot hold: {per_output[y].undefined.get(name)}"
                )
            elif diverged:
                y = diverged[0]
                why = per_output[y].undefined.get(name)
                reasons[name] = f"the mean over the outputs is infinite: {name}.{y}: {why}"
            else:
                reasons[name] = f"undefined for every output ({_each_why(per_output, name)})"
    if modes.components:
        if modes.accuracy is None:
            missing = modes.components_without_truth
            reasons["mode_accuracy"] = (
                "the log has the true mode of only some components: "
                f"{', '.join(modes.components)}"
                + (f" (not of {', '.join(missing)})" if missing else "")
                + "; see modes.components"
            )
        for name in ("detection_delay_s", "missed_switches"):
            reasons[name] = "a [components] model: switches are scored per component"
        for component, report in modes.components.items():
            if report.samples == 0:
                for name in ("mode_accuracy", "detection_delay_s", "missed_switches"):
                    reasons[f"{name}.{component}"] = (
                        f"the true mode of component {component} has no sample on the "
                        "analysed span (it starts after the last sample, or has none in it)"
                    )
                continue
            partial = report.samples is not None and report.samples < signals.n_samples
            why = _no_delay(report, f" of component {component}", partial=partial)
            if why is not None:
                reasons[f"detection_delay_s.{component}"] = why
    elif modes_given:
        for name in ("mode_accuracy", "detection_delay_s", "missed_switches"):
            reasons[name] = modes_given
    elif signals.truth_modes is None:
        for name in ("mode_accuracy", "detection_delay_s", "missed_switches"):
            reasons[name] = NO_TRUE_MODE_REASON
    elif modes.samples == 0:
        for name in ("mode_accuracy", "detection_delay_s", "missed_switches"):
            reasons[name] = (
                "the true mode has no sample on the analysed span (it starts after the last "
                "sample, or has none in it)"
            )
    elif (
        why := _no_delay(
            modes, partial=modes.samples is not None and modes.samples < signals.n_samples
        )
    ) is not None:
        reasons["detection_delay_s"] = why
    for j, (x, state) in enumerate(states.items()):
        if state.rmse is not None:
            continue
        truth = signals.truth_states
        if state.samples:  # rows whose RMSE float64 cannot hold, or an estimate went infinite
            why = f"the estimate of state {x} {state_reasons.get(x) or 'is not a finite number'}"
        elif truth is None or not np.isfinite(truth[:, j]).any():
            why = f"{NO_TRUE_STATE_REASON} {x}"
        elif held and held.get(x):
            why = (
                f"the estimator did not estimate state {x} on any sample with a true value "
                f"({held[x]:,} samples): it held a value there that it cannot vouch for "
                "(see the warning naming the states no filter estimated)"
            )
        else:
            why = f"no sample has both a true value and a finite estimate of state {x}"
        reasons[f"state_rmse.{x}"] = why
    if samples_per_s is None:
        reasons["samples_per_s"] = "the runtime was too short to measure"
    return reasons
