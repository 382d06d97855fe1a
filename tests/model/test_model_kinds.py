"""The model kinds papers 002–004 need: continuous time, linear forms, booleans, jumps,
components; each loaded and validated, and each bad variant refused naming its key."""

import re

import numpy as np
import pytest
import sympy
from hypothesis import given, settings
from hypothesis import strategies as st

from hybridlog.errors import ModelError
from hybridlog.estimators.switched_observer import linear_modes
from hybridlog.model.compiled import compile_model
from hybridlog.model.components import UNKNOWN
from hybridlog.model.expressions import previous_symbol
from hybridlog.model.loader import load_model, parse_model
from hybridlog.simulate import simulate
from tests.support.model_kinds import (
    CLUTCH_JUMPS,
    CONTINUOUS_TANK,
    THREE_COMPONENTS,
    VALVES_BOOLEAN,
)
from tests.support.model_text import edited as _replace
from tests.support.models import LINEAR_TWO_MODE, PENDULUM_ONE_MODE


def _value(expr, **values):
    return float(expr.subs({sympy.Symbol(k, real=True): v for k, v in values.items()}))


# --- timebase -----------------------------------------------------------------------------


def test_discrete_models_keep_their_timebase_and_flags():
    model = load_model("three_tank_hstf")
    assert model.timebase.kind == "discrete" and model.dt == 1.0
    assert model.timebase.step == 1.0 and model.timebase.method is None
    assert model.timebase.substeps == 1
    assert not (model.is_continuous or model.has_booleans or model.has_jumps)
    assert not model.has_components
    assert all(mode.f and not mode.dx and mode.dynamics == mode.f for mode in model.modes)


def test_continuous_model_has_dx_and_an_integration_step():
    model = parse_model(CONTINUOUS_TANK)
    assert model.is_continuous
    assert (model.timebase.kind, model.dt, model.timebase.step) == ("continuous", 0.01, 0.001)
    assert model.timebase.method == "euler" and model.timebase.substeps == 10
    open_ = model.modes[0]
    assert open_.f == () and open_.dynamics == open_.dx
    assert _value(open_.dx[0], h1=4.0, q=1.0) == pytest.approx(1.0 - 0.5 * 2.0)
    default = parse_model(_replace(CONTINUOUS_TANK, 'method = "euler", ', ""))
    assert default.timebase.method == "rk4"
    spaced = parse_model(_replace(CONTINUOUS_TANK, "[modes.closed]", '[modes."valve closed"]'))
    assert spaced.mode_ids[1] == "valve closed"


@pytest.mark.parametrize(
    ("old", "new", "words"),
    [
        # nanoseconds of the grid overflowed int64: an unexpected OverflowError in align.py
        ("dt = 0.01", "dt = 1e10", r"^m\.toml: dt: the sample time must be between 1e-09 s and"),
        ("dt = 0.01", "dt = 1e-10", r"^m\.toml: dt: .* got 1e-10"),
        # a billion substeps per sample: ran for hours without a word
        (
            "step = 0.001",
            "step = 1e-11",
            r"^m\.toml: integration\.step: 1e-11 s gives 1,000,000,000",
        ),
    ],
)
def test_time_steps_beyond_what_the_grid_and_integrator_can_take_are_refused(old, new, words):
    with pytest.raises(ModelError, match=words):
        parse_model(_replace(CONTINUOUS_TANK, old, new), origin="m.toml")


# --- linear modes as matrices -------------------------------------------------------------


def test_linear_forms_of_matrices_and_of_affine_expressions():
    model = parse_model(CONTINUOUS_TANK)
    assert model.modes[0].linear_form is None
    assert model.modes[0].nonlinear_key == "modes.open.dx[0]"
    closed = model.modes[1].linear_form
    assert closed is not None
    np.testing.assert_array_equal(closed.A, [[0.0]])
    np.testing.assert_array_equal(closed.B, [[1.0]])
    affine = model.modes[2].linear_form
    assert affine is not None
    np.testing.assert_array_equal(affine.A, [[-2.0]])
    np.testing.assert_array_equal(affine.B, [[3.0]])
    np.testing.assert_array_equal(affine.C, [[0.5]])
    np.testing.assert_array_equal(affine.D, [[0.0]])
    np.testing.assert_array_equal(affine.state_offset, [1.0])
    np.testing.assert_array_equal(affine.output_offset, [0.0])
    matrices = model.modes[3].linear_form
    assert matrices is not None
    np.testing.assert_array_equal(matrices.B, [[2.0]])
    with pytest.raises(ModelError, match=r"^<model>: modes\.open\.dx\[0\]: mode 'open' is not"):
        model.linear_modes()


