"""The k-best path's EKF without process noise: covariances that shrink into the subnormal range.

Along one mode path of a plant without process noise the covariance shrinks geometrically; on
double_cart_case2 it is below 1e-310 by sample 1123, where the rounding of the update left a
variance of -9.88e-324 beside others of 1e-320, and ``--mode-sequence kbest`` was refused as a
diverged filter on every log of 1,124 samples or more.
"""

import numpy as np
import pytest

from hybridlog.estimators.registry import prepare
from hybridlog.model.loader import load_model
from hybridlog.simulate import simulate


@pytest.mark.parametrize("smooth", [False, True])
def test_kbest_path_of_a_plant_without_process_noise_keeps_its_variances_non_negative(smooth):
    model = load_model("double_cart_case2")
    assert not model.modes[0].process_noise.any()
    log = simulate(model, steps=1130, seed=0)
    signals = log.signals(model)
    options = {"mode_sequence": "kbest", "beam": 4, "smooth": smooth}
    result = prepare(model, "imm", options).run(model, signals)  # vouched as analyze does
    assert result.state_variances.min() >= 0.0
    assert result.state_variances[1123:].max() < 1e-300  # the subnormal range was reached
    # The path's estimates are still the plant's.
    error = np.abs(result.state_means - log.states)[100:].max()
    assert error < 0.05
