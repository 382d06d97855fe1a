"""Continuous time: compiled ``dx``, ``G``/``D`` (paper 003 eq. (1)), the fixed-step
integrator and ``simulate`` with jumps, checked against exact solutions and ``solve_ivp``."""

import numpy as np
import pytest
import sympy
from scipy.integrate import solve_ivp

from hybridlog.errors import ModelError, OptionError
from hybridlog.jit import compile_for
from hybridlog.model.compiled import compile_continuous
from hybridlog.model.derivatives import boolean_affine_split
from hybridlog.model.integration import EULER, RK4, step_function
from hybridlog.model.loader import load_model, parse_model
from hybridlog.simulate import simulate
from hybridlog.simulation_inputs import Disturbance
from tests.support.model_kinds import CLUTCH_JUMPS, CONTINUOUS_TANK
from tests.support.models import PENDULUM_ONE_MODE

CLUTCH_RUN = CLUTCH_JUMPS.replace(
    "[initial]",
    '[simulation]\nschedule = "0:30,1:30,0:30"\ninputs = {alpha = "0.5 + 0.1*sin(t)"}\n[initial]',
)


def integrate_log(
    advance, dx, method: int, modes, inputs, x0, h: float, substeps: int, states
) -> None:
    r"""``states[k]`` for every sample of a mode sequence, without noise or jumps.

    ``states[0] = x0``; the interval :math:`(t_{k-1}, t_k]` runs in mode ``modes[k]`` with
    ``inputs[k-1]`` held (the convention of :mod:`hybridlog.simulate`); ``advance`` is
    :func:`step_function`.  Compiled with :func:`hybridlog.jit.compile_for`.
    """
    work = np.zeros((5, x0.shape[0]))
    x = x0.copy()
    states[0, :] = x
    for k in range(1, states.shape[0]):
        for _ in range(substeps):
            advance(dx, method, modes[k], x, inputs[k - 1], h, work)
        states[k, :] = x


def test_g_and_d_give_back_dx_in_every_mode():
    model = load_model("three_tank_valves")
    code = compile_continuous(model, jit=False)
    assert code.G is not None and code.D is not None
    rng = np.random.default_rng(1)
    for sigma in range(8):
        x, u = rng.uniform(0.05, 0.3, 3), rng.uniform(0, 1e-4, 1)
        dx, G, D = np.zeros(3), np.zeros(3), np.zeros((3, 3))
        code.dx(sigma, x, u, dx)
        code.G(sigma, x, u, G)
        code.D(sigma, x, u, D)
        delta = np.array(model.boolean_affine.delta(sigma))
        np.testing.assert_allclose(G + D @ delta, dx, rtol=1e-12, atol=1e-15)
        # eq. (46): D is lower bidiagonal, G = [q/β1, 0, 0] (eq. (45))
        assert D[0, 1] == D[0, 2] == D[1, 2] == D[2, 0] == 0.0 and G[1] == G[2] == 0.0


def test_boolean_affine_split_refuses_a_product_of_booleans():
    x, d1, d2 = sympy.symbols("x d1 d2", real=True)
    G, D = boolean_affine_split([x + 2 * d1 - x * d2], [d1, d2])
    assert [x] == G and [[2, -x]] == D
    with pytest.raises(ValueError, match=r"^0: not affine in the booleans \(d1\*d2 is a product"):
        boolean_affine_split([x * d1 * d2], [d1, d2])
    # the derivative of a Piecewise in a boolean is 0: G and D were e(δ=0) and 0
    with pytest.raises(ValueError, match=r"^0: not affine in the booleans \(a boolean appears "):
        boolean_affine_split([sympy.Piecewise((x, d1 > 0.5), (0, True))], [d1, d2])


def test_continuous_functions_refuse_a_discrete_model():
    model = parse_model(PENDULUM_ONE_MODE, origin="p.toml")
    with pytest.raises(ModelError, match=r"^p\.toml: time: the continuous-time mode functions"):
        compile_continuous(model, jit=False)


def _linear_run(method: str, step: float):
    """``dx = -2 h1 + 3 q + 1`` (mode ``linear``) from 1 for 1 s with q = 0.5: exact e^{-2t}."""
    model = parse_model(
        CONTINUOUS_TANK.replace(
            'integration = {method = "euler", step = 0.001}',
            f'integration = {{method = "{method}", step = {step}}}',
        ).replace("dt = 0.01", "dt = 0.1")
    )
    code = compile_continuous(model)
    n = 11
    modes = np.full(n, model.mode_index("linear"), dtype=np.int64)
    inputs = np.full((n, 1), 0.5)
    states = np.zeros((n, 1))
    arguments = (
        step_function(),
        code.dx,
        {"euler": EULER, "rk4": RK4}[method],
        modes,
        inputs,
        np.array([1.0]),
        model.timebase.step,
        model.timebase.substeps,
        states,
    )
    compile_for(integrate_log, arguments)(*arguments)
    t = np.arange(n) * 0.1
    exact = 1.25 - 0.25 * np.exp(-2 * t)
    return np.abs(states[:, 0] - exact).max()