def test_expanded_polynomials_count_as_affine_products_do_not():
    text = _replace(
        PENDULUM_ONE_MODE,
        'f = ["theta + 0.05*omega", "omega - 0.05*(g/l)*sin(theta) - 0.05*c*omega + 0.05*torque"]',
        'f = ["(theta + 1)**2 - theta**2 + 0.05*omega", "omega*(1 + torque) - omega*torque"]',
    )
    text = _replace(text, 'h = ["sin(theta)", "omega + 0.1*theta**2"]', 'h = ["theta", "2"]')
    form = parse_model(text).modes[0].linear_form
    assert form is not None
    np.testing.assert_allclose(form.A, [[2.0, 0.05], [0.0, 1.0]])
    np.testing.assert_allclose(form.state_offset, [1.0, 0.0])
    np.testing.assert_allclose(form.output_offset, [0.0, 2.0])
    product = _replace(text, '"theta", "2"', '"theta*omega", "2"')
    mode = parse_model(product).modes[0]
    assert mode.linear_form is None and mode.nonlinear_key == "modes.only.h[0]"


@pytest.mark.parametrize("source", ["double_cart_case1", "double_cart_case2", "linear_two_mode"])
def test_linear_modes_agree_with_the_jacobian_extraction(source):
    model = parse_model(LINEAR_TWO_MODE) if source == "linear_two_mode" else load_model(source)
    forms = model.linear_modes()
    reference = linear_modes(model)  # the switched observer's own sympy Jacobians
    for name in ("A", "B", "C", "D"):
        np.testing.assert_allclose(
            np.stack([getattr(f, name) for f in forms]), getattr(reference, name)
        )
    np.testing.assert_allclose(np.stack([f.state_offset for f in forms]), reference.state_offsets)
    np.testing.assert_allclose(np.stack([f.output_offset for f in forms]), reference.output_offsets)


def test_double_cart_matrices_are_the_files_values():
    forms = load_model("double_cart_case1").linear_modes()
    assert forms[0].A[0, 3] == 0.02006 and forms[1].B[3, 0] == 0.01778


def test_linear_modes_of_a_nonlinear_model_names_file_mode_and_key():
    with pytest.raises(
        ModelError, match=r"^three_tank_hstf: modes\.1\.f\[0\]: mode '1' is not linear"
    ):
        load_model("three_tank_hstf").linear_modes()


# --- booleans (paper 003) -----------------------------------------------------------------


def test_boolean_model_has_one_mode_per_combination_numbered_by_eq_48():
    model = parse_model(VALVES_BOOLEAN)
    affine = model.boolean_affine
    assert model.has_booleans and affine is not None
    assert affine.booleans == ("U1", "U2", "U3")
    assert model.mode_ids == tuple(str(s) for s in range(8))
    assert affine.delta(5) == (1, 0, 1) and affine.delta(4) == (1, 0, 0)
    np.testing.assert_array_equal(model.initial_mode_probabilities, np.eye(8)[7])
    point = {"H1": 0.2, "H2": 0.15, "H3": 0.1, "q": 1e-5}
    U1, U2, U3 = affine.symbols()
    for sigma, mode in enumerate(model.modes):
        d1, d2, d3 = affine.delta(sigma)
        assert sigma == 4 * d1 + 2 * d2 + d3  # eq. (48)
        for general, specific in zip(affine.dynamics, mode.dx, strict=True):
            expected = general.subs({U1: d1, U2: d2, U3: d3})
            assert _value(specific, **point) == pytest.approx(_value(expected, **point))
    # Valve 1 (δ1, the most significant bit) drains tank 1: dx1 = q/β1 only when closed.
    beta1 = 0.035 * 0.035
    assert _value(model.modes[3].dx[0], **point) == pytest.approx(1e-5 / beta1)
    assert _value(model.modes[4].dx[0], **point) < _value(model.modes[3].dx[0], **point)
    assert model.modes[0].linear_form is not None  # all valves closed: dx = (q/β1, 0, 0)
    assert model.modes[5].linear_form is None


# --- jumps (paper 004) --------------------------------------------------------------------


def test_jump_maps_reset_the_listed_states_and_keep_the_others():
    model = parse_model(CLUTCH_JUMPS)
    assert model.has_jumps and model.is_continuous and model.timebase.method == "rk4"
    engage = model.reset_map(0, 1)
    assert engage is not None
    values = {"m": 0.3, "omega": 200.0, "T": 6.0}
    assert [_value(e, **values) for e in engage] == pytest.approx(
        [0.3, 0.2 / 0.5 * 200.0, 15.0 / 5.0 * 6.0]  # eq. (45)
    )
    release = model.reset_map(1, 0)
    assert release is not None
    assert [_value(e, **values) for e in release] == pytest.approx([0.3, 200.0, 5.0 / 15.0 * 6.0])
    assert model.reset_map(0, 0) is None
    assert model.jumps[0].key == 'jumps."0->1"'


