"""State RMSE over a log whose true state is partial, absent or out of reach of the estimate."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from hybridlog.report import Report, build_report, render_markdown
from hybridlog.report.gates import evaluate_gates, parse_gates

from .test_report_files import DT, make_run

N = 400


def _report(truth_x1: np.ndarray, estimate_x1: np.ndarray | None = None):  # type: ignore[no-untyped-def]
    result, signals = make_run(N, seed=2)
    truth = signals.truth_states.copy()  # type: ignore[union-attr]
    truth[:, 0] = truth_x1
    means = result.state_means.copy()
    if estimate_x1 is not None:
        means[:, 0] = estimate_x1
    return build_report(
        dataclasses.replace(result, state_means=means),
        dataclasses.replace(signals, truth_states=truth),
        log="run.csv",
        model_name="tanks",
        dt=DT,
    ), means[:, 0]


@pytest.mark.parametrize("known", [1, 2, 37, N - 1])
def test_an_rmse_over_part_of_the_run_says_over_how_many_samples(known: int) -> None:
    rng = np.random.default_rng(known)
    truth = np.full(N, np.nan)
    rows = np.sort(rng.choice(N, size=known, replace=False))
    truth[rows] = rng.normal(size=known)
    report, estimate = _report(truth)
    state = report.states["x1"]
    assert state.samples == known
    expected = math.sqrt(float(np.mean((estimate[rows] - truth[rows]) ** 2)))
    assert state.rmse is not None and math.isclose(state.rmse, expected, rel_tol=1e-12)
    assert report.states["x3"].samples == N  # a whole true state: every row
    assert f"x1: RMSE over {known:,} of {N:,} samples" in render_markdown(report)
    assert "x3: RMSE over" not in render_markdown(report)
    again = Report.from_json(report.to_json())
    assert again.states == report.states
    assert json.loads(report.to_json())["states"]["x1"] == {"rmse": state.rmse, "samples": known}


def test_the_partial_rmse_line_points_at_warnings_only_where_there_are_some() -> None:
    truth = np.full(N, np.nan)
    truth[: N // 2] = 1.0
    report, _ = _report(truth)
    assert not any(note.startswith("WARNING: ") for note in report.notes)
    assert "see the warnings" not in render_markdown(report)
    warned = dataclasses.replace(report, notes=(*report.notes, "WARNING: x1 was not estimated"))
    assert "(not finite, or not estimated: see the warnings)" in render_markdown(warned)


def _no_truth() -> tuple[np.ndarray, None]:
    return np.full(N, np.nan), None


def _no_estimate() -> tuple[np.ndarray, np.ndarray]:
    truth = np.linspace(0.0, 1.0, N)
    estimate = np.full(N, np.nan)
    estimate[::2] = 1.0
    truth[::2] = np.nan  # the truth where the estimate is not, and the other way round
    return truth, estimate


def _diverged() -> tuple[np.ndarray, np.ndarray]:
    estimate = np.ones(N)
    estimate[N // 2 :] = np.inf
    return np.zeros(N), estimate


def _apart() -> tuple[np.ndarray, np.ndarray]:  # finite, but their difference overflows
    return np.full(N, -1.7e308), np.full(N, 1.7e308)


def _tiny() -> tuple[np.ndarray, np.ndarray]:  # an RMSE below float64's normal numbers
    return np.zeros(N), np.full(N, 1e-310)


@pytest.mark.parametrize(
    ("case", "samples", "why"),
    [
        (_no_truth, 0, "the log has no ground truth for state x1"),
        (_no_estimate, 0, "no sample has both a true value and a finite estimate of state x1"),
        (_diverged, N, "the estimate of state x1 diverged: its error overflows float64"),
        (
            _apart,
            N,
            "the estimate of state x1 and the truth differ by more than float64 holds in some "
            "rows, so RMSE is not computed",
        ),
        (
            _tiny,
            N,
            "the estimate of state x1 is off by at most 1e-310: RMSE ≈ 1e-310 is below "
            "float64's range (normal numbers from 2.2e-308)",
        ),
    ],
)
def test_an_undefined_rmse_says_why_and_fails_its_gates(case, samples: int, why: str) -> None:  # type: ignore[no-untyped-def]
    truth, estimate = case()
    report, _ = _report(truth, estimate)
    assert report.states["x1"].rmse is None
    assert report.states["x1"].samples == samples
    assert report.null_reasons["state_rmse.x1"] == why
    assert f"- state_rmse.x1 is n/a: {why}" in render_markdown(report)
    for gates in (
        parse_gates(fail_over=["state_rmse.x1=1e308"]),
        parse_gates(fail_under=["state_rmse.x1=0"]),
    ):
        (failure,) = evaluate_gates(report, gates)
        assert failure.startswith(f"state_rmse.x1 is not available ({why})")
    json.loads(report.to_json(), parse_constant=lambda c: pytest.fail(c))


@pytest.mark.parametrize("scale", [1e-300, 1e-200, 1e-150, 1.0, 1e150, 1e200, 1e300])
def test_an_rmse_scales_with_the_state_however_small_or_large(scale: float) -> None:
    """Errors of 1e-300 gave an RMSE of 0 (their squares underflow) and errors of 1e200
    an RMSE of null, "diverged" (their squares overflow): it is the error's size."""
    truth = np.linspace(0.0, 1.0, N)
    estimate = truth + np.where(np.arange(N) % 2, 0.5, -0.5)
    report, _ = _report(truth * scale, estimate * scale)
    rmse = report.states["x1"].rmse
    assert rmse is not None and math.isclose(rmse, 0.5 * scale, rel_tol=1e-12), (rmse, scale)
    assert "state_rmse.x1" not in report.null_reasons
