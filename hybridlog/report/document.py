"""The report of one run: a JSON-ready dict (``report.json``) and its Markdown rendering.

The dict has the keys of SPEC §8; everything that needs ground truth is ``None`` (``null``)
when the log has none, and every non-finite number becomes ``None`` so the JSON is strict.
Every gate metric that is ``null`` gets a one-sentence reason in ``null_reasons``.

Keys
----
``hybridlog_version, log, model, estimator, options, samples, dt, t_start, t_end,
outputs: {<y>: {mse, vaf, fit, samples}}, mse, vaf, fit,
modes: {labels, switches: [{t, from, to}], dwell_s: {<mode>: s}, accuracy,
confusion: {<true mode>: {<estimated mode>: count}}, detection_delay_s, detection},
states: {<x>: {rmse}}, runtime_s, compile_s, samples_per_s, notes, null_reasons``

``outputs.<y>.samples`` counts the rows the output metrics use (a measurement and a
one-step-ahead prediction); ``mse``, ``vaf`` and ``fit`` at the top are the means over the
outputs where the metric is defined.  ``null_reasons`` maps gate metric names (``vaf``,
``fit.y1``, ``mode_accuracy``, ``state_rmse.x2``, ...; see :mod:`hybridlog.report.gates`)
to why the report holds ``null`` for them.

``modes.detection`` (``None`` without a true mode) holds the details behind
``detection_delay_s`` (the mean): ``{mean_s, max_s, detected, missed,
events: [{t, from, to, detected, detected_t, delay_s, miss_reason}]}``, see
:func:`hybridlog.report.metrics.detection_delays`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from hybridlog import __version__
from hybridlog.errors import LogError
from hybridlog.estimators.result import EstimationResult
from hybridlog.report import metrics
from hybridlog.signals import AlignedSignals

__all__ = [
    "MIN_SAMPLES",
    "build_report",
    "check_compatible",
    "duration",
    "jsonable",
    "plural",
    "rate",
    "render_markdown",
    "report_json",
]

MIN_SAMPLES = 3
"""Fewest samples a run must have to be reported: row 0 is the estimators' prior (no
prediction), and VAF and fit compare spreads, which a single predicted sample does not have."""

MAX_LISTED_SWITCHES = 50
"""``report.md`` lists at most this many true switches (``report.json`` has all of them)."""


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

    Parameters
    ----------
    result:
        The estimation result.
    signals:
        The aligned signals it was computed from.

    Raises
    ------
    ValueError
        When sample counts, output columns or truth shapes disagree (a programming error,
        not a user error).

    """
    n = result.n_samples
    if signals.n_samples != n:
        raise ValueError(f"result has {n} samples but the signals have {signals.n_samples}")
    n_y = len(result.output_names)
    if signals.outputs.shape != (n, n_y) or result.output_predictions.shape != (n, n_y):
        raise ValueError(
            f"outputs have shape {signals.outputs.shape} and predictions "
            f"{result.output_predictions.shape}; expected {(n, n_y)}"
        )
    n_x = len(result.state_names)
    if result.state_means.shape != (n, n_x) or result.state_variances.shape != (n, n_x):
        raise ValueError(f"state means/variances do not have shape {(n, n_x)}")
    if result.mode_probabilities.shape != (n, len(result.mode_ids)):
        raise ValueError(f"mode probabilities do not have shape {(n, len(result.mode_ids))}")
    if signals.truth_modes is not None and signals.truth_modes.shape != (n,):
        raise ValueError(f"truth modes have shape {signals.truth_modes.shape}; expected {(n,)}")
    if signals.truth_states is not None and signals.truth_states.shape != (n, n_x):
        raise ValueError(
            f"truth states have shape {signals.truth_states.shape}; expected {(n, n_x)}"
        )


def _modes_section(result: EstimationResult, signals: AlignedSignals, dt: float) -> dict[str, Any]:
    ids = tuple(str(m) for m in result.mode_ids)
    dwell = metrics.dwell_times(result.time, result.modes, len(ids), dt)
    section: dict[str, Any] = {
        "labels": list(ids),
        "switches": [dict(s) for s in metrics.mode_switches(result.time, result.modes, ids)],
        "dwell_s": {m: float(d) for m, d in zip(ids, dwell, strict=True)},
        "accuracy": None,
        "confusion": None,
        "detection_delay_s": None,
        "detection": None,
    }
    truth = signals.truth_modes
    if truth is None:
        return section
    section["accuracy"] = _num(metrics.mode_accuracy(result.modes, truth))
    counts = metrics.confusion_matrix(result.modes, truth, len(ids))
    section["confusion"] = {
        t_id: {e_id: int(counts[i, j]) for j, e_id in enumerate(ids)} for i, t_id in enumerate(ids)
    }
    det = metrics.detection_delays(result.time, result.modes, truth, ids)
    section["detection_delay_s"] = _num(det.mean_s)
    section["detection"] = {
        "mean_s": _num(det.mean_s),
        "max_s": _num(det.max_s),
        "detected": det.detected,
        "missed": det.missed,
        "events": [
            {
                "t": e.t,
                "from": e.from_mode,
                "to": e.to_mode,
                "detected": e.detected,
                "detected_t": e.detected_t,
                "delay_s": e.delay_s,
                "miss_reason": e.miss_reason,
            }
            for e in det.events
        ],
    }
    return section


