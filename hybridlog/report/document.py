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

``smoothing`` is ``{method, mode_sequence, description, fallbacks, filtered: {...}, smoothed:
{...}}`` (:class:`~hybridlog.report.report_parts.Smoothing`): ``method`` names the
fixed-interval smoother (``null`` when only the mode sequence was changed), ``mode_sequence``
is ``argmax``, ``viterbi`` or ``kbest``; ``fallbacks`` (only when a smoother ran) is
``{samples, of, by_cause: {prediction, guard, rounding, covariance}, weight}``: of the ``of``
samples the backward pass smoothed (all but the last), the ``samples`` where at least one step
that carries weight was refused and the forward estimate stood in its place, ``weight`` the
share of the smoothed estimates those refused steps carry, averaged over the ``of`` samples
(:class:`~hybridlog.estimators.result.Fallbacks`), and per cause (the prediction's covariance
not positive definite, the guard, the rounding probe, the step's covariance not PSD;
docs/smoothing.md "The algorithms") the samples with such a step (with ``kbest``, those of the
RTS smoother along the path, whose states the report holds); ``filtered`` and ``smoothed`` hold
the same metrics (:class:`~hybridlog.report.report_parts.SmoothingMetrics`) of the causal
filter's estimates and of the report's own: ``mode_accuracy, confusion, detection_delay_s,
detection_max_s, detected, missed, estimated_switches, states: {<x>: {rmse, samples}}, outputs:
{<y>: {mse, vaf, fit, samples}}, fit``, and for a ``[components]`` model with the log's true
mode of components ``components: {<c>: {mode_accuracy, detection_delay_s, detection_max_s,
detected, missed}}`` (:class:`~hybridlog.report.report_parts.ComponentSide`; absent otherwise).
Their ``outputs`` are not the one-step-ahead prediction of the top-level ``outputs`` (which
stays the filter's either way): they are ``ŷ(k) = h_q̂(k)(x̂(k), u(k))``, the outputs the
estimated mode and state explain, ``null`` when the model was not at hand to evaluate ``h``.

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
:func:`hybridlog.report.mode_metrics.detection_delays`.  Where a gap in a sampled true mode
cuts a switch's window short before the estimate changed into the new mode, the switch is
neither detected nor missed: ``detection`` then has ``undetermined`` (their number, after
``missed``, which counts the definite misses only) and such an event ``undetermined_reason``
(``miss_reason`` ``null``), as do ``smoothing``'s sides (and their ``components``) an
``undetermined`` count; each key is absent where there is none, so a report of a log with
its whole true mode reads as before.

Reports written by earlier versions lack ``fit``, ``compile_s``, ``notes``,
``null_reasons``, ``outputs.<y>.samples``, ``states.<x>.samples``, ``modes.samples``,
``miss_reason``, ``undetermined`` or ``smoothing.fallbacks``; they
are read with ``None`` (or empty) in their place.
"""

from __future__ import annotations

import copy
import dataclasses
import json
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import TYPE_CHECKING, Final

from hybridlog.errors import ReportError
from hybridlog.report.report_json import JsonObject, JsonValue, indented_json
from hybridlog.report.report_parts import ModeReport, OutputReport, Smoothing, StateReport

__all__ = ["Report", "read_report"]


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
        clash = sorted(set(self.extra) & REPORT_KEYS)
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
        from hybridlog.report.report_reader import ReportReader  # which imports this module

        return ReportReader(source).report(data)

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
        if not REPORT_KEYS.isdisjoint(extra):
            return Report.from_dict({**self.to_dict(), **extra}, source=source)
        from hybridlog.report.report_reader import ReportReader  # which imports this module

        reader = ReportReader(source)
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


REPORT_KEYS: Final = frozenset(f.name for f in fields(Report)) - {"extra"}
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
    return sorted(
        k for k in keys if k.startswith("__") or (k in _OWN_NAMES and k not in REPORT_KEYS)
    )


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
