"""The report of one run: a typed, immutable :class:`Report` and its JSON form, ``report.json``.

:func:`hybridlog.report.build.build_report` computes a :class:`Report` from an estimation
result; :meth:`Report.to_json` writes ``report.json`` and :meth:`Report.from_json` (or
:func:`read_report`) reads one back, checking every key, so that a malformed or foreign file
is a :class:`~hybridlog.errors.ReportError` naming the file and the key, never a crash.

Keys of ``report.json``
-----------------------
``hybridlog_version, log, model, estimator, options, samples, dt, t_start, t_end,
outputs: {<y>: {mse, vaf, fit, samples}}, mse, vaf, fit,
modes: {labels, switches: [{t, from, to}], dwell_s: {<mode>: s}, accuracy, samples,
confusion: {<true mode>: {<estimated mode>: count}}, detection_delay_s, detection},
states: {<x>: {rmse, samples}}, runtime_s, compile_s, samples_per_s, notes, null_reasons``, then
``smoothing`` when the estimates are not the causal filter's own (``--smooth``,
``--mode-sequence viterbi``; absent otherwise), then ``reading`` (what reading the log did)
when known, then any further keys (:attr:`Report.extra`): those ``analyze``, ``compare``
and ``batch`` write are :data:`PARAMETERS_KEY` and :data:`ORIGINS_KEY`
(:mod:`hybridlog.jobs.origins`), and ``batch`` its provenance.  Every key is an attribute of
:class:`Report` holding its value, so a further key named like a method of it (``to_dict``)
or starting with ``__`` is refused (:func:`hidden_keys`).

``smoothing`` is ``{method, mode_sequence, description, fallbacks, filtered: {...},
smoothed: {...}}`` (:class:`Smoothing`): ``method`` names the fixed-interval smoother
(``null`` when only the mode sequence was changed), ``mode_sequence`` is ``argmax``,
``viterbi`` or ``kbest``; ``fallbacks`` (only when a smoother ran) is ``{samples, of,
by_cause: {prediction, guard, rounding, covariance}, weight}``: of the ``of`` samples the
backward pass smoothed (all but the last), the ``samples`` where at least one step that
carries weight was refused and the forward estimate stood in its place, ``weight`` the share
of the smoothed estimates those refused steps carry, averaged over the ``of`` samples
(:class:`~hybridlog.estimators.result.Fallbacks`), and per cause (the
prediction's covariance not positive definite, the guard, the rounding probe, the step's
covariance not PSD; docs/smoothing.md "The algorithms") the samples with such a step (with
``kbest``, those of the RTS smoother along the path, whose states the report holds); ``filtered``
and ``smoothed`` hold the same metrics (:class:`SmoothingMetrics`) of the causal filter's
estimates and of the report's own: ``mode_accuracy, confusion, detection_delay_s,
detection_max_s, detected, missed, estimated_switches, states: {<x>: {rmse, samples}},
outputs: {<y>: {mse, vaf, fit, samples}}, fit``, and for a ``[components]`` model with the
log's true mode of components ``components: {<c>: {mode_accuracy, detection_delay_s,
detection_max_s, detected, missed}}`` (:class:`ComponentSide`; absent otherwise).  Their
``outputs`` are not the one-step-ahead prediction of the top-level ``outputs`` (which stays
the filter's either way): they are
``ŷ(k) = h_q̂(k)(x̂(k), u(k))``, the outputs the estimated mode and state explain, ``null``
when the model was not at hand to evaluate ``h``.

Everything that needs ground truth is ``null`` when the log has none, and every number that
is not finite is ``null``, so the JSON is strict.  ``outputs.<y>.samples`` counts the rows the
output metrics use (a measurement and a one-step-ahead prediction), ``states.<x>.samples``
those the state RMSE uses (a true state and an estimate), ``modes.samples`` those the mode
metrics score (the samples a true mode covers: from its first sample on, when it starts
late; ``null`` without one); ``mse``, ``vaf`` and
``fit`` at the top are the means over the outputs where the metric is defined (``null``
when one output's is infinite or beyond float64's range: a prediction that diverged is
never left out).
``null_reasons`` maps gate metric names (``vaf``, ``fit.y1``, ``mode_accuracy``,
``state_rmse.x2``, ...; see :mod:`hybridlog.report.gates`) to why the report holds ``null``
for them.  ``modes.detection`` (``null`` without a true mode) holds the details behind
``detection_delay_s`` (their mean): ``{mean_s, max_s, detected, missed, events: [{t, from,
to, detected, detected_t, delay_s, miss_reason}]}``, see
:func:`hybridlog.report.mode_metrics.detection_delays`.

Reports written by earlier versions lack ``fit``, ``compile_s``, ``notes``,
``null_reasons``, ``outputs.<y>.samples``, ``states.<x>.samples``, ``modes.samples``,
``miss_reason`` or ``smoothing.fallbacks``; they
are read with ``None`` (or empty) in their place.
"""

from __future__ import annotations

import copy
import dataclasses
import json
import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import TYPE_CHECKING, Final, TypeAlias, TypeVar, cast

from hybridlog.errors import ReportError, excerpt
from hybridlog.estimators.filter_options import MODE_SEQUENCES
from hybridlog.estimators.result import FALLBACK_CAUSES, Fallbacks
from hybridlog.report.mode_metrics import SwitchDetection

__all__ = [
    "MODE_SEQUENCES",
    "ComponentSide",
    "Detection",
    "JsonValue",
    "ModeReport",
    "ModeSwitch",
    "OutputReport",
    "Report",
    "Smoothing",
    "SmoothingMetrics",
    "StateReport",
    "SwitchDetection",
    "read_report",
]

JsonValue: TypeAlias = bool | int | float | str | list["JsonValue"] | dict[str, "JsonValue"] | None
"""A value of plain JSON (strict: floats are finite)."""

JsonObject: TypeAlias = dict[str, JsonValue]