def test_euler_and_rk4_converge_to_the_exact_solution_at_their_orders():
    euler = [_linear_run("euler", h) for h in (0.01, 0.005)]
    rk4 = [_linear_run("rk4", h) for h in (0.05, 0.025)]
    assert 1.9 < euler[0] / euler[1] < 2.1  # first order
    assert 14 < rk4[0] / rk4[1] < 18  # fourth order
    assert rk4[0] < 1e-6 and euler[1] < 2e-3


def _clutch_reference(model, log):
    """The same run with solve_ivp (tight tolerances), interval by interval, jumps at switches."""
    dx = compile_continuous(model, jit=False).dx
    jump = compile_continuous(model, jit=False).jump
    x = log.states[0].copy()
    states = [x.copy()]
    for k in range(1, log.time.shape[0]):
        q, u = int(log.modes[k]), log.inputs[k - 1]
        if q != log.modes[k - 1]:
            after = np.zeros(3)
            jump(int(log.modes[k - 1]), q, x, after)
            x = after

        def rhs(_t, state, q=q, u=u):
            out = np.zeros(3)
            dx(q, np.ascontiguousarray(state), u, out)
            return out

        x = solve_ivp(rhs, (0, model.dt), x, rtol=1e-11, atol=1e-11, method="DOP853").y[:, -1]
        states.append(x.copy())
    return np.array(states)


def test_rk4_simulation_with_jumps_matches_solve_ivp_at_the_models_step():
    model = parse_model(CLUTCH_RUN)
    log = simulate(model, noise=False)
    assert log.modes.tolist() == [0] * 31 + [1] * 30 + [0] * 30
    reference = _clutch_reference(model, log)
    scale = np.abs(reference).max(axis=0)
    assert np.max(np.abs(log.states - reference) / scale) < 1e-8
    # the jump (45) of T at the switch into mode 1: T(t+) = (TE + TL)/TE·T(t−), T constant after
    assert log.states[30, 2] == pytest.approx(5.0) and log.states[31, 2] == pytest.approx(15.0)
    assert log.states[61, 2] == pytest.approx(5.0)
    np.testing.assert_array_equal(log.outputs[:, 0], log.states[:, 1])


def test_plain_python_and_compiled_simulations_agree_and_noise_is_seeded():
    model = load_model("three_tank_valves")
    compiled = simulate(model, seed=3, schedule="7:3,2:3")
    plain = simulate(model, seed=3, schedule="7:3,2:3", jit=False)
    np.testing.assert_allclose(compiled.outputs, plain.outputs, rtol=1e-12)
    quiet = simulate(model, seed=3, schedule="7:3,2:3", noise=False)
    np.testing.assert_array_equal(quiet.outputs, quiet.states)
    np.testing.assert_allclose(compiled.states, quiet.states, rtol=1e-12)  # no process noise
    assert 0 < np.abs(compiled.outputs - quiet.outputs).max() < 1e-5  # noise variance 1e-12


@pytest.mark.parametrize("step", [0.01, 0.001])
def test_continuous_process_noise_is_an_intensity_whatever_the_step(step):
    # docs/model_files.md: a sample's increment of dx = 0 has covariance process*dt, not
    # process per integration step (which a user could not have told from the file)
    text = (
        'time = "continuous"\ndt = 0.01\n'
        f'integration = {{method = "rk4", step = {step!r}}}\n'
        'states = ["x"]\noutputs = ["y"]\n[modes.a]\ndx = ["0"]\nh = ["x"]\n'
        "[noise]\nprocess = 2.0\nmeasurement = 1e-12\n[initial]\nstate = [0.0]\n"
    )
    log = simulate(parse_model(text), steps=20000, seed=5)
    variance = np.var(np.diff(log.states[:, 0]))
    assert abs(variance / (2.0 * 0.01) - 1) < 0.05  # 20,000 draws: 1 % standard error


