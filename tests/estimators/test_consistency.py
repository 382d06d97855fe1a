"""A log the filter explains sample by sample but not as a whole is reported, not passed silently.

A three-tank log with every level scaled by 1.5 (or noise the model does not know) made no
sample implausible to the IMM (``check_surprise`` refuses only a sample no mode explains):
``analyze`` wrote a good-looking report at exit 0.  Now the IMM records each sample's
whitened innovation ``L⁻¹ γ`` and the report tests them over the log
(:mod:`hybridlog.estimators.consistency`, Bar-Shalom et al. 2001 §5.4.2): ``report.json``'s
``consistency``, a ``WARNING`` in report.md and on the terminal.
"""

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter

from hybridlog.cli import main
from hybridlog.estimators.consistency import (
    BIAS_WARNING,
    NIS_QUIET_EFFECT,
    NIS_WARNING,
    ConsistencyAccumulator,
)
from hybridlog.estimators.filter_options import HstfOptions
from hybridlog.estimators.hstf import run_hstf
from hybridlog.estimators.imm import ImmOptions, run_imm
from hybridlog.model.builtins import builtin_text
from hybridlog.model.loader import parse_model
from hybridlog.report.build import build_report
from hybridlog.simulate import simulate
from tests.estimators.test_reductions import _linear_matrices
from tests.estimators.test_vouch_surprise import ONE_MODE

SAMPLES = Path(__file__).resolve().parents[2] / "sample_logs"


def _filterpy_whitened(model, signals):
    """Each sample's ``chol(S)⁻¹ y`` of FilterPy's Kalman filter (row 0: the prior, NaN)."""
    mode = model.modes[0]
    kf = KalmanFilter(dim_x=model.n_states, dim_z=model.n_outputs, dim_u=model.n_inputs)
    kf.x = model.initial_state.copy()
    kf.P = model.initial_covariance.copy()
    kf.F, kf.B, kf.H = _linear_matrices(model, 0)
    kf.Q, kf.R = mode.process_noise, mode.measurement_noise
    rows = [np.full(model.n_outputs, np.nan)]
    nis = [np.nan]
    for k in range(signals.n_samples - 1):
        kf.predict(u=signals.inputs[k])
        kf.update(signals.outputs[k + 1])
        rows.append(np.linalg.solve(np.linalg.cholesky(kf.S), kf.y))
        nis.append(float(kf.y @ np.linalg.solve(kf.S, kf.y)))
    return np.array(rows), np.array(nis)


@pytest.mark.parametrize("kernel", ["unrolled", "loops"])
def test_the_whitened_innovations_and_their_nis_are_filterpys(kernel):
    model = parse_model(ONE_MODE)
    signals = simulate(model, steps=199, seed=4).signals(model)
    whitened, nis = _filterpy_whitened(model, signals)
    result = run_imm(model, signals, ImmOptions(), kernel=kernel)
    ours = result.whitened_innovations
    assert ours is not None and np.isnan(ours[0]).all()
    np.testing.assert_allclose(ours[1:], whitened[1:], rtol=0, atol=1e-8)
    np.testing.assert_allclose((ours[1:] ** 2).sum(axis=1), nis[1:], rtol=1e-8, atol=1e-8)


def _scores(model, signals):
    result = run_imm(model, signals, ImmOptions())
    whole = ConsistencyAccumulator(result.output_names)
    assert result.whitened_innovations is not None
    whole.add(result.whitened_innovations, result.mode_probabilities)
    tested = whole.result()
    assert tested is not None
    return result, tested


def test_a_log_of_the_model_passes_a_scaled_or_noisier_one_warns():
    model = parse_model(ONE_MODE)
    signals = simulate(model, steps=599, seed=5).signals(model)
    _, clean = _scores(model, signals)
    assert clean.warnings() == ()
    assert abs(clean.nis_score) < NIS_WARNING
    assert all(abs(s) < BIAS_WARNING for s in clean.bias_scores.values())
    _, scaled = _scores(model, dataclasses.replace(signals, outputs=1.5 * signals.outputs))
    assert (
        scaled.nis_score > NIS_WARNING and "larger than the model's noise" in scaled.warnings()[0]
    )
    noise = np.random.default_rng(6).normal(0.0, 3.0 * np.sqrt(0.08), signals.outputs.shape)
    _, noisier = _scores(model, dataclasses.replace(signals, outputs=signals.outputs + noise))
    assert noisier.nis_score > NIS_WARNING


QUIET = "the innovations are smaller than the model's noise predicts"


