"""Hostile ``hybridlog simulate`` input: one line, exit 2, nothing written or replaced.

Found in the pass: a model with a sample time that is no whole number of nanoseconds
(``dt = 1.5e-9``) was written to bags and MCAP files, whose times are integer nanoseconds,
as steps of 2, 1, 2, 1 ns without a word; it is refused for those formats now (CSV and
Parquet keep the float seconds).
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest

from hybridlog.model.builtins import builtin_text
from tests.support.cli import run_main as _run


def _tank(tmp_path: Path, dt: str) -> Path:
    text = builtin_text("three_tank_hstf")
    assert text.count("\ndt = 1.0\n") == 1
    path = tmp_path / "tank.toml"
    path.write_text(text.replace("\ndt = 1.0\n", f"\ndt = {dt}\n"), encoding="utf-8")
    return path


@pytest.mark.parametrize("out", ["run.mcap", "run.bag", "bag"])
def test_times_off_whole_nanoseconds_are_refused_for_message_logs(
    out: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    model = _tank(tmp_path, "1.5e-9")
    extra = ["--format", "ros2-sqlite3"] if out == "bag" else []
    log = tmp_path / out
    code, output = _run(
        ["simulate", str(model), "--out", str(log), "--steps", "10", *extra], capsys
    )
    assert code == 2, output
    assert output.count("\n") == 1
    assert "ns off the whole nanoseconds" in output and "dt of whole nanoseconds" in output
    assert not log.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tank.toml"]


def test_a_time_off_whole_nanoseconds_is_shown_with_its_fraction(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``dt = 2.5e-9``: "t = 0.000000018 s is 0.5 ns off the whole nanoseconds", a time
    rounded to the nanosecond it was said to be off."""
    model = _tank(tmp_path, "2.5e-9")
    args = ["simulate", str(model), "--out", str(tmp_path / "run.mcap"), "--steps", "10"]
    code, output = _run(args, capsys)
    assert code == 2, output
    assert ": t = 0.0000000175 s is 0.5 ns off the whole nanoseconds" in output, output