def test_a_wildcard_jump_applies_where_no_pair_has_its_own():
    text = _replace(
        CLUTCH_JUMPS,
        '[jumps."0->1"]',
        '[modes.2]\ndx = ["0", "0", "0"]\nh = ["omega"]\n\n'
        '[jumps."*->1"]\nm = "2*m"\n\n[jumps."0->1"]',
    )
    model = parse_model(text)
    assert _value(model.reset_map(0, 1)[0], m=1.0) == 1.0  # "0->1" wins over "*->1"
    assert _value(model.reset_map(2, 1)[0], m=1.0) == 2.0
    assert model.reset_map(2, 0) is None


# --- components (paper 002) ---------------------------------------------------------------


def test_three_component_example_holds_the_papers_equations():
    model = parse_model(THREE_COMPONENTS)
    assert model.has_components and model.modes == () and model.n_modes == 0
    assert [c.name for c in model.components] == ["A1", "A2", "A3"]
    assert model.variables == ("wc1",) and model.commands == ("ud1",)
    a1, a2, a3 = model.components
    assert a2.states == ("xc1",) and a3.states == ("xc2", "xc3")
    assert [e.kind for e in a3.mode("m31").equations] == ["difference", "difference", "algebraic"]
    assert a1.equations(UNKNOWN) == ()
    # Solving the union of F1(m11), F2(m21), F3(m31) (eq. (8)) gives the model (3).
    mode = {"A1": "m11", "A2": "m21", "A3": "m31"}
    equations = [e for c in model.components for e in c.equations(mode[c.name])]
    algebraic = [e.residual for e in equations if e.kind == "algebraic"]
    names = ("wc1", "yc1", "yc2")
    now = [sympy.Symbol(n, real=True) for n in names]
    solved = sympy.solve(algebraic, now, dict=True)[0]
    before = {
        previous_symbol(n): solved[s].xreplace(
            {sym: previous_symbol(str(sym)) for sym in solved[s].free_symbols}
        )
        for n, s in zip(names, now, strict=True)
    }
    x1, x2, x3, u1 = (previous_symbol(n) for n in ("xc1", "xc2", "xc3", "uc1"))
    expected = {
        "xc1": 0.8 * x1 + 0.2 * u1,
        "xc2": x1 + x3,
        "xc3": 0.4 * x2 + 0.5 * u1,
    }
    for equation in equations:
        if equation.kind == "difference":
            derived = equation.rhs.xreplace(before)
            assert sympy.simplify(derived - expected[equation.state]) == 0, equation.key
    x_now = [sympy.Symbol(n, real=True) for n in ("xc1", "xc2", "xc3")]
    assert sympy.simplify(solved[now[1]] - x_now[0]) == 0  # y_c1 = x_c1
    assert sympy.simplify(solved[now[2]] - (2 * x_now[1] + x_now[2])) == 0  # y_c2 = 2 x_c2 + x_c3


def test_component_noise_defaults_and_overrides():
    a1, a2, a3 = parse_model(THREE_COMPONENTS).components
    assert a2.mode("m21").process_noise == {"xc1": 0.01}
    assert a2.mode("m21").measurement_noise == {"yc1": 0.5}
    assert a2.mode("m22").process_noise == {"xc1": 0.2}
    assert a2.mode("m22").measurement_noise == {"yc1": 0.04}
    assert a3.mode("m31").process_noise == {"xc2": 0.02, "xc3": 0.03}
    assert a3.mode("m31").measurement_noise == {"yc2": 0.05}
    assert a1.mode("m11").process_noise == {}


def test_component_transitions_rules_commands_and_the_unknown_mode():
    a1, a2, a3 = parse_model(THREE_COMPONENTS).components
    assert a1.initial_mode_probabilities == {"m11": 1.0, "m12": 0.0, UNKNOWN: 0.0}
    assert a2.initial_mode_probabilities == {"m21": 0.9, "m22": 0.0, UNKNOWN: 0.1}
    assert a3.initial_mode_probabilities == {"m31": 1.0, UNKNOWN: 0.0}
    commanded = a1.transition_probabilities("m11", {"ud1": 0.0})  # the `when` rule
    assert commanded == pytest.approx({"m12": 0.9 * 0.99, "m11": 0.1 * 0.99, UNKNOWN: 0.01})
    otherwise = a1.transition_probabilities("m11", {"ud1": 1.0})  # the "*" rule
    assert otherwise == pytest.approx({"m11": 0.99 * 0.99, "m12": 0.01 * 0.99, UNKNOWN: 0.01})
    assert a1.transition_probabilities("unknown") == pytest.approx({"m11": 0.1, UNKNOWN: 0.9})
    assert a2.transition_probabilities("m21") == pytest.approx({"m21": 0.999, UNKNOWN: 0.001})
    assert a2.transition_probabilities(UNKNOWN) == {UNKNOWN: 1.0}
    assert a3.transition_probabilities("m31") == {"m31": 1.0}
    for component in (a1, a2, a3):
        for source in (*component.mode_ids, UNKNOWN):
            for ud1 in (0.0, 1.0):
                total = sum(component.transition_probabilities(source, {"ud1": ud1}).values())
                assert total == pytest.approx(1.0)