@pytest.mark.parametrize(
    ("alteration", "scale"),
    [("other units", 1e-3), ("other units", 0.1), ("scaled to nothing", 1e-300), ("zero", 0.0)],
)
def test_a_log_in_other_units_or_zeroed_warns_that_its_innovations_are_too_small(alteration, scale):
    # outputs × 1e-3 (a log in mm of a model in m), × 1e-300 or zeroed made no warning at all:
    # the test warned only of a NIS too large (here 0.11-0.12 m, clean 0.97-1.06 m)
    model = parse_model(ONE_MODE)
    signals = simulate(model, steps=599, seed=5).signals(model)
    _, clean = _scores(model, signals)
    assert clean.warnings() == ()
    _, quiet = _scores(model, dataclasses.replace(signals, outputs=scale * signals.outputs))
    assert quiet.nis < NIS_QUIET_EFFECT * quiet.nis_expected and quiet.nis_score < -NIS_WARNING
    (warning,) = quiet.warnings()
    assert warning.startswith(QUIET)
    assert f"({quiet.nis_expected / quiet.nis:.3g} times in variance)" in warning
    assert "other units" in warning and "noise model far too large" in warning


def test_a_model_whose_measurement_noise_is_far_too_large_warns():
    model = parse_model(ONE_MODE)
    signals = simulate(model, steps=599, seed=5).signals(model)
    wide = parse_model(
        ONE_MODE.replace(
            "measurement = [[0.05, 0.01], [0.01, 0.08]]", "measurement = [[5.0, 1.0], [1.0, 8.0]]"
        )
    )
    _, tested = _scores(wide, signals)
    assert any(w.startswith(QUIET) for w in tested.warnings())


def test_a_nis_below_m_warns_only_when_both_far_below_and_significant():
    rng = np.random.default_rng(10)
    # the double cart case 1's own logs score 0.29-0.64 m, down to -10 standard scores: its S
    # exceeds the innovations' spread; a long log of it is significant but not small enough
    cart_like = ConsistencyAccumulator(("y",))
    cart_like.add(np.sqrt(0.45) * rng.normal(size=(10_000, 1)), np.ones((10_000, 1)))
    tested = cart_like.result()
    assert tested is not None and tested.nis_score < -NIS_WARNING and tested.warnings() == ()
    # small enough but over few samples: (0.09 - 1) / sqrt(2/40) = -4 standard scores
    short = ConsistencyAccumulator(("y",))
    short.add(0.3 * rng.normal(size=(40, 1)), np.ones((40, 1)))
    tested = short.result()
    assert tested is not None and tested.nis < NIS_QUIET_EFFECT and tested.warnings() == ()
    # no innovation at all: the ratio has no value, the warning still says what was seen
    flat = ConsistencyAccumulator(("y",))
    flat.add(np.zeros((100, 1)), np.ones((100, 1)))
    tested = flat.result()
    assert tested is not None
    (warning,) = tested.warnings()
    assert warning.startswith(f"{QUIET} (all of them 0)")


@pytest.mark.parametrize(("size", "shown"), [(1e-160, "2.4e-160"), (1e-200, "2.4e-200")])
def test_innovations_whose_squares_no_double_holds_are_not_inf_times_nor_zero(size, shown):
    # squares of 1e-160 are subnormal: m / mean NIS overflowed to 'inf times in variance';
    # squares of 1e-200 are 0: innovations that are not were said to be 'all of them 0'
    tiny = ConsistencyAccumulator(("y",))
    tiny.add(size * np.random.default_rng(0).normal(size=(200, 1)), np.ones((200, 1)))
    tested = tiny.result()
    assert tested is not None
    (warning,) = tested.warnings()
    assert warning.startswith(f"{QUIET} (all of them within {shown} standard deviations of 0)")


def test_the_chunks_of_a_run_test_what_the_whole_run_tests():
    model = parse_model(ONE_MODE)
    # more settled rows than one summed block: a report has the same bits however it is read
    signals = simulate(model, steps=20_000, seed=7).signals(model)
    result, whole = _scores(model, signals)
    assert whole.samples > 1 << 14
    chunked = ConsistencyAccumulator(result.output_names)
    for start in range(0, result.n_samples, 37):
        part = result.rows(start, min(start + 37, result.n_samples))
        assert part.whitened_innovations is not None
        chunked.add(part.whitened_innovations, part.mode_probabilities)
    tested = chunked.result()
    assert tested is not None and tested.to_dict() == whole.to_dict()


def test_a_constant_bias_of_the_whitened_innovations_warns():
    accumulator = ConsistencyAccumulator(("y1", "y2"))
    whitened = np.random.default_rng(8).normal(size=(400, 2))
    whitened[:, 1] += 0.5  # 0.5 sqrt(400) = 10 standard scores
    accumulator.add(whitened, np.ones((400, 1)))
    tested = accumulator.result()
    assert tested is not None
    (warning,) = tested.warnings()
    assert "biased" in warning and "y2" in warning and "y1" not in warning


