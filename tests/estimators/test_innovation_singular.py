"""An innovation covariance singular in double precision stops the filter, naming why.

Two outputs measuring one state, a prior variance of ``1e20`` and a measurement noise of
``1e-10``: ``H P Hᵀ`` rounds ``R`` away and ``S = H P Hᵀ + R`` is singular as computed, so
no mode's EKF update (paper 000 eqs. (9)-(11)) exists.  The straight-line code and the HSTF
came out NaN there, which was refused as "every expression of the model is finite", naming
nothing a user could change; the IMM's generic loop, past ``MAX_UNROLLED_MODES`` modes, kept
every mode's prediction and the predicted mode probabilities silently.  Every kernel now
refuses the sample as one no mode could weigh (``vouch._first_unweighed``), as it does where
``S`` overflows to infinity (``test_numerics_constants``).
"""

from dataclasses import replace

import numpy as np
import pytest

from hybridlog.errors import DivergenceError
from hybridlog.estimators import prepare
from hybridlog.model.loader import parse_model
from hybridlog.signals import AlignedSignals

N = 6


def _model(n_modes: int, *, gains: bool = True):
    modes = "".join(
        f'[modes.m{i}]\nf = ["x1 + u"]\nh = ["{i + 1 if gains else 1}*x1", '
        f'"{i + 1 if gains else 1}*x1"]\n\n'
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


@pytest.mark.parametrize(
    ("estimator", "n_modes", "gains"),
    [("imm", 2, True), ("hstf", 2, True), ("imm", 9, False), ("hstf", 9, False)],
    ids=["imm", "hstf", "imm-generic-loop", "hstf-9-modes"],
)
def test_every_singular_innovation_covariance_is_refused_and_named(estimator, n_modes, gains):
    model = _model(n_modes, gains=gains)
    with pytest.raises(DivergenceError) as caught:
        prepare(model, estimator).run(model, _signals())
    message = str(caught.value)
    # The straight-line code's update comes out NaN there (and the HSTF's generic loop's): a
    # diverged state, said with its cause; the IMM's generic loop had kept the prediction: a
    # sample no mode could weigh.
    generic_imm = estimator == "imm" and n_modes > 8
    start = "cannot weigh the measurement" if generic_imm else "diverged"
    assert message.startswith(f"redundant.toml: {estimator} {start} at t = 1 s (sample 1): ")
    assert (
        "; every mode's innovation covariance H P Hᵀ + R is singular in float64 (mode 'm0': "
        "2e+20 rounds away R's 1e-10), from variances x1 1e+20 at the sample before"
    ) in message
    assert "every expression of the model is finite" not in message
    assert "\n" not in message


def test_a_sample_measuring_nothing_is_not_refused_as_unweighed():
    """No output measured: there is nothing to weigh, and the prediction is the estimate."""
    model = _model(2)
    signals = _signals()
    signals = replace(signals, unmeasured_outputs=np.ones(signals.outputs.shape, dtype=bool))
    for estimator in ("imm", "hstf"):
        result = prepare(model, estimator).run(model, signals)
        assert np.isfinite(result.state_means).all()
        np.testing.assert_array_equal(result.state_variances, 1e20)
