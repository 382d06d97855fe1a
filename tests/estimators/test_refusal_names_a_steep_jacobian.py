"""A covariance lost to rounding through a steep but finite Jacobian is named as the cause.

The HSTF on a three-tank log of empty tanks at rest (inputs and levels all zero) drove the
levels to within 1e-21 of each other, where the derivative of ``sqrt(|x1 - x3|)`` is 1e9:
``F P Fᵀ`` of 1e16 rounded by more than the variances of 0.05 the update subtracts it down
to, and the variance of x3 came out -0.82.  The refusal said "every expression of the model
is finite at the estimate of sample 12", which pointed at nothing a user could change.
"""

import numpy as np

from hybridlog.errors import ModelError
from hybridlog.estimators.result import EstimationResult
from hybridlog.estimators.vouch import check_result
from hybridlog.model.loader import load_model
from hybridlog.signals import AlignedSignals

N = 3


def _signals() -> AlignedSignals:
    return AlignedSignals(
        source="empty.csv",
        time=np.arange(N, dtype=float),
        input_names=("u",),
        output_names=("y1", "y2", "y3"),
        inputs=np.zeros((N, 1)),
        outputs=np.zeros((N, 3)),
    )


def _result(before: list[float]) -> EstimationResult:
    means = np.array([[20.0, 5.0, 10.0], before, [0.0, 0.0, 0.0]])
    variances = np.full((N, 3), 0.05)
    variances[2, 2] = -0.8  # the covariance of the step into sample 2 lost its sign
    predictions = np.zeros((N, 3))
    predictions[0] = np.nan
    return EstimationResult(
        estimator="hstf",
        options={},
        time=np.arange(N, dtype=float),
        mode_ids=("1", "2", "3"),
        state_names=("x1", "x2", "x3"),
        output_names=("y1", "y2", "y3"),
        modes=np.zeros(N, dtype=np.int64),
        mode_probabilities=np.tile([1.0, 0.0, 0.0], (N, 1)),
        state_means=means,
        state_variances=variances,
        output_predictions=predictions,
    )


def _message(before: list[float]) -> str:
    model = load_model("three_tank_hstf")
    try:
        check_result(model, _signals(), _result(before))
    except ModelError as err:
        return str(err)
    raise AssertionError("a negative variance was not refused")


def test_a_negative_variance_behind_a_steep_derivative_names_it():
    # x1 - x3 = 1e-21: d/dx of sqrt(|x1 - x3|) is about 1e9
    message = _message([1e-21, 0.5, 0.0])
    assert message.startswith(
        "three_tank_hstf: hstf diverged at t = 2 s (sample 2): the variance of x3 is negative"
    )
    assert "; the derivative by x" in message
    assert "of modes.1.f[" in message
    assert "F P Fᵀ = " in message and " swamps variances of 0.05" in message
    assert "every expression of the model is finite" not in message
    assert "\n" not in message


def test_a_negative_variance_where_the_derivatives_are_mild_blames_no_expression():
    message = _message([15.0, 10.0, 12.0])
    assert "every expression of the model is finite at the estimate of sample 1" in message
    assert "swamps" not in message
