"""CI gates: ``--fail-under METRIC=VALUE`` and ``--fail-over METRIC=VALUE``.

A ``--fail-under`` gate fails when the metric is below its bound, a ``--fail-over`` gate
when it is above.  A gated metric that is ``null`` in the report (for instance
``mode_accuracy`` of a log without ground truth) fails the gate, with a message saying so.

Metric names
------------
``vaf``, ``mse``, ``fit``
    Mean over the outputs where the metric is defined (``report.vaf``, ...); ``fit`` is
    MATLAB ``compare``'s NRMSE fit in percent.  A gate on the mean fails while any
    output's value is ``null`` (a stuck sensor's VAF or fit is undefined): a mean over the
    other outputs would pass a run on the outputs it left out.
``vaf.<y>``, ``mse.<y>``, ``fit.<y>``
    Of one output ``<y>`` (``report.outputs[y].vaf``, ...).
``mode_accuracy``
    ``report.modes.accuracy``, a fraction in ``[0, 1]``.
``detection_delay_s``
    Mean detection delay of the detected true mode switches, seconds.  A ``--fail-over``
    gate on it fails while any true switch was missed (a miss has no delay, so the mean
    over the others vouches for no bound), naming the missed switches.
``missed_switches``
    Number of true mode switches never detected.
``state_rmse.<x>``
    RMSE of state ``<x>``.
``mode_accuracy.<c>``, ``detection_delay_s.<c>``, ``missed_switches.<c>``
    Of one component ``<c>`` of a ``[components]`` model (``report.modes.components[c]``),
    against the log's true mode of that component; ``mode_accuracy`` is then the fraction
    of samples where every component is right.  A gate on any of these mode metrics is
    refused before the run when a chosen estimator reads its modes from the log instead
    of estimating them (``switching-observer``: its report scores none,
    :func:`validate_gates`).
``runtime_s``, ``samples_per_s``
    Estimation speed.
``smoothing_fallback_weight``, ``smoothing_fallback_samples``
    Where the smoother left the forward estimate standing (``report.smoothing.fallbacks``,
    :class:`~hybridlog.estimators.result.Fallbacks`): ``weight``, the share of the smoothed
    estimates' weight the refused steps carry, a fraction in ``[0, 1]``, and ``samples``,
    the samples with a refused step (a count).  ``--fail-over
    smoothing_fallback_weight=0.5`` fails a run whose "smoothed" estimate is mostly the
    filter's (the double cart: 0.991).  Only a run with a smoother has them: a gate on
    one is refused before the run when a chosen estimator runs none (:func:`validate_gates`:
    no ``--smooth``, ``--mode-sequence`` alone, an estimator without a smoother), and fails
    as ``null`` (with why) on a report that has none (one of an earlier version).

A smoothed run (``--smooth``, ``--mode-sequence viterbi|kbest``) is gated on its report's own
values: ``mode_accuracy``, ``detection_delay_s``, ``missed_switches`` and ``state_rmse.<x>``
(and their per-component forms) are then those of the offline estimates, while ``vaf``,
``mse`` and ``fit`` stay the filter's one-step-ahead prediction (the filter's own mode and
state metrics are in ``report.json``'s ``smoothing.filtered``, not gated).  A failed gate's
message says which side it read (:func:`evaluate_gates`), so summary.csv, summary.md, JUnit
and the terminal do too.

:func:`metric` reads any of them from a :class:`~hybridlog.report.document.Report` through
one typed accessor per name (:data:`METRICS` lists the unqualified ones).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Final, Literal

from hybridlog.errors import OptionError
from hybridlog.numbers import parse_float
from hybridlog.report.coverage import component_coverage, mode_coverage
from hybridlog.report.document import Report
from hybridlog.report.report_json import JsonValue
from hybridlog.report.report_parts import ModeReport, OutputReport, Smoothing, StateReport
from hybridlog.times import format_time

__all__ = [
    "FALLBACK_METRICS",
    "METRICS",
    "MODE_METRICS",
    "Gate",
    "evaluate_gates",
    "gate_records",
    "met_value",
    "metric",
    "metric_value",
    "null_reason",
    "outputs_left_out",
    "parse_gate",
    "parse_gates",
    "recorded_failures",
    "switches_missed",
    "validate_gates",
]

GateKind = Literal["under", "over"]


def _fallbacks_of(report: Report, field: Literal["weight", "samples"]) -> float | int | None:
    """``report.smoothing.fallbacks.<field>``, ``None`` where the report has no fallbacks."""
    fallbacks = None if report.smoothing is None else report.smoothing.fallbacks
    if fallbacks is None:
        return None
    return fallbacks.weight if field == "weight" else fallbacks.samples


#: The metric of each unqualified name.
_REPORT_METRICS: Final[Mapping[str, Callable[[Report], float | int | None]]] = {
    "vaf": lambda r: r.vaf,
    "mse": lambda r: r.mse,
    "fit": lambda r: r.fit,
    "mode_accuracy": lambda r: r.modes.accuracy,
    "detection_delay_s": lambda r: r.modes.detection_delay_s,
    "missed_switches": lambda r: None if r.modes.detection is None else r.modes.detection.missed,
    "runtime_s": lambda r: r.runtime_s,
    "samples_per_s": lambda r: r.samples_per_s,
    "smoothing_fallback_weight": lambda r: _fallbacks_of(r, "weight"),
    "smoothing_fallback_samples": lambda r: _fallbacks_of(r, "samples"),
}
#: Metrics qualified by an output (``vaf.y1``) ...
_OUTPUT_METRICS: Final[Mapping[str, Callable[[OutputReport], float | None]]] = {
    "vaf": lambda o: o.vaf,
    "mse": lambda o: o.mse,
    "fit": lambda o: o.fit,
}
#: ... or by a state (``state_rmse.x1``).
_STATE_METRICS: Final[Mapping[str, Callable[[StateReport], float | None]]] = {
    "state_rmse": lambda s: s.rmse,
}
#: ... or by a component of a ``[components]`` model (``mode_accuracy.fr2``).
_COMPONENT_METRICS: Final[Mapping[str, Callable[[ModeReport], float | int | None]]] = {
    "mode_accuracy": lambda m: m.accuracy,
    "detection_delay_s": lambda m: m.detection_delay_s,
    "missed_switches": lambda m: None if m.detection is None else m.detection.missed,
}
#: The values each metric can take (by its unqualified name), for bounds it can never meet.
_RANGES: Final[Mapping[str, tuple[float, float]]] = {
    "vaf": (0.0, 100.0),
    "fit": (-math.inf, 100.0),
    "mode_accuracy": (0.0, 1.0),
    "smoothing_fallback_weight": (0.0, 1.0),
    **{
        name: (0.0, math.inf)
        for name in (
            "mse",
            "detection_delay_s",
            "missed_switches",
            "runtime_s",
            "samples_per_s",
            "state_rmse",
            "smoothing_fallback_samples",
        )
    },
}
_UNITS: Final[Mapping[str, str]] = {"vaf": " %", "fit": " %"}
#: Metrics that are fractions in ``[0, 1]`` (a bound such as 95 was meant as a percentage).
_FRACTIONS: Final[frozenset[str]] = frozenset({"mode_accuracy", "smoothing_fallback_weight"})
#: Metrics of the smoother's fallbacks: only a run with a smoother has them.
FALLBACK_METRICS: Final[frozenset[str]] = frozenset(
    {"smoothing_fallback_weight", "smoothing_fallback_samples"}
)
#: Metrics of the estimated modes against the true ones (and their per-component forms):
#: a report whose modes were read from the log, not estimated, scores none.
MODE_METRICS: Final[frozenset[str]] = frozenset(_COMPONENT_METRICS)
#: Metrics without a qualifier.
METRICS: tuple[str, ...] = tuple(_REPORT_METRICS)

# Fallbacks for reports without ``null_reasons`` (written by older versions).
_WHY_NULL = {
    "mode_accuracy": "the log has no ground-truth mode",
    "detection_delay_s.": "the log has no true mode of this component, or none of its true "
    "switches was detected",
    "mode_accuracy.": "the log has no true mode of this component",
    "missed_switches.": "the log has no true mode of this component",
    "missed_switches": "the log has no ground-truth mode",
    "detection_delay_s": "no ground-truth mode or no true switch was detected",
    "state_rmse": "the log has no ground truth for this state",
    "vaf": "no finite one-step-ahead prediction",
    "mse": "no finite one-step-ahead prediction",
    "fit": "no finite one-step-ahead prediction",
    "samples_per_s": "the runtime was not measured",
}


@dataclass(frozen=True)
class Gate:
    """One CI gate.

    Attributes
    ----------
    metric:
        Metric name, e.g. ``vaf`` or ``state_rmse.x1`` (see the module docstring).
    bound:
        The bound.
    kind:
        ``"under"``: fail when the metric is below ``bound``; ``"over"``: when above.
    spec:
        ``METRIC=VALUE`` as given, without the blanks around either part (``' fit = 60 '``
        is ``fit=60``) and a sign that is not the bound's (``fit=-0`` and ``fit=+0`` are
        ``fit=0``): the name of the gate in report.json, report.md, summary.md and
        JUnit, where a blank would make the same gate another test case.

    """

    metric: str
    bound: float
    kind: GateKind
    spec: str

    @property
    def option(self) -> str:
        """The command-line option that set this gate."""
        return f"--fail-{self.kind}"


def _is_gated(metric: str) -> bool:
    """Whether ``metric`` names a metric gates read (its qualifier, if any, unchecked)."""
    base, dot, qualifier = metric.partition(".")
    if dot:
        return bool(qualifier) and base in (*_OUTPUT_METRICS, *_STATE_METRICS, *_COMPONENT_METRICS)
    return base in METRICS


def _known_names() -> str:
    return ", ".join(
        [
            *METRICS,
            *(f"{m}.<output>" for m in _OUTPUT_METRICS),
            "state_rmse.<state>",
            *(f"{m}.<component>" for m in _COMPONENT_METRICS),
        ]
    )


def parse_gate(spec: str, kind: GateKind) -> Gate:
    """Parse one ``METRIC=VALUE`` gate specification.

    Parameters
    ----------
    spec:
        E.g. ``"vaf=90"`` or ``"state_rmse.x1=0.5"``.
    kind:
        ``"under"`` for ``--fail-under``, ``"over"`` for ``--fail-over``.

    Returns
    -------
    Gate
        The parsed gate.

    Raises
    ------
    OptionError
        When the spec has no ``=``, an unknown metric name, a bound that is not a finite
        number, or one beyond the values the metric can take: a gate that could never pass
        (``--fail-under mode_accuracy=99.5``: a fraction is at most 1; ``--fail-over
        mse=-1``) or never fail (``--fail-under mse.y1=-1``; ``--fail-over
        smoothing_fallback_weight=50``, a percentage where a fraction is meant); the message
        names the spec.

    """
    option = f"--fail-{kind}"
    metric, sep, value = spec.partition("=")
    metric = metric.strip()
    value = value.strip()
    if not sep or not metric or not value:
        raise OptionError(f"{option} {spec!r} is not of the form METRIC=VALUE")
    base = metric.partition(".")[0]
    known = _is_gated(metric)
    if not known and metric.startswith("filtered_") and _is_gated(metric[len("filtered_") :]):
        # batch's summary.csv has these columns beside the gated ones: not a gate of their own
        raise OptionError(
            f"{option} {spec!r}: {metric} is the filter's own value beside an offline pass's "
            f"(summary.csv), not gated; gates read {metric[len('filtered_') :]}, the offline "
            "estimates' (run without --smooth and --mode-sequence to gate the filter's)"
        )
    if not known:
        raise OptionError(f"{option} {spec!r}: unknown metric {metric!r}; known: {_known_names()}")
    try:
        # + 0.0: a bound of -0 is 0 (IEEE -0.0 + 0.0), never "the bound -0" nor -0.0 in JSON
        bound = parse_float(value) + 0.0
    except ValueError as err:
        hint = _percent_sign_hint(base, value)
        raise OptionError(f"{option} {spec!r}: bound {value!r}: {err}{hint}") from None
    _check_attainable(spec, option, metric, bound, kind)
    return Gate(metric=metric, bound=bound, kind=kind, spec=f"{metric}={_bound_text(value, bound)}")


def _bound_text(value: str, bound: float) -> str:
    """A bound's text in a gate's name: as given, but for a sign that is not the bound's.

    ``-0`` (``-0.0``, ``-0e5``) is the bound 0 and is named ``0`` (``0.0``, ``0e5``), and a
    leading ``+`` is dropped (``+60`` is ``60``): ``fit=-0`` was another JUnit case, summary
    column and report.md gate than ``fit=0`` for the same bound.
    """
    if value.startswith("+") or (value.startswith("-") and bound == 0.0):
        return value[1:]
    return value


def _check_attainable(spec: str, option: str, metric: str, bound: float, kind: GateKind) -> None:
    """Refuse a bound beyond the values ``metric`` can take (:data:`_RANGES`), on either side.

    On the side no value meets, the gate could only fail (``--fail-under
    mode_accuracy=2``); on the side every value meets, it could only pass, a CI gate doing
    nothing: a sign typed wrong (``--fail-under mode_accuracy=-0.1``, ``mse.y1=-1``) or a
    percentage where a fraction is meant (``--fail-over smoothing_fallback_weight=50``,
    50 %, which passed every run however much of the estimate the smoother left to the
    filter).  A bound at the range's end stays a gate: ``--fail-under vaf=0`` fails only
    where the metric is ``null`` (undefined, or a mean that leaves an output out), the way
    to that check and to a gated column in the summaries, and the refusal says so.
    """
    base = metric.partition(".")[0]
    low, high = _RANGES[base]
    hint = _fraction_hint(base, bound)
    unit = _UNITS.get(base, "")
    edge = low if kind == "under" else high
    if (kind == "under" and bound < low) or (kind == "over" and bound > high):
        side = "least" if kind == "under" else "most"
        # the percentage's fraction, else the bound that checks what such a gate does check
        instead = "" if hint else f"; {option} {metric}={edge:g} checks only that it is defined"
        raise OptionError(
            f"{option} {spec!r}: {base} is at {side} {edge:g}{unit}{hint}, so this gate could "
            f"never fail{instead}"
        )
    if (kind == "under" and bound <= high) or (kind == "over" and bound >= low):
        return
    where = f"at most {high:g}{unit}" if kind == "under" else f"at least {low:g}{unit}"
    raise OptionError(f"{option} {spec!r}: {base} is {where}{hint}, so this gate could never pass")


def _fraction_hint(base: str, bound: float) -> str:
    """`` (a fraction: for 95 % write 0.95)`` where ``bound`` reads as a percentage of a fraction.

    Only a bound above 1 and at most 100 of a metric that is a fraction reads so: a negative
    bound, or one above 100, is no percentage the metric could take, and a hint would offer a
    bound refused in turn.
    """
    if base in _FRACTIONS and 1.0 < bound <= 100.0:
        return f" (a fraction: for {bound:g} % write {bound / 100:g})"
    return ""


def _percent_sign_hint(base: str, value: str) -> str:
    """What to write instead of a bound with a percent sign (``vaf=95%``), or ``""``.

    A percent metric takes the number alone, a fraction the number over 100 (when that is a
    fraction it can take); a metric of neither kind gets no hint.
    """
    number, sign, rest = value.rpartition("%")
    if not sign or rest.strip():
        return ""
    try:
        percent = parse_float(number)
    except ValueError:
        return ""
    if base in _UNITS and _RANGES[base][0] <= percent <= _RANGES[base][1]:
        return f" ({base} is in percent already: write {percent:g})"
    if base in _FRACTIONS and 0.0 <= percent <= 100.0:
        return f" ({base} is a fraction: for {percent:g} % write {percent / 100:g})"
    return ""


def parse_gates(fail_under: Iterable[str] = (), fail_over: Iterable[str] = ()) -> list[Gate]:
    """Parse every ``--fail-under`` and ``--fail-over`` value.

    Parameters
    ----------
    fail_under:
        ``METRIC=VALUE`` specs that fail when the metric is below the value.
    fail_over:
        ``METRIC=VALUE`` specs that fail when the metric is above the value.

    Returns
    -------
    list of Gate
        ``--fail-under`` gates first, each group in the order given.

    Raises
    ------
    OptionError
        As :func:`parse_gate`; when a gate is given twice (``vaf=50`` and ``vaf=50.0``: its
        JUnit case and its failure were each written twice, the case's name no longer
        telling one test); and when a ``--fail-under`` bound of a metric is above one of
        its ``--fail-over`` bounds: no value meets both, so every run would fail.

    """
    given = [*fail_under, *fail_over]  # each gate's text as given, for the messages
    gates = [parse_gate(s, "under") for s in fail_under]
    gates += [parse_gate(s, "over") for s in fail_over]
    seen: dict[tuple[str, str, float], int] = {}
    for i, gate in enumerate(gates):
        first = seen.setdefault((gate.kind, gate.metric, gate.bound), i)
        if first != i:
            same = (
                "given twice" if given[first] == given[i] else f"the same gate as {given[first]!r}"
            )
            raise OptionError(f"{gate.option} {given[i]!r}: {same}; give it once")
    for low in gates:
        for high in gates:
            if (low.kind, high.kind, low.metric) == ("under", "over", high.metric) and (
                low.bound > high.bound
            ):
                least, most = _fmt_apart(low.bound, high.bound)
                raise OptionError(
                    f"{low.option} {low.spec!r} and {high.option} {high.spec!r}: {low.metric} "
                    f"cannot be at least {least} and at most {most}, "
                    "so these gates could never both pass"
                )
    return gates


def validate_gates(
    gates: Iterable[Gate],
    *,
    output_names: Sequence[str],
    state_names: Sequence[str],
    component_names: Sequence[str] = (),
    without_smoother: Mapping[str, str] | None = None,
    modes_given: Mapping[str, str] | None = None,
) -> None:
    """Check that every gate can be read from the reports of the run configured.

    Call this before a long run so that ``--fail-under vaf.y9=90`` fails early: qualified
    metrics must name an output, state or component of the model, and a gate on the
    smoother's fallbacks (:data:`FALLBACK_METRICS`) needs a smoother on every estimator the
    gates apply to.  Without one the metric is ``null`` in every report and the gate could
    only fail, as ``vaf.y9`` would: refused, as it is.  So is a gate on a mode metric
    (:data:`MODE_METRICS`) when an estimator reads its modes from the log rather than
    estimating them (``modes_given``: ``switching-observer``, whose report scores none).
    (A metric a log may lack, such as
    ``mode_accuracy`` without a true mode, is not known before the log is read: its gate
    fails on that log, saying why.)

    Parameters
    ----------
    gates:
        Parsed gates.
    output_names, state_names, component_names:
        The model's outputs, states and components.
    without_smoother:
        The estimators the gates apply to that run no smoother, each with why (``{"imm":
        "smooth = false ..."}``); ``None`` when not known (fallback gates are not checked).
    modes_given:
        The estimators the gates apply to that score no mode metric, each with why
        (``{"switching-observer": "it reads its modes from the log's switching signal"}``).

    Raises
    ------
    OptionError
        Naming the first gate whose output, state or component is unknown, a gate on the
        fallbacks and the first estimator without a smoother, or a gate on a mode metric and
        the first estimator that scores none.

    """
    for gate in gates:
        base, dot, qualifier = gate.metric.partition(".")
        if base in FALLBACK_METRICS and without_smoother:
            name, why = next(iter(without_smoother.items()))
            raise OptionError(
                f"{gate.option} {gate.spec!r}: estimator '{name}' runs no smoother ({why}), "
                f"so its report has no {base} and this gate could never pass"
            )
        if base in MODE_METRICS and modes_given:
            name, why = next(iter(modes_given.items()))
            raise OptionError(
                f"{gate.option} {gate.spec!r}: estimator '{name}' scores no mode metric "
                f"({why}), so its report has no {base} and this gate could never pass"
            )
        if not dot:
            continue
        if base in _OUTPUT_METRICS and qualifier not in output_names:
            raise OptionError(
                f"{gate.option} {gate.spec!r}: {qualifier!r} is not an output; "
                f"outputs: {', '.join(output_names)}"
            )
        if base in _STATE_METRICS and qualifier not in state_names:
            raise OptionError(
                f"{gate.option} {gate.spec!r}: {qualifier!r} is not a state; "
                f"states: {', '.join(state_names)}"
            )
        if base in _COMPONENT_METRICS and qualifier not in component_names:
            known = (
                f"components: {', '.join(component_names)}"
                if component_names
                else "the model has no [components]"
            )
            raise OptionError(
                f"{gate.option} {gate.spec!r}: {qualifier!r} is not a component; {known}"
            )


def metric(report: Report, name: str) -> float | int | None:
    """Read a metric of a report by its name (see the module docstring).

    Parameters
    ----------
    report:
        A report from :func:`hybridlog.report.build.build_report` (or read back).
    name:
        A metric name such as ``vaf``, ``fit.y1``, ``state_rmse.x2`` or ``mode_accuracy``.

    Returns
    -------
    float, int or None
        The value as the report holds it (``missed_switches`` is a count), ``None`` when
        the report holds ``null`` for it.

    Raises
    ------
    OptionError
        When the name is unknown or names an output/state the report does not have.

    """
    base, dot, qualifier = name.partition(".")
    if not dot and base in _REPORT_METRICS:
        return _REPORT_METRICS[base](report)
    if dot and base in _OUTPUT_METRICS:
        if qualifier not in report.outputs:
            raise OptionError(f"gate metric {name!r}: {qualifier!r} is not an output")
        return _OUTPUT_METRICS[base](report.outputs[qualifier])
    if dot and base in _STATE_METRICS:
        if qualifier not in report.states:
            raise OptionError(f"gate metric {name!r}: {qualifier!r} is not a state")
        return _STATE_METRICS[base](report.states[qualifier])
    if dot and base in _COMPONENT_METRICS:
        component = report.modes.components.get(qualifier)
        return None if component is None else _COMPONENT_METRICS[base](component)
    raise OptionError(f"unknown gate metric {name!r}; known: {_known_names()}")


def metric_value(report: Report, name: str) -> float | None:
    """A metric of a report as a float, for a gate (see :func:`metric`).

    Returns
    -------
    float or None
        The value, ``None`` when the report holds ``null`` for it.

    Raises
    ------
    OptionError
        When the name is unknown or names an output/state the report does not have.

    """
    value = metric(report, name)
    if value is None:
        return None
    f = float(value)
    return f if math.isfinite(f) else None


def _fmt(x: float) -> str:
    return f"{x:.6g}"


def _fmt_apart(x: float, y: float) -> tuple[str, str]:
    """``x`` and ``y`` as :func:`_fmt` writes them, with more digits while they print alike.

    A value just under its bound must not read ``vaf = 21.7984 is under the bound 21.7984``:
    two different numbers get the digits that tell them apart (up to the 17 of a float).
    """
    for digits in range(6, 18):
        shown = f"{x:.{digits}g}", f"{y:.{digits}g}"
        if x == y or shown[0] != shown[1]:
            return shown
    return f"{x!r}", f"{y!r}"


#: Metrics an offline pass changes: read from the report's own (offline) modes and states.
_OFFLINE_METRICS: Final = frozenset({"mode_accuracy", "detection_delay_s", "missed_switches"})


def _filtered_metric(smoothing: Smoothing, name: str) -> float | int | None:
    """The filter's own value of a metric an offline pass changes (``smoothing.filtered``)."""
    base, dot, qualifier = name.partition(".")
    filtered = smoothing.filtered
    if base in _STATE_METRICS:
        state = filtered.states.get(qualifier)
        return None if state is None else state.rmse
    if dot:
        component = filtered.components.get(qualifier)
        if component is None:
            return None
        return {
            "mode_accuracy": component.mode_accuracy,
            "detection_delay_s": component.detection_delay_s,
            "missed_switches": component.missed,
        }[base]
    return {
        "mode_accuracy": filtered.mode_accuracy,
        "detection_delay_s": filtered.detection_delay_s,
        "missed_switches": filtered.missed,
    }[base]