# --- bad variants: each names its key -----------------------------------------------------

_CONTINUOUS_ERRORS = [
    ('integration = {method = "euler", step = 0.001}\n', "", r"integration: required key"),
    ("step = 0.001", "step = 0.003", r"integration\.step: dt = 0\.01 must be an integer mult"),
    ("step = 0.001", "step = 0.1", r"integration\.step: dt = 0\.01 must be an integer mult"),
    ("step = 0.001", "step = -1", r"integration\.step: must be positive"),
    ("step = 0.001", "step = nan", r"integration\.step: non-finite number"),
    ('method = "euler"', 'method = "heun"', r"integration\.method: expected one of euler, rk4"),
    ("step = 0.001", "stp = 0.001", r"integration\.stp: unknown key"),
    ('time = "continuous"', 'time = "hybrid"', r"time: expected 'discrete' or 'continuous'"),
    ('dx = ["q"]', 'f = ["q"]', r"modes\.closed\.f: a continuous-time model"),
    ("A = [[-1.0]]", 'A = [["2*h1"]]', r"modes\.matrices\.A\[0\]\[0\]: a matrix entry may use"),
    ("A = [[-1.0]]", 'A = [["sqrt(-c)"]]', r"modes\.matrices\.A\[0\]\[0\]: .*complex-valued"),
    ('dx = ["q"]', 'dx = ["q", "q"]', r"modes\.closed\.dx: wrong number of expressions"),
    ("[modes.closed]", '[modes."clo:sed"]', r"modes\.'clo:sed': 'clo:sed' is not a valid mode"),
    ("[modes.closed]", '[modes." closed"]', r"modes\.' closed': ' closed' is not a valid mode"),
]


@pytest.mark.parametrize(("old", "new", "message"), _CONTINUOUS_ERRORS)
def test_bad_continuous_models_name_the_key(old, new, message):
    with pytest.raises(ModelError, match=r"^tank\.toml: " + message):
        parse_model(_replace(CONTINUOUS_TANK, old, new), origin="tank.toml")


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ("dt = 0.05", "dt = 0.05\nintegration = {step = 0.01}", r"integration: only a contin"),
        ('f = ["theta', 'dx = ["theta', r"modes\.only\.dx: a discrete-time model"),
        ("dt = 0.05", 'dt = 0.05\nvariables = ["w"]', r"variables: only a components model"),
        ("dt = 0.05", 'dt = 0.05\ncommands = ["c"]', r"commands: only a components model"),
        ("[noise]", "[dynamics]\nh = []\n[noise]", r"dynamics: only a boolean-affine model"),
        (
            "[noise]",
            '[jumps."only->only"]\ntheta = "0"\n[noise]',
            r'jumps\."only->only": a mode do',
        ),
    ],
)
def test_keys_of_other_kinds_are_refused_in_a_discrete_model(old, new, message):
    with pytest.raises(ModelError, match=r"^plant\.toml: " + message):
        parse_model(_replace(PENDULUM_ONE_MODE, old, new), origin="plant.toml")


_BOOLEAN_ERRORS = [
    (
        'booleans = ["U1", "U2", "U3"]',
        'booleans = ["U1", "U2", "H1"]',
        r"booleans: 'H1' is already one of the states",
    ),
    (
        'booleans = ["U1", "U2", "U3"]',
        'booleans = ["U1", "U2", "U3", "a"]',
        r"parameters\.a: the name is already one of the booleans",
    ),
    (
        'booleans = ["U1", "U2", "U3"]',
        'booleans = ["U1", "U2", "U3", "U4"]',
        r"booleans: 'U4' appears in no expression",
    ),
    ('booleans = ["U1", "U2", "U3"]', "booleans = []", r"booleans: at least one name"),
    (
        'booleans = ["U1", "U2", "U3"]',
        'booleans = ["U1", "U2", "lambda"]',
        r"booleans: 'lambda' is a Python keyword",
    ),
    (
        '"(q - C1*sqrt(H1)*U1)/(a*w)"',
        '"(q - C1*sqrt(H1)*U1*U2)/(a*w)"',
        r"dynamics\.dx\[0\]: not affine in the booleans",
    ),
    (
        '"(q - C1*sqrt(H1)*U1)/(a*w)"',
        '"(q - C1*sqrt(H1*U1))/(a*w)"',
        r"dynamics\.dx\[0\]: not affine in the booleans",
    ),
    (
        "[dynamics]",
        "[modes.1]\nh = []\n[dynamics]",
        r"modes: a boolean-affine model's modes are the combinations",
    ),
    ("[dynamics]\ndx", "[dynamix]\ndx", r"dynamix: unknown key"),
    (
        'h = ["H1", "H2", "H3"]',
        'h = ["H1", "H2", "H3"]\nguard = "H1 > 0"',
        r"dynamics\.guard: unknown key",
    ),
    ("dx = [\n", "f = [\n", r"dynamics\.f: a continuous-time model"),
    ('h = ["H1", "H2", "H3"]', 'h = ["H1", "H2"]', r"dynamics\.h: wrong number of expressions"),
    ('mode = "7"', 'mode = "8"', r"initial\.mode: unknown mode '8'"),
]


