"""A state the reported hypothesis held rather than estimated is named and not scored.

Paper 002 §3.1 holds the mean of a state in no filter cluster and grows its variance; the
report scored that held value (the initial state, for a state no cluster ever held) against
the log's true state as an estimate, first without a word, then with a warning that said so
while the RMSE, estimates.csv and the plots still presented it as an estimate.
"""

import csv
import json
import math
from dataclasses import replace

import numpy as np
import pytest

from hybridlog.estimators.cpha.unknown_mode import UnknownModeOptions, run_unknown_mode
from hybridlog.io.writers import write_table
from hybridlog.model.loader import parse_model
from hybridlog.report import build_report
from hybridlog.report.build import ReportBuilder
from hybridlog.report.plot_reducer import reduce_result
from hybridlog.signals import AlignedSignals
from tests.estimators.test_hp_cpha_solving import analyze, model_text
from tests.support.cpha import CPHA_EXAMPLE, cpha_log


def run(text, options):
    model = parse_model(text)
    n = 30
    u = 1.0 + 0.5 * np.sin(np.arange(n) / 5.0)
    t = np.arange(n, dtype=np.float64)
    log = AlignedSignals("log.csv", t, model.inputs, model.outputs, u[:, None], u[:, None].copy())
    return run_unknown_mode(model, log, options)


def held_notes(result):
    return [note for note in result.notes if "a reported state no filter estimated" in note]


def test_an_unobservable_state_is_named_on_every_sample_it_was_held():
    text = model_text("x1[k] = 0.8*x1[k-1] + u1[k-1]", "y1 = u1")
    for sequence in ("argmax", "kbest"):
        result = run(text, UnknownModeOptions(unknown_mode=False, mode_sequence=sequence))
        (note,) = held_notes(result)
        assert note.startswith("WARNING: a reported state no filter estimated: x1 on 30 of 30 ")
        assert "the state RMSE, estimates.csv and the plots leave those samples out" in note
        # the warning is true: the mean never moved from the initial state
        assert (result.state_means[:, 0] == 0.0).all()
        assert result.states_not_estimated is not None and result.states_not_estimated.all()
        assert np.isnan(result.estimated_state_means()).all()
        if result.post_processing is not None:
            assert held_notes(result.post_processing.filtered) == [note]
            filtered = result.post_processing.filtered
            assert filtered.states_not_estimated is not None


def test_an_estimated_state_has_no_warning():
    text = model_text("x1[k] = 0.8*x1[k-1] + u1[k-1]", "y1 = x1")
    result = run(text, UnknownModeOptions(unknown_mode=False))
    assert held_notes(result) == []
    assert result.states_not_estimated is None
    assert result.estimated_state_means() is result.state_means


def test_a_state_never_estimated_has_no_rmse_no_estimate_and_says_why(tmp_path, capsys):
    # x1 is unobservable on every sample (y1 = u1): the log's true x1 was scored against the
    # initial state, "x1 RMSE 1.1 over 40 samples"
    n = 40
    u = 1.0 + 0.5 * np.sin(np.arange(n) / 5.0)
    x1 = np.zeros(n)
    for k in range(1, n):
        x1[k] = 0.8 * x1[k - 1] + u[k - 1]
    log = write_table(
        tmp_path / "log.csv", {"t": np.arange(n, dtype=np.float64), "u1": u, "y1": u, "x1": x1}
    )
    text = model_text("x1[k] = 0.8*x1[k-1] + u1[k-1]", "y1 = u1")
    code, _ = analyze(tmp_path, text, log, capsys)
    assert code == 0
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    assert report["states"]["x1"] == {"rmse": None, "samples": 0}
    why = report["null_reasons"]["state_rmse.x1"]
    assert why.startswith("the estimator did not estimate state x1 on any sample with a true")
    with (tmp_path / "out" / "estimates.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert [row["x1_hat"] for row in rows] == [""] * n
    assert all(row["x1_true"] for row in rows)
    assert "x1 is n/a: the estimator did not estimate" in (
        (tmp_path / "out" / "report.md").read_text()
    )


def drift_run(sequence):
    """The CPHA example with A1 drifting from step 60: A1 goes unknown, x_c1 is held."""
    model = parse_model(CPHA_EXAMPLE)
    signals = cpha_log(model, 150, seed=5, a1=lambda k: "drift" if k >= 60 else "m11")
    truth = np.zeros((signals.n_samples, 3))  # any true state: the rows scored are the point
    signals = replace(signals, truth_states=truth)
    options = UnknownModeOptions(mode_sequence=sequence)
    return model, signals, run_unknown_mode(model, signals, options)


@pytest.mark.parametrize("sequence", ["argmax", "kbest"])
def test_the_rmse_of_a_state_held_on_some_samples_is_over_the_others(sequence):
    model, signals, result = drift_run(sequence)
    held = result.states_not_estimated
    assert held is not None and 0 < held[:, 0].sum() < signals.n_samples
    estimated = ~held[:, 0]
    report = build_report(result, signals, log="log.csv", model_name=model.name, dt=1.0)
    state = report.states["xc1"]
    assert state.samples == int(estimated.sum())
    expected = math.sqrt(float(np.mean(result.state_means[estimated, 0] ** 2)))
    assert state.rmse is not None and math.isclose(state.rmse, expected, rel_tol=1e-12)
    # the report's numbers do not depend on how the rows crossed in chunks
    builder = ReportBuilder(signals, log="log.csv", dt=1.0)
    for start in range(0, signals.n_samples, 7):
        builder.add(result.rows(start, min(start + 7, signals.n_samples)))
    assert builder.report(model_name=model.name).states == report.states
    # states.png draws no estimate (and no band) where the state was held
    (curves, *_) = reduce_result(result, signals).states
    assert curves.name == "xc1" and not curves.estimate.reduced
    assert np.array_equal(np.isnan(curves.estimate.values), held[:, 0])
    assert curves.band is not None and np.isnan(curves.band.low[held[:, 0]]).all()
    if result.post_processing is not None:  # kbest: the filter's side masks its own held rows
        filtered = result.post_processing.filtered
        assert filtered.states_not_estimated is not None
        assert report.smoothing is not None
        side = report.smoothing.filtered.states["xc1"]
        assert side.samples == int((~filtered.states_not_estimated[:, 0]).sum())


def test_kbest_keeps_the_causal_probabilities_whole_and_its_predictions():
    # a previous pass read timeline.csv's p_ columns as not summing to 1 under kbest and
    # yc1_hat as wrongly empty: each row's joint p_ columns sum to 1 (the p_unknown.<c>
    # columns are marginals beside them), and y-hat is the causal estimate's, made before
    # y(k): empty where the most likely hypothesis of the step before, held in its modes
    # (leaving unknown is less likely than staying here), has no cluster predicting the output
    # (A1 unknown: w_c1, so x_c1, undetermined; A2 unknown: no y_c1 equation)
    _, _, causal = drift_run("argmax")
    _, _, result = drift_run("kbest")
    assert np.allclose(result.mode_probabilities.sum(axis=1), 1.0)
    assert np.array_equal(result.mode_probabilities, causal.mode_probabilities)
    assert np.array_equal(result.output_predictions, causal.output_predictions, equal_nan=True)
    labels = [label.split("|") for label in causal.mode_ids]
    either = np.array(["unknown" in (a1, a2) for a1, a2, _ in labels])[causal.modes]
    unpredicted = np.isnan(causal.output_predictions[1:, 0])
    assert unpredicted.any() and np.array_equal(unpredicted, either[:-1])