def _which_side(report: Report, name: str) -> str:
    """For a report of offline estimates, which estimates a gated metric is of.

    ``""`` for a filter's report.  A mode or state metric is of the offline estimates (named
    by the smoother and the mode sequence), the filter's own value beside it (``n/a`` where
    it has none); ``vaf``, ``mse`` and ``fit`` are the filter's prediction.
    """
    smoothing = report.smoothing
    if smoothing is None:
        return ""
    base = name.partition(".")[0]
    if base in _OUTPUT_METRICS:
        return " (the filter's one-step-ahead prediction)"
    if base not in _OFFLINE_METRICS and base not in _STATE_METRICS:
        return ""
    label = ", ".join(n for n in (smoothing.method, smoothing.mode_sequence) if n)
    filtered = _filtered_metric(smoothing, name)
    own = "n/a" if filtered is None else _fmt(float(filtered))
    return f" (of the offline estimates: {label}; the filter's own: {own})"


def _over_part(report: Report, name: str) -> str:
    """A metric over part of the log or few samples: which, or the switches left undetermined.

    A true mode that starts late is scored from its first sample on: ``mode_accuracy = 1 is
    under ...`` would read as the whole log's (:mod:`hybridlog.report.coverage`).  Likewise
    ``missed_switches`` counts the definite misses only: where the true mode's gaps leave some
    switches undetermined, how many (``met (missed_switches = 0)`` read as every switch
    detected).  A metric over fewer than ``FEW_SAMPLES`` samples says how few
    (:func:`~hybridlog.report.few_samples.few_samples_of`): ``met (vaf = 0.9)`` over 4
    samples passed CI with the warning printed apart from the gate.
    """
    base, dot, qualifier = name.partition(".")
    if base == "missed_switches":
        modes = report.modes.components.get(qualifier) if dot else report.modes
        detection = None if modes is None else modes.detection
        if detection is None or not detection.undetermined:
            return ""
        return (
            f" (not counting {detection.undetermined:,} undetermined true "
            f"{'switch' if detection.undetermined == 1 else 'switches'}: the true mode's gaps "
            "cut their windows short)"
        )
    part = None
    if base == "mode_accuracy":
        part = component_coverage(report, qualifier) if dot else mode_coverage(report)
    if part is not None:
        return f" over {part}"
    from hybridlog.report.few_samples import few_samples_of  # which imports this module
    from hybridlog.report.markdown import plural

    few = few_samples_of(report, name)
    return "" if few is None else f" over only {plural(few, 'sample')}"


