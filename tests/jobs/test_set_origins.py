"""What ``--set`` gave, said where it matters: the report, and an error its value caused.

report.json named the model and the estimator's options but not the parameter values: a run
with ``--set A=150`` and one with ``--set A=154`` wrote reports that said the same model ran,
and nothing told an option ``--set`` gave from the model file's.  A parameter value that made
the model invalid (``--set A=0``: a division by zero) was refused naming the model file alone,
as if the file were wrong.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from hybridlog.errors import OptionError
from hybridlog.jobs.analysis import analyze
from hybridlog.jobs.batch import run_batch
from hybridlog.jobs.compare import compare
from hybridlog.jobs.origins import run_values
from hybridlog.jobs.overrides import parse_sets, prepare_estimators
from tests.jobs.test_batch_resume import TANK, write_logs
from tests.support.cli import run_main


def _report(folder: Path) -> dict[str, object]:
    loaded: dict[str, object] = json.loads((folder / "report.json").read_text())
    return loaded


def test_analyze_records_each_parameter_and_option_and_where_it_came_from(
    tmp_path: Path,
) -> None:
    (log,) = write_logs(tmp_path / "logs", ["a.csv"])
    out = tmp_path / "out"
    analyze(log, TANK, out_dir=out, estimator="hstf", sets=["A = 150", "rho=0.9"])
    report = _report(out)
    parameters = report["parameters"]
    assert isinstance(parameters, dict)
    assert parameters["A"] == 150.0 and parameters["g"] == 981.0
    assert report["origins"] == {
        "parameters.A": "--set A=150",
        **{f"parameters.{p}": f"{TANK}: parameters.{p}" for p in parameters if p != "A"},
        "options.rho": "--set rho=0.9",
        "options.beta": f"{TANK}: estimators.hstf.beta",
        "options.theta": f"{TANK}: estimators.hstf.theta",
        "options.fading": "default",
        "options.likelihood": "default",
    }
    md = (out / "report.md").read_text()
    assert "\n- given: `--set A=150`, `--set rho=0.9`\n" in md
    analyze(log, TANK, out_dir=out, estimator="hstf", force=True)
    assert "- given:" not in (out / "report.md").read_text()
    assert _report(out)["origins"]["parameters.A"] == f"{TANK}: parameters.A"  # type: ignore[index]


def test_compare_and_batch_reports_record_them_too(tmp_path: Path) -> None:
    logs = write_logs(tmp_path / "logs", ["a.csv"])
    compare(logs[0], TANK, ["imm", "hstf"], out_dir=tmp_path / "cmp", sets=["A=150", "theta=0.9"])
    imm, hstf = _report(tmp_path / "cmp" / "imm"), _report(tmp_path / "cmp" / "hstf")
    assert imm["parameters"] == hstf["parameters"]
    assert imm["origins"]["parameters.A"] == "--set A=150"  # type: ignore[index]
    assert hstf["origins"]["options.theta"] == "--set theta=0.9"  # type: ignore[index]
    assert "options.theta" not in imm["origins"]  # type: ignore[operator]
    run_batch(logs, TANK, out_dir=tmp_path / "batch", estimator="hstf", sets=["A=150"])
    report = _report(tmp_path / "batch" / "a.csv")
    assert report["origins"]["parameters.A"] == "--set A=150"  # type: ignore[index]
    assert report["parameters"]["A"] == 150.0  # type: ignore[index]


def test_an_option_a_flag_gave_is_said_as_the_flag() -> None:
    model, overrides = parse_sets(["beam=3"], TANK)
    (prepared,) = prepare_estimators(model, ["imm"], overrides, smooth=True, mode_sequence="kbest")
    origins = run_values(model, prepared, overrides.parameter_texts)["origins"]
    assert origins["options.smooth"] == "--smooth"  # was "--set smooth=true"
    assert origins["options.mode_sequence"] == "--mode-sequence kbest"
    assert origins["options.beam"] == "--set beam=3"


@pytest.mark.parametrize(
    ("sets", "start"),
    [
        (["A=0"], "--set A=0: three_tank_hstf: modes.1.f[0]:"),
        (["A=-0", "g=3"], "--set A=-0, g=3: three_tank_hstf: modes.1.f[0]:"),
    ],
)
def test_a_parameter_value_that_breaks_the_model_is_refused_naming_the_set(
    sets: list[str], start: str
) -> None:
    with pytest.raises(OptionError) as raised:
        parse_sets(sets, TANK)
    assert str(raised.value).startswith(start)
    assert "not finite" in str(raised.value)


def test_simulate_moves_a_model_parameter_and_names_a_value_that_breaks_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # simulate refused --set A=140: "three_tank_hstf has no scenario parameters"
    runs = {}
    for name, sets in (("base", []), ("narrow", ["--set", "A=140"]), ("again", [])):
        out = tmp_path / f"{name}.csv"
        args = ["simulate", TANK, "--out", str(out), "--steps", "30", *sets]
        code, output = run_main(args, capsys)
        assert code == 0, output
        runs[name] = out.read_bytes()
    assert runs["narrow"] != runs["base"] == runs["again"]  # the model cache keyed on A
    code, output = run_main(
        ["simulate", TANK, "--out", str(tmp_path / "z.csv"), "--set", "A=0"], capsys
    )
    assert code == 2 and output.startswith("hybridlog: error: --set A=0: three_tank_hstf: modes.1")
    assert not (tmp_path / "z.csv").exists()


def test_a_scenario_parameter_given_to_an_analysis_is_said_to_be_one() -> None:
    # it was "neither a parameter ... nor an estimator option; did you mean 'light_full'?"
    model, overrides = parse_sets(["light_fault=950"], "bioplex_pgc")
    with pytest.raises(OptionError) as raised:
        prepare_estimators(model, [None], overrides)
    assert str(raised.value) == (
        "--set light_fault=950: a scenario parameter of model bioplex_pgc "
        "([simulation.parameters]), which only simulate plays; an estimator reads the log, "
        "not the scenario"
    )