@pytest.mark.parametrize(("old", "new", "message"), _BOOLEAN_ERRORS)
def test_bad_boolean_models_name_the_key(old, new, message):
    with pytest.raises(ModelError, match=r"^valves\.toml: " + message):
        parse_model(_replace(VALVES_BOOLEAN, old, new), origin="valves.toml")


_JUMP_ERRORS = [
    ('[jumps."0->1"]', '[jumps."0->2"]', r'jumps\."0->2": unknown mode \'2\''),
    ('[jumps."0->1"]', '[jumps."0-1"]', r'jumps\."0-1": expected \'a->b\''),
    ('[jumps."0->1"]', '[jumps."1->*"]', r'jumps\."1->\*": unknown mode \'\*\''),
    ('[jumps."0->1"]', '[jumps."1->1"]', r'jumps\."1->1": a mode does not jump to itself'),
    (
        '[jumps."1->0"]',
        '[jumps." 0 -> 1 "]',
        r'jumps\." 0 -> 1 ": the same switch as jumps\."0->1"',
    ),
    ('omega = "JE/(JE + JL)*omega"', 'omega2 = "omega"', r'jumps\."0->1"\.omega2: not a state'),
    (
        'omega = "JE/(JE + JL)*omega"',
        'omega = "alpha*omega"',
        r'jumps\."0->1"\.omega: unknown symbol \'alpha\'',
    ),
    (
        'omega = "JE/(JE + JL)*omega"',
        'omega = "sqrt(-JE)*omega"',
        r'jumps\."0->1"\.omega: .*complex-valued',
    ),
    (
        'omega = "JE/(JE + JL)*omega"',
        'omega = "1e999*omega"',
        r'jumps\."0->1"\.omega: .1e999. is beyond the largest double',
    ),
    ('T = "TE/(TE + TL)*T"', "", r'jumps\."1->0": no state is reset'),
    (
        '[jumps."1->0"]\nT = "TE/(TE + TL)*T"',
        '[jumps]\n"1->0" = "T"',
        r'jumps\."1->0": expected a table, got str',
    ),
]


@pytest.mark.parametrize(("old", "new", "message"), _JUMP_ERRORS)
def test_bad_jumps_name_the_key(old, new, message):
    with pytest.raises(ModelError, match=r"^clutch\.toml: " + message):
        parse_model(_replace(CLUTCH_JUMPS, old, new), origin="clutch.toml")