def _no_fallbacks(report: Report) -> str:
    """Why ``report`` has no ``smoothing.fallbacks`` (to gate on)."""
    smoothing = report.smoothing
    if smoothing is None:
        return "no smoother ran: the estimates are the filter's own"
    if smoothing.method is None:
        return f"no smoother ran: mode sequence {smoothing.mode_sequence} alone"
    return (
        f"the report ({smoothing.method}) does not count the smoother's fallbacks: "
        "one of an earlier version"
    )


def _fallback_context(report: Report, name: str) -> str:
    """For a gate on the fallbacks, the other figure and the smoother, as analyze says it."""
    smoothing = report.smoothing
    fallbacks = None if smoothing is None else smoothing.fallbacks
    if name not in FALLBACK_METRICS or smoothing is None or fallbacks is None:
        return ""
    label = ", ".join(n for n in (smoothing.method, smoothing.mode_sequence) if n)
    if name == "smoothing_fallback_weight":
        other = f"fell back on {fallbacks.samples:,} of {fallbacks.of:,} samples"
    else:
        other = f"of {fallbacks.of:,} samples, carrying {fallbacks.weight_text()} of the weight"
    return f" ({label}: {other})"


def null_reason(report: Report, name: str) -> str:
    """Why ``report`` holds ``null`` for the metric ``name`` (``vaf``, ``state_rmse.x1``).

    The report's own :attr:`~Report.null_reasons`, else the general reason of the metric
    (reports of versions that did not record one).
    """
    base, dot, _ = name.partition(".")
    if base in FALLBACK_METRICS and not dot:
        return _no_fallbacks(report)
    return (
        report.null_reasons.get(name)
        or _WHY_NULL.get(base + dot if base in _COMPONENT_METRICS else base)
        or "the report has no value for it"
    )


