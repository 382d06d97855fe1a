"""The one sympy → compiled-code path: derivatives, printer, and the cache keyed by model.

The cache must never hand out code for another model (the key changes with everything that
shapes the code) and, once warm, must give a new process its compiled code without running
sympy's code generation at all.
"""

import dataclasses
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
import sympy

from hybridlog.errors import OutputError
from hybridlog.estimators.imm import ImmOptions, run_imm
from hybridlog.model import compiled
from hybridlog.model.codegen import lambdify
from hybridlog.model.compiled import (
    artefact_key,
    code_fingerprint,
    input_functions,
    load_generated,
    model_key,
)
from hybridlog.model.derivatives import jacobian, lie_derivative
from hybridlog.model.loader import load_model, parse_model
from hybridlog.simulate import simulate
from tests.support.models import LINEAR_TWO_MODE, PENDULUM_ONE_MODE

# Simulation inputs calling every function of the grammar: the NumPy printer writes some
# with other modules than numpy (max as functools.reduce(numpy.maximum, ...)).
EVERY_FUNCTION_INPUTS = LINEAR_TWO_MODE.replace(
    'a = "sin(0.7*t) + 0.5*cos(0.13*t)"',
    'a = "max(sin(t), 0) + min(t, 3, k) + Piecewise(1, t > 5, 2, k < 3, 0) + sign(cos(t))"',
)

MODELS = {
    "every_function_inputs": lambda: parse_model(EVERY_FUNCTION_INPUTS),
    "three_tank_hstf": lambda: load_model("three_tank_hstf"),
    "double_cart_case1": lambda: load_model("double_cart_case1"),
    "double_cart_case2": lambda: load_model("double_cart_case2"),
    "linear_two_mode": lambda: parse_model(LINEAR_TWO_MODE),
    "pendulum": lambda: parse_model(PENDULUM_ONE_MODE),
}


# -- derivatives ------------------------------------------------------------------------


def test_lie_derivatives_of_a_pendulum():
    x1, x2 = sympy.symbols("x1 x2", real=True)
    f = [x2, -sympy.sin(x1)]
    h = [x1, x1 * x2]
    assert lie_derivative(h, f, [x1, x2], order=0) == h
    first = lie_derivative(h, f, [x1, x2])
    expected_first = [x2, x2**2 - x1 * sympy.sin(x1)]
    assert all(sympy.simplify(a - b) == 0 for a, b in zip(first, expected_first, strict=True))
    # L_f^2 h = L_f (L_f h): the observability map of paper 004 stacks these.
    second = lie_derivative(h, f, [x1, x2], order=2)
    again = lie_derivative(first, f, [x1, x2])
    assert all(sympy.simplify(a - b) == 0 for a, b in zip(second, again, strict=True))
    assert sympy.simplify(second[0] + sympy.sin(x1)) == 0
    with pytest.raises(ValueError, match="2 states"):
        lie_derivative(h, [x2], [x1, x2])
    with pytest.raises(ValueError, match="non-negative"):
        lie_derivative(h, f, [x1, x2], order=-1)


def test_jacobians_of_kinks_are_printable_functions():
    x, y = sympy.symbols("x y", real=True)
    J = jacobian([sympy.Max(x, 0) * y, sympy.sign(x) + y, sympy.Abs(x)], [x, y])
    assert not any(entry.has(sympy.Heaviside, sympy.DiracDelta) for row in J for entry in row)
    assert J[0][1] == sympy.Max(x, 0)
    assert J[0][0].subs({x: 2, y: 3}) == 3 and J[0][0].subs({x: -2, y: 3}) == 0
    assert J[0][0].subs({x: 0, y: 3}) == sympy.Rational(3, 2)  # the mean of 0 and 3
    assert J[1] == [0, 1]
    assert J[2][0] == sympy.sign(x)


def test_jacobian_reads_a_sum_of_numbers_times_symbols_off_without_differentiating(monkeypatch):
    from hybridlog.model import derivatives

    x, y, u = sympy.symbols("x y u", real=True)
    rows = [sympy.Float(0.1 + 0.2) * x - 3 * y + u / 3 + 2.5, -y, sympy.Integer(4), x * y + x]
    differentiate = derivatives._derivative
    expected = [[differentiate(row, v) for v in (x, y)] for row in rows]

    def only_the_product(expression, variable):
        assert expression == x * y + x, f"{expression} was differentiated by sympy"
        return differentiate(expression, variable)

    monkeypatch.setattr(derivatives, "_derivative", only_the_product)
    got = jacobian(rows, [x, y])
    assert got == expected
    assert [[type(e) for e in row] for row in got] == [[type(e) for e in row] for row in expected]


