"""What the structure's explicit solving and a cluster's EKF make of awkward equations.

Three kinds, each once seen as a crash or a silent guess on ``analyze``:

* a cluster without a state (its outputs fixed by inputs: ``y1 = u1``) crashed compiling;
* equations with several real solutions (``w1**2 = x1 + 1``) ran on sympy's first one;
* a fractional power of a negative number (``x1**(1/3)``, sympy's real cube root) made the
  unrolled EKF step complex, which crashed instead of naming the cluster and the values.
"""

from pathlib import Path

import numpy as np
import pytest

from hybridlog.errors import ModelError
from hybridlog.estimators.cpha.cluster_filter import compile_cluster
from hybridlog.estimators.cpha.structure import decompose
from hybridlog.io.writers import write_table
from hybridlog.model.loader import parse_model
from tests.support.cli import run_main

MODEL = """
name = "awkward"
dt = 1.0
states = ["x1"]
inputs = ["u1"]
outputs = ["y1"]
variables = [{variables}]

[noise]
process = [0.01]
measurement = [0.01]

[initial]
state = [0.0]
covariance = 1.0

[components.plant]
unknown = 0.01
initial = "a"

[components.plant.modes.a]
equations = [{equations}]
"""


def model_text(*equations: str, variables: tuple[str, ...] = ()) -> str:
    """:data:`MODEL` with mode ``a``'s equations and the internal variables."""
    return MODEL.format(
        equations=", ".join(f'"{e}"' for e in equations),
        variables=", ".join(f'"{v}"' for v in variables),
    )


def decomposition(text: str):
    model = parse_model(text)
    names = {"states": model.states, "inputs": model.inputs, "outputs": model.outputs}
    return model, decompose(model.components, ("a",), variables=model.variables, **names)


def write_log(root: Path, u: np.ndarray, y: np.ndarray) -> Path:
    t = np.arange(len(u), dtype=np.float64)
    return write_table(root / "log.csv", {"t": t, "u1": u, "y1": y})


def analyze(root: Path, text: str, log: Path, capsys) -> tuple[int, str]:
    model_file = root / "model.toml"
    model_file.write_text(text)
    args = ["analyze", str(log), "--model", str(model_file), "--estimator", "unknown-mode"]
    return run_main([*args, "--out", str(root / "out")], capsys)


def test_a_cluster_without_a_state_is_an_ekf_of_its_outputs_alone():
    model, found = decomposition(model_text("x1[k] = 0.8*x1[k-1] + u1[k-1]", "y1 = u1"))
    (cluster,) = found.clusters
    assert cluster.states == () and cluster.outputs == ("y1",)
    compiled = compile_cluster(
        cluster, states=model.states, inputs=model.inputs, outputs=model.outputs
    )
    empty = np.zeros(0)
    u, y = np.array([2.0]), np.array([2.3])
    result = compiled.step(empty, np.zeros((0, 0)), u, y, u, y)
    numeric = compiled.step_numeric(empty, np.zeros((0, 0)), u, y, u, y)
    # r = 0.3, S = R = 0.01: log P_O = -0.09/0.02
    assert result.log_po == pytest.approx(-4.5) and numeric.log_po == pytest.approx(-4.5)
    assert result.y_pred.tolist() == [2.0] and result.x.shape == (0,)


def test_a_stateless_cluster_runs_through_analyze(tmp_path, capsys):
    rng = np.random.default_rng(0)
    u = 1.0 + 0.5 * np.sin(np.arange(60) / 5.0)
    log = write_log(tmp_path, u, u + rng.normal(0.0, 0.05, 60))
    text = model_text("x1[k] = 0.8*x1[k-1] + u1[k-1]", "y1 = u1")
    code, out = analyze(tmp_path, text, log, capsys)
    assert code == 0, out
    estimates = (tmp_path / "out" / "estimates.csv").read_text().splitlines()
    assert estimates[0].startswith("t,x1_hat,x1_var,y1_hat")
    assert float(estimates[2].split(",")[3]) == pytest.approx(u[1])  # ŷ(1) = u1(1)


@pytest.mark.parametrize(
    ("equations", "variables", "target"),
    [
        (("w1**2 = x1 + 1", "y1 = w1"), ("w1",), "w1"),
        (("y1**2 = x1 + 1",), (), "y1"),
        (("sin(w1) = 0.1*x1", "y1 = w1"), ("w1",), "w1"),
    ],
)
def test_several_real_solutions_are_refused_naming_the_equation(equations, variables, target):
    text = model_text("x1[k] = 0.8*x1[k-1] + u1[k-1]", *equations, variables=variables)
    with pytest.raises(ModelError) as caught:
        decomposition(text)
    message = str(caught.value)
    assert message.startswith("components.plant.modes.a.equations[1]: has 2 solutions for ")
    assert f"write the equation solved for {target}" in message


def test_the_complex_roots_are_not_solutions_of_a_real_model():
    text = model_text("x1[k] = 0.8*x1[k-1] + u1[k-1]", "w1**3 = x1", "y1 = w1", variables=("w1",))
    _, found = decomposition(text)
    (cluster,) = found.clusters
    assert str(cluster.h[0]) == "x1**(1/3)"


def test_one_explicit_solution_is_the_one_used():
    text = model_text(
        "x1[k] = 0.8*x1[k-1] + u1[k-1]", "w1 = sqrt(x1 + 1)", "y1 = w1", variables=("w1",)
    )
    _, found = decomposition(text)
    assert str(found.clusters[0].h[0]) == "sqrt(x1 + 1)"