def outputs_left_out(report: Report, name: str) -> str | None:
    """For a mean over the outputs (``vaf``, ``mse``, ``fit``), the outputs it left out.

    ``None`` for another metric or when every output's value is there; else the outputs
    whose value is ``null``, each with why (``vaf.y2 (var(ŷ) = 0: ...)``).
    """
    if name not in _OUTPUT_METRICS:
        return None
    read = _OUTPUT_METRICS[name]
    missing = [y for y, output in report.outputs.items() if read(output) is None]
    if not missing:
        return None
    reasons = [
        f"{name}.{y} ({report.null_reasons.get(f'{name}.{y}') or _WHY_NULL[name]})" for y in missing
    ]
    return f"{len(missing)} of {len(report.outputs)} outputs: " + "; ".join(reasons)


def switches_missed(report: Report, name: str) -> str | None:
    """For ``detection_delay_s`` (or ``.<c>``), the true switches its mean leaves out as missed.

    ``None`` for another metric or when no switch was missed; else ``1 of 2 true switches,
    missed: 2 → 1 at t=81 s``.  A missed switch has no delay, so the mean over the detected
    ones is no upper bound of the detection delay: ``--fail-over detection_delay_s=100``
    was met with ``detection_delay_s = 91`` while the switch at 81 s was never detected.
    """
    base, dot, qualifier = name.partition(".")
    if base != "detection_delay_s":
        return None
    modes = report.modes.components.get(qualifier) if dot else report.modes
    detection = None if modes is None else modes.detection
    if detection is None or not detection.missed:
        return None
    missed = [e for e in detection.events if e.missed]
    listed = ", ".join(f"{e.from_mode} → {e.to_mode} at t={format_time(e.t)} s" for e in missed[:3])
    more = f" and {len(missed) - 3:,} more" if len(missed) > 3 else ""
    return f"{len(missed):,} of {len(detection.events):,} true switches, missed: {listed}{more}"


