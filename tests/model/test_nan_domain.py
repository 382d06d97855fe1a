"""A mode function outside its domain gives NaN, whatever function wraps the NaN.

``sqrt`` or ``log`` of a negative value is NaN in the compiled code, and the simulation and
the estimators report a NaN as the model leaving its domain.  ``max``, ``min`` and ``sign``
used to turn that NaN into a plausible number (Python's ``max(0, nan)`` is 0, sympy's
``sign`` printed as ``math.copysign(1, x)`` is ±1 for a NaN, a ``Piecewise`` condition
comparing a NaN took the next branch), and the Jacobian of ``sign`` or
``abs`` of an argument sympy cannot prove real was unprintable or 0/0.
"""

import math
import re

import numpy as np
import pytest
import sympy

from hybridlog.model.compiled import compile_model
from hybridlog.model.derivatives import jacobian
from hybridlog.model.loader import parse_model

MODEL = """
name = "domain"
time = "discrete"
dt = 1.0
states = ["x1", "x2"]
inputs = ["u"]
outputs = ["y", "z"]

[modes.clamped]
f = ["max(sqrt(x1), 0)", "min(0, log(x1), x2)"]
h = ["sign(sqrt(x1)) + abs(sqrt(x1) - 1)", "Piecewise(1, sqrt(x1) > 1, 2, x2 < 0, 3)"]

[noise]
process = 0.1
measurement = 0.1

[initial]
state = [1.0, 0.0]
covariance = 1.0
mode = "clamped"
"""


@pytest.fixture(scope="module")
def model():
    return parse_model(MODEL, origin="domain.toml")


def test_a_value_outside_the_domain_stays_nan(model):
    functions = compile_model(model)  # numba: sqrt and log of a negative value are NaN
    u = np.zeros(1)
    f, h, H = np.zeros(2), np.zeros(2), np.zeros((2, 2))
    outside = np.array([-0.25, 3.0])
    functions.f(0, outside, u, f)
    functions.h(0, outside, u, h)
    functions.H(0, outside, u, H)
    assert np.isnan(f).all(), f
    assert np.isnan(h).all() and np.isnan(H[0, 0]), (h, H)


@pytest.mark.parametrize("jit", [False, True])
def test_values_inside_the_domain(model, jit):
    functions = compile_model(model, jit=jit)
    u = np.zeros(1)
    f, h, H = np.zeros(2), np.zeros(2), np.zeros((2, 2))
    inside = np.array([0.25, -3.0])
    functions.f(0, inside, u, f)
    functions.h(0, inside, u, h)
    functions.H(0, inside, u, H)
    np.testing.assert_allclose(f, [0.5, -3.0])
    np.testing.assert_allclose(h, [1.5, 2.0])
    # d/dx1 (sign(sqrt(x1)) + |sqrt(x1) - 1|) = -1/(2 sqrt(x1)) below x1 = 1
    np.testing.assert_allclose(H, [[-1.0, 0.0], [0.0, 0.0]])


def test_sign_and_abs_of_arguments_sympy_cannot_prove_real_differentiate():
    x = sympy.Symbol("x", real=True)
    expressions = [
        sympy.sign(sympy.sqrt(x)),
        sympy.sign(sympy.log(x)),
        sympy.Abs(sympy.sqrt(x) - 1),
        sympy.Abs(sympy.log(x)),
    ]
    rows = jacobian(expressions, [x])
    assert not any(row[0].has(sympy.Derivative, sympy.re, sympy.im) for row in rows), rows
    # At x = 1 every argument is 0: the subgradient sign(0) = 0, not 0/0.
    values = [float(row[0].subs(x, 1)) for row in rows]
    assert values == [0.0, 0.0, 0.0, 0.0]
    values = [float(row[0].subs(x, 4)) for row in rows]
    assert values == pytest.approx([0.0, 0.0, 0.25, 0.25])
    assert not math.isnan(sum(values))


POLES = """
name = "poles"
dt = 1.0
states = ["x"]
outputs = ["y"]

[modes.a]
f = ["1/x + exp(10*x)"]
h = ["log(x)"]

[noise]
measurement = 0.1

[initial]
state = [1.0]
"""


@pytest.mark.parametrize(
    ("function", "x", "value", "why"),
    [
        # 1/x and log(x) at x = 0 are infinite exactly: the state reached a pole
        ("f", 0.0, math.inf, r"a pole of f: a division by 0 or a log of 0 there"),
        ("h", 0.0, -math.inf, r"a pole of h: a division by 0 or a log of 0 there"),
        # exp(1480) is finite, beyond float64: the state ran away
        ("f", 148.0, math.inf, r"more than float64 holds: the state ran away"),
    ],
)
def test_an_infinite_value_tells_a_pole_from_an_overflow(function, x, value, why):
    # 1/x at x = 0 was said as "more than float64 holds: the state ran away"
    from hybridlog.model.escape import Escape, escape_error

    model = parse_model(POLES, origin="poles.toml")
    escape = Escape(function, 0, -1, np.array([x]), np.zeros(0), np.array([value]))
    error = escape_error(model, escape, "at t = 1 s", "the simulation diverged")
    assert f"poles.toml: modes.a.{function}[0]: " in str(error)
    assert re.search(rf"\({why}\): the simulation diverged$", str(error)), str(error)


def test_a_merged_piecewise_condition_comparing_a_nan_is_nan():
    # sympy merges two adjacent branches of one value into one, its condition their Or:
    # printed as sympy does, a comparison of NaN in it was false and the next branch taken
    text = MODEL.replace(
        'h = ["sign(sqrt(x1)) + abs(sqrt(x1) - 1)", "Piecewise(1, sqrt(x1) > 1, 2, x2 < 0, 3)"]',
        'h = ["Piecewise(1, x1 > 0, 1, u > 1, 0)", "x2"]',
    )
    model = parse_model(text, origin="domain.toml")
    assert model.modes[0].h[0].args[0].cond.func is sympy.Or  # merged by sympy
    h = compile_model(model, jit=False).h  # plain Python: the NaN is an input, no math error
    out = np.zeros(2)
    for x1, u, expected in [(1.0, math.nan, 1.0), (-1.0, 2.0, 1.0), (-1.0, 0.0, 0.0)]:
        h(0, np.array([x1, 0.0]), np.array([u]), out)
        assert out[0] == expected, (x1, u, out)
    h(0, np.array([-1.0, 0.0]), np.array([math.nan]), out)
    assert math.isnan(out[0]), out  # undecided: neither branch


def test_a_negative_whole_power_at_zero_is_infinite_not_a_crash():
    # numba's x**(-3) raised ZeroDivisionError at x = 0: analyze said "unexpected
    # ZeroDivisionError ... (a bug ...)" where 1/x gave inf and a named error
    model = parse_model(POLES.replace('h = ["log(x)"]', 'h = ["x**(-3)"]'), origin="poles.toml")
    h, H = compile_model(model).h, compile_model(model).H
    out, slope = np.zeros(1), np.zeros((1, 1))
    h(0, np.zeros(1), np.zeros(0), out)
    H(0, np.zeros(1), np.zeros(0), slope)
    assert out[0] == math.inf and slope[0, 0] == -math.inf, (out, slope)
    h(0, np.array([-2.0]), np.zeros(0), out)
    assert out[0] == -0.125
