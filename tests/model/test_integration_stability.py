"""The integration step against its method's stability region (``hybridlog.model.stability``).

Independent references: one step of the integrator itself on ``dx = λ x`` (the stability
function must be what the code does), the real stability boundaries found as roots with
NumPy and SciPy, and the exact solution of a stiff linear model.
"""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.optimize import brentq

from hybridlog.errors import ModelError, OptionError
from hybridlog.estimators.hybrid_observer import run_switching_observer
from hybridlog.estimators.hybrid_observer_options import SwitchingObserverOptions
from hybridlog.model.integration import EULER, RK4, integrate_step, work_buffer
from hybridlog.model.loader import parse_model
from hybridlog.model.stability import TOTAL_POINTS, _rows, amplification, step_flaw
from hybridlog.signals import AlignedSignals
from hybridlog.simulate import simulate

STIFF = """
name = "stiff"
time = "continuous"
dt = 0.01
integration = {{method = "{method}", step = {step}}}
states = ["x1", "x2"]
inputs = ["u"]
outputs = ["y"]

[modes.a]
dx = ["u - x1", "-1990*(x2 - x1)"]
h = ["x2"]

[noise]
process = 0.0
measurement = 0.01

[initial]
state = [1.0, 0.0]
mode = "a"

[simulation.inputs]
u = "1"
"""


def _scalar(rate):
    def dx(_q, x, _u, out):
        out[0] = rate * x[0]

    return dx


@given(
    rate=st.floats(-5000.0, 5000.0, allow_nan=False),
    step=st.floats(1e-5, 1e-2),
    method=st.sampled_from(["euler", "rk4"]),
)
def test_the_stability_function_is_one_step_of_the_integrator(rate, step, method):
    x = np.array([1.0])
    code = EULER if method == "euler" else RK4
    integrate_step(_scalar(rate), code, 0, x, np.zeros(0), step, work_buffer(1))
    expected = amplification(method, step * rate)
    assert x[0] == pytest.approx(expected.real, rel=1e-12, abs=1e-12)


def test_real_boundaries_are_the_roots_of_the_stability_functions():
    # explicit Euler: the flips outlive the model where -(1 + z) > e^z, i.e. z < z*
    euler_edge = brentq(lambda z: 1 + z + math.exp(z), -2.0, -1.0)
    # RK4 is positive on the real axis; it leaves |R| <= 1 at the real root of R(z) = 1
    roots = np.roots([1 / 24, 1 / 6, 1 / 2, 1])
    unstable_edge = min(r.real for r in roots if abs(r.imag) < 1e-12)
    assert unstable_edge == pytest.approx(-2.785, abs=1e-3)
    # and before that, past z = -1, takes longer than a step to decay by e: R(z) = 1/e
    rk4_edge = brentq(lambda z: 1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24 - math.exp(-1), -2.5, -1.6)
    assert rk4_edge == pytest.approx(-2.09, abs=1e-2)
    rate = -1000.0
    kinds = [step_flaw("rk4", z / rate, np.array([[rate]])).kind for z in (-2.5, -2.8)]
    assert kinds == ["lingering", "unstable"]
    for method, edge in (("euler", euler_edge), ("rk4", rk4_edge)):
        rate = -1000.0
        inside = step_flaw(method, 0.999 * edge / rate, np.array([[rate]]))
        outside = step_flaw(method, 1.001 * edge / rate, np.array([[rate]]))
        assert inside is None
        assert outside is not None
        assert outside.longest_step == pytest.approx(edge / rate, rel=1e-9)
    assert step_flaw("euler", 1.5 / 1000, np.array([[-1000.0]])).kind == "alternating"
    assert step_flaw("euler", 2.5 / 1000, np.array([[-1000.0]])).kind == "unstable"
    # a flip that dies out faster than the model (R = -0.1 against e^z = 0.33) is accepted
    assert step_flaw("euler", 1.1 / 1000, np.array([[-1000.0]])) is None


def test_oscillators():
    omega = 100.0
    undamped = np.array([[0.0, 1.0], [-(omega**2), 0.0]])
    # an undamped mode neither decays nor grows: no flaw, although Euler grows on it
    assert step_flaw("euler", 1e-3, undamped) is None
    damped = np.array([[0.0, 1.0], [-(omega**2), -2 * 0.01 * omega]])  # ζ = 0.01
    flaw = step_flaw("euler", 1e-3, damped)  # |1 + hλ|² = 1 - 2ζωh + (ωh)² > 1
    assert flaw is not None and flaw.kind == "unstable"
    assert flaw.longest_step == pytest.approx(2 * 0.01 / omega, rel=1e-6)
    assert step_flaw("rk4", 1e-3, damped) is None
    assert step_flaw("euler", 1e-3, np.array([[np.inf]])) is None