_EQ = "components.A2.modes.m21.equations"
_COMPONENT_ERRORS = [
    (
        '"xc1[k] = 0.8*xc1[k-1] + wc1[k-1]"',
        '"xc1[k] = 0.8*xz[k-1] + wc1[k-1]"',
        rf"{_EQ}\[0\]: unknown symbol 'xz'",
    ),
    (
        '"xc1[k] = 0.8*xc1[k-1] + wc1[k-1]"',
        '"xc1[k] = 0.8*xc1 + wc1[k-1]"',
        rf"{_EQ}\[0\]: the right side of a difference equation uses step k−1 only; "
        r"write xc1\[k-1\]",
    ),
    (
        '"xc1[k] = 0.8*xc1[k-1] + wc1[k-1]"',
        '"xc1[k] = 0.8*xc1[k-2] + wc1[k-1]"',
        rf"{_EQ}\[0\]: the time index of 'xc1' must be \[k\] or \[k-1\], got \[k - 2\]",
    ),
    (
        '"xc1[k] = 0.8*xc1[k-1] + wc1[k-1]"',
        '"xc1[k] = 0.8*xc1[k-1] == wc1[k-1]"',
        rf"{_EQ}\[0\]: .==. is not a comparison of model expressions",
    ),
    (
        '"xc1[k] = 0.8*xc1[k-1] + wc1[k-1]"',
        '"xc1[k] = 0.8*xc1[k-1] = wc1[k-1]"',
        rf"{_EQ}\[0\]: expected one equation 'lhs = rhs'",
    ),
    (
        '"xc1[k] = 0.8*xc1[k-1] + wc1[k-1]"',
        '"xc1[k] + 0.8*xc1[k-1]"',
        rf"{_EQ}\[0\]: expected one equation",
    ),
    (
        '"xc1[k] = 0.8*xc1[k-1] + wc1[k-1]"',
        '"xc1[k] = sqrt(-1)*xc1[k-1]"',
        rf"{_EQ}\[0\]: .*complex-valued",
    ),
    (
        '"xc1[k] = 0.8*xc1[k-1] + wc1[k-1]"',
        '"xc1[k] = 0.8*xc1[k-1] + wc1[k-1]", "xc1[k] = 0"',
        rf"{_EQ}\[1\]: a second difference equation for 'xc1'",
    ),
    (
        '"yc1 = xc1"',
        '"yc1 = xc1[k-1]"',
        rf"{_EQ}\[1\]: an algebraic equation relates variables at one step",
    ),
    ('"yc1 = xc1"', '"2 = 3"', rf"{_EQ}\[1\]: '2 = 3' uses no variable"),
    ('"yc1 = xc1"', '"yc1 = xc1(2)"', rf"{_EQ}\[1\]: unknown function 'xc1'"),
    ('"yc1 = xc1"', '"yc1 = xc1.real"', rf"{_EQ}\[1\]: attribute access"),
    ('"yc1 = xc1"', "\"yc1 = __import__('os')\"", rf"{_EQ}\[1\]: unknown function '__import__'"),
    (
        '"yc2 = 2.0*xc2 + xc3"',
        '"yc2 = 2.0*xc2 + xc3", "xc1[k] = 0"',
        r"components\.A3\.modes\.m31\.equations\[3\]: 'xc1' already has difference "
        r"equations in components\.A2",
    ),
    (
        'variables = ["wc1"]',
        'variables = ["wc1", "wc9"]',
        r"variables: 'wc9' appears in no component equation",
    ),
    (
        ('states = ["xc1", "xc2", "xc3"]', "process = [0.01, 0.02, 0.03]", "[0.0, 0.0, 0.0]"),
        ('states = ["xc1", "xc2", "xc3", "xc4"]', "process = 0.01", "[0.0, 0.0, 0.0, 0.0]"),
        r"states: 'xc4' has no difference equation",
    ),
    (
        # A1, the one component relating wc1 at step k, taken out: wc1 is then only read at
        # k-1 by A2, no joint mode gives it a value, and the estimator ran without xc1.
        ('equations = ["uc1 = 5.0*wc1"]', 'equations = ["wc1 = 0"]'),
        ('equations = ["uc1 = 5.0*uc1"]', 'equations = ["uc1 = 0"]'),
        r"variables: 'wc1' is used but appears in no algebraic equation of any component, so "
        r"no mode gives it a value \(is its component missing\?\)",
    ),
    (
        ('outputs = ["yc1", "yc2"]', "measurement = [0.04, 0.05]"),
        ('outputs = ["yc1", "yc2", "yc3"]', "measurement = [0.04, 0.05, 0.06]"),
        r"outputs: 'yc3' appears in no component equation",
    ),
    (
        'variables = ["wc1"]',
        'variables = ["wc1", "xc1"]',
        r"variables: 'xc1' is already one of the states",
    ),
    ('commands = ["ud1"]', 'commands = ["ud1", "class"]', r"commands: 'class' is a Python keyword"),
    (
        "[components.A1.modes.m12]",
        "[components.A1.modes.unknown]",
        r"components\.A1\.modes\.unknown: 'unknown' is every component's implicit",
    ),
    ("unknown = 0.0\n", "", r"components\.A3\.unknown: required key is missing"),
    (
        "unknown = 0.0\n",
        "unknown = 1.0\n",
        r"components\.A3\.unknown: must be a probability in \[0, 1\), got 1\.0$",
    ),
    (
        "unknown = 0.0\n",
        "unknown = 1.5\n",
        r"components\.A3\.unknown: must be a probability in \[0, 1\), got 1\.5$",
    ),
    ("unknown = 0.0\n", "unknown = -0.5\n", r"components\.A3\.unknown: must be a probability"),
    ("unknown = 0.0\n", "unknown = 0.0\ncolour = 1\n", r"components\.A3\.colour: unknown key"),
    (
        'equations = ["wc1 = 0"]',
        'equations = ["wc1 = 0"]\nflow = 2',
        r"components\.A1\.modes\.m12\.flow: unknown key",
    ),
    ('from = "m11"', 'from = "m13"', r"components\.A1\.transitions\[0\]\.from: unknown mode 'm13'"),
    (
        "when = {ud1 = 0}",
        "when = {ud9 = 0}",
        r"components\.A1\.transitions\[0\]\.when\.ud9: not a command",
    ),
    (
        "when = {ud1 = 0}",
        "when = {ud1 = inf}",
        r"components\.A1\.transitions\[0\]\.when\.ud1: non-finite",
    ),
    (
        "to = {m12 = 0.9}",
        "to = {m12 = 0.9, unknown = 0.2}",
        r"components\.A1\.transitions\[0\]\.to: probabilities sum to 1\.1 > 1",
    ),
    (
        "to = {m12 = 0.9}",
        "to = {m19 = 0.9}",
        r"components\.A1\.transitions\[0\]\.to\.m19: unknown mode",
    ),
    (
        "to = {m12 = 0.9}",
        'to = {m12 = "0.9"}',
        r"components\.A1\.transitions\[0\]\.to\.m12: expected a number",
    ),
    (
        'from = "unknown"',
        'from = "*"',
        r"components\.A1\.transitions\[2\]: the same from and when as "
        r"components\.A1\.transitions\[1\]",
    ),
    (
        "measurement_noise = {yc1 = 0.5}",
        "measurement_noise = {yc2 = 0.5}",
        r"components\.A2\.modes\.m21\.measurement_noise\.yc2: not one of the outputs",
    ),
    (
        'equations = ["wc1 = 0"]',
        "equations = []",
        r"components\.A1\.modes\.m12\.equations: at least one equation is required",
    ),
    (
        "process_noise = {xc1 = 0.2}",
        "process_noise = {xc2 = 0.2}",
        r"components\.A2\.modes\.m22\.process_noise\.xc2: not one of the states",
    ),
    (
        "process_noise = {xc1 = 0.2}",
        "process_noise = {xc1 = -0.2}",
        r"components\.A2\.modes\.m22\.process_noise\.xc1: a variance must be non-negative",
    ),
    ('initial = "m11"', 'initial = "m13"', r"components\.A1\.initial: unknown mode 'm13'"),
    (
        "initial = {m21 = 0.9, unknown = 0.1}",
        "initial = {m21 = 0.9}",
        r"components\.A2\.initial: probabilities must sum to 1; they sum to 0\.9$",
    ),
    (
        "[components.A3]",
        '[components."A,3"]',
        r"components\.'A,3': 'A,3' is not a valid component name",
    ),
    (
        "[components.A1.modes.m12]",
        '[components.A1.modes."12.0"]',
        r"components\.A1\.modes\.'12\.0': '12\.0' is not a valid mode id: a log holding the "
        r"mode as a number reads it as '12'",
    ),
    (
        "covariance = 1.0",
        'covariance = 1.0\nmode = "m11"',
        r"initial\.mode: a components model gives its initial modes per component",
    ),
    (
        "dt = 1.0",
        'dt = 1.0\ntime = "continuous"\nintegration = {step = 0.5}',
        r"time: a components model is discrete-time",
    ),
    (  # without [integration], which a continuous-time model needs: it was named missing
        "dt = 1.0",
        'dt = 1.0\ntime = "continuous"',
        r"time: a components model is discrete-time",
    ),
    ("dt = 1.0", "dt = 1.0\n[modes.a]\nf = []", r"modes: not part of a components model"),
    (
        "measurement = [0.04, 0.05]",
        "measurement = [[0.04, 0.01], [0.01, 0.05]]",
        r"noise\.measurement: a components model takes variances",
    ),
    (
        "covariance = 1.0",
        'covariance = 1.0\n[simulation]\nschedule = "m11:3"',
        r"simulation\.schedule: a components model has no joint mode schedule",
    ),
    (
        "covariance = 1.0",
        'covariance = 1.0\n[truth]\nmode = "/m"',
        r"truth\.mode: a components model has no mode of the whole model; map each "
        r"component's true mode as \"mode\.<component>\"$",
    ),
    (
        "[components.A3.modes.m31]",
        '[components.A3.modes."m3|1"]',
        r"components\.A3\.modes\.'m3\|1': a component's mode id may not hold '\|', which joins",
    ),
    (
        "covariance = 1.0",
        "covariance = 1.0\n[simulation]\nstate_min = [0.0, 0.0, 0.0]",
        r"simulation\.state_min: a components model's scenario does not bound its states",
    ),
    (
        "covariance = 1.0",
        'covariance = 1.0\n[truth]\nud1 = "/cmd.data"',
        r"truth\.ud1: a command; commands map under \[signals\]$",
    ),
    (
        "covariance = 1.0",
        'covariance = 1.0\n[truth]\nwc1 = "/w.data"',
        r"truth\.wc1: a variable, which no log holds$",
    ),
]


