"""Numerical invariants of the filters over long runs with gross outliers (hypothesis)."""

import dataclasses
import re

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hybridlog.errors import DivergenceError
from hybridlog.estimators.hstf import HstfOptions, run_hstf
from hybridlog.estimators.imm import ImmOptions, run_imm
from hybridlog.model.loader import load_model, parse_model
from hybridlog.simulate import simulate
from tests.support.models import LINEAR_TWO_MODE

STEPS = 100_000
MODELS = {
    "three_tank_hstf": lambda: load_model("three_tank_hstf"),
    "linear_two_mode": lambda: parse_model(LINEAR_TWO_MODE),
}
RUNS = {
    "hstf": lambda m, s: run_hstf(m, s, HstfOptions(), store_covariances=True),
    "hstf-unfaded": lambda m, s: run_hstf(
        m, s, HstfOptions(likelihood="unfaded"), store_covariances=True
    ),
    "imm": lambda m, s: run_imm(m, s, ImmOptions(), store_covariances=True),
}

REFUSING = {"imm", "hstf", "hstf-unfaded"}
"""Runs that refuse a sample no mode explains (hybridlog.estimators.vouch.check_surprise)."""
ABSORBING = {"hstf"}
"""Runs that may take such a sample instead: the paper's faded S_i grows with the innovation."""


@pytest.fixture(scope="module")
def long_logs():
    logs = {}
    for name, make in MODELS.items():
        model = make()
        logs[name] = (model, simulate(model, steps=STEPS - 1, seed=5))
    return logs


def with_outliers(model, log, n_outliers, sigmas, seed):
    """The aligned signals of ``log`` with ``n_outliers`` samples pushed ``sigmas`` standard
    deviations of mode 1's measurement noise off, up or down per output (drawn from ``seed``)."""
    rng = np.random.default_rng(seed)
    outputs = log.outputs.copy()
    rows = rng.choice(len(outputs), size=n_outliers, replace=False)
    std = np.sqrt(np.diag(model.modes[0].measurement_noise))
    outputs[rows] += rng.choice([-1.0, 1.0], size=(n_outliers, model.n_outputs)) * sigmas * std
    return dataclasses.replace(log.signals(model), outputs=outputs)


def assert_filter_invariants(result):
    P = result.covariances
    assert np.isfinite(P).all()
    assert np.isfinite(result.state_means).all()
    np.testing.assert_array_equal(P, P.transpose(0, 2, 1))  # symmetric exactly
    scale = np.maximum(np.abs(P).max(axis=(1, 2)), 1e-300)
    smallest = np.linalg.eigvalsh(P).min(axis=1) / scale
    assert smallest.min() >= -1e-12, f"P not PSD at row {int(np.argmin(smallest))}"
    mu = result.mode_probabilities
    assert np.isfinite(mu).all()
    assert (mu >= 0).all()
    np.testing.assert_allclose(mu.sum(axis=1), 1.0, rtol=0, atol=1e-12)


@settings(
    max_examples=4, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    model_name=st.sampled_from(sorted(MODELS)),
    run_name=st.sampled_from(sorted(RUNS)),
    n_outliers=st.integers(min_value=0, max_value=200),
    sigmas=st.sampled_from([10.0, 1e3, 1e6]),
    seed=st.integers(min_value=0, max_value=2**32 - 1),
)
def test_covariances_stay_symmetric_psd_and_probabilities_normalised(
    long_logs, model_name, run_name, n_outliers, sigmas, seed
):
    model, log = long_logs[model_name]
    signals = with_outliers(model, log, n_outliers, sigmas, seed)
    try:
        result = RUNS[run_name](model, signals)
    except DivergenceError as error:  # the IMM refuses a sample no mode explains
        assert run_name in REFUSING and "cannot explain the log" in str(error)
        assert sigmas >= 1e3 and n_outliers > 0  # 10 σ outliers are noise a model may meet
        return
    assert_filter_invariants(result)


@pytest.mark.parametrize("run_name", sorted(RUNS))
def test_invariants_hold_with_a_burst_of_outliers_on_every_model(long_logs, run_name):
    """The explicit worst case: consecutive 10^6-sigma outliers on all outputs (refused at
    the first by the filters that test their innovations, REFUSING)."""
    for model, log in long_logs.values():
        outputs = log.outputs.copy()
        outputs[1000:1020] += 1e6 * np.sqrt(np.diag(model.modes[0].measurement_noise))
        signals = dataclasses.replace(log.signals(model), outputs=outputs)
        if run_name in REFUSING:
            try:
                result = RUNS[run_name](model, signals)
            except DivergenceError as error:  # at the burst, whose first sample may be absorbed
                assert re.search(r"cannot explain .*\(sample 100[01]\)", str(error)), error
                continue
            assert run_name in ABSORBING
        else:
            result = RUNS[run_name](model, signals)
        assert_filter_invariants(result)
        # The filter recovers: the last tenth of the run tracks the measurements again.
        tail = slice(STEPS - STEPS // 10, STEPS)
        error = np.abs(result.output_predictions[tail] - log.outputs[tail])
        assert np.median(error) < 10 * std_of(model)


def std_of(model):
    return float(np.sqrt(np.max(np.diag(model.modes[0].measurement_noise))))
