"""A sample no successor explains is refused by ``unknown-mode`` as by ``imm``.

With the unknown mode switched off (``unknown_mode = false``, or ``unknown = 0`` for the
component measuring the sample, the valve's unknown mode leaving the tank checked), a spike
of millions of standard deviations was absorbed: every successor's ``P_O`` was ~0, the
beliefs were normalised, the cluster filters took the spike as a good measurement, and the
run ended with exit 0, mode accuracy 20 % and a fit of -72,000 %, where ``imm`` on the same
log refused "cannot explain the log" (vouch).  With the unknown mode, a successor with that
component unknown explains the sample (``P_O = 1``): the run goes on, as paper 002 means it
to.
"""

import numpy as np
import pytest

from hybridlog.errors import DivergenceError
from hybridlog.estimators.cpha.unknown_mode import UnknownModeOptions, run_unknown_mode
from hybridlog.model.loader import parse_model
from hybridlog.signals import AlignedSignals

TWO = """
name = "two"
dt = 1.0
states = ["x1", "x2"]
inputs = ["u"]
outputs = ["y1", "y2"]

[noise]
process = [0.01, 0.01]
measurement = [0.04, 0.04]

[initial]
state = [0.0, 0.0]
covariance = 1.0

[components.valve]
unknown = 0.001
initial = "open"

[components.valve.modes.open]
equations = ["x1[k] = 0.5*x1[k-1] + u[k-1]", "y1 = x1"]

[[components.valve.transitions]]
from = "unknown"
to = {open = 0.8}

[components.tank]
unknown = TANK_UNKNOWN
initial = "ok"

[components.tank.modes.ok]
equations = ["x2[k] = 0.9*x2[k-1] + u[k-1]", "y2 = x2"]

[[components.tank.transitions]]
from = "unknown"
to = {ok = 0.8}
"""


def _log(model, spike: float | None) -> AlignedSignals:
    """60 noise-free samples of the model in its known modes; ``spike`` added to y2 at 30."""
    n = 60
    u = np.ones((n, 1))
    x1 = np.zeros(n)
    x2 = np.zeros(n)
    for k in range(1, n):
        x1[k] = 0.5 * x1[k - 1] + u[k - 1, 0]
        x2[k] = 0.9 * x2[k - 1] + u[k - 1, 0]
    y = np.column_stack([x1, x2])
    if spike is not None:
        y[30, 1] += spike
    t = np.arange(n, dtype=np.float64)
    return AlignedSignals("log.csv", t, model.inputs, model.outputs, u, y)


@pytest.mark.parametrize(
    ("tank_unknown", "unknown_mode"), [("0.001", False), ("0.0", True)], ids=["off", "zero"]
)
def test_a_sample_no_successor_explains_is_refused(tank_unknown: str, unknown_mode: bool) -> None:
    model = parse_model(TWO.replace("TANK_UNKNOWN", tank_unknown), origin="two.toml")
    options = UnknownModeOptions(unknown_mode=unknown_mode)
    run_unknown_mode(model, _log(model, None), options)  # the clean log passes
    with pytest.raises(DivergenceError) as refused:
        run_unknown_mode(model, _log(model, 1e6), options)
    message = str(refused.value)
    assert message.startswith(
        "two.toml: unknown-mode cannot explain the log at t = 30 s (sample 30): y1 = "
    )
    assert "y2 = 1e+06" in message
    assert "standard deviations from every possible mode's prediction" in message


def test_the_unknown_mode_explains_it() -> None:
    model = parse_model(TWO.replace("TANK_UNKNOWN", "0.001"), origin="two.toml")
    result = run_unknown_mode(model, _log(model, 1e6), UnknownModeOptions())
    tank = next(c for c in result.timeline_columns if c.name == "mode.tank")
    assert tank.labels[int(tank.values[30])] == "unknown"


def test_a_refusal_where_candidates_cut_the_search_says_so() -> None:
    # one successor filtered a step: the unknown tank, which explains the spike, was not
    model = parse_model(TWO.replace("TANK_UNKNOWN", "0.001"), origin="two.toml")
    with pytest.raises(DivergenceError) as refused:
        run_unknown_mode(model, _log(model, 1e6), UnknownModeOptions(beam=1, candidates=1))
    assert str(refused.value).endswith(
        "(at that step the bound of 1 candidates stopped the search before every successor "
        "was filtered: a larger candidates may find one that explains the sample, a component "
        "in the unknown mode)"
    )
