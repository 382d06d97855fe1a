"""The compiled HSTF against an independent NumPy transcription of paper 000."""

import numpy as np
import pytest

from hybridlog.estimators.hstf import HstfOptions, run_hstf
from hybridlog.model.loader import load_model
from hybridlog.simulate import simulate
from tests.support.reference_hstf import reference_hstf


@pytest.fixture(scope="module")
def three_tank():
    model = load_model("three_tank_hstf")
    return model, simulate(model, seed=7).signals(model)


@pytest.mark.parametrize(
    "options",
    [
        HstfOptions(),
        HstfOptions(likelihood="unfaded"),
        HstfOptions(rho=0.6, beta=2.0, theta=0.9),
        HstfOptions(fading=False),
    ],
    ids=["paper", "unfaded-likelihood", "other-factors", "no-fading"],
)
def test_compiled_hstf_matches_numpy_transcription(three_tank, options):
    model, signals = three_tank
    result = run_hstf(model, signals, options)
    means, probabilities, modes = reference_hstf(
        model,
        signals.inputs,
        signals.outputs,
        rho=options.rho,
        beta=options.beta,
        theta=options.theta,
        fading=options.fading,
        unfaded=options.likelihood == "unfaded",
    )
    np.testing.assert_allclose(result.state_means, means, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(result.mode_probabilities, probabilities, rtol=1e-7, atol=1e-9)
    np.testing.assert_array_equal(result.modes, modes)


def test_plain_python_path_matches_compiled(three_tank):
    model, signals = three_tank
    compiled = run_hstf(model, signals, HstfOptions())
    plain = run_hstf(model, signals, HstfOptions(), jit=False)
    np.testing.assert_allclose(plain.state_means, compiled.state_means, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(
        plain.mode_probabilities, compiled.mode_probabilities, rtol=1e-12, atol=1e-12
    )