@dataclass(frozen=True)
class OutputReport:
    """Metrics of one output (paper 001, section 5; MATLAB ``compare``'s fit).

    Attributes
    ----------
    mse, vaf, fit:
        See :func:`hybridlog.report.metrics.output_metrics`; ``None`` where undefined or
        beyond float64's range (the report's :attr:`~Report.null_reasons` says why).
    samples:
        Rows the metrics use (a finite measurement and prediction); ``None`` in reports of
        versions that did not record it.

    """

    mse: float | None
    vaf: float | None
    fit: float | None
    samples: int | None

    def to_dict(self) -> JsonObject:
        """The JSON object ``{mse, vaf, fit, samples}``."""
        return {"mse": self.mse, "vaf": self.vaf, "fit": self.fit, "samples": self.samples}


@dataclass(frozen=True)
class StateReport:
    """Error of one state estimate against the true state.

    Attributes
    ----------
    rmse:
        Root mean square error over ``samples`` rows; ``None`` where undefined (no truth, a
        diverged estimate, or an RMSE float64 cannot hold: the report's
        :attr:`~Report.null_reasons` says why).
    samples:
        Rows the RMSE is over: where the true state is finite and its estimate is not NaN
        (a log's true state may cover only part of the run); ``None`` in reports of versions
        that did not record it.

    """

    rmse: float | None
    samples: int | None = None

    def to_dict(self) -> JsonObject:
        """The JSON object ``{rmse, samples}``."""
        return {"rmse": self.rmse, "samples": self.samples}


@dataclass(frozen=True)
class ModeSwitch:
    """One change of the estimated mode: at time ``t``, the first sample in ``to_mode``."""

    t: float
    from_mode: str
    to_mode: str

    def to_dict(self) -> JsonObject:
        """The JSON object ``{t, from, to}``."""
        return {"t": self.t, "from": self.from_mode, "to": self.to_mode}


def _event_dict(event: SwitchDetection) -> JsonObject:
    return {
        "t": event.t,
        "from": event.from_mode,
        "to": event.to_mode,
        "detected": event.detected,
        "detected_t": event.detected_t,
        "delay_s": event.delay_s,
        "miss_reason": event.miss_reason,
    }


@dataclass(frozen=True)
class Detection:
    """How every true mode switch was detected.

    By :func:`~hybridlog.report.mode_metrics.detection_delays`.

    Attributes
    ----------
    mean_s, max_s:
        Mean and largest delay over the detected switches; ``None`` when none was detected.
    events:
        One entry per true switch, in time order.

    """

    mean_s: float | None
    max_s: float | None
    events: tuple[SwitchDetection, ...]

    @property
    def detected(self) -> int:
        """Number of true switches detected."""
        return sum(1 for e in self.events if e.detected)

    @property
    def missed(self) -> int:
        """Number of true switches missed."""
        return len(self.events) - self.detected

    def to_dict(self) -> JsonObject:
        """The JSON object ``{mean_s, max_s, detected, missed, events}``."""
        return {
            "mean_s": self.mean_s,
            "max_s": self.max_s,
            "detected": self.detected,
            "missed": self.missed,
            "events": [_event_dict(e) for e in self.events],
        }


@dataclass(frozen=True)
class ModeReport:
    """The estimated mode sequence and, with a true mode, how well it matches.

    Attributes
    ----------
    labels:
        The model's mode ids.
    switches:
        Every change of the estimated mode.
    dwell_s:
        Seconds spent in each mode (``{label: s}``).
    accuracy:
        Fraction of the scored samples (``samples``) whose estimated mode is the true one;
        ``None`` without truth.
    samples:
        How many samples the true mode covers and the accuracy, confusion and detection
        score: all of them, or those from the first of a true mode that starts late (as
        ``states.<x>.samples``) and outside a sampled one's gaps, the samples without one
        within ``dt/2`` (``reading.truth_gaps``); for a ``[components]`` model
        those where every component has one; ``None`` without truth (or in a report of an
        older version).
    confusion:
        ``{true mode: {estimated mode: sample count}}``; ``None`` without truth.
    detection:
        Detection of every true switch; ``None`` without truth.
    components:
        For a ``[components]`` model and a log with the true mode of components: each such
        component's own report (``labels`` the union of its modes and the estimated ones).
        ``accuracy`` is then the fraction of samples where every component is right (``None``
        unless the log has every component's), and ``confusion``/``detection`` are per
        component only.
    components_without_truth:
        For a ``[components]`` model: the components whose true mode the log does not have
        (not in ``components``, not scored), so a reader is told rather than left to notice
        one missing.

    """

    labels: tuple[str, ...]
    switches: tuple[ModeSwitch, ...]
    dwell_s: Mapping[str, float | None]
    accuracy: float | None = None
    confusion: Mapping[str, Mapping[str, int]] | None = None
    detection: Detection | None = None
    components: Mapping[str, ModeReport] = field(default_factory=dict)
    samples: int | None = None
    components_without_truth: tuple[str, ...] = ()

    @property
    def detection_delay_s(self) -> float | None:
        """Mean detection delay in seconds; ``None`` without truth or detected switch."""
        return None if self.detection is None else self.detection.mean_s

    def to_dict(self) -> JsonObject:
        """The JSON object ``modes`` of ``report.json``."""
        return {
            "labels": list(self.labels),
            "switches": [s.to_dict() for s in self.switches],
            "dwell_s": dict(self.dwell_s),
            "accuracy": self.accuracy,
            "samples": self.samples,
            "confusion": _confusion_dict(self.confusion),
            "detection_delay_s": self.detection_delay_s,
            "detection": None if self.detection is None else self.detection.to_dict(),
            **(
                {"components": {c: m.to_dict() for c, m in self.components.items()}}
                if self.components
                else {}
            ),
            **(
                {"components_without_truth": list(self.components_without_truth)}
                if self.components_without_truth
                else {}
            ),
        }


def _confusion_dict(confusion: Mapping[str, Mapping[str, int]] | None) -> JsonValue:
    return None if confusion is None else {t: dict(row) for t, row in confusion.items()}