@pytest.mark.parametrize(("dt", "out"), [("1.5e-9", "run.csv"), ("2e-9", "run.mcap")])
def test_times_a_log_holds_are_written(
    dt: str, out: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    model = _tank(tmp_path, dt)
    code, output = _run(
        ["simulate", str(model), "--out", str(tmp_path / out), "--steps", "10"], capsys
    )
    assert code == 0, output


BAD = {
    "steps 0": ["--steps", "0"],
    "negative steps": ["--steps", "-3"],
    "steps beyond the log's times": ["--steps", "99999999999999"],
    "empty schedule": ["--schedule", ""],
    "empty schedule item": ["--schedule", "1:5,,2:5"],
    "zero count": ["--schedule", "1:0"],
    "unknown mode": ["--schedule", "9:5"],
    "underscored count": ["--schedule", "1:1_0"],
    "negative seed": ["--seed", "-1"],
    "underscored seed": ["--seed", "1_0"],
    "unknown format": ["--format", "xlsx"],
    "format against suffix": ["--format", "mcap"],
    "encoding of a table": ["--encoding", "json"],
    "disturbance of discrete time": ["--disturbance", "1,2"],
    "setting of a plain model": ["--set", "a=1"],
}


@pytest.mark.parametrize("name", list(BAD))
def test_bad_options_are_one_line_and_write_nothing(
    name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = tmp_path / "run.csv"
    code, output = _run(["simulate", "three_tank_hstf", "--out", str(log), *BAD[name]], capsys)
    assert code == 2, output
    assert output.count("\n") == 1 and "unexpected" not in output
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("out", "extra"),
    [("run.csv", []), ("run.mcap", []), ("bag", ["--format", "ros2-mcap"])],
)
def test_existing_outputs_are_replaced_only_with_force_and_only_ours(
    out: str, extra: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = tmp_path / out
    args = ["simulate", "three_tank_hstf", "--out", str(log), "--steps", "5", *extra]
    assert _run(args, capsys)[0] == 0
    before = {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    code, output = _run([*args, "--seed", "7"], capsys)
    assert code == 2 and output.count("\n") == 1
    assert {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()} == before
    assert _run([*args, "--seed", "7", "--force"], capsys)[0] == 0
    # a file of the user's in its place is never replaced, with --force or not
    mine = tmp_path / f"mine_{out}"
    if extra:
        mine.mkdir()
        (mine / "notes.txt").write_text("mine")
    else:
        mine.write_text("mine")
    code, output = _run([*args[:3], str(mine), *args[4:], "--force"], capsys)
    assert code == 2 and output.count("\n") == 1
    assert (mine / "notes.txt" if extra else mine).read_text() == "mine"


@pytest.mark.parametrize("out", [".", "./"])
def test_a_bag_into_the_working_directory_is_written_in_place(
    out: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--out .`` in an empty folder failed with "…hybridlog-tmp-… exists already" (the
    bag's storage file was named after ``.``), then was refused: the bag was renamed over
    the working folder, which would have left the shell in a deleted one.  The folder is
    filled in place now, again with ``--force``: the shell stays in it."""
    here = tmp_path / "bag"
    here.mkdir()
    monkeypatch.chdir(here)
    args = ["simulate", "three_tank_hstf", "--out", out, "--steps", "3"]
    for storage in ("sqlite3", "mcap"):
        code, output = _run([*args, "--format", f"ros2-{storage}", "--force"], capsys)
        assert code == 0, output
        suffix = ".db3" if storage == "sqlite3" else ".mcap"
        assert sorted(p.name for p in here.iterdir()) == [f"bag{suffix}", "metadata.yaml"]
        assert os.path.samefile(os.getcwd(), here)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bag"]


def test_a_bag_folder_holding_the_working_directory_is_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    here = tmp_path / "bag" / "inner"
    here.mkdir(parents=True)
    monkeypatch.chdir(here)
    args = ["simulate", "three_tank_hstf", "--out", "..", "--format", "ros2-sqlite3"]
    code, output = _run([*args, "--steps", "3", "--force"], capsys)
    assert code == 2 and output.count("\n") == 1, output
    assert "holds files hybridlog did not write" in output
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["bag", "inner"]


def test_a_controller_without_a_number_names_itself_and_the_settings(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--set ki=0`` (bioplex_pgc's anti-windup divides by it) said "numerical trouble in
    simulate_components.py:271: divide by zero ..."; the controller and the value are named."""
    log = tmp_path / "run.csv"
    args = ["simulate", "bioplex_pgc", "--out", str(log), "--steps", "3", "--set", "ki=0"]
    code, output = _run(args, capsys)
    assert code == 2 and output.count("\n") == 1, output
    assert output.startswith("hybridlog: error: bioplex_pgc: simulation.controller: divide by zero")
    assert "at t = 0 s (with --set ki=0)" in output
    assert list(tmp_path.iterdir()) == []


def test_steps_that_cut_the_schedule_before_a_mode_say_so(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--schedule 1:10,2:10,3:10 --steps 5`` wrote a log of mode 1 alone without a word."""
    log = tmp_path / "run.csv"
    args = ["simulate", "three_tank_hstf", "--out", str(log), "--schedule", "1:10,2:10,3:10"]
    code, output = _run([*args, "--steps", "5"], capsys)
    assert code == 0 and log.read_text().count("\n") == 7
    assert (
        "note: --steps 5 ends the run within the schedule's 30 steps (--schedule): "
        "modes '2', '3' never run"
    ) in output
    # the model's own schedule is named as such; a run through every mode says nothing
    code, output = _run([*args[:4], "--steps", "150", "--force"], capsys)
    assert code == 0 and "(three_tank_hstf: simulation.schedule): mode '3' never run" in output
    code, output = _run([*args, "--steps", "21", "--force"], capsys)
    assert code == 0 and "never run" not in output


def test_steps_that_end_a_scenario_before_its_events_say_so(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``bioplex_pgc --steps 500`` wrote a run without its drift (step 700) or its light
    fault (900), without a word."""
    log = tmp_path / "run.csv"
    args = ["simulate", "bioplex_pgc", "--out", str(log), "--steps", "500"]
    code, output = _run(args, capsys)
    assert code == 0 and log.exists()
    assert (
        "note: --steps 500 ends the run before these events of bioplex_pgc's scenario, which "
        "never run: simulation.unmodelled[0] (fr2) from drift_start = 700; "
        "simulation.modes.ls: one_bank_out at light_fault = 900\n"
    ) in output
    # a fault moved into the run is no longer noted; a repair to a mode the run had is no news
    code, output = _run([*args, "--force", "--set", "light_fault=500"], capsys)
    assert code == 0 and "light_fault" not in output and "drift_start = 700" in output
    code, output = _run([*args[:5], "1000", "--force"], capsys)
    assert code == 0 and "note" not in output
    # the scenario's own steps end the run too: a fault moved past them was a run without it
    moved = ["--set", "light_fault=1600", "--set", "light_repair=1700"]
    code, output = _run([*args[:4], "--force", *moved], capsys)
    assert (
        code == 0
        and (
            "note: simulation.steps = 1,500 ends the run before these events of bioplex_pgc's "
            "scenario, which never run: simulation.modes.ls: one_bank_out at light_fault = 1600\n"
        )
        in output
    )


def test_a_controller_overflow_is_said_in_words_not_as_an_errno_tuple() -> None:
    """``x ** y`` overflowing in a controller is ``OverflowError(34, '...')``, whose text was the
    tuple "(34, 'Numerical result out of range')" in the error line."""
    from hybridlog.simulate_components import _controller_failed

    message = _controller_failed(
        "m.toml", OverflowError(34, "Numerical result out of range"), 2.0, {"ki": 1e300}
    )
    assert message.startswith("m.toml: simulation.controller: Numerical result out of range at t")
    assert "(34" not in message and "(with --set ki=1e+300)" in message


@pytest.mark.parametrize(
    ("settings", "said"),
    [
        (["A=inf"], "--set A=inf: expected a finite number"),
        (["nosuch=1"], "--set nosuch: neither a parameter of model"),
        (["A=150"], None),  # all else sound: the output's refusal
    ],
)
def test_what_the_simulation_reads_is_checked_before_its_output(
    settings: list[str], said: str | None, tmp_path: Path
) -> None:
    """``simulate --out existing.csv --set A=inf`` said "already exists (use --force ...)",
    and the bad ``--set`` only once ``--force`` was given: as ``analyze``, ``compare`` and
    ``batch`` do, what is read is checked first, the output last (the file is kept)."""
    from hybridlog.errors import HybridlogError, OptionError, OutputError
    from hybridlog.jobs.simulate import simulate_log

    out = tmp_path / "existing.csv"
    out.write_text("the user's\n", encoding="utf-8")
    with pytest.raises(HybridlogError) as refused:
        simulate_log("three_tank_hstf", out, sets=settings, steps=10)
    if said is None:
        assert isinstance(refused.value, OutputError), refused.value
    else:
        assert isinstance(refused.value, OptionError) and str(refused.value).startswith(said)
    assert out.read_text(encoding="utf-8") == "the user's\n"


@pytest.mark.parametrize(
    ("options", "said"),
    [
        ({"schedule": "1:10"}, "--schedule: bioplex_pgc is a components model; its components'"),
        (
            {"disturbance": "1,2"},
            "--disturbance: bioplex_pgc is a components model; what its modes do not describe",
        ),
        # "its noise ... set in its [simulation] table": no key there sets noise
        ({"noise": False}, "--no-noise: bioplex_pgc is a components model, simulated with the "),
    ],
)
def test_options_a_components_model_does_not_read_are_refused_before_its_output(
    options: dict[str, object], said: str, tmp_path: Path
) -> None:
    from hybridlog.errors import OptionError
    from hybridlog.jobs.simulate import simulate_log

    out = tmp_path / "existing.csv"
    out.write_text("the user's\n", encoding="utf-8")
    with pytest.raises(OptionError, match="^" + re.escape(said)):
        simulate_log("bioplex_pgc", out, steps=10, **options)
    assert out.read_text(encoding="utf-8") == "the user's\n"


@pytest.mark.parametrize(
    ("model", "options", "said"),
    [
        ("three_tank_hstf", {"schedule": "garbage"}, "--schedule: 'garbage' is not MODE:STEPS"),
        ("three_tank_hstf", {"schedule": "9:10"}, "--schedule: unknown mode '9'"),
        ("bioplex_pgc", {"sets": ["nosuch=1"]}, "--set nosuch: neither a scenario parameter"),
        ("bioplex_pgc", {"sets": ["drift_start=-5"]}, "--set drift_start: bioplex_pgc: "),
    ],
)
def test_a_bad_schedule_or_scenario_setting_is_refused_before_the_output(
    model: str, options: dict[str, object], said: str, tmp_path: Path
) -> None:
    """``--schedule garbage`` and a components model's unknown or unplayable scenario
    ``--set`` were checked as the simulation ran, after the output: "already exists" first."""
    from hybridlog.errors import OptionError
    from hybridlog.jobs.simulate import simulate_log

    out = tmp_path / "existing.csv"
    out.write_text("the user's\n", encoding="utf-8")
    with pytest.raises(OptionError, match="^" + re.escape(said)):
        simulate_log(model, out, steps=10, **options)  # type: ignore[arg-type]
    assert out.read_text(encoding="utf-8") == "the user's\n"