# Eight states: the constant Jacobian of a linear mode is a table, the nonlinear mode's
# derived entries stay stores.
_ROWS = [[f"{0.1 * ((i * 3 + j) % 7) - 0.3 + 1e-17:.17g}" for j in range(8)] for i in range(8)]
TABLE_MODEL = f"""
name = "tables"
dt = 0.1
states = [{", ".join(f'"x{i}"' for i in range(8))}]
inputs = ["u"]
outputs = ["y1", "y2"]

[modes.lin]
A = [{", ".join("[" + ", ".join(row) + "]" for row in _ROWS)}]
B = [{", ".join("[0.5]" for _ in range(8))}]
C = [[1.0, 0, 0, 0, 0, 0, 0, 0], [0, 0.30000000000000004, 0, 0, 0, 0, 0, 1]]

[modes.curved]
f = [{", ".join(f'"0.9*x{i} + 0.01*sin(x{(i + 1) % 8})"' for i in range(8))}]
h = ["x0**2", "x1 + u"]

[noise]
measurement = 0.01

[initial]
state = [{", ".join("0.0" for _ in range(8))}]
"""


@pytest.mark.parametrize("jit", [False, True])
def test_a_linear_modes_jacobians_are_tables_holding_the_doubles_stores_held(jit):
    from hybridlog.model.codegen import _printer, mode_expressions, model_source

    model = parse_model(TABLE_MODEL)
    source = model_source(model)
    # a store per entry of a linear mode's F and H took 45 s to compile for six modes of
    # 20 states, copied from a table about a second: only the nonlinear mode's F and H store
    assert "F_TABLE" in source and "H_TABLE" in source
    assert source.count("out[0, 0] = ") == 2
    functions = compiled.compile_model(model, jit=jit)
    xs, (u,) = model.symbols()
    point = np.linspace(-1.0, 1.0, 8)
    printer = _printer()
    for q, name, rows in ((0, "F", 8), (0, "H", 2), (1, "F", 8), (1, "H", 2)):
        out = np.full((rows, 8), np.nan)
        getattr(functions, name)(q, point, np.array([0.3]), out)
        entries = mode_expressions(model, q, name)
        if q == 0:  # each entry as its store printed it: the double itself
            assert out.ravel().tolist() == [float(printer.doprint(e)) for e in entries]
            assert out.ravel().tolist() == [float(e) for e in entries]
        else:
            value = sympy.lambdify([*xs, u], entries)(*point, 0.3)
            np.testing.assert_allclose(out.ravel(), value, rtol=1e-15, atol=1e-15)


# -- the key ----------------------------------------------------------------------------


def test_same_model_same_key_and_every_change_that_shapes_code_another_key():
    tank = load_model("three_tank_hstf")
    assert model_key(tank) == model_key(load_model("three_tank_hstf"))
    assert model_key(tank) != model_key(load_model("three_tank_hstf", parameters={"a3": 0.6}))
    mode = tank.modes[0]
    noisier = dataclasses.replace(mode, measurement_noise=mode.measurement_noise * 2.0)
    changed = dataclasses.replace(tank, modes=(noisier, *tank.modes[1:]))
    assert model_key(changed) != model_key(tank)
    x1 = sympy.Symbol("x1", real=True)
    bent = dataclasses.replace(mode, f=(mode.f[0] + 1e-12 * x1, *mode.f[1:]))
    assert model_key(dataclasses.replace(tank, modes=(bent, *tank.modes[1:]))) != model_key(tank)
    # Equal values of different kinds are different code (a rational, a float).
    half = [dataclasses.replace(mode, f=(mode.f[0] + c * x1, *mode.f[1:])) for c in (0.5, 1 / 2)]
    half_exact = dataclasses.replace(mode, f=(mode.f[0] + sympy.Rational(1, 2) * x1, *mode.f[1:]))
    keys = [model_key(dataclasses.replace(tank, modes=(m, *tank.modes[1:]))) for m in half]
    assert keys[0] == keys[1]
    assert keys[0] != model_key(dataclasses.replace(tank, modes=(half_exact, *tank.modes[1:])))
    # What the compiled code receives as arguments at run time does not change the code.
    moved = dataclasses.replace(tank, initial_state=tank.initial_state + 1.0, origin="x.toml")
    assert model_key(moved) == model_key(tank)
    keys = {model_key(make()) for make in MODELS.values()}
    assert len(keys) == len(MODELS)