@dataclass(frozen=True)
class ComponentSide:
    """One component's mode metrics on one side (filtered or offline) of a smoothed run.

    As the component's :class:`ModeReport` (``modes.components``): the fraction of samples
    with its mode right, and its true switches detected and missed, the mean and largest
    delay of those detected (``None`` when none was).
    """

    mode_accuracy: float | None
    detection_delay_s: float | None
    detection_max_s: float | None
    detected: int
    missed: int

    @classmethod
    def of(cls, modes: ModeReport) -> ComponentSide:
        """The side's metrics from the component's :class:`ModeReport`."""
        detection = modes.detection
        return cls(
            mode_accuracy=modes.accuracy,
            detection_delay_s=modes.detection_delay_s,
            detection_max_s=None if detection is None else detection.max_s,
            detected=0 if detection is None else detection.detected,
            missed=0 if detection is None else detection.missed,
        )

    def to_dict(self) -> JsonObject:
        """The JSON object ``smoothing.<side>.components.<c>``."""
        return {
            "mode_accuracy": self.mode_accuracy,
            "detection_delay_s": self.detection_delay_s,
            "detection_max_s": self.detection_max_s,
            "detected": self.detected,
            "missed": self.missed,
        }


@dataclass(frozen=True)
class SmoothingMetrics:
    """Metrics of one side of a smoothed run: the causal filter's estimates or the smoothed.

    Attributes
    ----------
    mode_accuracy:
        Fraction of samples whose mode is the true one; ``None`` without a true mode.  For a
        ``[components]`` model, the fraction with every component's mode right (the log's
        truth is per component; ``confusion`` and the switches are then ``None``).
    confusion:
        ``{true mode: {estimated mode: sample count}}``; ``None`` without a true mode.
    detection_delay_s, detection_max_s:
        Mean and largest delay of the detected true switches; ``None`` without a true mode
        or a detected switch.
    detected, missed:
        True switches detected and missed; ``None`` without a true mode.
    estimated_switches:
        Changes of the estimated mode (blips count twice).
    states:
        RMSE per state against the true state.
    outputs:
        Per output, MSE/VAF/fit of ``ŷ(k) = h_q̂(k)(x̂(k), u(k))`` (the outputs the estimated
        mode and state explain, not a prediction); ``None`` when ``h`` was not evaluated.
    fit:
        Mean of ``outputs``' fit over the outputs where it is defined.
    components:
        For a ``[components]`` model, each component with a true mode in the log: its own
        accuracy and detections on this side (empty otherwise).

    """

    mode_accuracy: float | None
    confusion: Mapping[str, Mapping[str, int]] | None
    detection_delay_s: float | None
    detection_max_s: float | None
    detected: int | None
    missed: int | None
    estimated_switches: int
    states: Mapping[str, StateReport]
    outputs: Mapping[str, OutputReport] | None
    fit: float | None
    components: Mapping[str, ComponentSide] = field(default_factory=dict)

    def to_dict(self) -> JsonObject:
        """The JSON object ``smoothing.filtered`` or ``smoothing.smoothed``."""
        data: JsonObject = {
            "mode_accuracy": self.mode_accuracy,
            "confusion": _confusion_dict(self.confusion),
            "detection_delay_s": self.detection_delay_s,
            "detection_max_s": self.detection_max_s,
            "detected": self.detected,
            "missed": self.missed,
            "estimated_switches": self.estimated_switches,
            "states": {x: s.to_dict() for x, s in self.states.items()},
            "outputs": None
            if self.outputs is None
            else {y: o.to_dict() for y, o in self.outputs.items()},
            "fit": self.fit,
        }
        if self.components:
            data["components"] = {c: side.to_dict() for c, side in self.components.items()}
        return data


@dataclass(frozen=True)
class Smoothing:
    """What an offline pass after the filter did, and the metrics before and after it.

    Attributes
    ----------
    method:
        The fixed-interval smoother (e.g. ``kim-rts``), or ``None`` when only the mode
        sequence was chosen differently.
    mode_sequence:
        ``argmax`` (of the mode probabilities), ``viterbi`` (the most likely sequence) or
        ``kbest`` (the best of the k best mode histories, each with its own filters).
    description:
        One line: the algorithm, its paper and equations.
    filtered:
        Metrics of the causal filter's own estimates.
    smoothed:
        Metrics of the report's estimates (those of the tables and the top-level ``modes``
        and ``states``).
    fallbacks:
        Where the smoother left the forward estimate standing
        (:class:`~hybridlog.estimators.result.Fallbacks`); ``None`` without a smoother, or
        in a report of an earlier version.

    """

    method: str | None
    mode_sequence: str
    description: str
    filtered: SmoothingMetrics
    smoothed: SmoothingMetrics
    fallbacks: Fallbacks | None = None

    @property
    def keeps_filter_states(self) -> bool:
        """Whether the report's states are the causal filter's own.

        Only without a smoother and with the Viterbi path, which changes the modes alone:
        ``kbest`` brings the states of its own filters along the path it chose (the path's
        EKF for ``imm``, the trajectory's cluster filters for ``unknown-mode``), with or
        without a smoother.
        """
        return self.method is None and self.mode_sequence == "viterbi"

    def samples_apart(self, state: str) -> tuple[int, int] | None:
        """``(filter's samples, offline samples)`` of ``state``'s RMSEs, where they differ.

        Each side's RMSE is over the samples where that side estimated the state: a
        ``kbest`` path of ``unknown-mode`` estimates none while a component on it is
        ``unknown``, where the causal estimate may have one.  Two RMSEs over other samples are
        no gain or loss of either side (13 samples against 101 read as a gain of 10 %).
        ``None`` where both cover the same samples, or a side's are not known.
        """
        own, offline = self.filtered.states.get(state), self.smoothed.states.get(state)
        if own is None or offline is None or own.samples is None or offline.samples is None:
            return None
        return None if own.samples == offline.samples else (own.samples, offline.samples)

    def to_dict(self) -> JsonObject:
        """The JSON object ``smoothing`` of ``report.json``."""
        data: JsonObject = {
            "method": self.method,
            "mode_sequence": self.mode_sequence,
            "description": self.description,
        }
        if self.fallbacks is not None:
            data["fallbacks"] = {
                "samples": self.fallbacks.samples,
                "of": self.fallbacks.of,
                "by_cause": dict(self.fallbacks.by_cause),
                "weight": self.fallbacks.weight,
            }
        data["filtered"] = self.filtered.to_dict()
        data["smoothed"] = self.smoothed.to_dict()
        return data