def evaluate_gates(report: Report, gates: Iterable[Gate]) -> list[str]:
    """Check gates against a report.

    Parameters
    ----------
    report:
        A report from :func:`hybridlog.report.build.build_report` (or read back).
    gates:
        Parsed gates.

    Returns
    -------
    list of str
        One message per failed gate, e.g. ``"vaf = 87.2 is under the bound 90"``; empty
        when every gate is met.  A gate on a mean over the outputs (``vaf``, ``mse``,
        ``fit``) fails while any output's value is ``null``, naming those outputs and why:
        ``"vaf = 95.1 is a mean that leaves out 1 of 2 outputs: vaf.y2 (var(ŷ) = 0: ...),
        so the --fail-under bound 90 cannot be met"``.  For a report of offline estimates
        (``smoothing``) the value says which it is: ``"mode_accuracy = 0.92 (of the
        offline estimates: kim-rts, argmax; the filter's own: 0.86) is under the bound
        0.95"``.  A ``--fail-over`` gate on ``detection_delay_s`` fails while a true switch
        was missed (:func:`switches_missed`).  A mode accuracy scored over part of the log
        (a true mode that starts late) says over which samples: ``"mode_accuracy = 0.8 over
        201 of 301 samples (the true mode starts at t = 100 s) is under the bound 0.9"``.

    Raises
    ------
    OptionError
        When a gate names an output or state the report does not have.

    """
    failures: list[str] = []
    for gate in gates:
        value = metric_value(report, gate.metric)
        if value is None:
            why = null_reason(report, gate.metric)
            failures.append(
                f"{gate.metric} is not available ({why}), so the {gate.option} bound "
                f"{_fmt(gate.bound)} cannot be met"
            )
        elif (partial := outputs_left_out(report, gate.metric)) is not None:
            failures.append(
                f"{gate.metric} = {_fmt(value)}{_which_side(report, gate.metric)} is a mean "
                f"that leaves out {partial}, so the {gate.option} bound {_fmt(gate.bound)} "
                "cannot be met"
            )
        elif gate.kind == "over" and (missed := switches_missed(report, gate.metric)):
            failures.append(
                f"{gate.metric} = {_fmt(value)}{_which_side(report, gate.metric)} is a mean "
                f"over the detected switches that leaves out {missed}, so the {gate.option} "
                f"bound {_fmt(gate.bound)} cannot be met"
            )
        elif (gate.kind == "under" and value < gate.bound) or (
            gate.kind == "over" and value > gate.bound
        ):
            shown, bound = _fmt_apart(value, gate.bound)
            failures.append(
                f"{gate.metric} = {shown}{_which_side(report, gate.metric)}"
                f"{_over_part(report, gate.metric)}{_fallback_context(report, gate.metric)} "
                f"is {gate.kind} the bound {bound}"
            )
    return failures


