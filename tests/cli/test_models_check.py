"""``hybridlog models FILE`` checks a user's model file as ``analyze`` would.

Before, ``models`` printed built-ins only ("not a built-in model" for a path): a user
editing a model file could check it only by analysing or simulating a log.
"""

from pathlib import Path

import pytest

from hybridlog.errors import ModelError
from hybridlog.jobs.model_description import check_and_describe
from hybridlog.model.builtins import builtin_names, builtin_text
from tests.cli.test_cli import run
from tests.support.paths import TANK_CSV

SUITED = {
    "three_tank_hstf": "hstf, imm",
    "bioplex_pgc": "unknown-mode",
    "three_tank_valves": "sliding-mode",
    "ice_clutch": "switching-observer",
}


@pytest.mark.parametrize("name", builtin_names())
def test_every_printed_built_in_checks_as_a_file(tmp_path: Path, name: str) -> None:
    path = tmp_path / f"{name}.toml"
    path.write_text(builtin_text(name), encoding="utf-8")
    described = check_and_describe(path).splitlines()
    assert described[0] == f"{path}: a valid model file"
    assert described[1].startswith(f"name: {name}")
    if name in SUITED:
        assert described[-2] == f"estimators for it: {SUITED[name]}"
        assert described[-1].startswith("default_estimator: ")


def test_a_bad_estimator_table_is_found_whichever_estimator_would_run(tmp_path: Path) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(
        builtin_text("three_tank_hstf") + "\n[estimators.imm]\ntransition_stay = 7\n",
        encoding="utf-8",
    )
    with pytest.raises(ModelError, match=r"estimators\.imm\.transition_stay.*outside \[0, 1\]"):
        check_and_describe(path)


def test_the_command_describes_a_file_prints_a_built_in_and_refuses_in_one_line(
    tmp_path: Path,
) -> None:
    path = tmp_path / "mine.toml"
    path.write_text(builtin_text("double_cart_case1").replace("dt = ", "dt = -"), "utf-8")
    result = run(["models", str(path)], expect=2)
    (line,) = result.stderr.strip().splitlines()
    assert line.startswith(f"hybridlog: error: {path}: ") and "dt" in line
    assert result.stdout == ""
    assert run(["models", "double_cart_case1"]).stdout == builtin_text("double_cart_case1")


def test_a_default_estimator_that_cannot_run_the_model_is_refused_as_analyze_does(
    tmp_path: Path,
) -> None:
    # models called the file valid, and analyze without --estimator then refused it
    text = builtin_text("three_tank_hstf")
    written = next(line for line in text.splitlines() if line.startswith("default_estimator"))
    path = tmp_path / "mine.toml"
    path.write_text(text.replace(written, 'default_estimator = "sliding-mode"', 1), "utf-8")
    refused = run(["models", str(path)], expect=2).stderr.strip()
    assert refused.startswith(f"hybridlog: error: {path}: default_estimator 'sliding-mode' ")
    assert "needs a continuous-time model" in refused and "\n" not in refused
    analyzed = run(
        ["analyze", str(TANK_CSV), "--model", str(path), "--out", str(tmp_path / "r")], 2
    )
    assert analyzed.stderr.strip() == refused
    assert not (tmp_path / "r").exists()


def test_a_file_writing_no_default_estimator_is_valid_and_says_analyze_needs_one(
    tmp_path: Path,
) -> None:
    # a continuous model without default_estimator (as docs/model_files.md's example): imm,
    # the default, cannot run it; models refused a file every key of which is right, and
    # that analyze --estimator switching-observer and simulate take
    text = builtin_text("ice_clutch")
    written = next(line for line in text.splitlines() if line.startswith("default_estimator"))
    path = tmp_path / "mine.toml"
    path.write_text(text.replace(written, "", 1), encoding="utf-8")
    described = run(["models", str(path)]).stdout.splitlines()
    assert described[-2] == "estimators for it: switching-observer"
    assert described[-1] == (
        "default_estimator: not written, and the default 'imm' needs a discrete-time model; "
        "the model's time is continuous: analyze needs --estimator"
    )
    analyzed = run(
        ["analyze", str(TANK_CSV), "--model", str(path), "--out", str(tmp_path / "r")], 2
    )
    (line,) = analyzed.stderr.strip().splitlines()
    assert line.startswith(f"hybridlog: error: {path}: no default_estimator is written, and ")
    assert line.endswith("give --estimator (estimators for this model: switching-observer)")
    assert not (tmp_path / "r").exists()


def test_a_missing_file_an_estimator_table_names_is_found_as_analyze_finds_it(
    tmp_path: Path,
) -> None:
    # models read the [estimators.chiu] table's values but not the file it names: "a valid
    # model file", which analyze (chiu is double_cart_case1's default) then refused
    path = tmp_path / "mine.toml"
    text = builtin_text("double_cart_case1") + '\n[estimators.chiu]\ncenters = "gone.json"\n'
    path.write_text(text, encoding="utf-8")
    refused = run(["models", str(path)], expect=2).stderr.strip()
    assert refused == (
        f"hybridlog: error: {path}: estimators.chiu.centers: {tmp_path / 'gone.json'}: "
        "no such centers file"
    )
    log = tmp_path / "cart.csv"
    run(["simulate", "double_cart_case1", "--out", str(log), "--steps", "20"])
    analyzed = run(["analyze", str(log), "--model", str(path), "--out", str(tmp_path / "r")], 2)
    assert analyzed.stderr.strip() == refused


