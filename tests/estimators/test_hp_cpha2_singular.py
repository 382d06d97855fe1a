"""A cluster whose innovation covariance is singular is refused naming the cluster and why.

With zero noise in a small cluster (at most four states, the straight-line EKF) the step
divided by ``det S = 0`` and the refusal read "float division by zero … its equations or
their Jacobian are not finite there", pointing at the model's equations; the numpy EKF of a
larger cluster read the same ``S`` as ``P_O = 0``, so that with the unknown mode every
hypothesis went unknown without a word.
"""

import numpy as np
import pytest

from hybridlog.errors import ModelError
from hybridlog.estimators.cpha.unknown_mode import UnknownModeOptions, run_unknown_mode
from hybridlog.model.loader import parse_model
from hybridlog.signals import AlignedSignals

ONE_STATE = """
name = "noiseless_small"
dt = 1.0
states = ["x1"]
inputs = ["u1"]
outputs = ["y1"]

[noise]
process = [{q}]
measurement = [{r}]

[initial]
state = [{x0}]
covariance = {p0}

[components.plant]
unknown = 0.001
initial = "a"

[components.plant.modes.a]
equations = ["x1[k] = {f}", "y1 = x1"]
"""


def signals(model, n=8):
    u = np.ones((n, 1))
    y = np.linspace(0.0, 3.0, n)[:, None]
    t = np.arange(n, dtype=np.float64)
    return AlignedSignals("log.csv", t, model.inputs, model.outputs, u, y)


def model_of(*, q="0.0", r="0.0", x0="0.0", p0="0.0", f="0.8*x1[k-1] + u1[k-1]"):
    text = ONE_STATE.format(q=q, r=r, x0=x0, p0=p0, f=f)
    return parse_model(text, origin="noiseless_small.toml")


@pytest.mark.parametrize("unknown_mode", [True, False])
def test_zero_noise_in_a_small_cluster_names_the_singular_innovation_covariance(unknown_mode):
    model = model_of()
    options = UnknownModeOptions(unknown_mode=unknown_mode)
    with pytest.raises(ModelError) as caught:
        run_unknown_mode(model, signals(model), options)
    message = str(caught.value)
    assert message.startswith("noiseless_small.toml: components: at t = 1 s the EKF of the ")
    assert "the cluster of x1 (components plant)" in message
    assert "innovation covariance S is singular" in message
    assert "division by zero" not in message and "not finite" not in message
    assert "\n" not in message


def test_a_division_by_zero_in_the_equations_still_names_the_equations():
    # 1/x1 at x1 = 0: the model's own division, not a singular S
    model = model_of(q="0.01", r="0.01", p0="1.0", f="0.5*x1[k-1] + 1/x1[k-1]")
    with pytest.raises(ModelError) as caught:
        run_unknown_mode(model, signals(model), UnknownModeOptions())
    message = str(caught.value)
    assert "the cluster of x1 (components plant)" in message
    assert "its equations or their Jacobian are not finite there" in message
    assert "singular" not in message