_COMPACT = json.JSONEncoder(allow_nan=False, separators=(", ", ": ")).encode
"""One value as JSON on one line (the C encoder), non-finite numbers refused."""


def indented_json(value: object, level: int = 0) -> str:
    """``value`` as JSON, objects and lists opened over lines indented by two spaces a level.

    As ``json.dumps(value, indent=2)`` for objects (a key per line, nested objects indented)
    and lists (an item per line), but each item of a list is written on one line by the C
    encoder: the report of a 10^6-sample run, with its 10,000 detection events, in 0.038 s
    against 0.08 s, one event a line.  Non-finite numbers raise ``ValueError``, as with
    ``allow_nan=False``.
    """
    inner, outer = "  " * (level + 1), "  " * level
    if isinstance(value, dict) and value:
        members = (
            f"{inner}{_COMPACT(key if isinstance(key, str) else _COMPACT(key))}: "
            f"{indented_json(item, level + 1)}"
            for key, item in value.items()
        )
        return "{\n" + ",\n".join(members) + f"\n{outer}}}"
    if isinstance(value, list | tuple) and value:
        return "[\n" + ",\n".join(f"{inner}{_COMPACT(item)}" for item in value) + f"\n{outer}]"
    return _COMPACT(value)


@dataclass(frozen=True)
class Report:
    """Everything ``report.json`` records about one run of one estimator over one log.

    Built by :func:`hybridlog.report.build.build_report`; the mappings are fresh copies
    owned by the report and typed read-only.  :meth:`to_dict` gives the keys and values of
    ``report.json`` in its order (module docstring), :meth:`from_json` reads them back.

    Attributes
    ----------
    hybridlog_version, log, model, estimator:
        What ran on what.
    options:
        The estimator's options as JSON.
    samples, dt, t_start, t_end:
        The grid: number of samples, sample time and first and last time (seconds).
    outputs:
        Metrics per output.
    mse, vaf, fit:
        Means of the per-output metrics over the outputs where they are defined.
    modes:
        The mode sequence and its accuracy.
    states:
        Error per state.
    runtime_s, compile_s, samples_per_s:
        Speed of the estimation and time spent compiling.
    notes:
        The estimator's remarks.
    null_reasons:
        ``{gate metric name: why it is None}``.
    smoothing:
        What ran after the filter and the metrics before and after it; ``None`` when the
        estimates are the causal filter's own (the key is then absent from ``report.json``).
    reading:
        What reading the log did (format, time source, dropped samples, ...), when known.
    extra:
        Further top-level keys, written after all others (names of no other attribute);
        each is an attribute too (``report.consistency``, ``report.parameters``), as README
        promises of every key of ``report.json``.  So none may be named like one of the
        class's own names (``to_dict``, ``with_extra``, ``extra``, ...: ``report.to_dict``
        would be the method) or start with ``__``: :func:`hidden_keys`; building such a
        report is a ``ValueError``, reading one a :class:`~hybridlog.errors.ReportError`.

    """

    hybridlog_version: str
    log: str
    model: str
    estimator: str
    options: Mapping[str, JsonValue]
    samples: int
    dt: float
    t_start: float | None
    t_end: float | None
    outputs: Mapping[str, OutputReport]
    mse: float | None
    vaf: float | None
    fit: float | None
    modes: ModeReport
    states: Mapping[str, StateReport]
    runtime_s: float | None
    compile_s: float | None
    samples_per_s: float | None
    notes: tuple[str, ...] = ()
    null_reasons: Mapping[str, str] = field(default_factory=dict)
    smoothing: Smoothing | None = None
    reading: Mapping[str, JsonValue] | None = None
    extra: Mapping[str, JsonValue] = field(default_factory=dict)

    if not TYPE_CHECKING:  # mypy still refuses a misspelt attribute (``report.vaff``)

        def __getattr__(self, name: str) -> JsonValue:
            """A key of ``extra`` as an attribute: ``report.consistency`` was an AttributeError.

            Called only for a name no attribute has; ``extra`` itself is looked up in the
            instance's ``__dict__`` (absent while :mod:`pickle` or :mod:`copy` rebuild one).
            """
            extra = self.__dict__.get("extra", {})
            if not name.startswith("__") and name in extra:
                return extra[name]
            raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    def __dir__(self) -> list[str]:
        """The attributes with the keys of ``extra`` (a notebook's completion offers them)."""
        return sorted({*super().__dir__(), *self.extra})

    def __post_init__(self) -> None:
        clash = sorted(set(self.extra) & _KEYS)
        if clash:
            raise ValueError(f"extra keys {clash} are report attributes; set those instead")
        hidden = hidden_keys(self.extra)
        if hidden:
            raise ValueError(f"extra key {hidden[0]!r} {HIDDEN_KEY}; choose another name")

    def to_dict(self) -> JsonObject:
        """The report as plain JSON values: the keys and values of ``report.json``, in order.

        Returns
        -------
        dict
            A new dict (changing it does not change the report).

        """
        data: JsonObject = {
            "hybridlog_version": self.hybridlog_version,
            "log": self.log,
            "model": self.model,
            "estimator": self.estimator,
            "options": copy.deepcopy(dict(self.options)),
            "samples": self.samples,
            "dt": self.dt,
            "t_start": self.t_start,
            "t_end": self.t_end,
            "outputs": {y: m.to_dict() for y, m in self.outputs.items()},
            "mse": self.mse,
            "vaf": self.vaf,
            "fit": self.fit,
            "modes": self.modes.to_dict(),
            "states": {x: s.to_dict() for x, s in self.states.items()},
            "runtime_s": self.runtime_s,
            "compile_s": self.compile_s,
            "samples_per_s": self.samples_per_s,
            "notes": list(self.notes),
            "null_reasons": dict(self.null_reasons),
        }
        if self.smoothing is not None:
            data["smoothing"] = self.smoothing.to_dict()
        if self.reading is not None:
            data["reading"] = copy.deepcopy(dict(self.reading))
        data.update(copy.deepcopy(dict(self.extra)))
        return data

    def to_json(self) -> str:
        """``report.json``: the report as strict, indented JSON text ending in a newline.

        Objects have a key per line and lists an item per line (:func:`indented_json`), so
        a switch or a detection event is one line.

        Raises
        ------
        ValueError
            When a number is not finite (the report was built with one where only ``None``
            may stand: a programming error).

        """
        return indented_json(self.to_dict()) + "\n"

    @classmethod
    def from_dict(cls, data: object, *, source: str = "report.json") -> Report:
        """Read a report from parsed JSON, checking every key.

        Parameters
        ----------
        data:
            What :func:`json.loads` returned for a ``report.json``.
        source:
            Where it came from, for error messages.

        Returns
        -------
        Report
            The report; keys it does not know are kept in :attr:`extra`.

        Raises
        ------
        ReportError
            When ``data`` is not a hybridlog report (no ``hybridlog_version``) or a key is
            missing or holds a value of the wrong kind; the message names ``source`` and
            the key.

        """
        return _Reader(source).report(data)

    @classmethod
    def from_json(cls, text: str | bytes, *, source: str = "report.json") -> Report:
        """Read a report from the text of a ``report.json`` (see :meth:`from_dict`).

        Raises
        ------
        ReportError
            When the text is not strict JSON or not a hybridlog report.

        """
        try:
            data = json.loads(text, parse_constant=_refuse_constant)
        except json.JSONDecodeError as err:
            raise ReportError(
                f"{source}: not JSON ({err.msg} at line {err.lineno}, column {err.colno})"
            ) from None
        except (ValueError, RecursionError) as err:  # NaN/Infinity; nesting beyond the stack
            reason = "nested too deeply" if isinstance(err, RecursionError) else str(err)
            raise ReportError(f"{source}: not strict JSON ({reason})") from None
        return cls.from_dict(data, source=source)

    def with_extra(self, extra: Mapping[str, object], *, source: str = "report.json") -> Report:
        """The report with the further top-level keys ``extra`` (parsed JSON values).

        As :meth:`from_dict` of ``{**self.to_dict(), **extra}``: a key naming a report
        attribute replaces its value, read and checked as from a ``report.json``; the others
        join :attr:`extra` after its keys, checked as :meth:`from_dict` checks them.  Without
        an attribute's key the report's own parts are not read back: at 10^6 samples, with
        10,000 detection events, that took 0.05-0.07 s of every ``analyze``.

        Raises
        ------
        ReportError
            As :meth:`from_dict`, naming ``source`` and the key.

        """
        if not _KEYS.isdisjoint(extra):
            return Report.from_dict({**self.to_dict(), **extra}, source=source)
        reader = _Reader(source)
        hidden = hidden_keys(extra)
        if hidden:
            raise reader.error(hidden[0], f"{HIDDEN_KEY}; choose another name")
        merged = {**self.extra, **extra}
        return dataclasses.replace(
            self, extra={k: reader.json_value(v, k) for k, v in merged.items()}
        )


