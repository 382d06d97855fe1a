"""Metrics of hybridlog.report.metrics: hand-computed cases and hypothesis properties."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import numpy.typing as npt
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from hybridlog.report import Report, build_report, metrics, mode_metrics, state_error
from hybridlog.report.markdown import render_markdown
from hybridlog.times import format_time

from .test_report_files import DT, make_run

NAN = float("nan")


# --- MSE / VAF (paper 001, section 5) -------------------------------------------------------


def test_mse_and_vaf_by_hand() -> None:
    y = np.array([1.0, 2.0, 3.0, 4.0])
    y_hat = np.array([NAN, 2.0, 2.0, 5.0])  # row 0: no prediction, ignored
    # errors over rows 1..3: [0, 1, -1] -> MSE 2/3; var(e) = 2/3; var(ŷ) = var([2,2,5]) = 2
    assert metrics.mse(y, y_hat) == pytest.approx([2.0 / 3.0], rel=1e-15)
    assert metrics.vaf(y, y_hat) == pytest.approx([(1.0 - (2.0 / 3.0) / 2.0) * 100.0], rel=1e-15)


def test_vaf_uses_variance_of_prediction_not_of_measurement() -> None:
    y = np.array([0.0, 1.0, 2.0, 3.0])
    y_hat = np.array([0.0, 0.0, 4.0, 4.0])
    e = y - y_hat
    expected = (1.0 - np.var(e) / np.var(y_hat)) * 100.0
    wrong = (1.0 - np.var(e) / np.var(y)) * 100.0
    assert expected != pytest.approx(wrong)
    assert metrics.vaf(y, y_hat)[0] == pytest.approx(expected, rel=1e-15)


def test_vaf_is_clamped_at_zero() -> None:
    y_hat = np.array([1.0, -1.0, 1.0, -1.0])
    y = -y_hat  # e = -2ŷ: var(e) = 4 var(ŷ)
    assert metrics.vaf(y, y_hat)[0] == 0.0


# var(ŷ) = 0 leaves VAF undefined (issue 7: a 2-row log scored "VAF 100 %").  These cases
# were 100, 100 and 0 (the limits) before; the contract is now NaN with a reason.
@pytest.mark.parametrize(
    ("y", "y_hat"),
    [
        ([3.0, 3.0, 3.0], [3.0, 3.0, 3.0]),  # constant and exact
        ([5.0, 5.0, 5.0], [3.0, 3.0, 3.0]),  # constant offset: error variance 0
        ([1.0, 2.0, 3.0], [2.0, 2.0, 2.0]),  # var(ŷ) = 0 but the error varies
        ([NAN, 7.0], [NAN, 6.0]),  # a 2-row log: one predicted sample
    ],
)
def test_vaf_with_constant_prediction_is_undefined(y: list[float], y_hat: list[float]) -> None:
    assert math.isnan(metrics.vaf(np.array(y), np.array(y_hat))[0])
    (m,) = metrics.output_metrics(np.array(y), np.array(y_hat))
    assert math.isnan(m.vaf)
    assert "var(ŷ) = 0" in m.undefined["vaf"]
    assert "mse" not in m.undefined  # MSE is defined for a single sample


# A constant prediction mixed from equal per-mode ones (imm: sum(c_j * ŷ_j), the weights' sum
# 1 to a few ulps) varies by rounding alone; it scored VAF 0 % (a ratio to var(ŷ) ~ 1e-32)
# where the same prediction, exactly constant (hstf), was undefined.
@pytest.mark.parametrize("centre", [1.0, -3.5e7, 1e-300, 1e300])
def test_vaf_of_a_prediction_constant_but_for_rounding_is_undefined(centre: float) -> None:
    jitter = np.array([0.0, 1.0, -1.0, 2.0, 0.0, -1.0]) * math.ulp(centre)
    y_hat = centre + jitter
    assert np.ptp(y_hat) > 0.0
    y = centre + np.array([0.3, -0.2, 0.1, 0.4, -0.5, 0.2]) * abs(centre)
    (m,) = metrics.output_metrics(y, y_hat)
    assert math.isnan(m.vaf)
    assert m.undefined["vaf"].startswith("var(ŷ) = 0: the prediction is the same to rounding")


@pytest.mark.parametrize(
    "y_hat",
    [
        1.0 + np.array([0.0, 1.0, 2.0, 3.0]) * 1e3 * math.ulp(1.0),  # 3,000 ulps: a value
        np.array([5e-324, 1e-323, 5e-324, 1.5e-323]),  # subnormal: ulps are its values
    ],
)
def test_vaf_of_a_prediction_varying_beyond_rounding_is_a_number(
    y_hat: npt.NDArray[np.float64],
) -> None:
    (m,) = metrics.output_metrics(y_hat.copy(), y_hat)
    assert m.vaf == 100.0
    assert "vaf" not in m.undefined


def test_fit_by_hand() -> None:
    y = np.array([NAN, 1.0, 2.0, 3.0, 6.0])
    y_hat = np.array([NAN, 1.0, 3.0, 3.0, 4.0])
    # rows 1..4: y - ŷ = [0, -1, 0, 2] -> ‖·‖ = √5; mean(y) = 3 -> y - ȳ = [-2, -1, 0, 3] -> √14
    assert metrics.fit(y, y_hat)[0] == pytest.approx((1.0 - math.sqrt(5.0 / 14.0)) * 100.0)


def test_fit_can_be_negative_and_rewards_no_worse_predictor() -> None:
    y = np.array([0.0, 1.0, 2.0, 3.0])
    mean_predictor = np.full(4, 1.5)
    assert metrics.fit(y, mean_predictor)[0] == pytest.approx(0.0)
    assert metrics.fit(y, -y)[0] < 0.0
    # VAF's var(ŷ) denominator rewards inflating the prediction; fit's does not.
    good, inflated = y + 0.1 * np.array([1, -1, 1, -1]), 3.0 * y
    assert metrics.vaf(y, inflated)[0] > 0.0
    assert metrics.fit(y, good)[0] > metrics.fit(y, inflated)[0]


def test_fit_of_a_constant_measurement_is_undefined() -> None:
    y, y_hat = np.array([2.0, 2.0, 2.0]), np.array([1.0, 2.0, 3.0])
    assert math.isnan(metrics.fit(y, y_hat)[0])
    (m,) = metrics.output_metrics(y, y_hat)
    assert "‖y − mean(y)‖ = 0" in m.undefined["fit"]
    assert m.samples == 3


def test_metrics_without_a_usable_row_say_so() -> None:
    (m,) = metrics.output_metrics(np.array([1.0, 2.0]), np.array([NAN, NAN]))
    assert m.samples == 0
    assert set(m.undefined) == {"mse", "vaf", "fit"}
    assert math.isnan(m.mse) and math.isnan(m.vaf) and math.isnan(m.fit)


def test_a_prediction_far_off_gives_null_metrics_beyond_float_range_without_a_warning() -> None:
    y = np.array([NAN, 1.0, 2.0, 3.0])
    y_hat = np.array([NAN, 1e300, -1e300, 1e300])
    (m,) = metrics.output_metrics(y, y_hat)  # filterwarnings = error: an overflow would raise
    assert not math.isfinite(m.mse) and m.out_of_range == {"mse"}
    assert m.undefined == {
        "mse": "MSE ≈ 1e+600 is beyond float64's range (at most 1.8e+308): errors |y − ŷ| "
        "up to 1e+300"
    }
    # ‖e‖/‖y − ȳ‖ = √3·1e300/√2: a number (the squares overflow, the ratio does not)
    assert m.fit == pytest.approx(100.0 * (1.0 - math.sqrt(1.5) * 1e300), rel=1e-12)
    assert 0.0 <= m.vaf <= 100.0


def test_metrics_per_column_and_empty_column() -> None:
    y = np.array([[1.0, 1.0], [2.0, 2.0], [4.0, 3.0]])
    y_hat = np.array([[NAN, NAN], [2.0, NAN], [3.0, NAN]])
    out_mse = metrics.mse(y, y_hat)
    assert out_mse[0] == pytest.approx(0.5)
    assert math.isnan(out_mse[1])
    assert math.isnan(metrics.vaf(y, y_hat)[1])
    assert metrics.mean_where_defined(out_mse) == pytest.approx(0.5)
    assert math.isnan(metrics.mean_where_defined([NAN, NAN]))
    # a diverged output (its error overflows) is the worst, never left out of the mean
    assert metrics.mean_where_defined([0.5, math.inf, NAN]) == math.inf
    assert metrics.mean_where_defined([-math.inf, 50.0]) == -math.inf


def test_shape_mismatch_is_an_error() -> None:
    with pytest.raises(ValueError, match="shape"):
        metrics.mse(np.zeros((3, 2)), np.zeros((3, 1)))


finite = st.floats(min_value=-1e6, max_value=1e6, allow_nan=False, allow_subnormal=False)
columns = hnp.arrays(np.float64, st.tuples(st.integers(2, 40), st.integers(1, 3)), elements=finite)


@given(columns)
@settings(max_examples=200, deadline=None)
def test_perfect_predictor_gives_mse_0_and_vaf_and_fit_100(y: np.ndarray) -> None:
    y_hat = y.copy()
    y_hat[0] = NAN  # like an EstimationResult: no prediction for the prior
    assert np.all(metrics.mse(y, y_hat) == 0.0)
    # VAF and fit are 100 wherever defined (y varies over the predicted rows); NaN otherwise.
    varies = np.ptp(y[1:], axis=0) > 0.0
    v, f = metrics.vaf(y, y_hat), metrics.fit(y, y_hat)
    assert np.all(v[varies] == 100.0) and np.all(f[varies] == 100.0)
    assert np.all(np.isnan(v[~varies])) and np.all(np.isnan(f[~varies]))


@given(columns, st.data())
@settings(max_examples=200, deadline=None)
def test_vaf_is_within_0_and_100(y: np.ndarray, data: st.DataObject) -> None:
    y_hat = data.draw(hnp.arrays(np.float64, y.shape, elements=finite))
    v = metrics.vaf(y, y_hat)
    defined = ~np.isnan(v)
    assert np.all((v[defined] >= 0.0) & (v[defined] <= 100.0))
    assert np.array_equal(defined, np.ptp(y_hat, axis=0) > 0.0)  # undefined: constant ŷ
    mse_values = metrics.mse(y, y_hat)  # NaN where below float64's normal numbers
    below = [m.out_of_range == {"mse"} for m in metrics.output_metrics(y, y_hat)]
    assert np.all((mse_values >= 0.0) | (np.isnan(mse_values) & below))
    f = metrics.fit(y, y_hat)
    assert np.all(f[~np.isnan(f)] <= 100.0)


# --- modes ------------------------------------------------------------------------------------

IDS = ("a", "b", "c")


def test_accuracy_and_confusion_by_hand() -> None:
    est = np.array([0, 0, 1, 1, 2])
    truth = np.array([0, 1, 1, 1, 2])
    assert mode_metrics.mode_accuracy(est, truth) == pytest.approx(0.8)
    counts = mode_metrics.confusion_matrix(est, truth, 3)
    # rows: true mode, columns: estimated mode
    np.testing.assert_array_equal(counts, [[1, 0, 0], [1, 2, 0], [0, 0, 1]])


@pytest.mark.parametrize(
    ("estimated", "shown"),
    [([0.0, 0.5, 1.0], "0.5 at sample 1"), ([0.0, np.nan, 1.0], "nan at sample 1")],
)
def test_modes_that_are_no_whole_number_are_refused_not_truncated(
    estimated: list[float], shown: str
) -> None:
    # a cast truncated 0.5 to mode 0 and NaN to a huge negative index (with a
    # RuntimeWarning, which the module promises never to give): an accuracy of 2/3 or 1/3
    truth = np.array([0, 0, 1])
    with pytest.raises(ValueError, match=f"estimated modes: {shown} is not a mode index"):
        mode_metrics.mode_accuracy(np.array(estimated), truth)
    with pytest.raises(ValueError, match=f"estimated modes: {shown} is not a mode index"):
        mode_metrics.confusion_matrix(np.array(estimated), truth, 2)
    assert mode_metrics.mode_accuracy([0.0, 1.0, 1.0], truth) == pytest.approx(2 / 3)
    with pytest.raises(ValueError, match="must be 1-D"):
        mode_metrics.mode_accuracy(np.zeros((3, 1)), np.zeros((3, 1)))


def test_confusion_rejects_out_of_range_modes() -> None:
    with pytest.raises(ValueError, match="outside"):
        mode_metrics.confusion_matrix(np.array([0, 3]), np.array([0, 0]), 3)


def test_switches_by_hand() -> None:
    t = np.arange(5) * 0.1
    switches = mode_metrics.mode_switches(t, np.array([0, 0, 1, 1, 0]), IDS)
    assert switches == [
        {"t": pytest.approx(0.2), "from": "a", "to": "b"},
        {"t": pytest.approx(0.4), "from": "b", "to": "a"},
    ]
    assert mode_metrics.mode_switches(t, np.zeros(5, dtype=np.int64), IDS) == []


def test_dwell_times_by_hand() -> None:
    t = np.array([0.0, 1.0, 2.0, 4.0])
    # durations: 1, 1, 2 and dt = 0.5 for the last sample
    dwell = mode_metrics.dwell_times(t, np.array([0, 1, 1, 0]), 3, 0.5)
    np.testing.assert_allclose(dwell, [1.5, 3.0, 0.0])


def test_detection_delays_by_hand() -> None:
    t = np.arange(11, dtype=float)
    truth = np.array([0, 0, 0, 1, 1, 1, 1, 2, 2, 0, 0])
    est = np.array([0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 2])
    det = mode_metrics.detection_delays(t, est, truth, IDS)
    # switch at 3 into b: estimate reaches b at 5 -> 2 s
    # switch at 7 into c: never c before the next true switch at 9 -> missed
    # switch at 9 into a: never a before the end (2 at 10 is the wrong mode) -> missed
    assert [(e.t, e.from_mode, e.to_mode, e.delay_s) for e in det.events] == [
        (3.0, "a", "b", 2.0),
        (7.0, "b", "c", None),
        (9.0, "c", "a", None),
    ]
    assert (det.detected, det.missed) == (1, 2)
    assert det.mean_s == 2.0
    assert det.max_s == 2.0


# Issue 7 changed this contract: an estimate that switched early (was already in the new
# mode before the true switch) used to count as "detected, 0 s"; it is now a miss.
def test_an_estimate_already_in_the_new_mode_is_a_miss() -> None:
    t = np.arange(6) * 0.5
    truth = np.array([0, 0, 0, 1, 1, 1])
    est = np.array([0, 1, 1, 1, 1, 1])
    det = mode_metrics.detection_delays(t, est, truth, IDS)
    assert det.delays_s.tolist() == []
    assert (det.detected, det.missed) == (0, 1)
    (event,) = det.events
    assert event.miss_reason is not None
    assert "already in mode b (since t=0.5 s)" in event.miss_reason


def test_a_filter_stuck_in_a_mode_the_truth_enters_detects_nothing() -> None:
    # The demo's case: hstf starts (wrongly) in mode 2 and stays; the truth goes 1 -> 2 -> 3.
    t = np.arange(9, dtype=float)
    truth = np.array([0, 0, 0, 1, 1, 1, 2, 2, 2])
    stuck = np.ones(9, dtype=np.int64)
    det = mode_metrics.detection_delays(t, stuck, truth, IDS)
    assert [e.detected for e in det.events] == [False, False]
    assert math.isnan(det.mean_s)
    first, second = det.events
    assert first.miss_reason is not None and "already in mode b" in first.miss_reason
    assert "before the next true switch at t=6 s" in first.miss_reason
    assert second.miss_reason is not None and "never changed into mode c" in second.miss_reason
    assert "before the end of the log" in second.miss_reason
    # Leaving the mode and changing back into it after the switch is no detection either
    # (SPEC §8: an estimate that already sat in the new mode is a miss); the switch into
    # mode c, which the estimate was not in, is detected.
    est = np.array([1, 1, 1, 1, 0, 1, 1, 2, 2])
    det = mode_metrics.detection_delays(t, est, truth, IDS)
    assert det.delays_s.tolist() == [1.0]
    first, _ = det.events
    assert first.detected_t is None and first.miss_reason is not None
    assert "already in mode b (since t=0 s)" in first.miss_reason
    assert "change back into mode b at t=5 s" in first.miss_reason


def test_a_switch_entered_early_is_missed_not_timed_by_the_recovery() -> None:
    # A smoother a sample early into mode b, out of it again and back 5 samples later: the
    # switch was not missed by 5 s, and the recovery must not be reported as its delay.
    t = np.arange(12, dtype=float)
    truth = np.array([0, 0, 0, 1, 1, 1, 1, 1, 1, 1, 1, 1])
    est = np.array([0, 0, 1, 1, 1, 0, 0, 0, 1, 1, 1, 1])
    det = mode_metrics.detection_delays(t, est, truth, IDS)
    assert (det.detected, det.missed) == (0, 1)
    assert math.isnan(det.mean_s)


def test_detection_delays_mean_and_max() -> None:
    t = np.arange(10, dtype=float)
    truth = np.array([0, 0, 1, 1, 1, 0, 0, 0, 0, 0])
    est = np.array([0, 0, 0, 1, 1, 1, 1, 1, 0, 0])
    det = mode_metrics.detection_delays(t, est, truth, IDS)
    assert det.delays_s.tolist() == [1.0, 3.0]
    assert det.mean_s == 2.0
    assert det.max_s == 3.0


def test_delays_and_dwell_of_unix_times_are_whole_steps_of_the_grid() -> None:
    # A ROS bag's times are Unix times: float64 holds 1.7e9 s to 2.4e-7 s, and the difference
    # of two of them made a two-step delay on a 10 ms grid 0.020000219 s (a gate
    # detection_delay_s <= 0.02 failed) and a mode's dwell 9.860000134 s.
    result, signals = make_run(400, seed=1)
    epoch = 1.7e9
    late = build_report(
        dataclasses.replace(result, time=result.time + epoch),
        dataclasses.replace(signals, time=signals.time + epoch),
        log="run.csv",
        model_name="m",
        dt=DT,
    )
    assert late.modes.detection is not None
    delays = [e.delay_s for e in late.modes.detection.events if e.delay_s is not None]
    assert delays and all(d == mode_metrics.steps_seconds(round(d / DT), DT) for d in delays), (
        delays
    )
    counts = np.bincount(result.modes, minlength=len(late.modes.labels))
    assert list(late.modes.dwell_s.values()) == [mode_metrics.steps_seconds(c, DT) for c in counts]
    # the grid's steps, whatever the times' offset
    early = build_report(result, signals, log="run.csv", model_name="m", dt=DT)
    assert early.modes.detection is not None
    assert late.modes.detection.mean_s == early.modes.detection.mean_s
    assert late.modes.dwell_s == early.modes.dwell_s
    # and a report read back keeps them
    again = Report.from_dict(late.to_dict(), source="report.json")
    assert again.modes.detection == late.modes.detection


def test_times_at_unix_magnitudes_are_written_in_full() -> None:
    """report.md wrote every time of a Unix-time log as 1.7e+09 (six significant digits):
    the span 't = 1.7e+09 … 1.7e+09 s', every switch, 'since t=1.7e+09 s' in a miss reason,
    and 1.7000002e+09 at nine.  Times are now fixed point, to the digits a float holds."""
    result, signals = make_run(400, seed=1)
    shift = 1.7e9 + 0.25
    late = build_report(
        dataclasses.replace(result, time=result.time + shift),
        dataclasses.replace(signals, time=signals.time + shift),
        log="run.csv",
        model_name="m",
        dt=DT,
    )
    text = render_markdown(late)
    assert "e+09" not in text

    def fixed(t: float) -> str:  # the grid's times (dt = 0.05 s) to the hundredth
        return f"{t:.2f}".rstrip("0").rstrip(".")

    first, last = signals.time[0] + shift, signals.time[-1] + shift
    assert f"t = {fixed(first)} … {fixed(last)} s" in text
    assert late.modes.detection is not None
    for event in late.modes.detection.events:
        assert f"| {fixed(event.t)} | " in text
        assert "e+09" not in (event.miss_reason or "")
    # the times a miss reason names
    t = 1.7e9 + np.arange(6) * 0.05
    det = mode_metrics.detection_delays(t, np.ones(6, int), np.array([0, 0, 1, 1, 0, 1]), IDS)
    assert det.events[0].miss_reason == (
        "the estimate was already in mode b (since t=1700000000 s) when the truth switched "
        "to it, and no estimated change into mode b followed before the next true switch at "
        "t=1700000000.2 s"
    )


@settings(max_examples=300, deadline=None)
@given(
    steps=st.integers(-(10**12), 10**12),
    dt=st.floats(min_value=1e-300, max_value=1e6, allow_nan=False, allow_infinity=False),
)
def test_steps_seconds_is_the_written_decimal_times_the_steps_rounded_once(
    steps: int, dt: float
) -> None:
    """The exact product of ``dt`` as written and ``steps``, rounded once, whatever the two
    (``dt``'s decimal is parsed once per ``dt``, not once per switch)."""
    from fractions import Fraction

    assert mode_metrics.steps_seconds(steps, dt) == float(Fraction(repr(dt)) * steps)
    assert mode_metrics.steps_seconds(np.int64(steps), dt) == float(Fraction(repr(dt)) * steps)


def test_steps_on_the_grid_are_dt_as_written_times_their_number() -> None:
    """351 samples of 10 ms dwelt 3.5100000000000002 s in report.json, a delay of 3 steps of
    50 ms was 0.15000000000000002 s: float products, whose last digits say nothing."""
    assert mode_metrics.steps_seconds(351, 0.01) == 3.51
    assert mode_metrics.steps_seconds(3, 0.05) == 0.15
    assert mode_metrics.steps_seconds(0, 0.05) == 0.0
    assert mode_metrics.steps_seconds(3, 0.1) == 0.3  # not 0.30000000000000004
    modes = np.array([0] * 351 + [1] * 3)
    dwell = mode_metrics.dwell_times(np.zeros(354), modes, 2, 0.01, on_grid=True)
    assert dwell.tolist() == [3.51, 0.03]
    det = mode_metrics.detection_delays(
        np.arange(8) * 0.05, np.array([0, 0, 0, 0, 0, 1, 1, 1]), np.array([0, 0, 1, 1, 1, 1, 1, 1]),
        ("a", "b"), 0.05,
    )  # fmt: skip
    assert [e.delay_s for e in det.events] == [0.15]


@pytest.mark.parametrize(
    ("seconds", "text"),
    [
        (1700000101.01, "1700000101.01"),
        (1.7e9 + 1e-6, "1700000000.000001"),
        (1.7e9 + 0.1, "1700000000.1"),  # the float is 1700000000.0999999046
        (0.1999999999999993, "0.2"),
        (0.1, "0.1"),
        (2e-9, "0.000000002"),
        (0.0, "0"),
        (-2.5, "-2.5"),
        (-1e-12, "0"),
        (None, "n/a"),
    ],
)
def test_a_time_is_written_to_the_digits_it_holds(seconds: float | None, text: str) -> None:
    assert format_time(seconds) == text


def test_no_true_switch_gives_nan_delay() -> None:
    det = mode_metrics.detection_delays(np.arange(4.0), np.zeros(4, int), np.zeros(4, int), IDS)
    assert det.events == ()
    assert math.isnan(det.mean_s)
    assert det.missed == 0


mode_seqs = hnp.arrays(np.int64, st.integers(1, 60), elements=st.integers(0, 2))


@given(mode_seqs)
@settings(max_examples=200, deadline=None)
def test_estimate_equal_to_truth_is_perfect(modes: np.ndarray) -> None:
    t = np.arange(modes.size) * 0.25
    assert mode_metrics.mode_accuracy(modes, modes) == 1.0
    counts = mode_metrics.confusion_matrix(modes, modes, 3)
    assert np.count_nonzero(counts - np.diag(np.diag(counts))) == 0
    assert counts.sum() == modes.size
    det = mode_metrics.detection_delays(t, modes, modes, IDS)
    assert det.missed == 0
    assert np.all(det.delays_s == 0.0)
    assert mode_metrics.dwell_times(t, modes, 3, 0.25).sum() == pytest.approx(modes.size * 0.25)


def _detections_by_definition(
    t: np.ndarray, est: np.ndarray, truth: np.ndarray
) -> list[tuple[float, str, str, float | None, str | None]]:
    """The docstring of ``detection_delays`` read literally, one switch and one sample at a time."""
    events = []
    starts = [s for s in range(1, truth.size) if truth[s] != truth[s - 1]]
    for s, end in zip(starts, [*starts[1:], truth.size][: len(starts)], strict=True):
        m = truth[s]
        hits = [k for k in range(s, end) if est[k] == m and est[k - 1] != m]
        already = est[s - 1] == m
        window = (
            f"before the next true switch at t={format_time(t[end])} s"
            if end < truth.size
            else "before the end of the log"
        )
        reason = None
        if not hits and not already:
            reason = f"the estimate never changed into mode {IDS[m]} {window}"
        elif already:
            stay = s - 1
            while stay > 0 and est[stay - 1] == m:
                stay -= 1
            reason = (
                f"the estimate was already in mode {IDS[m]} (since t={format_time(t[stay])} s) "
                "when the truth switched to it"
            )
            reason += (
                f"; its change back into mode {IDS[m]} at t={format_time(t[hits[0]])} s, after "
                "leaving it, does not detect the switch"
                if hits
                else f", and no estimated change into mode {IDS[m]} followed {window}"
            )
        detected = float(t[hits[0]]) if hits and not already else None
        events.append((float(t[s]), IDS[truth[s - 1]], IDS[m], detected, reason))
    return events


@given(mode_seqs, st.data())
@settings(max_examples=300, deadline=None)
def test_detection_delays_follow_their_definition(truth: np.ndarray, data: st.DataObject) -> None:
    # detection_delays works on change points of whole arrays; this walks the samples.
    est = data.draw(hnp.arrays(np.int64, truth.shape, elements=st.integers(0, 2)))
    t = np.cumsum(data.draw(hnp.arrays(np.float64, truth.shape, elements=st.floats(0.01, 2.0))))
    det = mode_metrics.detection_delays(t, est, truth, IDS)
    got = [(e.t, e.from_mode, e.to_mode, e.detected_t, e.miss_reason) for e in det.events]
    assert got == _detections_by_definition(t, est, truth)


@given(mode_seqs, st.data())
@settings(max_examples=200, deadline=None)
def test_accuracy_is_the_confusion_diagonal(truth: np.ndarray, data: st.DataObject) -> None:
    est = data.draw(hnp.arrays(np.int64, truth.shape, elements=st.integers(0, 2)))
    counts = mode_metrics.confusion_matrix(est, truth, 3)
    assert mode_metrics.mode_accuracy(est, truth) == pytest.approx(np.trace(counts) / truth.size)
    assert 0.0 <= mode_metrics.mode_accuracy(est, truth) <= 1.0
    np.testing.assert_array_equal(counts.sum(axis=1), np.bincount(truth, minlength=3))
    np.testing.assert_array_equal(counts.sum(axis=0), np.bincount(est, minlength=3))


# --- states -----------------------------------------------------------------------------------


def test_state_rmse_by_hand() -> None:
    x_hat = np.array([[1.0, 0.0, 5.0], [2.0, 0.0, 5.0], [3.0, 0.0, 5.0]])
    x_true = np.array([[1.0, NAN, 2.0], [4.0, NAN, NAN], [3.0, NAN, 1.0]])
    rmse = state_error.state_rmse(x_hat, x_true)
    assert rmse[0] == pytest.approx(math.sqrt(4.0 / 3.0))
    assert math.isnan(rmse[1])  # no truth for this state
    assert rmse[2] == pytest.approx(math.sqrt((9.0 + 16.0) / 2.0))  # NaN rows ignored


# Magnitudes in [1e-50, 1e6] (or 0): scaled by 1e±250 they stay representable.
moderate = st.one_of(
    st.just(0.0),
    st.floats(min_value=1e-50, max_value=1e6),
    st.floats(min_value=-1e6, max_value=-1e-50),
)


def _constant(a: np.ndarray) -> np.ndarray:
    """Per column: whether every value equals the first."""
    return np.all(a == a[:1], axis=0)


@given(
    hnp.arrays(np.float64, st.tuples(st.integers(2, 40), st.integers(1, 3)), elements=moderate),
    st.data(),
    st.sampled_from([1e-250, 1e-100, 1e100, 1e250]),
)
@settings(max_examples=100, deadline=None)
def test_vaf_and_fit_do_not_depend_on_the_unit(
    y: np.ndarray, data: st.DataObject, scale: float
) -> None:
    # Ratios of spreads: the same in any unit, even where squares of the values would
    # underflow or overflow float64 (no warning either: filterwarnings = error).
    y_hat = data.draw(hnp.arrays(np.float64, y.shape, elements=moderate))
    # Scaling rounds every value (relative error ≤ eps); a spread far below the values'
    # magnitude amplifies that by magnitude / spread (hypothesis found y = 539370.75 twice
    # against ŷ = 0, −2^-7: VAF 0 and 1.1e-6 %). The allowance is that first-order bound on
    # each metric's spreads (VAF: of y − ŷ and ŷ; fit: of y), per output, on top of 1e-6 %.
    eps = np.finfo(np.float64).eps
    size = np.abs(y).max(axis=0) + np.abs(y_hat).max(axis=0)
    # Each metric is undefined where one signal is constant (VAF: ŷ; fit: y); scaling can
    # round distinct values to one (hypothesis found ŷ = -1e6 and its neighbour below, both
    # -1e-94 at scale 1e-100), and then the scaled metric is rightly undefined.
    spreads = {
        metrics.vaf: (y_hat, ((y - y_hat).std(axis=0), y_hat.std(axis=0))),
        metrics.fit: (y, (y.std(axis=0),)),
    }
    for metric, (varied, by) in spreads.items():
        plain, scaled = metric(y, y_hat), metric(y * scale, y_hat * scale)
        kept = _constant(varied * scale) == _constant(varied)
        np.testing.assert_array_equal(np.isnan(scaled)[kept], np.isnan(plain)[kept])
        defined = ~np.isnan(plain) & kept
        with np.errstate(divide="ignore", invalid="ignore"):  # 0/0: the metric is undefined
            condition = sum(size / spread for spread in by)
        # The metrics are 100·(1 − ratio): a relative error δ of the ratio moves them by
        # 100·ratio·δ = (100 − metric)·δ, which for a fit far below zero (hypothesis found
        # −1.5e6, y nearly constant at 7e5) is far more than 100·δ.
        allowance = 1e-6 + (100.0 + np.abs(plain)) * 8.0 * eps * condition
        error = np.abs(scaled - plain)
        assert (error[defined] <= allowance[defined]).all(), (metric, scaled, plain, allowance)


def test_vaf_of_a_prediction_with_a_tiny_spread_is_defined() -> None:
    # hypothesis found it: var(ŷ) = (1.8e-220)² underflows float64 if computed naively.
    (m,) = metrics.output_metrics(np.array([1.0, 1.0]), np.array([3.54270596e-220, 0.0]))
    assert 0.0 <= m.vaf <= 100.0 and "vaf" not in m.undefined


# --- memory: no full-size copy of every column, no list of every sample ---------------------


def _reference_output_metrics(y: np.ndarray, y_hat: np.ndarray) -> list[tuple[float, ...]]:
    """MSE, VAF and fit computed as plainly as the formulas read (the pre-streaming code)."""

    def unit(v: np.ndarray) -> tuple[float, np.ndarray]:
        m = float(np.max(np.abs(v))) if v.size else 0.0
        return (m, v / m) if 0.0 < m < np.inf else (m, v)

    def ratio(a: np.ndarray, b: np.ndarray, spread: object) -> float:
        ma, ua = unit(a)
        mb, ub = unit(b)
        if ma == 0.0:
            return 0.0
        if ma == np.inf:
            return np.inf
        size = float(spread(ub))  # type: ignore[operator]
        if not size > 0.0:
            return np.nan
        r = float(spread(ua)) / size  # type: ignore[operator]
        return (ma / mb) * r if r else 0.0

    out = []
    with np.errstate(over="ignore", invalid="ignore"):
        for j in range(y.shape[1]):
            yc, hc = np.ascontiguousarray(y[:, j]), np.ascontiguousarray(y_hat[:, j])
            ok = np.isfinite(yc) & np.isfinite(hc)
            yo, ho = yc[ok], hc[ok]
            mse = float(np.mean((yo - ho) * (yo - ho))) if yo.size else np.nan
            vaf = np.nan
            if ho.size and not np.all(ho == ho[0]):
                r = ratio(yo - ho, ho, np.std)
                vaf = max(1.0 - r * r, 0.0) * 100.0
            fit = np.nan
            if yo.size and not np.all(yo == yo[0]):
                fit = (1.0 - ratio(yo - ho, yo - np.mean(yo), np.linalg.norm)) * 100.0
            out.append((mse, vaf, fit))
    return out


def test_streamed_output_metrics_are_bit_identical_to_the_plain_formulas() -> None:
    rng = np.random.default_rng(7)
    n = 5_000
    y = rng.normal(size=(n, 4)) * np.array([1.0, 1e-150, 1e150, 3.0])
    y_hat = y + rng.normal(size=(n, 4)) * np.array([0.1, 1e-151, 1e149, 1e300])
    y_hat[0] = NAN  # no prediction in row 0
    y[17, 0] = np.inf
    y_hat[40:60, 1] = NAN
    y_hat[:, 3] *= 1e7  # |ŷ| near 1e307: the error overflows to infinity
    got = [(m.mse, m.vaf, m.fit) for m in metrics.output_metrics(y, y_hat)]
    expected = _reference_output_metrics(y, y_hat)
    assert np.array_equal(np.array(got), np.array(expected), equal_nan=True)
    assert np.array_equal(metrics.mse(y, y_hat), np.array([e[0] for e in expected]), equal_nan=True)


def _traced_peak(function: object, *args: object) -> int:
    """Peak bytes NumPy and Python allocated while ``function(*args)`` ran (tracemalloc).

    NumPy reports every array buffer to tracemalloc, so the figure counts the arrays a
    function makes, deterministically (no allocator, no other process in it).
    """
    import tracemalloc

    tracemalloc.start()
    try:
        function(*args)  # type: ignore[operator]
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_output_metrics_hold_one_column_at_a_time() -> None:
    # Selecting every column's usable rows at once (after contiguous copies of each) peaked
    # at 10 column-sized arrays for three outputs; one column pair at a time, with the
    # temporaries of one metric, peaks near 4 (3 for the state RMSE).
    n = 200_000
    rng = np.random.default_rng(1)
    y = rng.normal(size=(n, 3))
    y_hat = y + rng.normal(size=(n, 3))
    y_hat[0] = NAN
    column = 8 * n
    assert _traced_peak(metrics.output_metrics, y, y_hat) < 5 * column
    assert _traced_peak(state_error.state_rmse, y_hat, y) < 5 * column


def test_detection_delays_make_no_per_sample_python_objects() -> None:
    # time.tolist() made a Python float per sample (32 bytes each: four columns' worth).
    n = 200_000
    time = np.arange(n) * 0.01
    truth = (np.arange(n) // 2_000) % 3  # 99 true switches
    estimated = np.roll(truth, 3)
    assert _traced_peak(mode_metrics.detection_delays, time, estimated, truth, ("a", "b", "c")) < (
        8 * n
    )


def test_detection_delays_write_each_time_of_the_reasons_once(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # A filter that sits in one mode misses every switch into it "since t=0 s": the reasons
    # of a 10^6-row log named that time thousands of times, each written anew.
    time = np.arange(6_000) * 0.5
    truth = (np.arange(6_000) // 20) % 3  # 299 true switches
    estimated = np.zeros(6_000, dtype=np.int64)  # always mode a: every switch missed
    written: list[float] = []

    def counted(t: float | None) -> str:
        written.append(t if t is not None else math.nan)
        return format_time(t)

    mode_metrics._seconds.cache_clear()
    monkeypatch.setattr(mode_metrics, "format_time", counted)
    det = mode_metrics.detection_delays(time, estimated, truth, ("a", "b", "c"))
    assert det.missed == 299
    reasons = [e.miss_reason for e in det.events]
    assert sum("(since t=0 s)" in r for r in reasons if r) == 99
    assert sorted(written) == sorted(set(written))
