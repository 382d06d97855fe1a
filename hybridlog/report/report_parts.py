"""The typed parts of a :class:`~hybridlog.report.document.Report`, each with its JSON object.

:class:`OutputReport` and :class:`StateReport` (``outputs.<y>``, ``states.<x>``),
:class:`ModeReport` with its switches and detections (``modes``), and :class:`Smoothing`
with its two sides and their components (``smoothing``); :mod:`hybridlog.report.document`
describes the keys of ``report.json``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from hybridlog.estimators.result import Fallbacks
from hybridlog.report.mode_metrics import SwitchDetection
from hybridlog.report.report_json import JsonObject, JsonValue

__all__ = [
    "ComponentSide",
    "Detection",
    "ModeReport",
    "ModeSwitch",
    "OutputReport",
    "Smoothing",
    "SmoothingMetrics",
    "StateReport",
]


@dataclass(frozen=True)
class OutputReport:
    """Metrics of one output (paper 001, section 5; MATLAB ``compare``'s fit).

    Attributes
    ----------
    mse, vaf, fit:
        See :func:`hybridlog.report.metrics.output_metrics`; ``None`` where undefined or
        beyond float64's range (the report's
        :attr:`~hybridlog.report.document.Report.null_reasons` says why).
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
        :attr:`~hybridlog.report.document.Report.null_reasons` says why).
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
        # only where the true mode's gaps leave it undetermined: a report of a log with its
        # whole truth reads as before
        **(
            {"undetermined_reason": event.undetermined_reason}
            if event.undetermined_reason is not None
            else {}
        ),
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
        """Number of true switches missed (not those undetermined)."""
        return sum(1 for e in self.events if e.missed)

    @property
    def undetermined(self) -> int:
        """Number of true switches the true mode's gaps leave undetermined."""
        return sum(1 for e in self.events if e.undetermined)

    def to_dict(self) -> JsonObject:
        """The JSON object ``{mean_s, max_s, detected, missed, [undetermined], events}``.

        ``undetermined`` only where some switch is (a gap in the true mode).
        """
        return {
            "mean_s": self.mean_s,
            "max_s": self.max_s,
            "detected": self.detected,
            "missed": self.missed,
            **({"undetermined": self.undetermined} if self.undetermined else {}),
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
    with its mode right, and its true switches detected, missed and undetermined (the true
    mode's gaps), the mean and largest delay of those detected (``None`` when none was).
    """

    mode_accuracy: float | None
    detection_delay_s: float | None
    detection_max_s: float | None
    detected: int
    missed: int
    undetermined: int = 0

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
            undetermined=0 if detection is None else detection.undetermined,
        )

    def to_dict(self) -> JsonObject:
        """The JSON object ``smoothing.<side>.components.<c>`` (``undetermined`` when > 0)."""
        return {
            "mode_accuracy": self.mode_accuracy,
            "detection_delay_s": self.detection_delay_s,
            "detection_max_s": self.detection_max_s,
            "detected": self.detected,
            "missed": self.missed,
            **({"undetermined": self.undetermined} if self.undetermined else {}),
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
    undetermined:
        True switches the true mode's gaps leave undetermined (neither detected nor missed,
        :func:`~hybridlog.report.mode_metrics.detection_delays`); in ``report.json`` only when
        more than 0.
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
    undetermined: int = 0

    def to_dict(self) -> JsonObject:
        """The JSON object ``smoothing.filtered`` or ``smoothing.smoothed``."""
        data: JsonObject = {
            "mode_accuracy": self.mode_accuracy,
            "confusion": _confusion_dict(self.confusion),
            "detection_delay_s": self.detection_delay_s,
            "detection_max_s": self.detection_max_s,
            "detected": self.detected,
            "missed": self.missed,
            **({"undetermined": self.undetermined} if self.undetermined else {}),
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
