"""An innovation covariance singular in double precision stops the filter, naming why.

Two outputs measuring one state, a prior variance of ``1e20`` and a measurement noise of
``1e-10``: ``H P Hᵀ`` rounds ``R`` away and ``S = H P Hᵀ + R`` is singular as computed, so
no mode's EKF update (paper 000 eqs. (9)-(11)) exists.  The straight-line code and the HSTF
come out NaN there, which was refused as "every expression of the model is finite", naming
nothing a user could change.  (The IMM's generic loop, past ``MAX_UNROLLED_MODES`` modes,
keeps every mode's prediction instead, as both kernels do where ``S`` overflows to infinity:
``test_numerics_constants`` holds them equal there.)
"""

import numpy as np
import pytest

from hybridlog.errors import DivergenceError
from hybridlog.estimators import prepare
from hybridlog.model.loader import parse_model
from hybridlog.signals import AlignedSignals

N = 6


def _model(n_modes: int):
    modes = "".join(
        f'[modes.m{i}]\nf = ["x1 + u"]\nh = ["{i + 1}*x1", "{i + 1}*x1"]\n\n'
        for i in range(n_modes)
    )
    return parse_model(
        'dt = 1.0\nstates = ["x1"]\ninputs = ["u"]\noutputs = ["y1", "y2"]\n\n'
        f"{modes}[noise]\nprocess = 0.0\nmeasurement = 1e-10\n\n"
        "[initial]\nstate = [0.0]\ncovariance = 1e20\n",
        origin="redundant.toml",
    )


def _signals() -> AlignedSignals:
    return AlignedSignals(
        source="redundant.csv",
        time=np.arange(N, dtype=float),
        input_names=("u",),
        output_names=("y1", "y2"),
        inputs=np.zeros((N, 1)),
        outputs=np.full((N, 2), 5.0),
    )


@pytest.mark.parametrize(("estimator", "n_modes"), [("imm", 2), ("hstf", 2)])
def test_every_singular_innovation_covariance_is_refused_and_named(estimator, n_modes):
    model = _model(n_modes)
    with pytest.raises(DivergenceError) as caught:
        prepare(model, estimator).run(model, _signals())
    message = str(caught.value)
    assert message.startswith(
        f"redundant.toml: {estimator} diverged at t = 1 s (sample 1): the state estimate is "
        "not finite; every mode's innovation covariance H P Hᵀ + R is singular in float64 "
        "(mode 'm0': 2e+20 rounds away R's 1e-10), from variances x1 1e+20 at the sample before"
    )
    assert "every expression of the model is finite" not in message
    assert "\n" not in message