def test_the_key_is_the_same_in_another_process():
    code = textwrap.dedent(
        """
        from hybridlog.model.compiled import model_key
        from hybridlog.model.loader import load_model
        print(model_key(load_model("double_cart_case1")))
        """
    )
    environment = {**os.environ, "PYTHONHASHSEED": "12345"}
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=environment, check=True
    )
    assert done.stdout.strip() == model_key(load_model("double_cart_case1"))


def test_the_key_changes_with_the_code_that_writes_the_module(tmp_path, monkeypatch):
    model = parse_model(PENDULUM_ONE_MODE)
    assert artefact_key(model, "hstf") != artefact_key(model, "imm")
    generator = tmp_path / "fake_generator.py"
    generator.write_text("VERSION = 1\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(compiled, "_FINGERPRINTS", {})
    before = artefact_key(model, "fake", ["fake_generator"])
    assert before != artefact_key(model, "fake")
    generator.write_text("VERSION = 2\n")
    monkeypatch.setattr(compiled, "_FINGERPRINTS", {})
    assert artefact_key(model, "fake", ["fake_generator"]) != before
    assert code_fingerprint(["fake_generator"]) != code_fingerprint([])


# -- the cache --------------------------------------------------------------------------


def test_a_warm_cache_imports_without_generating_and_a_damaged_file_is_rewritten(
    tmp_path, monkeypatch
):
    monkeypatch.setenv("HYBRIDLOG_CACHE_DIR", str(tmp_path))
    model = parse_model(PENDULUM_ONE_MODE)
    calls = []

    def generate():
        calls.append(1)
        return "ANSWER = 42\n"

    assert load_generated(model, "probe", generate).ANSWER == 42
    (path,) = (tmp_path / "models").glob("probe_*.py")
    monkeypatch.setattr(compiled, "_MODULES", {})  # as in a new process

    def refuse():
        raise AssertionError("generated again although the cache holds the module")

    assert load_generated(model, "probe", refuse).ANSWER == 42
    assert calls == [1]
    # A truncated or altered file (a crash, a full disk) is regenerated, never imported.
    for damage in (lambda text: text[:-10], lambda text: text.replace("42", "43")):
        path.write_text(damage(path.read_text()))
        monkeypatch.setattr(compiled, "_MODULES", {})
        assert load_generated(model, "probe", generate).ANSWER == 42
    assert calls == [1, 1, 1]
    assert path.read_text().startswith("# hybridlog generated probe ")


def test_a_folder_in_place_of_a_cached_module_is_one_line_naming_the_cache(tmp_path, monkeypatch):
    """Garbage in the cache folder: an unexpected IsADirectoryError, said to be a bug."""
    monkeypatch.setenv("HYBRIDLOG_CACHE_DIR", str(tmp_path))
    model = parse_model(PENDULUM_ONE_MODE)
    path = tmp_path / "models" / f"probe_{artefact_key(model, 'probe')}.py"
    path.mkdir(parents=True)
    with pytest.raises(OutputError, match=rf"^cache folder {tmp_path}: cannot write probe_"):
        load_generated(model, "probe", lambda: "ANSWER = 42\n")


def test_a_warm_process_runs_filters_and_simulation_without_the_code_generator():
    # Warm the cache here (a no-op when earlier tests did), then a fresh process must find
    # everything: no import of model/codegen.py, hence no sympy printing, cse or diff.
    code = textwrap.dedent(
        """
        import sys
        from hybridlog.estimators.hstf import HstfOptions, run_hstf
        from hybridlog.estimators.imm import ImmOptions, run_imm
        from hybridlog.model.loader import load_model
        from hybridlog.simulate import simulate

        simulate(load_model("double_cart_case1"), steps=30, seed=1)  # guards and inputs
        model = load_model("three_tank_hstf")
        signals = simulate(model, steps=30, seed=1).signals(model)
        for kernel in ("auto", "loops"):
            run_hstf(model, signals, HstfOptions(), kernel=kernel)
            run_imm(model, signals, ImmOptions(), kernel=kernel)
        print("hybridlog.model.codegen" in sys.modules)
        """
    )
    subprocess.run([sys.executable, "-c", code], check=True, capture_output=True)
    done = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True)
    assert done.stdout.strip() == "False"