def test_a_long_log_s_significant_but_immaterial_differences_do_not_warn():
    """A 10^6-sample log of the three-tank model itself warned of a bias of 0.013 (12.9
    standard scores): the EKF's own linearisation bias, significant only by its length."""
    rows = 1_000_000
    whitened = np.random.default_rng(9).normal(size=(rows, 2))
    whitened[:, 1] += 0.013  # 13 standard scores
    whitened[:, 0] *= 1.04  # mean NIS about 2.04 of 2: 14 standard scores
    accumulator = ConsistencyAccumulator(("y1", "y2"))
    accumulator.add(whitened, np.ones((rows, 1)))
    tested = accumulator.result()
    assert tested is not None
    assert tested.bias_scores["y2"] > BIAS_WARNING and tested.nis_score > NIS_WARNING
    assert tested.warnings() == ()


def test_report_json_md_and_terminal_carry_the_warning_and_exit_0(tmp_path, capsys):
    lines = (SAMPLES / "three_tank_hstf.csv").read_text().splitlines()
    header = lines[0].split(",")
    outputs = [header.index(name) for name in ("y1", "y2", "y3")]
    scaled = [lines[0]]
    for line in lines[1:]:
        cells = line.split(",")
        for column in outputs:
            cells[column] = repr(1.5 * float(cells[column]))
        scaled.append(",".join(cells))
    log = tmp_path / "scaled.csv"
    log.write_text("\n".join(scaled) + "\n")
    out = tmp_path / "out"
    analyze = ["analyze", str(log), "--model", "three_tank_hstf", "--estimator", "imm"]
    main([*analyze, "--out", str(out)])  # exit 0: no SystemExit
    err = capsys.readouterr().err
    assert "hybridlog: warning: the innovations are larger than the model's noise" in err
    report = json.loads((out / "report.json").read_text())
    consistency = report["consistency"]
    assert consistency["nis_expected"] == 3.0 and consistency["nis_score"] > NIS_WARNING
    assert "WARNING: the innovations are larger" in (out / "report.md").read_text()


def test_the_sample_log_in_other_units_is_reported_as_too_quiet():
    model = parse_model(builtin_text("three_tank_hstf"))
    signals = simulate(model, seed=2024).signals(model)  # sample_logs/three_tank_hstf.csv
    millimetres = dataclasses.replace(signals, outputs=1e-3 * signals.outputs)
    result = run_imm(model, millimetres, ImmOptions())
    report = build_report(result, millimetres, log="mm", model_name="three_tank_hstf", dt=1.0)
    consistency = report.extra["consistency"]
    assert isinstance(consistency, dict) and consistency["nis_quiet_effect"] == NIS_QUIET_EFFECT
    (warning,) = consistency["warnings"]
    assert warning.startswith(QUIET) and f"WARNING: {warning}" in report.notes


def test_the_sample_log_is_not_flagged_and_the_hstf_keeps_no_innovations():
    model = parse_model(builtin_text("three_tank_hstf"))
    signals = simulate(model, seed=2024).signals(model)  # sample_logs/three_tank_hstf.csv
    result = run_imm(model, signals, ImmOptions())
    report = build_report(result, signals, log="sample", model_name="three_tank_hstf", dt=1.0)
    consistency = report.extra["consistency"]
    assert isinstance(consistency, dict) and consistency["warnings"] == []
    assert run_hstf(model, signals, HstfOptions()).whitened_innovations is None


@pytest.mark.parametrize("smoother", ["kim", "ec"])
def test_an_offline_pass_leaves_the_filters_innovation_test_as_it_was(smoother):
    # the innovations are the filter's, and so is the test of them: its settled samples were
    # those of the smoothed mode probabilities, which settle earlier (three-tank: 296 samples
    # with --smooth against the filter's 292, another mean NIS and another verdict)
    model = parse_model(builtin_text("three_tank_hstf"))
    signals = simulate(model, seed=2024).signals(model)
    smoothed = run_imm(model, signals, ImmOptions(smooth=True, smoother=smoother))
    assert smoothed.post_processing is not None
    filtered = smoothed.post_processing.filtered
    assert not np.array_equal(smoothed.mode_probabilities, filtered.mode_probabilities)
    reports = [
        build_report(r, signals, log="sample", model_name="three_tank_hstf", dt=1.0)
        for r in (filtered, smoothed)
    ]
    alone, offline = (report.extra["consistency"] for report in reports)
    assert isinstance(alone, dict) and alone["samples"] > 0
    assert offline == alone


def _sparse(signals, output, every):
    """``signals`` with ``output`` measured at every ``every``-th row only (a slower sensor)."""
    unmeasured = np.zeros(signals.outputs.shape, dtype=bool)
    unmeasured[:, output] = True
    unmeasured[::every, output] = False
    return dataclasses.replace(signals, unmeasured_outputs=unmeasured)