def test_rk4_beyond_its_stretch_of_the_imaginary_axis_grows_an_undamped_oscillator():
    # |R(iy)|² = 1 - y⁶/72 + y⁸/576 for RK4: above 1 from y = 2√2 on
    edge = 2 * math.sqrt(2)
    omega = 300.0
    undamped = np.array([[0.0, 1.0], [-(omega**2), 0.0]])
    assert step_flaw("rk4", 0.999 * edge / omega, undamped) is None
    flaw = step_flaw("rk4", 0.01, undamped)  # hω = 3: |R| = 1.5 a step
    assert flaw is not None and flaw.kind == "undamped"
    assert abs(flaw.factor) == pytest.approx(abs(1 + 3j + (3j) ** 2 / 2 + (3j) ** 3 / 6 + 81 / 24))
    assert flaw.longest_step == pytest.approx(edge / omega, rel=1e-9)
    # explicit Euler grows it at every step by its first-order error: accuracy, accepted
    assert step_flaw("euler", 1e-3, undamped) is None
    assert step_flaw("euler", 0.01, undamped) is None
    text = STIFF.format(method="rk4", step=0.01).replace(
        '"u - x1", "-1990*(x2 - x1)"', '"x2", "-90000*x1"'
    )
    model = parse_model(text, origin="osc.toml")
    with pytest.raises(ModelError, match=r"λ = 0\+300j 1/s; RK4 .* grows an oscillation"):
        simulate(model, steps=100, noise=False, jit=False)  # it wrote x1 = -2.6e17, exit 0


def test_simulate_refuses_a_step_too_long_for_a_stiff_mode():
    model = parse_model(STIFF.format(method="euler", step=0.001), origin="stiff.toml")
    with pytest.raises(ModelError) as err:
        simulate(model, steps=20, jit=False)
    message = str(err.value)
    assert message.startswith("stiff.toml: integration.step: 0.001 s is too long for mode 'a'")
    assert "λ = -1990 1/s" in message and "at most 0.000642 s" in message
    # RK4 at the same step, and Euler at half of it, follow the exact solution
    for method, step in (("rk4", 0.001), ("euler", 0.0005)):
        model = parse_model(STIFF.format(method=method, step=step), origin="stiff.toml")
        log = simulate(model, steps=20, noise=False, jit=False)
        exact = 1.0 - np.exp(-1990 * log.time)  # x1 stays at 1 under u = 1
        assert np.abs(log.states[:, 1] - exact).max() < 1e-4  # the refused run: 0.90


def test_the_switching_observer_refuses_eigenvalues_its_step_cannot_follow():
    model = parse_model(STIFF.format(method="rk4", step=0.001), origin="stiff.toml")
    count = 5
    signals = AlignedSignals(
        source="log.csv",
        time=np.arange(count) * 0.01,
        input_names=("u",),
        output_names=("y",),
        inputs=np.ones((count, 1)),
        outputs=np.zeros((count, 1)),
        truth_modes=np.zeros(count, dtype=np.int64),
    )
    options = SwitchingObserverOptions(eigenvalues="-1000,-3000")
    with pytest.raises(OptionError, match=r"'eigenvalues': λ = -3000 1/s is too fast for "):
        run_switching_observer(model, signals, options)


BRIEF = """
name = "brief"
time = "continuous"
dt = 0.01
integration = {method = "euler", step = 0.001}
states = ["x"]
inputs = ["u"]
outputs = ["y"]

[modes.a]
dx = ["-x + u"]
h = ["x"]

[modes.b]
dx = ["-1990*(x - 1)"]
h = ["x"]

[noise]
process = 0.0
measurement = 0.01

[initial]
state = [0.0]
mode = "a"

[simulation.inputs]
u = "0"
"""


def test_a_mode_the_run_visits_briefly_is_linearised_all_the_same():
    # one sample of the stiff mode among 4000: evenly spaced samples of the run missed it
    # and the run went on, 0.9 off the exact solution, without a word
    model = parse_model(BRIEF, origin="brief.toml")
    with pytest.raises(ModelError, match=r"too long for mode 'b' at t = 20 s just after the"):
        simulate(model, schedule="a:2000,b:1,a:2000", noise=False, jit=False)


JUMPED = """
name = "jumped"
time = "continuous"
dt = 0.01
integration = {method = "euler", step = 0.001}
states = ["x"]
inputs = ["u"]
outputs = ["y"]

[modes.a]
dx = ["0*x"]
h = ["x"]

[modes.b]
dx = ["-1000*x**2"]
h = ["x"]

[jumps."a->b"]
x = "0.001*x"

[noise]
process = 0.0
measurement = 0.01

[initial]
state = [1.0]
mode = "a"

[simulation.inputs]
u = "0"
"""