def build_report(
    result: EstimationResult,
    signals: AlignedSignals,
    *,
    log: str,
    model_name: str,
    dt: float,
    extra: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """Compute every metric of a run and assemble the ``report.json`` dict.

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
    extra:
        Additional top-level keys; they replace computed keys of the same name.

    Returns
    -------
    dict
        JSON-ready (strict: no NaN) report; see the module docstring for the keys.

    Raises
    ------
    LogError
        When the run has fewer than :data:`MIN_SAMPLES` samples (naming ``log``).

    """
    check_compatible(result, signals)
    n = result.n_samples
    if n < MIN_SAMPLES:
        raise LogError(
            f"{log}: too short: {plural(n, 'sample')} on the model's grid (dt = {dt:g} s); "
            f"a report needs at least {MIN_SAMPLES}: the first sample is the prior, and VAF "
            "and fit need the spread of at least two predicted samples"
        )
    per_output = dict(
        zip(
            result.output_names,
            metrics.output_metrics(signals.outputs, result.output_predictions),
            strict=True,
        )
    )
    states: dict[str, Any] = {x: {"rmse": None} for x in result.state_names}
    if signals.truth_states is not None:
        rmse = metrics.state_rmse(result.state_means, signals.truth_states)
        for x, r in zip(result.state_names, rmse, strict=True):
            states[x]["rmse"] = _num(float(r))
    runtime = float(result.runtime_s)
    modes = _modes_section(result, signals, dt)
    report: dict[str, Any] = {
        "hybridlog_version": __version__,
        "log": str(log),
        "model": model_name,
        "estimator": result.estimator,
        "options": jsonable(result.options),
        "samples": n,
        "dt": float(dt),
        "t_start": float(result.time[0]) if n else None,
        "t_end": float(result.time[-1]) if n else None,
        "outputs": {
            y: {"mse": _num(m.mse), "vaf": _num(m.vaf), "fit": _num(m.fit), "samples": m.samples}
            for y, m in per_output.items()
        },
        "mse": _num(metrics.mean_of_finite([m.mse for m in per_output.values()])),
        "vaf": _num(metrics.mean_of_finite([m.vaf for m in per_output.values()])),
        "fit": _num(metrics.mean_of_finite([m.fit for m in per_output.values()])),
        "modes": modes,
        "states": states,
        "runtime_s": runtime,
        "compile_s": float(result.compile_s),
        "samples_per_s": n / runtime if runtime > 0.0 else None,
        "notes": list(result.notes),
    }
    report["null_reasons"] = _null_reasons(report, per_output, signals)
    if extra:
        report.update(extra)
    cleaned: dict[str, Any] = jsonable(report)
    return cleaned


def _null_reasons(
    report: Mapping[str, Any],
    per_output: Mapping[str, metrics.OutputMetrics],
    signals: AlignedSignals,
) -> dict[str, str]:
    """Why each gate metric that is ``null`` in ``report`` is null (keys as in gates)."""
    reasons: dict[str, str] = {}
    for name in ("mse", "vaf", "fit"):
        for y, m in per_output.items():
            if name in m.undefined:
                reasons[f"{name}.{y}"] = m.undefined[name]
        if report[name] is None and per_output:
            y, m = next(iter(per_output.items()))
            reasons[name] = f"undefined for every output ({y}: {m.undefined.get(name)})"
    modes = report["modes"]
    if signals.truth_modes is None:
        for name in ("mode_accuracy", "detection_delay_s", "missed_switches"):
            reasons[name] = "the log has no ground-truth mode"
    elif modes["detection_delay_s"] is None:
        events = modes["detection"]["events"]
        reasons["detection_delay_s"] = (
            "the true mode never switches"
            if not events
            else f"every true switch ({len(events)}) was missed"
        )
    for x, value in report["states"].items():
        if value["rmse"] is None:
            reasons[f"state_rmse.{x}"] = f"the log has no ground truth for state {x}"
    if report["samples_per_s"] is None:
        reasons["samples_per_s"] = "the runtime was too short to measure"
    return reasons


def report_json(report: Mapping[str, Any]) -> str:
    """Serialise a report as strict JSON (``NaN`` is never written).

    Parameters
    ----------
    report:
        A report from :func:`build_report`.

    Returns
    -------
    str
        Indented JSON text ending in a newline.

    """
    return json.dumps(jsonable(report), indent=2, allow_nan=False) + "\n"


def _fmt(value: Any, spec: str = ".6g") -> str:
    if value is None:
        return "n/a"
    if isinstance(value, float):
        return format(value, spec)
    return str(value)


def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def plural(count: int, noun: str, plural_form: str | None = None) -> str:
    """``"1 switch"``, ``"2 switches"``: a count with its noun in agreement.

    Parameters
    ----------
    count:
        How many.
    noun:
        The singular noun (or noun phrase ending in the noun).
    plural_form:
        The plural when it is not ``noun + "s"`` (``"es"`` after s, x, ch, sh).

    Returns
    -------
    str
        E.g. ``"1 estimated mode switch"``, ``"0 estimated mode switches"``.

    """
    if count == 1:
        return f"{count} {noun}"
    if plural_form is None:
        plural_form = noun + ("es" if noun.endswith(("s", "x", "ch", "sh")) else "s")
    return f"{count:,} {plural_form}"


def duration(seconds: float | None) -> str:
    """A duration for people, with three significant digits and a unit that fits.

    ``0.00031`` → ``"0.31 ms"``, ``2.5e-6`` → ``"2.5 µs"``, ``12.345`` → ``"12.3 s"``,
    ``None`` → ``"n/a"``.
    """
    if seconds is None or not math.isfinite(seconds):
        return "n/a"
    magnitude = abs(seconds)
    for unit, scale in (("s", 1.0), ("ms", 1e-3), ("µs", 1e-6)):
        if magnitude >= scale:
            return f"{seconds / scale:.3g} {unit}"
    return f"{seconds * 1e9:.3g} ns" if magnitude > 0 else "0 s"


def rate(per_second: float | None, noun: str) -> str:
    """``1234567.8`` → ``"1,234,568 samples/s"`` (``"n/a"`` when unknown)."""
    if per_second is None or not math.isfinite(per_second):
        return "n/a"
    return f"{per_second:,.0f} {noun}/s" if per_second >= 100 else f"{per_second:.3g} {noun}/s"


DEFINITIONS = (
    "MSE = mean((y − ŷ)²) and VAF = max(1 − var(y − ŷ)/var(ŷ), 0)·100 % (paper 001) use the "
    "one-step-ahead prediction ŷ(k), made before y(k) is used; the first sample (the prior) "
    "has none.",
    "Fit = (1 − ‖y − ŷ‖/‖y − mean(y)‖)·100 % (MATLAB `compare`'s NRMSE): 100 is perfect, "
    "0 no better than the mean of y, negative worse. Unlike VAF, its denominator does not "
    "depend on the prediction, so a worse predictor cannot score higher.",
    "A metric is n/a (null) when undefined, with the reason given: VAF when var(ŷ) = 0, fit "
    "when y is constant. The top rows are the means over the outputs where it is defined.",
    "Mode accuracy: the fraction of all samples whose estimated mode is the true one.",
    "Detection delay: from a true switch to the first estimated change *into* the new mode at "
    "or after it, before the next true switch. An estimate that was already in that mode "
    "before the switch has not detected it: a miss, as is a switch never followed by such a "
    "change. The mean and max are over the detected switches.",
)


def render_markdown(report: Mapping[str, Any]) -> str:
    """Render a report for people (``report.md``, CI job summaries).

    Parameters
    ----------
    report:
        A report from :func:`build_report`.

    Returns
    -------
    str
        Markdown: title, run facts, per-output MSE/VAF/fit table (with why a metric is
        n/a), mode summary (with accuracy, confusion matrix and every true switch with its
        detection or why it was missed, when the true mode is known), state RMSE table,
        runtime, the estimator's notes and the definitions of the metrics.

    """
    reasons: Mapping[str, str] = report.get("null_reasons") or {}
    lines: list[str] = [
        f"# hybridlog report: {_cell(str(report.get('log')))}",
        "",
        f"- model: `{report.get('model')}`, estimator: `{report.get('estimator')}`",
        f"- samples: {report.get('samples')}, dt = {_fmt(report.get('dt'))} s, "
        f"t = {_fmt(report.get('t_start'))} … {_fmt(report.get('t_end'))} s",
        f"- hybridlog {report.get('hybridlog_version')}",
        "",
        "## Outputs",
        "",
        "| output | MSE | VAF (%) | fit (%) |",
        "|---|---:|---:|---:|",
    ]
    outputs: Mapping[str, Mapping[str, Any]] = report.get("outputs") or {}
    for y, m in outputs.items():
        lines.append(
            f"| {_cell(y)} | {_fmt(m.get('mse'))} | {_fmt(m.get('vaf'), '.4f')} "
            f"| {_fmt(m.get('fit'), '.4f')} |"
        )
    lines.append(
        f"| **mean** | **{_fmt(report.get('mse'))}** | **{_fmt(report.get('vaf'), '.4f')}** "
        f"| **{_fmt(report.get('fit'), '.4f')}** |"
    )
    undefined = [
        f"- {name} is n/a: {why}"
        for name, why in reasons.items()
        if name.partition(".")[0] in ("mse", "vaf", "fit")
    ]
    expected = int(report.get("samples") or 0) - 1  # every sample after the prior
    undefined += [
        f"- {y}: metrics over {m['samples']:,} of {expected:,} samples; the others have no "
        "finite measurement or prediction"
        for y, m in outputs.items()
        if isinstance(m.get("samples"), int) and m["samples"] < expected
    ]
    if undefined:
        lines += ["", *undefined]

    modes: Mapping[str, Any] = report.get("modes") or {}
    labels = [str(m) for m in modes.get("labels") or []]
    switches = list(modes.get("switches") or [])
    dwell: Mapping[str, Any] = modes.get("dwell_s") or {}
    lines += ["", "## Modes", "", f"{plural(len(switches), 'estimated mode switch')}.", ""]
    lines += ["| mode | dwell (s) |", "|---|---:|"]
    lines += [f"| {_cell(m)} | {_fmt(dwell.get(m))} |" for m in labels]
    lines.append("")
    if modes.get("accuracy") is None:
        lines.append("No ground-truth mode in the log: accuracy and delays are not known.")
    else:
        lines += _truth_lines(modes, labels)

    states: Mapping[str, Mapping[str, Any]] = report.get("states") or {}
    if states:
        lines += ["", "## States", "", "| state | RMSE |", "|---|---:|"]
        lines += [f"| {_cell(x)} | {_fmt(s.get('rmse'))} |" for x, s in states.items()]

    samples_per_s = report.get("samples_per_s")
    lines += [
        "",
        "## Runtime",
        "",
        f"- estimation: {duration(report.get('runtime_s'))} ({rate(samples_per_s, 'samples')})",
    ]
    if report.get("compile_s") is not None:
        lines.append(f"- compilation: {duration(report.get('compile_s'))}")
    notes = [str(note) for note in report.get("notes") or []]
    if notes:
        lines += ["", "## Notes", ""]
        lines += [f"- {note}" for note in notes]
    lines += ["", "## How the metrics are defined", ""]
    lines += [f"- {text}" for text in DEFINITIONS]
    return "\n".join(lines) + "\n"


def _truth_lines(modes: Mapping[str, Any], labels: list[str]) -> list[str]:
    """Accuracy, detection of every true switch, and the confusion matrix."""
    det: Mapping[str, Any] = modes.get("detection") or {}
    events: list[Mapping[str, Any]] = list(det.get("events") or [])
    detected = int(det.get("detected", 0))
    missed = int(det.get("missed", 0))
    lines = [
        f"- mode accuracy: {_fmt(modes['accuracy'], '.4%')}",
        f"- {plural(len(events), 'true mode switch')}: {detected:,} detected, {missed:,} missed"
        + (
            f"; detection delay mean {_fmt(modes.get('detection_delay_s'))} s, "
            f"max {_fmt(det.get('max_s'))} s"
            if modes.get("detection_delay_s") is not None
            else ""
        ),
    ]
    if events:
        lines += ["", "| true switch at (s) | from → to | detected at (s) | delay (s) |"]
        lines.append("|---:|---|---|---:|")
        for e in events[:MAX_LISTED_SWITCHES]:
            found = e.get("detected_t")
            when = _fmt(found) if found is not None else f"missed: {e.get('miss_reason')}"
            lines.append(
                f"| {_fmt(e.get('t'))} | {_cell(str(e.get('from')))} → {_cell(str(e.get('to')))} "
                f"| {_cell(when)} | {_fmt(e.get('delay_s'))} |"
            )
        if len(events) > MAX_LISTED_SWITCHES:
            lines.append(f"\n… and {len(events) - MAX_LISTED_SWITCHES:,} more in report.json.")
    confusion: Mapping[str, Mapping[str, Any]] = modes.get("confusion") or {}
    lines += [
        "",
        "Confusion (rows: true mode, columns: estimated mode, sample counts):",
        "",
        "| true \\ estimated | " + " | ".join(_cell(m) for m in labels) + " |",
        "|---|" + "---:|" * len(labels),
    ]
    for t_id in labels:
        row = confusion.get(t_id, {})
        lines.append(f"| {_cell(t_id)} | " + " | ".join(str(row.get(e, 0)) for e in labels) + " |")
    return lines
