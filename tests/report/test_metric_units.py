"""Output and state metrics in any unit of the signals (scaled by 10^k, k in -300..300).

A log in units of 1e-300 got ``fit = -1.05e301``, and one of errors of 1e200 an MSE of
``null, "the prediction diverged"`` beside a finite fit: the squares underflowed or
overflowed float64 where the metrics themselves did not.  VAF and fit do not depend on the
unit; MSE scales with its square and RMSE with it, or is ``null`` with a reason saying that
float64 cannot hold it (never 0 and never "diverged").
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from hybridlog.report import build_report, metrics, state_error

from .test_report_files import DT, make_run

SMALLEST, LARGEST = 2.2250738585072014e-308, 1.7976931348623157e308

# Whole numbers: scaled by 10^k (k in -300..300) they stay normal, distinct ones distinct,
# and a spread is at least 1/2000 of the magnitude (the rounding of scaling stays small).
whole = st.integers(-1000, 1000).map(float)
runs = st.integers(2, 40).flatmap(
    lambda n: st.tuples(
        hnp.arrays(np.float64, (n, 2), elements=whole),
        hnp.arrays(np.float64, (n, 2), elements=whole),
    )
)


@given(runs, st.integers(-300, 300))
@settings(max_examples=300, deadline=None)
def test_vaf_and_fit_do_not_depend_on_the_unit_and_mse_scales_with_its_square(
    run: tuple[np.ndarray, np.ndarray], k: int
) -> None:
    y, y_hat = run
    scale = 10.0**k
    plain = metrics.output_metrics(y, y_hat)
    scaled = metrics.output_metrics(y * scale, y_hat * scale)
    for p, s in zip(plain, scaled, strict=True):
        for name in ("vaf", "fit"):
            a, b = getattr(p, name), getattr(s, name)
            assert math.isnan(a) == math.isnan(b), (name, a, b)
            if not math.isnan(a):
                assert abs(a - b) <= 1e-8 * (1.0 + abs(a)), (name, a, b, k)
        assert s.undefined.get("vaf") == p.undefined.get("vaf")
        assert s.undefined.get("fit") == p.undefined.get("fit")
        if p.mse == 0.0:
            assert s.mse == 0.0
            continue
        digits = math.log10(p.mse) + 2 * k  # of the scaled MSE
        if math.log10(2 * SMALLEST) < digits < math.log10(LARGEST / 2):
            assert s.mse == pytest.approx(p.mse * 10.0 ** (digits - math.log10(p.mse)), rel=1e-12)
            assert "mse" not in s.undefined
        elif digits > math.log10(LARGEST) or digits < math.log10(SMALLEST):
            assert not math.isfinite(s.mse) and s.out_of_range == {"mse"}
            side = "beyond" if digits > 0 else "below"
            assert f"is {side} float64's range" in s.undefined["mse"], s.undefined
            assert "diverged" not in s.undefined["mse"]


@given(runs, st.integers(-300, 300))
@settings(max_examples=100, deadline=None)
def test_state_rmse_scales_with_the_unit(run: tuple[np.ndarray, np.ndarray], k: int) -> None:
    truth, estimate = run
    scale = 10.0**k
    plain = state_error.state_rmse(estimate, truth)
    scaled = state_error.state_rmse(estimate * scale, truth * scale)
    for p, s in zip(plain, scaled, strict=True):
        if p == 0.0:
            assert s == 0.0
        else:  # RMSE >= 1/√40 · 10^k > 2.2e-308: always held
            assert s == pytest.approx(p * scale, rel=1e-12)


@pytest.mark.parametrize("k", [-300, -200, -160, 160, 200, 300])
def test_a_report_in_any_unit_has_the_vaf_and_fit_of_plain_units(k: int) -> None:
    result, signals = make_run(200, seed=3)
    scale = 10.0**k
    report = build_report(
        dataclasses.replace(
            result,
            output_predictions=result.output_predictions * scale,
            state_means=result.state_means * scale,
        ),
        dataclasses.replace(
            signals,
            outputs=signals.outputs * scale,
            truth_states=None if signals.truth_states is None else signals.truth_states * scale,
        ),
        log="run.csv",
        model_name="m",
        dt=DT,
    )
    plain = build_report(result, signals, log="run.csv", model_name="m", dt=DT)
    assert report.vaf == pytest.approx(plain.vaf, rel=1e-10)
    assert report.fit == pytest.approx(plain.fit, rel=1e-10)
    for name, state in report.states.items():
        expected = plain.states[name].rmse
        assert state.rmse == (None if expected is None else pytest.approx(expected * scale))
    # MSE of 10^k-sized errors is 10^2k: beyond float64's range or below it, never 0
    assert report.mse is None and report.outputs["y1"].mse is None
    side = "beyond" if k > 0 else "below"
    assert f"is {side} float64's range" in report.null_reasons["mse.y1"]
    assert report.null_reasons["mse"].startswith(
        "a mean over the outputs cannot leave out mse.y1, which float64 cannot hold: MSE ≈ "
    )