def test_a_switch_is_linearised_where_the_jump_map_puts_the_state():
    # mode b starts at x = 0.001 (J = -2 1/s), not at x = 1 (J = -2000 1/s, refused before)
    model = parse_model(JUMPED, origin="jumped.toml")
    log = simulate(model, schedule="a:3,b:10", noise=False, jit=False)
    assert log.modes[3] == 0 and log.modes[4] == 1  # (t_3, t_4] the first interval in b
    t = log.time[4:] - log.time[3]
    exact = 0.001 / (1.0 + 1000 * 0.001 * t)  # dx = -1000 x², x = 0.001 at t_3
    assert np.abs(log.states[4:, 0] - exact).max() < 1e-6  # Euler: O(h)


def test_a_jacobian_dividing_by_zero_in_plain_python_says_nothing_about_the_step():
    # d/dx sqrt(|x|) at x = 0: compiled, an inf (skipped); plain Python raised ZeroDivisionError
    text = BRIEF.replace('"-x + u"', '"u - 0.5*sqrt(abs(x))"')
    model = parse_model(text, origin="brief.toml")
    log = simulate(model, steps=3, noise=False, jit=False)
    assert np.all(np.isfinite(log.states))


def test_every_visited_mode_is_linearised_within_a_bounded_cost():
    names = [f"U{i}" for i in range(7)]
    text = f"""
name = "many"
time = "continuous"
dt = 0.01
integration = {{method = "rk4", step = 0.01}}
states = ["x"]
outputs = ["y"]
booleans = {names!r}

[dynamics]
dx = ["-x*abs(x)*(1 + {" + ".join(names)})"]
h = ["x"]

[noise]
process = 0.0
measurement = 0.01

[initial]
state = [1.0]
mode = "0"
""".replace("'", '"')
    model = parse_model(text, origin="many.toml")
    modes = np.repeat(np.arange(128), 1000)
    rows = _rows(model, modes)
    # 128 nonlinear modes visited: 4096 / 128 = 32 samples each, the first of each among them
    assert np.array_equal(np.unique(modes[rows]), np.arange(128))
    assert rows.size == TOTAL_POINTS
    assert np.all(np.isin(np.flatnonzero(np.diff(modes)) + 1, rows))
    # an affine mode has one Jacobian: linearised once
    linear = parse_model(STIFF.format(method="rk4", step=0.001), origin="stiff.toml")
    assert _rows(linear, np.zeros(100_000, dtype=np.int64)).tolist() == [1]


TANK = """
name = "tank"
time = "continuous"
dt = 0.001
integration = {{method = "euler", step = 0.001}}
states = ["x"]
outputs = ["y"]

[modes.a]
dx = ["{dx}"]
h = ["x"]

[noise]
process = 0.0
measurement = 0.01

[initial]
state = [{x0!r}]
mode = "a"

[simulation]
state_min = [0.0]
"""


def test_a_tank_emptying_is_not_refused_for_its_last_step():
    # -c*sqrt(x) has the Jacobian -c/(2√x): as stiff as one likes just above 0, where the
    # step that lands at 0 is the last (three_tank_valves --schedule 2:97634 was refused at
    # H2 = 2.5e-11 m, 97633 and 97635 were not); the run is what the model says
    a = 0.5 * 0.001
    x = 1e-12  # the level five Euler steps x <- x - a*sqrt(x) reach from the initial one
    for _ in range(5):
        x = ((a + math.sqrt(a * a + 4 * x)) / 2) ** 2
    model = parse_model(TANK.format(dx="-0.5*sqrt(x)", x0=x), origin="tank.toml")
    log = simulate(model, steps=6, noise=False, jit=False)
    assert 0.0 < log.states[5, 0] < 1e-11 and log.states[6, 0] == 0.0
    # the same Jacobian on a linear mode, where each step keeps it, is refused
    model = parse_model(TANK.format(dx="-250000*x", x0=1.0), origin="tank.toml")
    with pytest.raises(ModelError, match=r"λ = -2.5e\+05 1/s"):
        simulate(model, steps=6, noise=False, jit=False)


def test_rk4_drawing_out_a_transient_the_model_ends_within_a_step_is_refused():
    # R(-2.78) = 0.992 a step: x reached 0.077 after a sample where the model reaches 1.0
    text = STIFF.format(method="rk4", step=0.001).replace("-1990*(x2 - x1)", "-2780*(x2 - x1)")
    with pytest.raises(ModelError, match=r"λ = -2780 1/s; RK4 .* takes more than a step to"):
        simulate(parse_model(text, origin="stiff.toml"), steps=5, noise=False, jit=False)


