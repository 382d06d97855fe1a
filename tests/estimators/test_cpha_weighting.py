"""Paper 002 eqs. (4)-(5), (7), (21) on a case small enough to work out by hand.

One component with one state: mode ``a`` halves x, mode ``b`` holds it, ``y = x``; the
unknown mode drops the filter (P_O = 1, §3) and holds x with its variance grown.  The
expected beliefs below are a scalar Kalman filter per trajectory, written out here from the
paper's appendix (eqs. (12)-(21)) without the estimator's structural analysis or compiled
cluster filters, with every trajectory kept (the beam holds all nine at step 2) and the
beliefs of trajectories sharing an assignment summed, as ``mode_probabilities`` reports.
"""

import math

import numpy as np
import pytest

from hybridlog.estimators.cpha.options import UnknownModeOptions
from hybridlog.estimators.cpha.unknown_mode import run_unknown_mode
from hybridlog.model.loader import parse_model
from hybridlog.signals import AlignedSignals

SCALAR = """
name = "scalar"
dt = 1.0
states = ["x"]
inputs = ["u"]
outputs = ["y"]

[noise]
process = [0.04]
measurement = [0.09]

[initial]
state = [1.0]
covariance = 0.5

[components.C]
unknown = 0.1
initial = "a"

[components.C.modes.a]
equations = ["x[k] = 0.5*x[k-1] + 0*u[k-1]", "y = x"]

[components.C.modes.b]
equations = ["x[k] = x[k-1]", "y = x"]

[[components.C.transitions]]
from = "*"
to = {a = 0.2, b = 0.2}

[[components.C.transitions]]
from = "unknown"
to = {a = 0.3, b = 0.3}
"""

Q, R, GROWTH = 0.04, 0.09, 1.1
GAIN = {"a": 0.5, "b": 1.0}  # x[k] = GAIN * x[k-1]
# P_T(to | from): the "*" rule leaves 0.6 on the source, scaled by 1 - unknown = 0.9
TRANSITION = {
    "a": {"a": 0.72, "b": 0.18, "unknown": 0.1},
    "b": {"a": 0.18, "b": 0.72, "unknown": 0.1},
    "unknown": {"a": 0.3, "b": 0.3, "unknown": 0.4},
}


def successor(mode: str, x: float, p: float, y: float) -> tuple[float, float, float]:
    """``(x, P, log P_O)`` of one trajectory entering ``mode`` (eqs. (12)-(21), scalar)."""
    if mode == "unknown":  # no filter: P_O's upper bound 1, x held, variance grown
        return x, p * GROWTH, 0.0
    x_pred, p_pred = GAIN[mode] * x, GAIN[mode] ** 2 * p + Q  # (12)-(14)
    residual, s = y - x_pred, p_pred + R  # (15)-(17)
    gain = p_pred / s  # (18)
    return x_pred + gain * residual, (1.0 - gain) * p_pred, -(residual**2) / (2.0 * s)  # (19)-(21)


def hand_beliefs(ys: list[float]) -> list[dict[str, float]]:
    """Per step, the normalised belief of each assignment, all trajectories kept."""
    trajectories = [("a", 1.0, 0.5, 1.0)]  # initial = "a": belief 1
    beliefs = [{"a": 1.0}]
    for y in ys:
        grown = []
        for mode, x, p, h in trajectories:
            for target, p_t in TRANSITION[mode].items():
                x_new, p_new, log_po = successor(target, x, p, y)
                grown.append((target, x_new, p_new, p_t * h * math.exp(log_po)))  # (4), (5)
        total = sum(t[3] for t in grown)
        trajectories = [(m, x, p, h / total) for m, x, p, h in grown]
        summed: dict[str, float] = {}
        for mode, _, _, h in trajectories:
            summed[mode] = summed.get(mode, 0.0) + h
        beliefs.append(summed)
    return beliefs


def test_beliefs_are_eqs_4_and_5_with_the_unknown_mode_at_its_upper_bound() -> None:
    model = parse_model(SCALAR)
    ys = [0.7, 0.2]
    signals = AlignedSignals(
        "hand",
        np.arange(3.0),
        model.inputs,
        model.outputs,
        np.zeros((3, 1)),
        np.array([[1.0], *([y] for y in ys)]),
    )
    result = run_unknown_mode(model, signals, UnknownModeOptions(beam=9, variance_growth=GROWTH))
    expected = hand_beliefs(ys)
    # step 1 by hand: 0.72 e^{-0.2²/(2·0.255)}, 0.18 e^{-0.3²/(2·0.63)}, 0.1 · 1, normalised
    assert expected[1]["a"] == pytest.approx(0.665685 / 0.933276, abs=1e-6)
    for k, beliefs in enumerate(expected):
        got = dict(zip(result.mode_ids, result.mode_probabilities[k], strict=True))
        for mode in result.mode_ids:
            assert got[mode] == pytest.approx(beliefs.get(mode, 0.0), rel=1e-9, abs=1e-12)
    # the hybrid estimate is the most likely trajectory's (§2.2): at step 1 mode a's filter
    x_a, p_a, _ = successor("a", 1.0, 0.5, ys[0])
    assert result.mode_ids[result.modes[1]] == "a"
    assert result.state_means[1, 0] == pytest.approx(x_a, rel=1e-12)
    assert result.state_variances[1, 0] == pytest.approx(p_a, rel=1e-12)
