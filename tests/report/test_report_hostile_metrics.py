"""A run whose prediction or estimate went infinite is scored as diverged, not on its rest."""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Callable
from fractions import Fraction

import numpy as np
import pytest

from hybridlog.report import build_report, metrics, render_markdown
from hybridlog.report.gates import evaluate_gates, parse_gates

from .test_report_files import DT, make_run

N = 300
DIVERGED = "the prediction diverged (infinite in some rows): its error overflows float64"


@pytest.mark.parametrize(
    "rows", [slice(1, 2), slice(100, 150), slice(N - 1, N), slice(1, N)], ids=repr
)
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_an_infinite_prediction_fails_every_output_gate(rows: slice, sign: float) -> None:
    result, signals = make_run(N, seed=4)
    predicted = result.output_predictions.copy()
    predicted[rows, 0] = sign * np.inf
    predicted[5:8, 0] = np.nan  # no prediction made: left out, as before
    report = build_report(
        dataclasses.replace(result, output_predictions=predicted),
        signals,
        log="run.csv",
        model_name="m",
        dt=DT,
    )
    y1 = report.outputs["y1"]
    assert (y1.mse, y1.fit, y1.vaf) == (None, None, 0.0)
    assert y1.samples == N - 1 - 3  # the infinite rows count; row 0 and the NaN ones do not
    assert report.null_reasons["mse.y1"] == report.null_reasons["fit.y1"] == DIVERGED
    assert report.mse is None and report.fit is None  # the mean never leaves it out
    assert (
        report.null_reasons["mse"] == f"the mean over the outputs is infinite: mse.y1: {DIVERGED}"
    )
    assert report.outputs["y2"].mse is not None
    gates = parse_gates(fail_under=["fit=-1e9", "vaf.y1=1", "fit.y1=-1e9"], fail_over=["mse=1e9"])
    failures = evaluate_gates(report, gates)
    assert [f.split(" ")[0] for f in failures] == ["fit", "vaf.y1", "fit.y1", "mse"]
    assert f"mse.y1 is n/a: {DIVERGED}" in render_markdown(report)
    json.loads(report.to_json(), parse_constant=lambda c: pytest.fail(c))


def test_an_infinite_state_estimate_is_a_diverged_rmse() -> None:
    result, signals = make_run(N, seed=4)
    means = result.state_means.copy()
    means[200:, 2] = np.inf
    means[10:20, 2] = np.nan  # no estimate: left out
    report = build_report(
        dataclasses.replace(result, state_means=means),
        signals,
        log="run.csv",
        model_name="m",
        dt=DT,
    )
    assert report.states["x3"].rmse is None and report.states["x3"].samples == N - 10
    assert report.null_reasons["state_rmse.x3"] == (
        "the estimate of state x3 diverged: its error overflows float64"
    )
    (failure,) = evaluate_gates(report, parse_gates(fail_over=["state_rmse.x3=1e300"]))
    assert "diverged" in failure


def _alternating(n: int, size: float) -> np.ndarray:
    return np.where(np.arange(n) % 2 == 0, size, -size)


@pytest.mark.parametrize(
    ("metric", "measured", "predicted"),
    [
        # errors of 1.3e154 in both outputs: each MSE 1.69e308, their sum beyond float64
        ("mse", lambda n: np.zeros(n), lambda n: _alternating(n, 1.3e154)),
        # a spread of 7.5e-163 against errors of 1e144: each fit -1.33e308 %
        ("fit", lambda n: _alternating(n, 7.5e-163), lambda n: np.full(n, 1e144)),
    ],
    ids=["mse", "fit"],
)
def test_a_mean_over_the_outputs_whose_sum_overflows_is_a_number(
    metric: str, measured: Callable[[int], np.ndarray], predicted: Callable[[int], np.ndarray]
) -> None:
    result, signals = make_run(N, seed=4)
    y = np.column_stack([measured(N), measured(N)])
    y_hat = np.column_stack([predicted(N), predicted(N)])
    y_hat[0] = np.nan
    report = build_report(
        dataclasses.replace(result, output_predictions=y_hat),
        dataclasses.replace(signals, outputs=y),
        log="run.csv",
        model_name="m",
        dt=DT,
    )
    each = getattr(report.outputs["y1"], metric)
    assert each is not None and abs(each) > 0.9e308  # two of them overflow a sum
    assert getattr(report.outputs["y2"], metric) == each
    assert getattr(report, metric) == each  # the mean of two equal values: "numerical trouble"
    assert metric not in report.null_reasons
    json.loads(report.to_json(), parse_constant=lambda c: pytest.fail(c))


@pytest.mark.parametrize(
    "values",
    [[1.5e308, 1.5e308], [-1.3e308, -1.7e308, -1.7e308], [1e308] * 10 + [math.nan], [1.7e308, 1.0]],
    ids=repr,
)
def test_the_mean_where_defined_never_overflows_its_sum(values: list[float]) -> None:
    defined = [v for v in values if not math.isnan(v)]
    exact = sum(Fraction(v) for v in defined) / len(defined)
    assert metrics.mean_where_defined(values) == pytest.approx(float(exact), rel=1e-15)