def test_each_estimator_table_is_described_as_analyze_applies_it(tmp_path: Path) -> None:
    # models checked the tables and said nothing of them: not the values read, nor that a
    # key waits for a command-line flag, nor a table of an estimator that cannot run it
    path = tmp_path / "mine.toml"
    path.write_text(
        builtin_text("three_tank_hstf")
        + '\n[estimators.imm]\nsmoother = "ec"\ntransition_stay = 1\n'
        + "[estimators.chiu]\nradius = 0.4\n",
        encoding="utf-8",
    )
    described = check_and_describe(path).splitlines()
    assert "[estimators.hstf]: rho = 0.95, beta = 1, theta = 0.95" in described
    (imm,) = [line for line in described if line.startswith("[estimators.imm]")]
    assert imm.startswith("[estimators.imm]: smoother = ec (no effect as written: only smooth")
    assert imm.endswith(", transition_stay = 1")
    assert "[estimators.chiu] (chiu cannot run this model): radius = 0.4" in described


def test_the_time_base_is_described_with_the_digits_the_file_gives(tmp_path: Path) -> None:
    # `:g` described dt = 0.0123456789 as 0.0123457: not the sample time analyze used
    path = tmp_path / "mine.toml"
    text = builtin_text("ice_clutch").replace("dt = 0.01", "dt = 0.0123456789", 1)
    path.write_text(text.replace("step = 0.001", "step = 0.0123456789", 1), encoding="utf-8")
    assert check_and_describe(path).splitlines()[2] == (
        "continuous time, dt 0.0123456789 s, integration rk4 with step 0.0123456789 s"
    )


def test_a_model_no_estimator_runs_says_what_each_needs(tmp_path: Path) -> None:
    # "estimators for it: none" left a user with a continuous-time model of two outputs to
    # try each estimator in turn to learn why
    path = tmp_path / "two_outputs.toml"
    path.write_text(
        'name = "two_outputs"\ntime = "continuous"\ndt = 0.1\n'
        'integration = {method = "rk4", step = 0.05}\nstates = ["x1", "x2"]\n'
        'outputs = ["y1", "y2"]\n'
        "[modes.a]\nA = [[-1.0, 0.0], [0.0, -2.0]]\nC = [[1.0, 0.0], [0.0, 1.0]]\n"
        "[modes.b]\nA = [[-2.0, 0.0], [0.0, -1.0]]\nC = [[1.0, 0.0], [0.0, 1.0]]\n"
        "[noise]\nprocess = 0.01\nmeasurement = 0.01\n"
        "[initial]\nstate = [0.0, 0.0]\ncovariance = 1.0\n",
        encoding="utf-8",
    )
    (line,) = [li for li in check_and_describe(path).splitlines() if "estimators for it" in li]
    assert line.startswith("estimators for it: none: 'hstf', 'imm', ")
    assert "(needs a discrete-time model)" in line
    assert "'switching-observer' (needs a single-output model)" in line
    assert "'sliding-mode' (needs a boolean-affine model" in line


@pytest.mark.parametrize("h_down", ["2*x", "x"])
def test_a_state_driven_model_says_how_the_filters_read_its_modes(
    tmp_path: Path, h_down: str
) -> None:
    # imm on the mode pairs runs n² filters and hstf warns in every report: models said
    # nothing of either before a log was analysed
    from tests.estimators.test_mode_step import SENSOR_BY_MODE

    path = tmp_path / "sensor.toml"
    path.write_text(SENSOR_BY_MODE % h_down, encoding="utf-8")
    (line,) = [li for li in check_and_describe(path).splitlines() if li.startswith("switching")]
    if h_down == "x":
        assert line == (
            "switching: by guards; the mode of sample k governs the step from x(k), so hstf and "
            "imm show at sample k the mode found for that step, at k+1"
        )
    else:
        assert "whose equations differ by mode: hstf moves its modes a sample earlier" in line
        assert "imm runs on the 4 mode pairs" in line
    scheduled = tmp_path / "scheduled.toml"
    scheduled.write_text(builtin_text("three_tank_hstf"), encoding="utf-8")
    assert "switching" not in check_and_describe(scheduled)


def test_a_joint_mode_imm_would_refuse_is_found(tmp_path: Path) -> None:
    # 'estimators for it: imm, unknown-mode' and 'a valid model file', while analyze (imm,
    # the default) refused it: a variable no equation of the joint mode m11|m21|m31 gives
    from tests.estimators.test_cpha_structure import UNGIVEN, UNGIVEN_ERROR

    path = tmp_path / "ungiven.toml"
    path.write_text(UNGIVEN, encoding="utf-8")
    with pytest.raises(ModelError, match=UNGIVEN_ERROR):
        check_and_describe(path)