def read_report(path: str | Path) -> Report:
    """Read a ``report.json`` file (:meth:`Report.from_json`).

    Raises
    ------
    ReportError
        When the file cannot be read, is not UTF-8 or is not a hybridlog report.

    """
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        reason = err.strerror if isinstance(err, OSError) else "not UTF-8 text"
        raise ReportError(f"{path}: cannot read the report: {reason}") from None
    return Report.from_json(text, source=str(path))


def _refuse_constant(name: str) -> object:
    raise ValueError(f"{name} is not a JSON number")


_KEYS: Final = frozenset(f.name for f in fields(Report)) - {"extra"}
"""Top-level keys of ``report.json`` that are attributes of :class:`Report`."""

_OWN_NAMES: Final = frozenset(dir(Report)) | {"extra"}
"""Names attribute access finds on :class:`Report` itself (its methods, ``extra``, ...)."""


def hidden_keys(keys: Iterable[str]) -> list[str]:
    """The further keys (:attr:`Report.extra`) that ``report.<key>`` would not reach, sorted.

    A key named like one of :class:`Report`'s own names (``to_dict``, ``with_extra``,
    ``extra``, ...) gives the method, and one starting with ``__`` is never read from
    ``extra`` (:mod:`copy` and :mod:`pickle` ask for such names): both are refused, so every
    key of ``report.json`` is an attribute holding its value.
    """
    return sorted(k for k in keys if k.startswith("__") or (k in _OWN_NAMES and k not in _KEYS))


HIDDEN_KEY: Final = (
    "would be hidden: report.<key> reads Report's own name of it (a method, or a name "
    "starting with __), not the key"
)
"""Why :func:`hidden_keys` refuses a key (the messages name the key before it)."""


PARAMETERS_KEY: Final = "parameters"
"""The further key (:attr:`Report.extra`) of the model's parameter values as the run used
them (written by :func:`hybridlog.jobs.origins.run_values`)."""

ORIGINS_KEY: Final = "origins"
"""The further key of where each parameter value (``parameters.<name>``) and estimator option
(``options.<name>``) came from: ``--set NAME=VALUE`` as typed, the model file's key, the key
of a file an option names (a centres file's ``chiu.parameters.radius``), or
:data:`DEFAULT_ORIGIN`."""

DEFAULT_ORIGIN: Final = "default"
"""The origin of an option the estimator's own default gave."""


def command_line_values(report: Report) -> list[str]:
    """The values of ``report`` given on the command line: ``["--set A=150", ...]``.

    From its :data:`ORIGINS_KEY`, as read back from any ``report.json``: a report without
    one, or whose value is not an object of strings, gives none.
    """
    origins = report.extra.get(ORIGINS_KEY)
    if not isinstance(origins, Mapping):
        return []
    return [v for v in origins.values() if isinstance(v, str) and v.startswith("--")]