GATES_KEY: Final = "gates"
"""The key of ``analyze``'s report.json that records its gates (:func:`gate_records`)."""


def gate_records(report: Report, gates: Iterable[Gate]) -> list[dict[str, JsonValue]]:
    """Each gate as ``analyze``'s report records it: what was asked, the value, the outcome.

    ``{"gate": "--fail-under vaf=90", "metric": "vaf", "bound": 90.0, "value": 95.1,
    "passed": true, "failure": null}``; ``failure`` is :func:`evaluate_gates`'s message for a
    missed gate (``value`` ``null`` where the metric is not available).  The report carries
    them (key :data:`GATES_KEY`, report.md's "Gates"): a missed gate had been said on stderr
    and in the exit code alone, and a report kept by CI did not show which bound it missed.
    """
    records: list[dict[str, JsonValue]] = []
    for gate in gates:
        failure = next(iter(evaluate_gates(report, [gate])), None)
        value = metric(report, gate.metric)  # a count stays an integer, as the report's own
        records.append(
            {
                "gate": f"{gate.option} {gate.spec}",
                "metric": gate.metric,
                "bound": gate.bound,
                "value": None if metric_value(report, gate.metric) is None else value,
                "passed": failure is None,
                "failure": failure,
            }
        )
    return records


def met_value(report: Report, name: str, value: float, bound: float) -> str:
    """``vaf = 95.1`` for a met gate of report.md's "Gates", as a missed one's message says it.

    With the digits that tell the value from its bound (:func:`_fmt_apart`: ``--fail-over
    vaf=99.97209383`` was ``met (vaf = 99.9721)``, a value over the bound by its digits) and,
    for a report of offline estimates, which estimates it is of (:func:`_which_side`); a
    mode accuracy over part of the log over which samples (:func:`_over_part`), as a missed
    gate's message says it: ``met (mode_accuracy = 0.75)`` over 4 of 301 samples read as
    the whole log's.
    """
    shown, _ = _fmt_apart(value, bound)
    return f"{name} = {shown}{_which_side(report, name)}{_over_part(report, name)}"


def recorded_failures(report: Report) -> list[str]:
    """The missed gates' messages :func:`gate_records` recorded in ``report`` (in order)."""
    records = report.extra.get(GATES_KEY)
    if not isinstance(records, list):
        return []
    return [
        str(record["failure"])
        for record in records
        if isinstance(record, dict) and record.get("failure") is not None
    ]
