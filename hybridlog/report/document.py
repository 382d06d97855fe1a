"""The report of one run: a JSON-ready dict (``report.json``) and its Markdown rendering.

The dict has the keys of SPEC §8; everything that needs ground truth is ``None`` (``null``)
when the log has none, and every non-finite number becomes ``None`` so the JSON is strict.

Keys
----
``hybridlog_version, log, model, estimator, options, samples, dt, t_start, t_end,
outputs: {<y>: {mse, vaf}}, mse, vaf,
modes: {labels, switches: [{t, from, to}], dwell_s: {<mode>: s}, accuracy,
confusion: {<true mode>: {<estimated mode>: count}}, detection_delay_s, detection},
states: {<x>: {rmse}}, runtime_s, compile_s, samples_per_s, notes``

``modes.detection`` (``None`` without a true mode) holds the details behind
``detection_delay_s`` (the mean): ``{mean_s, max_s, detected, missed,
events: [{t, from, to, detected_t, delay_s}]}``, see
:func:`hybridlog.report.metrics.detection_delays`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from hybridlog import __version__
from hybridlog.estimators.result import EstimationResult
from hybridlog.report import metrics
from hybridlog.signals import AlignedSignals

__all__ = ["build_report", "check_compatible", "jsonable", "render_markdown", "report_json"]


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
                "detected_t": e.detected_t,
                "delay_s": e.delay_s,
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

    """
    check_compatible(result, signals)
    n = result.n_samples
    out_mse = metrics.mse(signals.outputs, result.output_predictions)
    out_vaf = metrics.vaf(signals.outputs, result.output_predictions)
    states: dict[str, Any] = {x: {"rmse": None} for x in result.state_names}
    if signals.truth_states is not None:
        rmse = metrics.state_rmse(result.state_means, signals.truth_states)
        for x, r in zip(result.state_names, rmse, strict=True):
            states[x]["rmse"] = _num(float(r))
    runtime = float(result.runtime_s)
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
            y: {"mse": _num(float(m)), "vaf": _num(float(v))}
            for y, m, v in zip(result.output_names, out_mse, out_vaf, strict=True)
        },
        "mse": _num(metrics.mean_of_finite(out_mse)),
        "vaf": _num(metrics.mean_of_finite(out_vaf)),
        "modes": _modes_section(result, signals, dt),
        "states": states,
        "runtime_s": runtime,
        "compile_s": float(result.compile_s),
        "samples_per_s": n / runtime if runtime > 0.0 else None,
        "notes": list(result.notes),
    }
    if extra:
        report.update(extra)
    cleaned: dict[str, Any] = jsonable(report)
    return cleaned


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


def render_markdown(report: Mapping[str, Any]) -> str:
    """Render a report for people (``report.md``, CI job summaries).

    Parameters
    ----------
    report:
        A report from :func:`build_report`.

    Returns
    -------
    str
        Markdown: title, run facts, per-output MSE/VAF table, mode summary (with accuracy,
        confusion matrix and detection delays when the true mode is known), state RMSE
        table, runtime and the estimator's notes.

    """
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
        "| output | MSE | VAF (%) |",
        "|---|---:|---:|",
    ]
    for y, m in dict(report.get("outputs") or {}).items():
        lines.append(f"| {_cell(y)} | {_fmt(m.get('mse'))} | {_fmt(m.get('vaf'), '.4f')} |")
    lines.append(
        f"| **mean** | **{_fmt(report.get('mse'))}** | **{_fmt(report.get('vaf'), '.4f')}** |"
    )

    modes: Mapping[str, Any] = report.get("modes") or {}
    labels = [str(m) for m in modes.get("labels") or []]
    switches = list(modes.get("switches") or [])
    dwell: Mapping[str, Any] = modes.get("dwell_s") or {}
    lines += ["", "## Modes", "", f"{len(switches)} estimated mode switches.", ""]
    lines += ["| mode | dwell (s) |", "|---|---:|"]
    lines += [f"| {_cell(m)} | {_fmt(dwell.get(m))} |" for m in labels]
    lines.append("")
    if modes.get("accuracy") is None:
        lines.append("No ground-truth mode in the log: accuracy and delays are not known.")
    else:
        lines.append(f"- mode accuracy: {_fmt(modes['accuracy'], '.4%')}")
        det: Mapping[str, Any] = modes.get("detection") or {}
        lines.append(
            f"- detection delay: mean {_fmt(modes.get('detection_delay_s'))} s, "
            f"max {_fmt(det.get('max_s'))} s "
            f"({det.get('detected', 0)} detected, {det.get('missed', 0)} missed)"
        )
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
            lines.append(
                f"| {_cell(t_id)} | " + " | ".join(str(row.get(e, 0)) for e in labels) + " |"
            )

    states: Mapping[str, Mapping[str, Any]] = report.get("states") or {}
    if states:
        lines += ["", "## States", "", "| state | RMSE |", "|---|---:|"]
        lines += [f"| {_cell(x)} | {_fmt(s.get('rmse'))} |" for x, s in states.items()]

    lines += [
        "",
        "## Runtime",
        "",
        f"- estimation: {_fmt(report.get('runtime_s'), '.3f')} s "
        f"({_fmt(report.get('samples_per_s'), '.4g')} samples/s)",
    ]
    if report.get("compile_s") is not None:
        lines.append(f"- compilation: {_fmt(report.get('compile_s'), '.3f')} s")
    notes = [str(note) for note in report.get("notes") or []]
    if notes:
        lines += ["", "## Notes", ""]
        lines += [f"- {note}" for note in notes]
    return "\n".join(lines) + "\n"