MAX_DEPTH: Final = 64
"""Deepest nesting of lists and objects read back in ``options``, ``reading`` and further keys
(hybridlog writes a few levels; copying or writing far deeper ones would exhaust Python's
stack)."""


_MISSING: Final = object()
T = TypeVar("T")


def _kind(value: object) -> str:
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true/false"
    if isinstance(value, int | float):
        return "a number"
    if isinstance(value, str):
        return "a string"
    if isinstance(value, list):
        return "a list"
    return "an object"


@dataclass(frozen=True)
class _Reader:
    """Reads parsed ``report.json`` values into typed parts; errors name the file and key."""

    source: str

    def error(self, path: str, problem: str) -> ReportError:
        return ReportError(f"{self.source}: {excerpt(path)} {problem}")

    def wrong(self, path: str, value: object, expected: str) -> ReportError:
        return self.error(path, f"is {_kind(value)}; expected {expected}")

    def at(
        self,
        data: Mapping[str, object],
        path: str,
        key: str,
        read: Callable[[object, str], T],
        default: object = _MISSING,
    ) -> T:
        """``data[key]`` read by ``read``; ``default`` when missing (required without one)."""
        where = f"{path}.{key}" if path else key
        if key in data:
            return read(data[key], where)
        if default is _MISSING:
            raise self.error(where, "is missing")
        return read(default, where)

    def mapping(self, value: object, path: str) -> Mapping[str, object]:
        if not isinstance(value, dict):
            raise self.wrong(path, value, "an object")
        return value

    def items(self, value: object, path: str, read: Callable[[object, str], T]) -> dict[str, T]:
        return {k: read(v, f"{path}.{k}") for k, v in self.mapping(value, path).items()}

    def sequence(self, value: object, path: str, read: Callable[[object, str], T]) -> tuple[T, ...]:
        if not isinstance(value, list):
            raise self.wrong(path, value, "a list")
        return tuple(read(v, f"{path}[{i}]") for i, v in enumerate(value))

    def list_of(self, read: Callable[[object, str], T]) -> Callable[[object, str], tuple[T, ...]]:
        return lambda value, path: self.sequence(value, path, read)

    def map_of(self, read: Callable[[object, str], T]) -> Callable[[object, str], dict[str, T]]:
        return lambda value, path: self.items(value, path, read)

    def or_null(self, read: Callable[[object, str], T]) -> Callable[[object, str], T | None]:
        return lambda value, path: None if value is None else read(value, path)

    def string(self, value: object, path: str) -> str:
        if not isinstance(value, str):
            raise self.wrong(path, value, "a string")
        return value

    def boolean(self, value: object, path: str) -> bool:
        if not isinstance(value, bool):
            raise self.wrong(path, value, "true or false")
        return value

    def count(self, value: object, path: str) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.wrong(path, value, "a whole number")
        if value < 0:
            raise self.error(path, f"is {value}; expected a count (>= 0)")
        return value

    def number(self, value: object, path: str) -> float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.wrong(path, value, "a number")
        try:
            number = float(value)
        except OverflowError:  # an integer beyond float's range
            number = math.inf
        if not math.isfinite(number):  # or a float literal beyond it (1e400)
            raise self.error(path, "is not a finite number")
        return number

    def optional_number(self, value: object, path: str) -> float | None:
        if value is None:
            return None
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.wrong(path, value, "a number or null")
        return self.number(value, path)

    def json_object(self, value: object, path: str) -> JsonObject:
        return cast(JsonObject, self.json_value(self.mapping(value, path), path))

    def json_value(self, value: object, path: str) -> JsonValue:
        """A copy of a free-form JSON value: finite numbers, at most :data:`MAX_DEPTH` deep."""
        stack = [(value, 0)]
        while stack:
            item, depth = stack.pop()
            if isinstance(item, dict | list):
                if depth >= MAX_DEPTH:
                    raise self.error(path, f"is nested deeper than {MAX_DEPTH} levels")
                if isinstance(item, dict) and not all(isinstance(k, str) for k in item):
                    raise self.error(path, "holds an object key that is not a string")
                children = item.values() if isinstance(item, dict) else item
                stack += [(child, depth + 1) for child in children]
            elif isinstance(item, float) and not math.isfinite(item):
                raise self.error(path, "holds a number that is not finite")
            elif not (item is None or isinstance(item, bool | int | float | str)):
                raise self.error(path, f"holds a {type(item).__name__}, which JSON does not have")
        return cast(JsonValue, copy.deepcopy(value))

    # --- the parts ------------------------------------------------------------------------

    def output(self, value: object, path: str) -> OutputReport:
        data = self.mapping(value, path)
        return OutputReport(
            mse=self.at(data, path, "mse", self.optional_number),
            vaf=self.at(data, path, "vaf", self.optional_number),
            fit=self.at(data, path, "fit", self.optional_number, None),
            samples=self.at(data, path, "samples", self.or_null(self.count), None),
        )

    def state(self, value: object, path: str) -> StateReport:
        data = self.mapping(value, path)
        return StateReport(
            rmse=self.at(data, path, "rmse", self.optional_number),
            samples=self.at(data, path, "samples", self.or_null(self.count), None),
        )

    def switch(self, value: object, path: str) -> ModeSwitch:
        data = self.mapping(value, path)
        return ModeSwitch(
            t=self.at(data, path, "t", self.number),
            from_mode=self.at(data, path, "from", self.string),
            to_mode=self.at(data, path, "to", self.string),
        )

    def event(self, value: object, path: str) -> SwitchDetection:
        data = self.mapping(value, path)
        detected_t = self.at(data, path, "detected_t", self.optional_number)
        delay_s = self.at(data, path, "delay_s", self.optional_number, None)
        if detected_t is None and delay_s is not None:
            raise self.error(f"{path}.delay_s", f"is {delay_s} but detected_t is None")
        event = SwitchDetection(
            t=self.at(data, path, "t", self.number),
            from_mode=self.at(data, path, "from", self.string),
            to_mode=self.at(data, path, "to", self.string),
            detected_t=detected_t,
            miss_reason=self.at(data, path, "miss_reason", self.or_null(self.string), None),
            delay_s=delay_s,
        )
        detected = self.at(data, path, "detected", self.boolean)
        if detected != event.detected:
            raise self.error(
                f"{path}.detected",
                f"is {str(detected).lower()} but detected_t is {event.detected_t}",
            )
        return event

    def detection(self, value: object, path: str) -> Detection:
        data = self.mapping(value, path)
        detection = Detection(
            mean_s=self.at(data, path, "mean_s", self.optional_number),
            max_s=self.at(data, path, "max_s", self.optional_number),
            events=self.at(data, path, "events", self.list_of(self.event)),
        )
        for key in ("detected", "missed"):
            stated = self.at(data, path, key, self.count)
            if stated != getattr(detection, key):
                raise self.error(
                    f"{path}.{key}", f"is {stated} but the events say {getattr(detection, key)}"
                )
        return detection

    def confusion(
        self, data: Mapping[str, object], path: str, labels: tuple[str, ...]
    ) -> dict[str, dict[str, int]] | None:
        """``data["confusion"]``: null, or counts keyed by the mode labels in both levels."""
        counts = self.or_null(self.map_of(self.map_of(self.count)))
        confusion = self.at(data, path, "confusion", counts)
        if confusion is not None:
            self.same_labels(confusion, labels, f"{path}.confusion")
            for t, row in confusion.items():
                self.same_labels(row, labels, f"{path}.confusion.{t}")
        return confusion

    def fraction(self, value: object, path: str) -> float | None:
        """A number from 0 to 1 (an accuracy), or null."""
        number = self.optional_number(value, path)
        if number is not None and not 0.0 <= number <= 1.0:
            raise self.error(path, f"is {number}; expected a fraction from 0 to 1, or null")
        return number

    def component_modes(self, value: object, path: str) -> ModeReport:
        """One component's report: a :class:`ModeReport` of its own, without components."""
        modes = self.modes(value, path)
        if modes.components:
            raise self.error(f"{path}.components", "is set; a component has no components")
        if modes.components_without_truth:
            raise self.error(
                f"{path}.components_without_truth", "is set; a component has no components"
            )
        return modes

    def modes(self, value: object, path: str) -> ModeReport:
        data = self.mapping(value, path)
        labels = self.at(data, path, "labels", self.list_of(self.string))
        dwell = self.at(data, path, "dwell_s", self.map_of(self.optional_number))
        self.same_labels(dwell, labels, f"{path}.dwell_s")
        confusion = self.confusion(data, path, labels)
        modes = ModeReport(
            labels=labels,
            switches=self.at(data, path, "switches", self.list_of(self.switch)),
            dwell_s=dwell,
            accuracy=self.at(data, path, "accuracy", self.fraction),
            confusion=confusion,
            detection=self.at(data, path, "detection", self.or_null(self.detection), None),
            components=self.at(data, path, "components", self.map_of(self.component_modes), {}),
            samples=self.at(data, path, "samples", self.or_null(self.count), None),
            components_without_truth=self.at(
                data, path, "components_without_truth", self.list_of(self.string), []
            ),
        )
        scored = sorted(set(modes.components) & set(modes.components_without_truth))
        if scored:
            raise self.error(
                f"{path}.components_without_truth",
                f"names {', '.join(scored)}, which modes.components scores",
            )
        # every component right is at most as frequent as any one component right (over
        # the same samples: a component's true mode that starts late scores fewer)
        for name, component in modes.components.items():
            if (
                modes.accuracy is not None
                and component.accuracy is not None
                and component.samples == modes.samples
                and modes.accuracy > component.accuracy + 1e-9
            ):
                raise self.error(
                    f"{path}.accuracy",
                    f"is {modes.accuracy} but components.{name}.accuracy is only "
                    f"{component.accuracy}; every component right cannot be more frequent "
                    "than one component right",
                )
        delay = self.at(data, path, "detection_delay_s", self.optional_number)
        if delay != modes.detection_delay_s:
            raise self.error(
                f"{path}.detection_delay_s",
                f"is {delay} but detection.mean_s is {modes.detection_delay_s}",
            )
        return modes

    def smoothing_metrics(
        self, value: object, path: str, labels: tuple[str, ...], states: tuple[str, ...]
    ) -> SmoothingMetrics:
        data = self.mapping(value, path)
        outputs = self.at(data, path, "outputs", self.or_null(self.map_of(self.output)))
        metrics = SmoothingMetrics(
            mode_accuracy=self.at(data, path, "mode_accuracy", self.optional_number),
            confusion=self.confusion(data, path, labels),
            detection_delay_s=self.at(data, path, "detection_delay_s", self.optional_number),
            detection_max_s=self.at(data, path, "detection_max_s", self.optional_number),
            detected=self.at(data, path, "detected", self.or_null(self.count)),
            missed=self.at(data, path, "missed", self.or_null(self.count)),
            estimated_switches=self.at(data, path, "estimated_switches", self.count),
            states=self.at(data, path, "states", self.map_of(self.state)),
            outputs=outputs,
            fit=self.at(data, path, "fit", self.optional_number),
            components=self.at(data, path, "components", self.map_of(self.component_side), {}),
        )
        if set(metrics.states) != set(states):
            raise self.error(
                f"{path}.states",
                f"has keys {sorted(metrics.states)}; expected the report's states {sorted(states)}",
            )
        truth = (metrics.confusion is not None, metrics.detected is not None)
        if truth[0] != truth[1] or (truth[0] and metrics.mode_accuracy is None):
            raise self.error(
                path,
                "holds mode_accuracy, confusion and detected/missed only in part; all are "
                "null without a true mode, all set with one (mode_accuracy alone: every "
                "component right, for a [components] model)",
            )
        if (metrics.detected is None) != (metrics.missed is None):
            raise self.error(f"{path}.missed", "must be null exactly when detected is")
        return metrics

    def component_side(self, value: object, path: str) -> ComponentSide:
        data = self.mapping(value, path)
        return ComponentSide(
            mode_accuracy=self.at(data, path, "mode_accuracy", self.fraction),
            detection_delay_s=self.at(data, path, "detection_delay_s", self.optional_number),
            detection_max_s=self.at(data, path, "detection_max_s", self.optional_number),
            detected=self.at(data, path, "detected", self.count),
            missed=self.at(data, path, "missed", self.count),
        )

    def smoothing(
        self, value: object, path: str, labels: tuple[str, ...], states: tuple[str, ...]
    ) -> Smoothing:
        data = self.mapping(value, path)
        mode_sequence = self.at(data, path, "mode_sequence", self.string)
        if mode_sequence not in MODE_SEQUENCES:
            raise self.error(
                f"{path}.mode_sequence",
                f"is {excerpt(mode_sequence)}; expected one of {', '.join(MODE_SEQUENCES)}",
            )

        def side(value: object, where: str) -> SmoothingMetrics:
            return self.smoothing_metrics(value, where, labels, states)

        method = self.at(data, path, "method", self.or_null(self.string))
        fallbacks = self.at(data, path, "fallbacks", self.or_null(self.fallbacks), None)
        if fallbacks is not None and method is None:
            raise self.error(f"{path}.fallbacks", "is set but no smoother ran (method is null)")
        return Smoothing(
            method=method,
            mode_sequence=mode_sequence,
            description=self.at(data, path, "description", self.string),
            filtered=self.at(data, path, "filtered", side),
            smoothed=self.at(data, path, "smoothed", side),
            fallbacks=fallbacks,
        )

    def fallbacks(self, value: object, path: str) -> Fallbacks:
        data = self.mapping(value, path)
        fallbacks = Fallbacks(
            samples=self.at(data, path, "samples", self.count),
            of=self.at(data, path, "of", self.count),
            by_cause=self.at(data, path, "by_cause", self.map_of(self.count)),
            weight=self.at(data, path, "weight", self.number),
        )
        if set(fallbacks.by_cause) != set(FALLBACK_CAUSES):
            raise self.error(
                f"{path}.by_cause",
                f"has keys {sorted(fallbacks.by_cause)}; expected {sorted(FALLBACK_CAUSES)}",
            )
        counts = fallbacks.by_cause.values()
        if fallbacks.samples > fallbacks.of:
            raise self.error(
                f"{path}.samples", f"is {fallbacks.samples}, more than of ({fallbacks.of})"
            )
        if not max(counts) <= fallbacks.samples <= sum(counts):
            raise self.error(
                f"{path}.by_cause",
                f"counts {dict(fallbacks.by_cause)} do not fit samples = {fallbacks.samples} "
                "(each at most samples, together at least samples)",
            )
        # each refused sample carries a weight in (0, 1]: the mean over the of samples is
        # above 0 exactly when samples is, and at most samples / of
        most = fallbacks.samples / fallbacks.of if fallbacks.of else 0.0
        if not (0.0 < fallbacks.weight <= most if fallbacks.samples else fallbacks.weight == 0.0):
            raise self.error(
                f"{path}.weight",
                f"is {fallbacks.weight}; expected "
                + (f"above 0 and at most {most} (samples / of)" if fallbacks.samples else "0"),
            )
        return Fallbacks(
            fallbacks.samples,
            fallbacks.of,
            {cause: fallbacks.by_cause[cause] for cause in FALLBACK_CAUSES},
            fallbacks.weight,
        )

    def same_labels(self, data: Mapping[str, object], labels: tuple[str, ...], path: str) -> None:
        if set(data) != set(labels):
            raise self.error(
                path, f"has keys {sorted(data)}; expected the mode labels {sorted(labels)}"
            )

    def report(self, value: object) -> Report:
        if not isinstance(value, dict) or "hybridlog_version" not in value:
            raise ReportError(f"{self.source}: not a hybridlog report (no 'hybridlog_version' key)")
        data: Mapping[str, object] = value
        hidden = hidden_keys(data)
        if hidden:
            raise self.error(hidden[0], f"{HIDDEN_KEY}; not a key hybridlog writes")
        report = Report(
            hybridlog_version=self.string(data["hybridlog_version"], "hybridlog_version"),
            log=self.at(data, "", "log", self.string),
            model=self.at(data, "", "model", self.string),
            estimator=self.at(data, "", "estimator", self.string),
            options=self.at(data, "", "options", self.json_object),
            samples=self.at(data, "", "samples", self.count),
            dt=self.at(data, "", "dt", self.number),
            t_start=self.at(data, "", "t_start", self.optional_number),
            t_end=self.at(data, "", "t_end", self.optional_number),
            outputs=self.at(data, "", "outputs", self.map_of(self.output)),
            mse=self.at(data, "", "mse", self.optional_number),
            vaf=self.at(data, "", "vaf", self.optional_number),
            fit=self.at(data, "", "fit", self.optional_number, None),
            modes=self.at(data, "", "modes", self.modes),
            states=self.at(data, "", "states", self.map_of(self.state)),
            runtime_s=self.at(data, "", "runtime_s", self.optional_number),
            compile_s=self.at(data, "", "compile_s", self.optional_number, None),
            samples_per_s=self.at(data, "", "samples_per_s", self.optional_number),
            notes=self.at(data, "", "notes", self.list_of(self.string), []),
            null_reasons=self.at(data, "", "null_reasons", self.map_of(self.string), {}),
            reading=self.at(data, "", "reading", self.or_null(self.json_object), None),
            extra={k: self.json_value(v, k) for k, v in data.items() if k not in _KEYS},
        )
        labels, states = report.modes.labels, tuple(report.states)

        def smoothing(value: object, path: str) -> Smoothing:
            return self.smoothing(value, path, labels, states)

        found = self.at(data, "", "smoothing", self.or_null(smoothing), None)
        if found is None:
            return report
        smoothed = max(report.samples - 1, 0)  # the last sample is the filter's
        if found.fallbacks is not None and found.fallbacks.of != smoothed:
            raise self.error(
                "smoothing.fallbacks.of",
                f"is {found.fallbacks.of}; expected {smoothed} (samples − 1: the last sample "
                "is the filter's)",
            )
        return dataclasses.replace(report, smoothing=found)
