"""Model files: the restricted expression grammar and errors that name the key."""

import math

import numpy as np
import pytest
import sympy
from hypothesis import given, settings
from hypothesis import strategies as st

from hybridlog.errors import ModelError
from hybridlog.model.expressions import parse_expression
from hybridlog.model.loader import load_model, parse_model
from tests.models import LINEAR_TWO_MODE, PENDULUM_ONE_MODE

X = {"x": sympy.Symbol("x", real=True), "k_p": sympy.Float(2.0)}


@pytest.mark.parametrize(
    "text",
    [
        "__import__('os')",
        "__import__('os').system('echo hacked')",
        "x.__class__",
        "().__class__.__bases__[0]",
        "sqrt.__globals__",
        "open('/etc/passwd')",
        "eval('1')",
        "[x for x in ()]",
        "lambda: 1",
        "x if x else 1",
        "'text'",
        "x[0]",
        "exp(x=1)",
        "sin(*x)",
        "x @ x",
        "x // 2",
        "x and 1",
        "2**10**9",
    ],
)
def test_code_and_unknown_constructs_are_refused(text):
    with pytest.raises(ModelError, match=r"^modes\.a\.f\[0\]: "):
        parse_expression(text, X, key="modes.a.f[0]")


def test_whitelisted_functions_and_piecewise_parse():
    expr = parse_expression(
        "Piecewise(sqrt(x), x > 0, 0) + max(x, 1) - sign(x)*abs(x) + k_p*tanh(x)", X, key="k"
    )
    value = float(expr.subs(X["x"], 4.0))
    assert math.isclose(value, 2.0 + 4.0 - 4.0 + 2.0 * math.tanh(4.0))


@settings(max_examples=300, deadline=None)
@given(st.text(max_size=40))
def test_any_text_parses_or_fails_with_a_model_error(text):
    try:
        expr = parse_expression(text, X, key="k")
    except ModelError as err:
        assert str(err).startswith("k: ")
    else:
        assert isinstance(expr, sympy.Expr)


def _replace(text, old, new):
    assert old in text, old
    return text.replace(old, new, 1)


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        (
            '"theta + 0.05*omega"',
            '"theta + 0.05*omegaa"',
            r"modes\.only\.f\[0\]: unknown symbol 'omegaa'",
        ),
        (
            'h = ["sin(theta)", "omega + 0.1*theta**2"]',
            'h = ["sin(theta)"]',
            r"modes\.only\.h: wrong number of expressions; expected 2 instead of 1",
        ),
        ("l = 1.3", "l = inf", r"parameters\.l: non-finite number"),
        ("l = 1.3", "l = nan", r"parameters\.l: non-finite number"),
        ('name = "pendulum"', "colour = 'red'\nname = 'p'", r"colour: unknown key"),
        ("[noise]", "colour = 'red'\n[noise]", r"modes\.only\.colour: unknown key"),
        ("covariance = 0.5", "covariance = 0.5\nvariance = 2", r"initial\.variance: unknown key"),
        (
            "state = [0.3, 0.0]",
            "state = [0.3]",
            r"initial\.state: wrong length; expected 2 instead of 1",
        ),
        (
            "measurement = [0.01, 0.02]",
            "measurement = [[1, 2], [3, 4]]",
            r"noise\.measurement: covariance must be symmetric",
        ),
        ("dt = 0.05", "dt = -1", r"dt: must be positive"),
        (
            'outputs = ["y_sin", "y_speed"]',
            'outputs = ["y_sin", "theta"]',
            r"outputs: 'theta' is already one of the states",
        ),
    ],
)
def test_nonlinear_model_errors_name_the_key(old, new, message):
    with pytest.raises(ModelError, match=r"^plant\.toml: " + message):
        parse_model(_replace(PENDULUM_ONE_MODE, old, new), origin="plant.toml")


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        (
            "C = [[1.0, 0.0], [0.5, 2.0]]",
            "C = [[1.0, 0.0, 3.0], [0.5, 2.0, 1.0]]",
            r"modes\.fast\.C: matrix C of mode 'fast' has the wrong number of columns; "
            r"expected 2 instead of 3",
        ),
        (
            "A = [[1.0, 0.1], [-0.3, 0.7]]",
            "A = [[1.0, 0.1]]",
            r"modes\.fast\.A: matrix A of mode 'fast' has the wrong number of rows; "
            r"expected 2 instead of 1",
        ),
        (
            "matrix = [[0.97, 0.03], [0.05, 0.95]]",
            "matrix = [[0.97, 0.13], [0.05, 0.95]]",
            r"transitions\.matrix\[0\]: each row",
        ),
        (
            "mode_probabilities = [0.6, 0.4]",
            "mode = 'medium'",
            r"initial\.mode: unknown mode 'medium'",
        ),
        (
            "A = [[1.0, 0.1], [0.0, 0.95]]",
            "A = [[1.0, 0.1], [0.0, 'q*2']]",
            r"modes\.slow\.A\[1\]\[1\]: unknown symbol 'q'",
        ),
    ],
)
def test_linear_model_errors_name_the_key(old, new, message):
    with pytest.raises(ModelError, match=r"^m\.toml: " + message):
        parse_model(_replace(LINEAR_TWO_MODE, old, new), origin="m.toml")


def test_invalid_toml_names_the_file_and_line():
    with pytest.raises(ModelError, match=r"^bad\.toml: invalid TOML: .*line 2"):
        parse_model("name = 'x'\ndt = = 1\n", origin="bad.toml")


def test_unknown_model_name_lists_builtins():
    with pytest.raises(ModelError, match="three_tank_hstf"):
        load_model("no_such_model")


def test_parameter_override_changes_the_equations():
    base = parse_model(PENDULUM_ONE_MODE)
    changed = parse_model(PENDULUM_ONE_MODE, parameters={"l": 2.6})
    assert base.modes[0].f != changed.modes[0].f
    assert changed.parameters["l"] == 2.6
    with pytest.raises(ModelError, match=r"parameters\.length: no such parameter"):
        parse_model(PENDULUM_ONE_MODE, parameters={"length": 1.0})


def test_linear_modes_become_affine_expressions():
    model = parse_model(LINEAR_TWO_MODE)
    fast = model.modes[1]
    p, v = sympy.symbols("p v", real=True)
    a = sympy.Symbol("a", real=True)
    assert sympy.simplify(fast.f[1] - (-0.3 * p + 0.7 * v + 0.2 * a)) == 0
    np.testing.assert_allclose(fast.process_noise, [[0.02, 0.005], [0.005, 0.03]])
    assert fast.linear


def test_three_tank_builtin_matches_the_paper():
    model = load_model("three_tank_hstf")
    assert model.states == ("x1", "x2", "x3")
    assert model.mode_ids == ("1", "2", "3")
    assert model.dt == 1.0
    np.testing.assert_allclose(model.initial_state, [20, 5, 10])
    np.testing.assert_allclose(model.initial_covariance, 100 * np.eye(3))
    np.testing.assert_allclose(model.initial_mode_probabilities, [0, 1, 0])
    for mode in model.modes:
        np.testing.assert_allclose(mode.process_noise, 0.5 * np.eye(3))
        np.testing.assert_allclose(mode.measurement_noise, 0.5 * np.eye(3))
    x1, x2, x3 = sympy.symbols("x1 x2 x3", real=True)
    assert [
        sympy.simplify(e - k * x)
        for k, mode in enumerate(model.modes, 1)
        for e, x in zip(mode.h, (x1, x2, x3), strict=True)
    ] == [0] * 9
