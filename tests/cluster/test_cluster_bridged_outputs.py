"""Regression vectors holding an output the log did not measure are not clustered.

A log with short output gaps is bridged onto the model's grid (the nearest or interpolated
sample, ``AlignedSignals.unmeasured_outputs``); the metrics no longer scored those points,
but ``hybridlog cluster`` and the ``chiu``/``kmeans`` estimators fitted their centres on
φ(k) built from them (a log at half the model's rate gave centres with ``y(k) = y(k−1)``),
and labelled the clusters by how well the observer predicted the stand-ins.  Now those
vectors are left out of the fit and counted, the labelling scores measured outputs only, a
log with no measured vector is refused, and the estimators mark the samples whose mode was
decided without all outputs (timeline.csv's ``vouched``).
"""

import dataclasses

import numpy as np
import polars as pl
import pytest

from hybridlog.cluster.classifier import ModeClassifier, fit_classifier
from hybridlog.cluster.kmeans import KMeansParameters
from hybridlog.cluster.labels import NO_CLUSTER, decide_clusters
from hybridlog.cluster.regressors import RegressorSpec, measured_rows
from hybridlog.cluster.subtractive import SubtractiveOptions
from hybridlog.errors import DataShortError, LogError
from hybridlog.estimators.chiu import (
    ChiuOptions,
    _prediction_score,
    design_observer,
    mode_classifier,
    run_chiu,
)
from hybridlog.estimators.kmeans import KMeansOptions, run_kmeans
from hybridlog.model.cache import load_model
from hybridlog.signals import AlignedSignals
from tests.support.paths import SAMPLE_LOGS

_ROWS = 201


def test_measured_rows_drops_every_vector_holding_a_bridged_output_at_any_lag():
    unmeasured = np.zeros((8, 2), dtype=bool)
    unmeasured[3, 1] = True  # y_2(3): in φ(3) (lag 0) and φ(5) (lag 2)
    spec = RegressorSpec(output_lags=(0, 2), input_lags=(1,))
    kept = measured_rows(unmeasured, spec, 8)  # rows k = 2 … 7
    np.testing.assert_array_equal(kept, [True, False, True, False, True, True])
    assert measured_rows(None, spec, 8).all() and measured_rows(None, spec, 8).size == 6
    assert measured_rows(unmeasured, spec, 2).size == 0


def test_a_sample_is_decided_on_its_measured_outputs_and_held_without_any():
    # eqs. (2)-(3) read the stand-in the alignment put where the log measured nothing
    centres = np.array([[0.0, 0.0], [1.0, 10.0]])
    nan = np.nan
    y = np.array([[nan, nan], [0.9, nan], [nan, 0.1], [nan, nan], [0.2, 9.0], [nan, nan]])
    assert decide_clusters(y, centres).tolist() == [NO_CLUSTER, 1, 0, NO_CLUSTER, 1, NO_CLUSTER]
    classifier = ModeClassifier(
        algorithm="kmeans",
        spec=RegressorSpec(output_lags=(0,), input_lags=()),
        regressors=("y1(k)", "y2(k)"),
        decision_columns=(0, 1),
        centers=centres,
        lower=np.zeros(2),
        upper=np.ones(2),
        cluster_modes=None,
        labelling=(),
        notes=(),
        details={},
    )
    # none measured: the cluster of the sample before (the first decided one's, before it)
    assert classifier.decide(y).tolist() == [1, 1, 0, 0, 1, 1]
    with pytest.raises(DataShortError, match="no sample has a measured output"):
        classifier.decide(np.full((3, 2), nan))


