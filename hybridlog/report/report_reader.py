"""Parsed ``report.json`` values read back into a :class:`~hybridlog.report.document.Report`.

:class:`ReportReader` checks every key as it reads it (kind, range, and what the keys say of
each other), so that a malformed or foreign file is a :class:`~hybridlog.errors.ReportError`
naming the file and the key, never a crash (:meth:`~hybridlog.report.document.Report.from_dict`).
"""

from __future__ import annotations

import copy
import dataclasses
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Final, TypeVar, cast

from hybridlog.errors import ReportError, excerpt
from hybridlog.estimators.filter_options import MODE_SEQUENCES
from hybridlog.estimators.result import FALLBACK_CAUSES, Fallbacks
from hybridlog.report.document import HIDDEN_KEY, REPORT_KEYS, Report, hidden_keys
from hybridlog.report.mode_metrics import SwitchDetection
from hybridlog.report.report_json import JsonObject, JsonValue
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

__all__ = ["ReportReader"]


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
class ReportReader:
    """Reads parsed ``report.json`` values into typed parts; errors name the file and key."""

    source: str

    def error(self, path: str, problem: str) -> ReportError:
        """The :class:`~hybridlog.errors.ReportError` ``<source>: <path> <problem>``."""
        return ReportError(f"{self.source}: {excerpt(path)} {problem}")

    def wrong(self, path: str, value: object, expected: str) -> ReportError:
        """The error of a value of the wrong kind at ``path``, naming the one expected."""
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
        """``value`` when a JSON object."""
        if not isinstance(value, dict):
            raise self.wrong(path, value, "an object")
        return value

    def items(self, value: object, path: str, read: Callable[[object, str], T]) -> dict[str, T]:
        """Each value of the object ``value`` read by ``read``, keys kept."""
        return {k: read(v, f"{path}.{k}") for k, v in self.mapping(value, path).items()}

    def sequence(self, value: object, path: str, read: Callable[[object, str], T]) -> tuple[T, ...]:
        """Each item of the list ``value`` read by ``read``, as a tuple."""
        if not isinstance(value, list):
            raise self.wrong(path, value, "a list")
        return tuple(read(v, f"{path}[{i}]") for i, v in enumerate(value))

    def list_of(self, read: Callable[[object, str], T]) -> Callable[[object, str], tuple[T, ...]]:
        """A reader of a list whose items ``read`` reads (:meth:`sequence`)."""
        return lambda value, path: self.sequence(value, path, read)

    def map_of(self, read: Callable[[object, str], T]) -> Callable[[object, str], dict[str, T]]:
        """A reader of an object whose values ``read`` reads (:meth:`items`)."""
        return lambda value, path: self.items(value, path, read)

    def or_null(self, read: Callable[[object, str], T]) -> Callable[[object, str], T | None]:
        """A reader of null (``None``) or what ``read`` reads."""
        return lambda value, path: None if value is None else read(value, path)

    def string(self, value: object, path: str) -> str:
        """``value`` when a string."""
        if not isinstance(value, str):
            raise self.wrong(path, value, "a string")
        return value

    def boolean(self, value: object, path: str) -> bool:
        """``value`` when ``true`` or ``false``."""
        if not isinstance(value, bool):
            raise self.wrong(path, value, "true or false")
        return value

    def count(self, value: object, path: str) -> int:
        """``value`` when a whole number of at least 0 (not a boolean)."""
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.wrong(path, value, "a whole number")
        if value < 0:
            raise self.error(path, f"is {value}; expected a count (>= 0)")
        return value

    def number(self, value: object, path: str) -> float:
        """``value`` as a finite float (an integer too; not a boolean)."""
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
        """A finite number (:meth:`number`), or null."""
        if value is None:
            return None
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.wrong(path, value, "a number or null")
        return self.number(value, path)

    def json_object(self, value: object, path: str) -> JsonObject:
        """A copy of the free-form JSON object ``value`` (:meth:`json_value`)."""
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
        """One output's metrics (``outputs.<y>``)."""
        data = self.mapping(value, path)
        return OutputReport(
            mse=self.at(data, path, "mse", self.optional_number),
            vaf=self.at(data, path, "vaf", self.optional_number),
            fit=self.at(data, path, "fit", self.optional_number, None),
            samples=self.at(data, path, "samples", self.or_null(self.count), None),
        )

    def state(self, value: object, path: str) -> StateReport:
        """One state's error (``states.<x>``)."""
        data = self.mapping(value, path)
        return StateReport(
            rmse=self.at(data, path, "rmse", self.optional_number),
            samples=self.at(data, path, "samples", self.or_null(self.count), None),
        )

    def switch(self, value: object, path: str) -> ModeSwitch:
        """One change of the estimated mode (``modes.switches[i]``)."""
        data = self.mapping(value, path)
        return ModeSwitch(
            t=self.at(data, path, "t", self.number),
            from_mode=self.at(data, path, "from", self.string),
            to_mode=self.at(data, path, "to", self.string),
        )

    def event(self, value: object, path: str) -> SwitchDetection:
        """One true switch and its detection, ``detected`` agreeing with ``detected_t``."""
        data = self.mapping(value, path)
        detected_t = self.at(data, path, "detected_t", self.optional_number)
        delay_s = self.at(data, path, "delay_s", self.optional_number, None)
        if detected_t is None and delay_s is not None:
            raise self.error(f"{path}.delay_s", f"is {delay_s} but detected_t is None")
        miss_reason = self.at(data, path, "miss_reason", self.or_null(self.string), None)
        undetermined = self.at(data, path, "undetermined_reason", self.or_null(self.string), None)
        if undetermined is not None and (detected_t is not None or miss_reason is not None):
            raise self.error(
                f"{path}.undetermined_reason",
                "is set but the switch is "
                + ("detected" if detected_t is not None else "missed (miss_reason is set)")
                + "; an undetermined switch is neither",
            )
        event = SwitchDetection(
            t=self.at(data, path, "t", self.number),
            from_mode=self.at(data, path, "from", self.string),
            to_mode=self.at(data, path, "to", self.string),
            detected_t=detected_t,
            miss_reason=miss_reason,
            delay_s=delay_s,
            undetermined_reason=undetermined,
        )
        detected = self.at(data, path, "detected", self.boolean)
        if detected != event.detected:
            raise self.error(
                f"{path}.detected",
                f"is {str(detected).lower()} but detected_t is {event.detected_t}",
            )
        return event

    def detection(self, value: object, path: str) -> Detection:
        """``modes.detection``, its counts agreeing with its events.

        ``undetermined`` is absent where it is 0 (and from reports of earlier versions).
        """
        data = self.mapping(value, path)
        detection = Detection(
            mean_s=self.at(data, path, "mean_s", self.optional_number),
            max_s=self.at(data, path, "max_s", self.optional_number),
            events=self.at(data, path, "events", self.list_of(self.event)),
        )
        for key, default in (("detected", _MISSING), ("missed", _MISSING), ("undetermined", 0)):
            stated = self.at(data, path, key, self.count, default)
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
        """``modes`` (or a component's), its keys checked against each other."""
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
        """One side of ``smoothing``, its states those of the report."""
        data = self.mapping(value, path)
        outputs = self.at(data, path, "outputs", self.or_null(self.map_of(self.output)))
        metrics = SmoothingMetrics(
            mode_accuracy=self.at(data, path, "mode_accuracy", self.optional_number),
            confusion=self.confusion(data, path, labels),
            detection_delay_s=self.at(data, path, "detection_delay_s", self.optional_number),
            detection_max_s=self.at(data, path, "detection_max_s", self.optional_number),
            detected=self.at(data, path, "detected", self.or_null(self.count)),
            missed=self.at(data, path, "missed", self.or_null(self.count)),
            undetermined=self.at(data, path, "undetermined", self.count, 0),
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
        if metrics.detected is None and metrics.undetermined:
            raise self.error(f"{path}.undetermined", "is set but detected is null")
        return metrics

    def component_side(self, value: object, path: str) -> ComponentSide:
        """One component's metrics on one side of ``smoothing``."""
        data = self.mapping(value, path)
        return ComponentSide(
            mode_accuracy=self.at(data, path, "mode_accuracy", self.fraction),
            detection_delay_s=self.at(data, path, "detection_delay_s", self.optional_number),
            detection_max_s=self.at(data, path, "detection_max_s", self.optional_number),
            detected=self.at(data, path, "detected", self.count),
            missed=self.at(data, path, "missed", self.count),
            undetermined=self.at(data, path, "undetermined", self.count, 0),
        )

    def smoothing(
        self, value: object, path: str, labels: tuple[str, ...], states: tuple[str, ...]
    ) -> Smoothing:
        """``smoothing``: the offline pass and the metrics of both sides."""
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
        """``smoothing.fallbacks``, its counts and weight checked against each other."""
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
        """Refuse ``data`` unless its keys are the mode labels ``labels``."""
        if set(data) != set(labels):
            raise self.error(
                path, f"has keys {sorted(data)}; expected the mode labels {sorted(labels)}"
            )

    def report(self, value: object) -> Report:
        """The whole report from the parsed ``report.json`` ``value``."""
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
            extra={k: self.json_value(v, k) for k, v in data.items() if k not in REPORT_KEYS},
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
