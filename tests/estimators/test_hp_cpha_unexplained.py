"""A step no successor explains is refused, never answered with the step before's estimate.

The tracker kept the previous hypotheses when every successor's belief was 0 (``P_O = 0``
everywhere, or no successor at all), so that a model without noise reported its initial
state with variance 0, a certain estimate, on every sample of the log, and exit 0.
"""

import numpy as np
import pytest

from hybridlog.errors import ModelError
from hybridlog.estimators.cpha.unknown_mode import UnknownModeOptions, run_unknown_mode
from hybridlog.model.loader import parse_model
from hybridlog.signals import AlignedSignals

# Five states: the cluster's EKF is the numpy one (the unrolled one stops at four); its
# singular S is refused (tests/estimators/test_hp_cpha2_singular.py: the unrolled one's too).
NOISELESS = """
name = "noiseless"
dt = 1.0
states = ["x1", "x2", "x3", "x4", "x5"]
inputs = ["u1"]
outputs = ["y1"]

[noise]
process = [0.0, 0.0, 0.0, 0.0, 0.0]
measurement = [0.0]

[initial]
state = [0.0, 0.0, 0.0, 0.0, 0.0]
covariance = 0.0

[components.plant]
unknown = 0.0
initial = "a"

[components.plant.modes.a]
equations = [
  "x1[k] = 0.8*x2[k-1] + u1[k-1]",
  "x2[k] = 0.5*x3[k-1]",
  "x3[k] = 0.5*x4[k-1]",
  "x4[k] = 0.5*x5[k-1]",
  "x5[k] = 0.5*x1[k-1]",
  "y1 = x1",
]
"""

TO_UNKNOWN_ONLY = """
name = "to_unknown"
dt = 1.0
states = ["x1"]
inputs = ["u1"]
outputs = ["y1"]

[noise]
process = [0.01]
measurement = [0.01]

[initial]
state = [0.0]
covariance = 1.0

[components.plant]
unknown = 0.01
initial = "a"

[components.plant.modes.a]
equations = ["x1[k] = 0.8*x1[k-1] + u1[k-1]", "y1 = x1"]

[[components.plant.transitions]]
from = "a"
to = {unknown = 1.0}
"""


def signals(model, n=12):
    u = np.ones((n, 1))
    y = np.linspace(0.0, 3.0, n)[:, None]
    t = np.arange(n, dtype=np.float64)
    return AlignedSignals("log.csv", t, model.inputs, model.outputs, u, y)


def test_a_noiseless_model_is_refused_naming_the_cluster():
    model = parse_model(NOISELESS, origin="noiseless.toml")
    with pytest.raises(ModelError) as caught:
        run_unknown_mode(model, signals(model), UnknownModeOptions())
    message = str(caught.value)
    assert message.startswith("noiseless.toml: components: at t = 1 s the EKF of the cluster ")
    assert "the cluster of x1, x2, x3, x4, x5 (components plant)" in message
    assert "innovation covariance S is singular" in message and "\n" not in message


def test_no_successor_at_all_is_refused_naming_the_component():
    model = parse_model(TO_UNKNOWN_ONLY, origin="to_unknown.toml")
    options = UnknownModeOptions(unknown_mode=False)
    with pytest.raises(ModelError, match=r"^to_unknown\.toml: components: at t = 1 s ") as caught:
        run_unknown_mode(model, signals(model), options)
    assert "component plant cannot leave mode 'a' for a modelled mode" in str(caught.value)
    # with the unknown mode, the component goes there and the run is an estimate
    result = run_unknown_mode(model, signals(model), UnknownModeOptions())
    assert result.mode_ids[result.modes[-1]] == "unknown"
