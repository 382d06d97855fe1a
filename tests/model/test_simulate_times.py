"""A simulated log's times are ``k·dt`` to the digits: the decimal product, not float drift.

``np.arange(rows) * dt`` multiplied the float nearest 0.001, so 139,554 of the 10^6 times of
a run at ``dt = 0.001`` were written ``0.009000000000000001`` and alike in CSV and Parquet
logs (and a components model's run at ``dt = 0.1`` had ``t = 0.30000000000000004``).
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from hybridlog.model.builtins import builtin_text
from hybridlog.model.loader import parse_model
from hybridlog.simulate import simulate
from hybridlog.simulate_components import simulate_components
from hybridlog.simulation_inputs import sample_times

ONE_STATE = """
name = "decay"
time = "discrete"
dt = 0.001
states = ["x"]
inputs = []
outputs = ["y"]

[modes.a]
A = [[0.99]]
C = [[1.0]]

[noise]
measurement = 1.0

[initial]
state = [1.0]
"""


def _decimal_times(rows: int, dt: str) -> list[float]:
    """``float(k · dt)`` of the decimal ``dt``: the nearest float, one rounding."""
    step = Fraction(dt)
    return [float(k * step) for k in range(rows)]


@pytest.mark.parametrize("dt", ["0.001", "0.1", "0.05", "2.5e-05", "1e-07", "60.0", "100.0"])
def test_sample_times_are_the_nearest_floats_of_the_decimal_products(dt: str) -> None:
    rows = 20_001
    assert sample_times(rows, float(dt)).tolist() == _decimal_times(rows, dt)


def test_a_dt_without_a_short_decimal_keeps_the_float_products() -> None:
    dt = 1 / 3
    assert sample_times(1001, dt).tolist() == (np.arange(1001.0) * dt).tolist()
    assert sample_times(0, 0.001).shape == (0,)


def test_a_simulated_run_at_a_millisecond_holds_the_digits_of_its_times() -> None:
    log = simulate(parse_model(ONE_STATE, origin="decay.toml"), steps=20_000, noise=False)
    assert log.time.tolist() == _decimal_times(20_001, "0.001")
    assert repr(float(log.time[9])) == "0.009"  # was 0.009000000000000001


def test_a_components_run_holds_the_digits_of_its_times() -> None:
    text = builtin_text("bioplex_pgc")
    assert text.count("\ndt = 60.0\n") == 1
    model = parse_model(text.replace("\ndt = 60.0\n", "\ndt = 0.1\n"), origin="b.toml")
    run = simulate_components(model, steps=300, seed=1)
    assert run.time.tolist() == _decimal_times(301, "0.1")
    assert repr(float(run.time[3])) == "0.3"  # was 0.30000000000000004