@pytest.mark.parametrize("rate", [-1e80, -1e200, -1e308])
def test_an_eigenvalue_beyond_float64s_reach_is_a_flaw_with_a_positive_step(rate):
    # RK4's z**4 overflowed a Python complex: "unexpected OverflowError"
    flaw = step_flaw("rk4", 1e-3, np.array([[rate]]))
    assert flaw is not None and flaw.kind == "unstable"
    assert 0.0 < flaw.longest_step <= 2.1 / abs(rate)
    assert "more than float64 holds" in flaw.describe("rk4") or math.isfinite(abs(flaw.factor))


def test_a_step_missing_a_growing_modes_growth_by_more_than_e_is_refused():
    # growth was never judged: dx = a*x**2 from 1 blows up at t = 1/a, and RK4 at 10 ms
    # wrote x = 5.1e12 at t = 1 s for a = 1.01 (the model had blown up at 0.99 s), exit 0
    for method, polynomial in (("euler", [1, 1]), ("rk4", [1 / 24, 1 / 6, 1 / 2, 1, 1])):
        edge = brentq(lambda z, p=polynomial: z - math.log(np.polyval(p, z)) - 1, 1.0, 10.0)
        rate = 1000.0
        assert step_flaw(method, 0.999 * edge / rate, np.array([[rate]])) is None
        flaw = step_flaw(method, 1.001 * edge / rate, np.array([[rate]]))
        assert flaw is not None and flaw.kind == "misgrown"
        assert flaw.longest_step == pytest.approx(edge / rate, rel=1e-9)
    text = STIFF.format(method="rk4", step=0.01).replace(
        'dx = ["u - x1", "-1990*(x2 - x1)"]', 'dx = ["1.01*x1**2", "0"]'
    )
    model = parse_model(text, origin="blow.toml")
    with pytest.raises(
        ModelError, match=r"at t = 0\.99 s \(x1 = .* misses the growth of a growing"
    ):
        simulate(model, steps=100, noise=False, jit=False)
    # the same mode short of its blow-up grows as the model says: accepted
    log = simulate(
        parse_model(text.replace("1.01*", "0.9*"), origin="blow.toml"),
        steps=100,
        noise=False,
        jit=False,
    )
    assert log.states[100, 0] == pytest.approx(1 / (1 - 0.9), rel=1e-3)


def test_a_state_run_away_since_a_jump_is_refused_naming_the_jump_not_the_step():
    # omega = "-omega" at the engaging switch (t = 1.5 s) puts ice_clutch where the air mass
    # m decays no more but grows, -p*omega*(m - m_ss) with omega < 0: RK4 follows it faithfully
    # to m = -5.7e131 at t = 6 s, where the Jacobian is stiff only because m is huge. The run
    # was refused as "integration.step: 0.001 s is too long ... a step of at most 3.75e-122 s
    # avoids it", a step no clock of 8 s can take.
    from hybridlog.model.builtins import builtin_text

    text = builtin_text("ice_clutch").replace('omega = "JE/(JE + JL)*omega"', 'omega = "-omega"')
    with pytest.raises(ModelError) as caught:
        simulate(parse_model(text, origin="clutch.toml"), noise=False)
    message = str(caught.value)
    assert message.startswith(
        'clutch.toml: jumps."0->1": the state ran away since the jump at the switch from '
        "'0' to '1' at t = 1.5 s, which put it at m = 0.129, omega = -285, T = 25: m grew "
    )
    assert "to -5.697e+131 at t = 6 s" in message
    assert "integration.step:" not in message and message.endswith("nothing was written")


def test_a_step_no_clock_can_take_at_a_state_of_its_own_scale_still_blames_the_step():
    # λ = -1e20 at x2 = 1: the mode is stiff, nothing ran away; the step is what to change
    text = STIFF.format(method="rk4", step=0.001).replace("-1990*(x2 - x1)", "-1e20*(x2 - x1)")
    with pytest.raises(ModelError, match=r"^stiff\.toml: integration\.step: 0\.001 s is too long"):
        simulate(parse_model(text, origin="stiff.toml"), steps=10, noise=False)


def test_the_run_is_cut_at_its_switches_up_to_its_end():
    from hybridlog.model.stability import _pieces

    modes = np.array([0, 0, 0, 1, 1, 0, 0])
    states = np.arange(7.0).reshape(7, 1)
    at = np.array([99.0])
    # row 7, past the last, stands for the run's end (it raised a shape mismatch)
    for row in (6, 7):
        cut = [
            (k, float(before[0]), float(end[0]))
            for k, before, end in _pieces(modes, states, row, at)
        ]
        assert cut == [(1, 0.0, 2.0), (3, 2.0, 4.0), (5, 4.0, 99.0)]
    cut = [(k, float(before[0]), float(end[0])) for k, before, end in _pieces(modes, states, 3, at)]
    assert cut == [(1, 0.0, 2.0), (3, 2.0, 99.0)]