@pytest.mark.parametrize(("old", "new", "message"), _COMPONENT_ERRORS)
def test_bad_components_name_the_key(old, new, message):
    with pytest.raises(ModelError, match=r"^plant\.toml: " + message):
        parse_model(_replace(THREE_COMPONENTS, old, new), origin="plant.toml")


@pytest.mark.parametrize("key", ['"mode.A2"', "mode.A2"])
def test_components_model_takes_per_component_truth_quoted_or_dotted(key):
    text = _replace(
        THREE_COMPONENTS,
        "covariance = 1.0",
        f'covariance = 1.0\n[truth]\n{key} = "/truth/a2.data"\nxc1 = "/truth/x1.data"\n'
        '[signals]\nyc1 = "/y1.data"',
    )
    model = parse_model(text)
    assert model.truth == {"mode.A2": "/truth/a2.data", "xc1": "/truth/x1.data"}
    assert model.signals == {"yc1": "/y1.data"}


@pytest.mark.parametrize(
    ("text", "key"),
    [
        (CONTINUOUS_TANK, "time"),
        (CLUTCH_JUMPS, "time"),
        (THREE_COMPONENTS, "components"),
    ],
)
def test_discrete_only_code_refuses_other_kinds_instead_of_computing_nonsense(text, key):
    model = parse_model(text, origin="kind.toml")
    if key == "components":
        with pytest.raises(ModelError, match=rf"^kind\.toml: {key}: simulate "):
            simulate(model, steps=3)
    else:  # issue 11: simulate integrates continuous-time models (tests/model/test_continuous.py)
        with pytest.raises(ModelError, match=r"^kind\.toml: simulation\.inputs\.\w+: no input"):
            simulate(model, steps=3)
    with pytest.raises(ModelError, match=rf"^kind\.toml: {key}: the discrete-time mode func"):
        compile_model(model, jit=False)
    model.check_supported("x", continuous=True, jumps=True, components=True)