def test_a_complex_value_in_the_ekf_step_is_an_error_naming_the_cluster(tmp_path, capsys):
    u = -np.ones(20)
    log = write_log(tmp_path, u, np.zeros(20))
    text = model_text("x1[k] = 0.8*x1[k-1] + u1[k-1]", "y1 = x1**(1/3)")
    code, out = analyze(tmp_path, text, log, capsys)
    assert code == 2, out
    assert "Traceback" not in out and "unexpected" not in out
    assert "the EKF of the cluster of x1 (components plant) cannot step at sample 1" in out
    assert "a fractional power of a negative number" in out
    assert not (tmp_path / "out" / "report.md").exists()


SIMULATION = """
[simulation]
steps = 20

[simulation.modes]
plant = "a"

[simulation.inputs]
u1 = "1 + 0.5*sin(0.3*t)"
"""


def test_imm_and_simulate_solve_a_joint_mode_as_unknown_mode_does(tmp_path):
    """One answer for the three: imm took the first of several solutions without a word
    (``w1 = -sqrt(x1 + 1)``), simulate counted the complex cube roots of ``w1**3 = x1``
    ("3 solutions (one is needed)") and refused several real ones naming no equation."""
    from hybridlog.estimators.cpha.joint import joint_mode_model
    from hybridlog.jobs.simulate import simulate_log

    square = model_text(
        "x1[k] = 0.8*x1[k-1] + u1[k-1]", "w1**2 = x1 + 1", "y1 = w1", variables=("w1",)
    )
    with pytest.raises(ModelError) as unknown_mode:
        decomposition(square)
    with pytest.raises(ModelError) as imm:
        joint_mode_model(parse_model(square))
    (tmp_path / "square.toml").write_text(square + SIMULATION, encoding="utf-8")
    with pytest.raises(ModelError) as simulate:
        simulate_log(tmp_path / "square.toml", tmp_path / "square.csv")
    # unknown-mode solves cluster by cluster (w1, then y1 = w1), the others the joint mode
    # at once (w1 and y1 differ in its two solutions): the same equation and remedy
    said = str(imm.value).removeprefix("<model>: ")
    assert said.startswith("components.plant.modes.a.equations[1]: has 2 solutions for w1, y1 ")
    simulated = str(simulate.value).removeprefix(f"{tmp_path / 'square.toml'}: simulation: ")
    assert simulated.split(" (")[0] == said.split(" (")[0]  # simulate said "for y1, w1"
    for message in (said, simulated, str(unknown_mode.value)):
        assert message.startswith("components.plant.modes.a.equations[1]: has 2 solutions for ")
        # simulate named the joint mode {plant=a}, the estimators a (model.components)
        assert " at the mode assignment a (" in message
        assert "w1 = -sqrt(x1 + 1)" in message and "write the equation solved for " in message
    assert not (tmp_path / "square.csv").exists()

    cube = model_text("x1[k] = 0.8*x1[k-1] + u1[k-1]", "w1**3 = x1", "y1 = w1", variables=("w1",))
    (joint,) = joint_mode_model(parse_model(cube)).modes
    assert str(joint.h[0]) == "x1**(1/3)"
    (tmp_path / "cube.toml").write_text(cube + SIMULATION, encoding="utf-8")
    simulate_log(tmp_path / "cube.toml", tmp_path / "cube.csv")
    assert (tmp_path / "cube.csv").is_file()


def test_simulate_names_a_joint_mode_with_an_unmodelled_behaviour_as_the_estimators_do():
    """``{A1=m11, A2=simulation.unmodelled[0]}``: the estimators' form, the component
    ``unknown`` as the log's true mode says, and the behaviour named after it."""
    from types import SimpleNamespace

    from hybridlog.simulate_components import _describe

    scenario = SimpleNamespace(unmodelled=[SimpleNamespace(key="simulation.unmodelled[0]")])
    assert _describe({"A1": "m11", "A2": "m21"}, scenario) == "m11|m21"  # type: ignore[arg-type]
    assert (
        _describe({"A1": "m11", "A2": "~0:m21"}, scenario)  # type: ignore[arg-type]
        == "m11|unknown (simulation.unmodelled[0])"
    )


def test_a_solution_through_a_function_no_generated_code_evaluates_is_refused(tmp_path):
    """``w1 + exp(w1) = x1`` solves to ``x1 - LambertW(exp(x1))``: ``simulate`` and ``imm``
    ended in "unexpected PrintMethodNotImplementedError", ``unknown-mode`` in "NameError:
    name 'LambertW' is not defined"; each names the equation and the function now."""
    from hybridlog.estimators.cpha.joint import joint_mode_model
    from hybridlog.jobs.simulate import simulate_log

    text = model_text(
        "x1[k] = 0.8*x1[k-1] + u1[k-1]", "w1 + exp(w1) = x1", "y1 = w1", variables=("w1",)
    )
    (tmp_path / "m.toml").write_text(text + SIMULATION, encoding="utf-8")
    refusals = []
    for run in (
        lambda: decomposition(text),
        lambda: joint_mode_model(parse_model(text)),
        lambda: simulate_log(tmp_path / "m.toml", tmp_path / "m.csv"),
    ):
        with pytest.raises(ModelError) as caught:
            run()
        refusals.append(str(caught.value))
    for message in refusals:
        assert "components.plant.modes.a.equations[1]: solved for w1 at the mode assignment a" in (
            message
        )
        assert "which calls LambertW, a function hybridlog cannot evaluate" in message
    assert not (tmp_path / "m.csv").exists()