def _blobs_with_stand_ins() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Two blobs of measured y, and 40 % of the rows bridged, holding a stand-in 50."""
    rng = np.random.default_rng(3)
    y = np.where(np.arange(200) % 20 < 10, 0.0, 5.0) + rng.normal(0.0, 0.05, 200)
    unmeasured = rng.random(200) < 0.4
    y[unmeasured] = 50.0
    return y[:, None], np.zeros((200, 0)), unmeasured[:, None]


@pytest.mark.parametrize(
    "clustering", [SubtractiveOptions(), KMeansParameters(seed=1)], ids=["chiu", "kmeans"]
)
def test_centres_are_fitted_on_measured_vectors_only(clustering):
    y, u, unmeasured = _blobs_with_stand_ins()
    spec = RegressorSpec(output_lags=(0,), input_lags=())
    fitted = fit_classifier(
        y, u, spec, clustering, names=["y(k)"], n_modes=2, unmeasured=unmeasured
    )
    assert fitted.decision_values.max() < 10.0  # a centre at the stand-ins' 50 was fitted
    assert fitted.upper[0] < 10.0  # the unit box of the measured vectors
    left_out = int(unmeasured.sum())
    assert (
        f"({left_out} regression vectors left out: each holds an output value" in (fitted.notes[0])
    )
    if isinstance(clustering, SubtractiveOptions):  # the rows of the centres: measured ones
        assert not unmeasured[fitted.details["center_rows"], 0].any()


def test_a_log_without_one_measured_vector_is_refused():
    y = np.arange(10.0)[:, None]
    unmeasured = (np.arange(10) % 2 == 1)[:, None]  # half the model's rate
    with pytest.raises(DataShortError, match="every one of its 9 regression vectors holds"):
        fit_classifier(
            y,
            np.zeros((10, 0)),
            RegressorSpec(input_lags=()),
            SubtractiveOptions(),
            names=["y(k)", "y(k-1)"],
            n_modes=2,
            unmeasured=unmeasured,
        )


def _double_cart(every_other: bool = False) -> tuple[object, AlignedSignals]:
    """The double-cart log with every 5th output (or every other one) a bridged stand-in."""
    model = load_model("double_cart_case1")
    frame = pl.read_csv(SAMPLE_LOGS / "double_cart_case1.csv").head(_ROWS)
    n = frame.height
    unmeasured = (np.arange(n) % (2 if every_other else 5) == (1 if every_other else 3))[:, None]
    y = frame["y"].to_numpy().copy()[:, None]
    y[unmeasured[:, 0], 0] = y[np.flatnonzero(unmeasured[:, 0]) - 1, 0]  # the sample before
    truth = {m: i for i, m in enumerate(model.mode_ids)}
    signals = AlignedSignals(
        source="dc1.csv",
        time=frame["t"].to_numpy().astype(np.float64),
        input_names=model.inputs,
        output_names=model.outputs,
        inputs=frame["u"].to_numpy().astype(np.float64)[:, None],
        outputs=y,
        truth_modes=np.array([truth[str(m)] for m in frame["mode"]], dtype=np.int64),
        unmeasured_outputs=unmeasured,
    )
    return model, signals


@pytest.mark.parametrize("run, options", [(run_chiu, ChiuOptions()), (run_kmeans, KMeansOptions())])
def test_the_estimators_say_what_they_left_out_and_mark_the_modes_not_vouched(run, options):
    model, signals = _double_cart()
    result = run(model, signals, options, jit=False)
    notes = "\n".join(result.notes)
    assert "from 120 regression vectors" in notes and "(80 regression vectors left out" in notes
    assert "the mode of 40 of 201 samples (19.9 %) was decided without an output" in notes
    (vouched,) = [c for c in result.timeline_columns if c.name == "vouched"]
    np.testing.assert_array_equal(vouched.values == 0.0, signals.unmeasured_outputs[:, 0])
    measured = run(model, dataclasses.replace(signals, unmeasured_outputs=None), options, jit=False)
    assert not measured.timeline_columns  # a log measured throughout: no column, no note
    assert "left out" not in "\n".join(measured.notes)


def test_a_log_at_half_the_models_rate_is_refused_by_the_estimator_naming_the_log():
    model, signals = _double_cart(every_other=True)
    with pytest.raises(LogError, match=r"^dc1.csv: chiu cannot cluster .*every one of its 200"):
        mode_classifier(model, signals, ChiuOptions())


def test_the_labelling_scores_measured_outputs_only():
    # the score must not count the squared prediction errors at the stand-ins
    model, signals = _double_cart()
    observer = design_observer(model, 1.0)
    decided = np.zeros(signals.n_samples, dtype=np.int64)
    labels = np.array([0], dtype=np.int64)
    measured = _prediction_score(model, signals, *observer, decided)(labels)
    everything = dataclasses.replace(signals, unmeasured_outputs=None)
    assert _prediction_score(model, everything, *observer, decided)(labels) > measured > 0.0
