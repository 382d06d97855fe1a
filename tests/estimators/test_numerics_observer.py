"""Paper 001's observer design on a badly scaled model (a hostile plant model).

A mode ``x(k+1) = 1e200 x(k)``: SCS returned an "optimal_inaccurate" solution whose ``G_i``
is singular, and ``chiu``/``kmeans`` stopped with "unexpected LinAlgError: Singular matrix";
now the design is refused as infeasible, naming the model file and the mode.
"""

import numpy as np
import pytest

from hybridlog.errors import ModelError
from hybridlog.estimators import prepare
from hybridlog.estimators.lmi import ObserverDesignError, observer_gains
from hybridlog.model.loader import parse_model
from hybridlog.signals import AlignedSignals

SCALED = """
name = "scaled"
dt = 1.0
states = ["x1"]
inputs = ["u"]
outputs = ["y"]
[modes.m0]
f = ["2*x1"]
h = ["2*x1"]
[modes.m1]
f = ["x1*1e200"]
h = ["x1"]
[noise]
process = 0.1
measurement = 0.1
[initial]
state = [1.0]
covariance = 1.0
"""


def test_a_singular_solution_of_the_lmi_is_no_gain():
    A = np.array([[[2.0]], [[1e200]]])
    C = np.array([[[2.0]], [[1.0]]])
    with pytest.raises(ObserverDesignError, match="infeasible"):
        observer_gains(A, C, ("m0", "m1"), model_name="scaled.toml")


@pytest.mark.parametrize("name", ["chiu", "kmeans"])
def test_the_clustering_observers_refuse_it_naming_the_file_and_mode(name):
    model = parse_model(SCALED, origin="models/scaled.toml")
    n = 40
    rng = np.random.default_rng(2)
    signals = AlignedSignals(
        source="log.csv",
        time=np.arange(n, dtype=float),
        input_names=("u",),
        output_names=("y",),
        inputs=np.full((n, 1), 0.1),
        outputs=np.cumsum(rng.normal(0.0, 0.1, n))[:, None] + 1.0,
    )
    with pytest.raises(ModelError) as caught:
        prepare(model, name).run(model, signals)
    message = str(caught.value)
    assert message.startswith("models/scaled.toml: the observer LMI (15) of paper 001 is ")
    assert "infeasible" in message and "'m1'" in message and "\n" not in message