@pytest.mark.parametrize("name", sorted(MODELS))
def test_simulation_inputs_equal_sympy_lambdify_bit_for_bit(name):
    # sympy.lambdify with each Float printed as its double (its own prints 15 digits)

    model = MODELS[name]()
    t, k = sympy.Symbol("t", real=True), sympy.Symbol("k", real=True)
    time = np.arange(2000) * model.dt
    steps = np.arange(2000, dtype=float)
    functions = input_functions(model)
    assert set(functions) == set(model.simulation_inputs)
    for input_name, expression in model.simulation_inputs.items():
        reference = lambdify((t, k), expression, "numpy")
        expected = np.broadcast_to(np.asarray(reference(time, steps), dtype=float), time.shape)
        got = np.broadcast_to(
            np.asarray(functions[input_name](time, steps), dtype=float), time.shape
        )
        assert got.tobytes() == expected.tobytes()


def test_importing_simulate_and_the_compiled_code_cache_loads_neither_numba_nor_sympy():
    code = (
        "import sys, hybridlog.simulate, hybridlog.model.compiled, hybridlog.jit\n"
        "print([name for name in ('numba', 'sympy', 'scipy') if name in sys.modules])"
    )
    done = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True)
    assert done.stdout.strip() == "[]"


TIED_MAX = """
name = "tied"
dt = 0.1
states = ["x"]
outputs = ["y"]

[modes.a]
f = ["0.95*x"]
h = ["max(x, 2*x)"]

[noise]
process = 1e-4
measurement = 0.05

[initial]
state = [0.0]

[simulation]
state = [1.0]
"""


def test_a_derivative_at_a_tie_of_max_or_min_is_a_subgradient():
    # d max(x, 2x)/dx at x = 0 was 0, no slope of either argument: an EKF whose estimate
    # sat at 0 had H = 0, never moved, and ended at x = 0 with the log at 1 (RMSE 0.45)
    x, u = sympy.symbols("x u", real=True)
    cases = [
        (sympy.Max(x, 2 * x), {x: 0}, sympy.Rational(3, 2)),  # in [1, 2]
        (sympy.Min(x, 2 * x), {x: 0}, sympy.Rational(3, 2)),
        (sympy.Max(x, 2 * x - 1), {x: 1}, sympy.Rational(3, 2)),
        (sympy.Max(x, 0), {x: 0}, sympy.S.Half),
        (sympy.Max(x, -x), {x: 0}, 0),  # as d|x|/dx = sign(0)
        (sympy.Min(x, u), {x: 0, u: 0}, sympy.S.Half),
    ]
    for expression, point, slope in cases:
        assert jacobian([expression], [x])[0][0].subs(point) == slope, expression
    model = parse_model(TIED_MAX, origin="tied.toml")
    log = simulate(model, steps=30, seed=1, jit=False)
    result = run_imm(model, log.signals(model), ImmOptions(), jit=False)
    truth = log.states[:, 0]
    assert abs(result.state_means[-1, 0] - truth[-1]) < 0.1, (result.state_means[-1, 0], truth[-1])


def test_only_codegen_turns_expressions_into_code():
    # Issue 8: one place turns sympy expressions into code.  model/diagnosis.py called
    # sympy.lambdify with sympy's own printer (a Float printed to 15 digits, not the double it
    # holds), beside codegen.lambdify's exact one.
    import re

    from tests.support.paths import ROOT

    pattern = re.compile(r"sympy\.lambdify|sympy\.printing|sympy\.utilities\.(lambdify|autowrap)")
    found = [
        f"{path.relative_to(ROOT)}:{number}"
        for path in sorted((ROOT / "hybridlog").rglob("*.py"))
        if path.name != "codegen.py"
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
        if pattern.search(line)
    ]
    assert found == []
