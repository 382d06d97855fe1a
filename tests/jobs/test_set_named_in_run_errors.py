"""An error a run raises names the ``--set`` values that changed what failed.

``analyze --set fE=1000`` ended in "switching-observer diverged at t = 0.01 s ...", and a
user who had given several ``--set`` options could not tell which one broke the run: every
error of an estimator's run (``analyze``, ``compare``, ``batch``) and of a simulation now
ends ``(after --set fE=1000, ...)``, naming the values the command line gave of what the
run used, and only those (an option of another estimator is not named).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hybridlog.errors import HybridlogError, ModelError, OptionError
from hybridlog.jobs.analysis import analyze
from hybridlog.jobs.batch import run_batch
from hybridlog.jobs.compare import compare
from hybridlog.jobs.overrides import parse_sets
from hybridlog.jobs.simulate import simulate_log
from hybridlog.model.builtins import builtin_text
from tests.jobs.test_batch_resume import TANK, write_logs
from tests.support.cli import run_main

BROKEN = "A=1e-9"
"""A tank section that makes every filter leave the log at once."""


def test_an_analysis_names_each_set_its_run_used(tmp_path: Path) -> None:
    (log,) = write_logs(tmp_path / "logs", ["a.csv"])
    out = tmp_path / "out"
    with pytest.raises(HybridlogError) as raised:
        analyze(log, TANK, out_dir=out, estimator="hstf", sets=[BROKEN, "g = 981", "rho=0.9"])
    assert str(raised.value).endswith(" (after --set A=1e-9, --set g=981, --set rho=0.9)")
    assert not out.exists()


def test_the_filter_that_failed_before_an_offline_pass_does_not_blame_it(tmp_path: Path) -> None:
    # the IMM's forward pass, which no offline-pass option changes, ended "(after --smooth)"
    (log,) = write_logs(tmp_path / "logs", ["a.csv"])
    with pytest.raises(HybridlogError) as raised:
        analyze(
            log,
            TANK,
            out_dir=tmp_path / "out",
            estimator="imm",
            sets=[BROKEN, "smoother=ec", "beam=3"],
            smooth=True,
            mode_sequence="kbest",
        )
    assert str(raised.value).endswith(" (after --set A=1e-9)")


def test_compare_names_the_options_of_the_estimator_that_failed_only(tmp_path: Path) -> None:
    (log,) = write_logs(tmp_path / "logs", ["a.csv"])
    sets = [BROKEN, "likelihood=unfaded"]
    comparison = compare(log, TANK, ["imm", "hstf"], out_dir=tmp_path / "cmp", sets=sets)
    assert comparison.failures["imm"].endswith(" (after --set A=1e-9)")
    assert comparison.failures["hstf"].endswith(" (after --set A=1e-9, --set likelihood=unfaded)")


def test_a_batch_names_them_in_each_failed_log(tmp_path: Path) -> None:
    logs = write_logs(tmp_path / "logs", ["a.csv", "b.csv"])
    batch = run_batch(logs, TANK, out_dir=tmp_path / "batch", estimator="imm", sets=[BROKEN])
    errors = [outcome.error or "" for outcome in batch.logs]
    assert len(errors) == 2 and all(e.endswith(" (after --set A=1e-9)") for e in errors), errors


def test_a_simulation_names_them(tmp_path: Path) -> None:
    # the step check of the plant: "integration.step: 0.001 s is too long for mode '0'"
    out = tmp_path / "run.csv"
    with pytest.raises(ModelError) as raised:
        simulate_log("ice_clutch", out, steps=3, sets=["fE=1000"])
    assert "integration.step" in str(raised.value)
    assert str(raised.value).endswith(" (after --set fE=1000)")
    assert not out.exists()


def test_a_simulation_names_the_disturbance_that_drove_it_there(tmp_path: Path) -> None:
    # --disturbance 100,1 ended "integration.step: 0.001 s is too long for mode '0'" without
    # a word of it, and a user shortened the model's step, which suits the plant without it
    out = tmp_path / "run.csv"
    with pytest.raises(ModelError) as raised:
        simulate_log("ice_clutch", out, steps=30, disturbance="100, 1", sets=["fE=0.02"])
    assert "integration.step" in str(raised.value)
    assert str(raised.value).endswith(" (after --set fE=0.02, --disturbance 100, 1)")
    assert not out.exists()


def test_the_command_line_says_it_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "run.csv"
    args = ["simulate", "ice_clutch", "--out", str(out), "--steps", "3", "--set", "fE=1000"]
    code, output = run_main(args, capsys)
    assert code == 2 and output.count("\n") == 1, output
    assert output.startswith("hybridlog: error: ice_clutch: integration.step: ")
    assert output.endswith(" (after --set fE=1000)\n")
    assert list(tmp_path.iterdir()) == []


def test_a_model_file_in_a_folder_named_like_the_option_still_gets_the_set_named(
    tmp_path: Path,
) -> None:
    # the --set was said once the message held no "--set": one in the file's path hid it
    folder = tmp_path / "runs--set"
    folder.mkdir()
    model = folder / "tank.toml"
    model.write_text(builtin_text(TANK), encoding="utf-8")
    with pytest.raises(OptionError) as raised:
        parse_sets(["A=0"], model)
    assert str(raised.value).startswith(f"--set A=0: {model}: modes.1.f[0]")