def test_the_disturbance_of_eq_49_is_added_to_dx():
    model = load_model("three_tank_valves")
    log = simulate(model, schedule="0:40", noise=False, disturbance=Disturbance(0.1, 50.0))
    # mode 0 (all valves closed): dx = [q/(a w), 0, 0] + 0.1 (|H1|+|H2|+|H3|) sin(50 t), Euler
    x = np.array([0.22, 0.24, 0.24])
    step = 0.001
    for j in range(40):
        q = log.inputs[j, 0]
        x = x + step * (np.array([q / 0.035**2, 0, 0]) + 0.1 * x.sum() * np.sin(50 * j * step))
    np.testing.assert_allclose(log.states[-1], x, rtol=1e-12)


def test_a_disturbance_needs_a_continuous_model():
    model = parse_model(PENDULUM_ONE_MODE)
    with pytest.raises(OptionError, match=r"^--disturbance: .* needs a continuous-time model"):
        simulate(model, steps=3, disturbance=Disturbance(0.1, 1.0))


def test_cli_simulates_a_continuous_model_with_the_disturbance_and_refuses_a_bad_one(
    tmp_path, capsys
):
    import polars as pl

    from hybridlog.cli import main

    out = tmp_path / "valves.csv"
    with pytest.raises(SystemExit) as exit_:
        main(["simulate", "three_tank_valves", "--out", str(out), "--disturbance", "0.1"])
    assert exit_.value.code == 2 and not out.exists()
    assert capsys.readouterr().err.strip() == (
        "hybridlog: error: --disturbance: expected A,OMEGA (two finite numbers), got '0.1'"
    )
    args = ["--steps", "40", "--no-noise", "--disturbance", "2e-4,6.28", "--schedule", "3:20"]
    main(["simulate", "three_tank_valves", "--out", str(out), *args])
    frame = pl.read_csv(out)
    assert frame.columns == ["t", "q", "y1", "y2", "y3", "mode", "H1", "H2", "H3"]
    assert frame.height == 41 and frame["y3"].to_list() == frame["H3"].to_list()


def test_the_valve_sample_logs_are_what_their_commands_write(tmp_path):
    import re
    import shlex

    from hybridlog.cli import main
    from tests.support.paths import ROOT

    text = (ROOT / "sample_logs" / "README.md").read_text()
    commands = re.findall(r"`(hybridlog simulate three_tank_valves [^`]*)`", text)
    assert len(commands) == 2
    for command in commands:
        args = shlex.split(command)[1:]
        at = args.index("--out") + 1
        sample = ROOT / args[at]
        fresh = tmp_path / sample.name
        main([*args[:at], str(fresh), *args[at + 1 :]])
        assert fresh.read_bytes() == sample.read_bytes()


JUMP_OUT_OF_DOMAIN = """
name = "jumpy"
time = "continuous"
dt = 0.01
integration = {method = "rk4", step = 0.005}
states = ["x"]
inputs = ["u"]
outputs = ["y"]

[modes.a]
dx = ["-x + u"]
h = ["x"]

[modes.b]
dx = ["-2*x + u"]
h = ["x"]

[jumps."a->b"]
x = "sqrt(x - 2)"

[initial]
state = [1.0]
mode = "a"

[simulation]
schedule = "a:3,b:3"
inputs = {u = "0"}
"""


def test_a_jump_map_leaving_its_domain_is_named_with_the_switch():
    # was "the simulation diverged: x = nan at t = 0.04 s", naming no key
    model = parse_model(JUMP_OUT_OF_DOMAIN, origin="jumpy.toml")
    with pytest.raises(ModelError) as caught:
        simulate(model, noise=False)
    assert str(caught.value) == (
        "jumpy.toml: jumps.\"a->b\": the jump map gives x = nan at the switch from 'a' to 'b' "
        "at t = 0.03 s, from x = 0.970446: the simulation diverged there; nothing was written"
    )


def test_a_continuous_model_with_guards_is_refused_saying_what_would_simulate_it():
    text = (
        JUMP_OUT_OF_DOMAIN.replace('[jumps."a->b"]\nx = "sqrt(x - 2)"\n', "")
        .replace('h = ["x"]\n\n[modes.b]', 'h = ["x"]\nguard = "x > 0.5"\n\n[modes.b]')
        .replace('dx = ["-2*x + u"]\nh = ["x"]', 'dx = ["-2*x + u"]\nh = ["x"]\nguard = "x <= 0.5"')
    )
    text = text.replace('schedule = "a:3,b:3"\n', "")
    with pytest.raises(ModelError, match="remove the guards to simulate it along a schedule"):
        simulate(parse_model(text, origin="g.toml"), noise=False, jit=False)