def test_jump_maps_are_refused_where_they_would_be_ignored():
    text = _replace(
        PENDULUM_ONE_MODE,
        "[noise]",
        '[modes.other]\nf = ["theta", "omega"]\nh = ["theta", "omega"]\n'
        '[jumps."only->other"]\nomega = "0"\n[noise]',
    )
    model = parse_model(text, origin="j.toml")
    assert not model.is_continuous and model.has_jumps
    # it names the models simulate does apply jump maps to (it had read as if it applied none)
    with pytest.raises(
        ModelError,
        match=r'^j\.toml: jumps\."only->other": simulate applies jump maps to continuous',
    ):
        simulate(model, steps=3)


@settings(max_examples=25, deadline=None)
@given(
    st.lists(st.integers(-3, 3), min_size=9, max_size=9),
    st.sampled_from(
        [
            "{a}*p + {b}*v + {c}*a",
            "({a}*p + {b}*v)*2/2 + {c}*a",
            "{a}*(p + v) - {a}*v + {b}*v + {c}*a",
        ]
    ),
)
def test_affine_expressions_give_the_matrices_they_were_written_from(numbers, pattern):
    rows = [numbers[0:3], numbers[3:6], numbers[6:9]]
    f = [pattern.format(a=r[0], b=r[1], c=r[2]) for r in rows[:2]]
    h = [f"{rows[2][0]}*p + {rows[2][1]}*v + {rows[2][2]}*a + 1.5", "v"]
    text = _replace(LINEAR_TWO_MODE, "A = [[1.0, 0.1], [0.0, 0.95]]", f"f = {f}\nh = {h}")
    text = _replace(text, "B = [[0.005], [0.1]]\nC = [[1.0, 0.0], [0.0, 1.0]]\n", "")
    form = parse_model(text).modes[0].linear_form
    assert form is not None
    np.testing.assert_array_equal(form.A, [r[:2] for r in rows[:2]])
    np.testing.assert_array_equal(form.B, [[r[2]] for r in rows[:2]])
    np.testing.assert_array_equal(form.C, [rows[2][:2], [0, 1]])
    np.testing.assert_array_equal(form.D, [[rows[2][2]], [0]])
    np.testing.assert_array_equal(form.output_offset, [1.5, 0.0])


_NFC, _NFD = "\u00e9", "e\u0301"
"""One text in two Unicode forms: precomposed (NFC), and with a combining accent (NFD)."""


@pytest.mark.parametrize(
    ("old", "what", "key"),
    [
        (("m11", "m12"), "mode id", "components.A1.modes"),
        (("A1", "A2"), "component name", "components"),
    ],
)
def test_component_labels_one_text_in_two_unicode_forms_are_refused(old, what, key):
    """Two mode ids or component names that differ only in their Unicode form were shown
    as the same one twice in every report table, CSV header and plot."""
    first, second = old
    text = THREE_COMPONENTS
    for name, label in ((first, _NFC), (second, _NFD)):
        text = text.replace(f'"{name}"', f'"{label}"')  # in strings, then as keys
        text = re.sub(rf"\b{name}\b", f'"{label}"', text)
    with pytest.raises(
        ModelError,
        match=rf"^plant\.toml: {re.escape(key)}\.'?{_NFD}'?: '{_NFD}' is the "
        rf"{what} '{_NFC}' written in another Unicode form",
    ):
        parse_model(text, origin="plant.toml")


@pytest.mark.parametrize("kernel", ["auto", "loops"])
def test_the_discrete_filters_refuse_a_continuous_model_called_from_the_library(kernel):
    # the CLI refuses imm on a continuous model by its capabilities; a library caller's
    # run_imm with kernel="auto" ended in a bare IndexError of the straight-line code
    from hybridlog.estimators.imm import ImmOptions, run_imm
    from hybridlog.signals import AlignedSignals

    model = parse_model(CONTINUOUS_TANK)
    n = 5
    ones = np.ones((n, 1))
    signals = AlignedSignals(
        "log.csv", np.arange(n) * model.dt, model.inputs, model.outputs, ones, ones.copy()
    )
    with pytest.raises(ModelError, match=r"time: estimator 'imm' needs a discrete-time model"):
        run_imm(model, signals, ImmOptions(), kernel=kernel)
