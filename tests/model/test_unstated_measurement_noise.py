"""A measurement noise covariance the model file does not give is unstated, never guessed.

Before, a model without ``[noise] measurement`` silently got ``R = I``: ``imm``, ``hstf``
and ``unknown-mode`` weighed the outputs by a covariance nobody wrote, and ``simulate``
added measurement noise of variance 1 nobody asked for.  Now the loader records it as
unstated (NaN) and what weighs the outputs by it refuses the model in one line naming the
file and the key to add; what uses no ``R`` runs.  A missing ``process`` is still "no
process noise" (0).
"""

import numpy as np
import pytest

from hybridlog.errors import ModelError
from hybridlog.estimators.registry import prepare
from hybridlog.model.builtins import builtin_text
from hybridlog.model.loader import parse_model
from hybridlog.simulate import simulate
from hybridlog.simulate_components import simulate_components
from tests.support.model_kinds import THREE_COMPONENTS, VALVES_BOOLEAN

TWO_MODES = """
name = "quiet"
dt = 0.1
states = ["x"]
inputs = ["u"]
outputs = ["y"]

[modes.a]
f = ["0.9*x + u"]
h = ["x"]

[modes.b]
f = ["0.5*x + u"]
h = ["x"]
{own}
[initial]
state = [1.0]

[simulation]
inputs = {{u = "1"}}
schedule = "a:5,b:5"
{noise}
"""


def quiet(own: str = "", noise: str = "", origin: str = "quiet.toml"):
    return parse_model(TWO_MODES.format(own=own, noise=noise), origin=origin)


ADD = "add [noise] measurement (or modes.a.measurement_noise)"


def test_the_loader_records_an_unstated_covariance_instead_of_one() -> None:
    model = quiet()
    assert not any(m.measurement_noise_stated for m in model.modes)
    assert np.isnan(model.modes[0].measurement_noise).all()
    assert (model.modes[0].process_noise == 0.0).all()  # a statement: no process noise
    assert model.unstated_measurement_noise() == (
        f"the model gives no measurement noise covariance for mode 'a': {ADD}"
    )
    stated = quiet(noise="[noise]\nmeasurement = 1.0")
    assert all(m.measurement_noise_stated for m in stated.modes)
    assert stated.unstated_measurement_noise() is None
    assert (stated.modes[1].measurement_noise == np.eye(1)).all()


def test_a_mode_of_its_own_counts_and_the_next_one_is_named() -> None:
    model = quiet(own="measurement_noise = 0.2\n")  # under [modes.b]
    assert [m.measurement_noise_stated for m in model.modes] == [False, True]
    assert "for mode 'a'" in str(model.unstated_measurement_noise())


def test_a_boolean_model_names_its_dynamics_key() -> None:
    text = VALVES_BOOLEAN.replace("[noise]\nmeasurement = 1e-6\n", "")
    problem = parse_model(text, origin="v.toml").unstated_measurement_noise()
    assert problem is not None
    assert problem.endswith("add [noise] measurement (or dynamics.measurement_noise)")


def test_a_components_model_names_the_component_mode_and_output() -> None:
    text = THREE_COMPONENTS.replace("measurement = [0.04, 0.05]\n", "")
    model = parse_model(text, origin="c.toml")
    m21 = model.components[1].modes[0]
    assert m21.measurement_noise == {"yc1": 0.5}  # its own: stated
    assert model.unstated_measurement_noise() == (
        "the model gives no measurement noise covariance for output 'yc1' in mode 'm22' of "
        "component 'A2': add [noise] measurement (or components.A2.modes.m22.measurement_noise)"
    )
    with pytest.raises(ModelError) as refused:
        prepare(model, "unknown-mode")
    assert str(refused.value).startswith(
        "c.toml: estimator 'unknown-mode' weighs the outputs by their measurement noise "
        "covariance; the model gives no measurement noise covariance for output 'yc1'"
    )
    assert "\n" not in str(refused.value)


@pytest.mark.parametrize("name", ["imm", "hstf"])
def test_a_filter_refuses_the_model_before_any_log_is_read(name: str) -> None:
    with pytest.raises(ModelError) as refused:
        prepare(quiet(), name)
    message = str(refused.value)
    assert message.startswith(
        f"quiet.toml: estimator '{name}' weighs the outputs by their measurement noise "
        f"covariance; the model gives no measurement noise covariance for mode 'a': {ADD}"
    )
    assert "(estimators for this model: chiu, kmeans)" in message


@pytest.mark.parametrize("name", ["chiu", "kmeans"])
def test_an_estimator_without_r_takes_the_model(name: str) -> None:
    assert prepare(quiet(), name).name == name


def test_the_filters_own_check_refuses_a_model_given_past_the_registry() -> None:
    from hybridlog.estimators.common import noise_stacks

    with pytest.raises(ModelError, match=r"^quiet\.toml: noise\.measurement: estimator 'imm' "):
        noise_stacks(quiet(), "imm")


def test_simulate_refuses_noise_it_cannot_draw_and_runs_without_noise() -> None:
    model = quiet()
    with pytest.raises(ModelError) as refused:
        simulate(model, jit=False)
    assert str(refused.value) == (
        "quiet.toml: noise.measurement: simulate draws the outputs' measurement noise (or run "
        f"it with --no-noise); the model gives no measurement noise covariance for mode 'a': "
        f"{ADD}"
    )
    log = simulate(model, jit=False, noise=False)
    assert np.isfinite(log.outputs).all()
    assert (log.outputs[:, 0] == log.states[:, 0]).all()  # no noise drawn, none guessed


def test_simulate_of_a_components_model_refuses_an_unstated_sensor() -> None:
    text = builtin_text("bioplex_pgc")
    stated = "measurement = [4e-4, 4e-4, 16.0]"
    assert stated in text
    model = parse_model(text.replace(stated, ""), origin="bioplex.toml")
    with pytest.raises(ModelError, match=r"^bioplex\.toml: noise\.measurement: simulate draws"):
        simulate_components(model, steps=3)