LEVEL_INTO_LOG = CONTINUOUS_TANK.replace('"q - c*sqrt(abs(h1))"', '"q + log(h1)"').replace(
    "state = [1.0]",
    'state = [0.02]\nmode = "open"\n[simulation]\ninputs = {q = "0"}\n[noise]\n'
    "process = 1e-8\nmeasurement = 1e-6",
)


@pytest.mark.parametrize("noise", [False, True])
def test_dx_leaving_its_domain_within_an_interval_is_named(noise):
    # dx = log(h1) drives the level below 0 within the first interval (Euler, 1 ms steps):
    # was "the simulation diverged: h1 = nan at t = 0.01 s", naming neither mode nor key;
    # compiled, as a user runs it (plain Python raises math.log's ValueError itself)
    model = parse_model(LEVEL_INTO_LOG, origin="tank.toml")
    with pytest.raises(ModelError) as caught:
        simulate(model, steps=5, noise=noise, seed=4)
    message = str(caught.value)
    assert message.startswith("tank.toml: modes.open.dx[0]: 'q + log(h1)' is nan at h1 = -0.00")
    assert message.endswith(
        ", q = 0, a step of the interval from t = 0 s to 0.01 s (the state left the domain of "
        "dx there): the simulation diverged; nothing was written"
    )
    # the point named is where the run stood when dx was evaluated: below 0, out of log's domain
    at = float(message.split("h1 = ")[1].split(",")[0])
    assert at < 0.0


def test_dx_overflowing_within_an_interval_is_named():
    model = parse_model(LEVEL_INTO_LOG.replace("q + log(h1)", "q + exp(1000*h1)"), origin="e.toml")
    with pytest.raises(ModelError, match=r"^e\.toml: modes\.open\.dx\[0\]: .* is inf at h1 = "):
        simulate(model, steps=5, noise=False)


SPRING = """
time = "continuous"
dt = 0.05
integration = {method = "rk4", step = 0.005}
states = ["p", "v"]
inputs = ["u"]
outputs = ["y"]
[parameters]
stiffness = 4.0
damping = 0.5
[modes.a]
MODE_A
[noise]
process = 0.0
measurement = 0.0
[initial]
state = [1.0, 0.0]
mode = "a"
[simulation.inputs]
u = "sin(3*t)"
"""


def test_a_linear_mode_as_matrices_or_expressions_is_its_zero_order_hold_discretisation():
    # an independent reference: scipy's cont2discrete (expm of the augmented matrix)
    from scipy.signal import cont2discrete

    matrices = 'A = [[0, 1], ["-stiffness", "-damping"]]\nB = [[0], [1]]\nC = [[1, 0]]'
    written = 'dx = ["v", "-stiffness*p - damping*v + u"]\nh = ["p"]'
    logs = [
        simulate(parse_model(SPRING.replace("MODE_A", mode)), steps=80, noise=False)
        for mode in (matrices, written)
    ]
    np.testing.assert_array_equal(logs[0].states, logs[1].states)
    A = np.array([[0.0, 1.0], [-4.0, -0.5]])
    Ad, Bd, *_ = cont2discrete((A, np.array([[0.0], [1.0]]), np.eye(2), 0), 0.05, method="zoh")
    x = np.array([1.0, 0.0])
    reference = [x]
    for k in range(80):
        x = Ad @ x + Bd[:, 0] * logs[0].inputs[k, 0]
        reference.append(x)
    # RK4's error at h|λ| = 0.01: about 1e-12 a step
    np.testing.assert_allclose(logs[0].states, np.array(reference), rtol=0, atol=1e-9)


@pytest.mark.parametrize(
    ("dt", "step", "shown"),
    [
        (
            "0.0499999999",
            "0.01",
            "dt = 0.0499999999 must be an integer multiple of the "
            "integration step 0.01 (dt/step = 4.99999999)",
        ),
        (
            "0.05",
            "0.03",
            "dt = 0.05 must be an integer multiple of the integration step 0.03 "
            "(dt/step = 1.6666666666666667)",
        ),
    ],
)
def test_a_dt_off_a_multiple_of_the_step_is_shown_as_written(dt, step, shown):
    # 6 significant digits read "dt = 0.05 must be an integer multiple of the integration
    # step 0.01 (dt/step = 5)" for dt = 0.0499999999: a refusal of what looked right
    text = SPRING.replace("dt = 0.05", f"dt = {dt}").replace("step = 0.005", f"step = {step}")
    text = text.replace("MODE_A", 'dx = ["v", "-p"]\nh = ["p"]')
    with pytest.raises(ModelError, match=r"^s\.toml: integration\.step: ") as caught:
        parse_model(text, origin="s.toml")
    assert str(caught.value).endswith(shown)