@pytest.mark.parametrize("kernel", ["unrolled", "loops"])
def test_a_partly_measured_row_s_innovations_are_the_measured_ones_whitened(kernel):
    # what the test sums on a row where y2 was not measured: the filter updates on y1 alone,
    # so the row's NIS is γ1² / S11, FilterPy's update on y1 alone
    model = parse_model(ONE_MODE)
    signals = _sparse(simulate(model, steps=99, seed=4).signals(model), 1, 3)
    mode = model.modes[0]
    kf = KalmanFilter(dim_x=model.n_states, dim_z=model.n_outputs, dim_u=model.n_inputs)
    kf.x, kf.P = model.initial_state.copy(), model.initial_covariance.copy()
    kf.F, kf.B, H = _linear_matrices(model, 0)
    kf.Q = mode.process_noise
    nis = [np.nan]
    for k in range(signals.n_samples - 1):
        kf.predict(u=signals.inputs[k])
        kept = ~signals.unmeasured_outputs[k + 1]
        kf.dim_z = int(kept.sum())
        kf.H, kf.R = H[kept], mode.measurement_noise[np.ix_(kept, kept)]
        kf.update(signals.outputs[k + 1, kept])
        nis.append(float(kf.y @ np.linalg.solve(kf.S, kf.y)))
    ours = run_imm(model, signals, ImmOptions(), kernel=kernel).whitened_innovations
    assert ours is not None
    np.testing.assert_array_equal(np.isnan(ours[1:]), signals.unmeasured_outputs[1:])
    np.testing.assert_allclose(np.nansum(ours[1:] ** 2, axis=1), nis[1:], rtol=1e-8, atol=1e-8)


def test_a_log_whose_output_is_sampled_slower_is_tested_over_every_settled_row():
    # y2 measured on every 12th row: the test kept only the 25 rows that measured all three
    # outputs, so there was no 'consistency' and no word that the test had not run
    model = parse_model(builtin_text("three_tank_hstf"))
    signals = _sparse(simulate(model, seed=2024).signals(model), 1, 12)
    result = run_imm(model, signals, ImmOptions())
    report = build_report(result, signals, log="slow y2", model_name="three_tank_hstf", dt=1.0)
    consistency = report.extra["consistency"]
    assert isinstance(consistency, dict) and consistency["samples"] > 250
    measured = consistency["measured"]
    assert measured["y1"] == measured["y3"] == consistency["samples"] and measured["y2"] < 30
    expected = (2 * consistency["samples"] + measured["y2"]) / consistency["samples"]
    assert consistency["nis_expected"] == pytest.approx(expected, rel=1e-12)
    assert consistency["warnings"] == [] and set(consistency["bias"]) == {"y1", "y3"}
    scaled = dataclasses.replace(signals, outputs=1.5 * signals.outputs)
    result = run_imm(model, scaled, ImmOptions())
    report = build_report(result, scaled, log="slow y2", model_name="three_tank_hstf", dt=1.0)
    assert any("larger than the model's noise" in note for note in report.notes)


def test_the_nis_of_partly_measured_rows_is_chi_squared_with_the_measured_count():
    rng = np.random.default_rng(11)
    whitened = rng.normal(size=(3000, 3))
    whitened[rng.random(3000) < 0.7, 1] = np.nan  # y2 measured on 30 % of the rows
    whitened[::50] = np.nan  # nothing measured: not a tested row
    accumulator = ConsistencyAccumulator(("y1", "y2", "y3"))
    accumulator.add(whitened, np.ones((3000, 1)))
    tested = accumulator.result()
    assert tested is not None and tested.samples == 3000 - 60
    freedom = int(np.isfinite(whitened).sum())
    assert tested.nis_expected * tested.samples == pytest.approx(freedom, rel=1e-12)
    assert abs(tested.nis_score) < 3 and tested.warnings() == ()
    assert tested.measured["y2"] == int(np.isfinite(whitened[:, 1]).sum())
    # a biased y2 is seen over the rows that measured it alone
    whitened[:, 1] += 0.5
    biased = ConsistencyAccumulator(("y1", "y2", "y3"))
    biased.add(whitened, np.ones((3000, 1)))
    tested = biased.result()
    assert tested is not None
    (warning,) = tested.warnings()
    assert "biased" in warning and "y2 +0.5" in warning


def test_a_log_too_short_or_unsettled_for_the_test_says_so():
    model = parse_model(builtin_text("three_tank_hstf"))
    signals = simulate(model, steps=20, seed=2024).signals(model)
    result = run_imm(model, signals, ImmOptions())
    report = build_report(result, signals, log="short", model_name="three_tank_hstf", dt=1.0)
    assert "consistency" not in report.extra
    (note,) = [n for n in report.notes if "innovations' whole-log test did not run" in n]
    assert "fewer than the 30 it needs" in note
