"""Why each gate metric that is ``None`` in a report is (its ``null_reasons``).

:func:`null_reasons`: per output metric, mean over the outputs, mode metric (of each
component too), state RMSE and ``samples_per_s``, the reason it has no value.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from hybridlog.report import metrics
from hybridlog.report.markdown import NO_TRUE_MODE_REASON, NO_TRUE_STATE_REASON
from hybridlog.report.report_parts import ModeReport, StateReport
from hybridlog.signals import AlignedSignals

__all__ = ["null_reasons"]


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
    undetermined = modes.detection.undetermined
    if undetermined:
        return (
            f"no true switch{of} ({len(events)}) was detected: {modes.detection.missed} missed, "
            f"{undetermined} undetermined (the true mode's record stops before they could be "
            "told detected or missed)"
        )
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


def null_reasons(
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
    (:meth:`~hybridlog.report.state_error.StateAccumulator.undefined`); ``held``: per state, the
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
