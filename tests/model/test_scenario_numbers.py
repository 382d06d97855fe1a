"""Numbers written as text in a model file are read strictly, or refused naming file and key.

A components model's ``[simulation]`` scenario writes command values and steps as text
(``light_cmd = "1, 0@900"``): they were read with ``float()``/``int()``, so ``"1_0"`` was a
command of 10, ``"inf"``/``"nan"``/``"٣"`` were taken as numbers, ``"1, 0@١٠"`` switched at
step 10 and ``"1, 0@²"`` ended in a traceback.  They go through :mod:`hybridlog.numbers` now,
as a ``[simulation] schedule`` does.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hybridlog.errors import ModelError
from hybridlog.model.builtins import builtin_text
from hybridlog.model.loader import load_model
from hybridlog.model.values import as_mode_id
from tests.support.cli import run_main as _run


def _variant(tmp_path: Path, name: str, old: str, new: str) -> Path:
    text = builtin_text(name)
    assert text.count(old) == 1
    path = tmp_path / f"{name}_variant.toml"
    path.write_text(text.replace(old, new), encoding="utf-8")
    return path


@pytest.mark.parametrize("value", ["1_0", "inf", "nan", "-Infinity", "1e999", "٣", "0x1", "1,5"])
def test_command_values_are_read_strictly(value: str, tmp_path: Path) -> None:
    path = _variant(tmp_path, "bioplex_pgc", 'light_cmd = "1"', f'light_cmd = "{value}"')
    with pytest.raises(ModelError) as caught:
        load_model(path)
    message = str(caught.value)
    assert message.startswith(f"{path}: simulation.commands.light_cmd: ")
    assert "\n" not in message


@pytest.mark.parametrize("at", ["1_0", "١٠", "²", "-3", "1.5", ""])
def test_steps_are_read_strictly(at: str, tmp_path: Path) -> None:
    path = _variant(tmp_path, "bioplex_pgc", 'light_cmd = "1"', f'light_cmd = "1, 0@{at}"')
    with pytest.raises(ModelError, match=r"simulation\.commands\.light_cmd: ") as caught:
        load_model(path)
    assert str(caught.value).startswith(f"{path}: ")
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize(("at", "step"), [("900", 900), ("+900", 900), (" 0900 ", 900)])
def test_plain_whole_steps_still_read(at: str, step: int, tmp_path: Path) -> None:
    path = _variant(tmp_path, "bioplex_pgc", 'light_cmd = "1"', f'light_cmd = "1, 0.5@{at}"')
    scenario = load_model(path).scenario
    assert scenario is not None
    assert scenario.commands["light_cmd"] == ((1.0, 0), (0.5, step))


def test_cli_refuses_a_bad_scenario_number_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _variant(tmp_path, "bioplex_pgc", 'light_cmd = "1"', 'light_cmd = "1, 0@²"')
    out = tmp_path / "run.csv"
    code, output = _run(["simulate", str(path), "--out", str(out), "--steps", "3"], capsys)
    assert code == 2, output
    assert output.count("\n") == 1 and "unexpected" not in output
    assert f"{path}: simulation.commands.light_cmd: " in output
    assert not out.exists()


@pytest.mark.parametrize("schedule", ["1:1_0", "1:١٠", "1:1e2", "1:inf"])
def test_schedule_of_a_model_file_is_read_strictly(
    schedule: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _variant(
        tmp_path,
        "three_tank_hstf",
        'schedule = "1:100,2:100,3:100"',
        f'schedule = "{schedule}"',
    )
    out = tmp_path / "run.csv"
    code, output = _run(["simulate", str(path), "--out", str(out)], capsys)
    assert code == 2, output
    assert output.count("\n") == 1
    assert f"{path}: simulation.schedule: " in output
    assert not out.exists()


def test_mode_ids_of_other_digits_are_labels() -> None:
    """No log reads ``١.٥`` as the number 1.5: such a mode id is a plain label."""
    assert as_mode_id("١.٥", "modes") == "١.٥"
    with pytest.raises(ModelError, match="reads it as '1'"):
        as_mode_id("1.0", "modes")


def test_a_controller_state_without_an_update_is_refused(tmp_path: Path) -> None:
    """``states = {m = 0.0}`` with no ``update.m`` kept 0 at every step without a word (found
    by hostile59): a memory that never changes is a parameter, or a forgotten update."""
    update = 'update = {integral = "min(max(integral + setpoint - yc3, -u_max/ki), u_max/ki)"}'
    path = _variant(tmp_path, "bioplex_pgc", update, "")
    with pytest.raises(ModelError) as caught:
        load_model(path)
    assert str(caught.value) == (
        f"{path}: simulation.controller.states.integral: the controller state has no update "
        "(simulation.controller.update.integral): it would keep 0 at every step; write its "
        "update, or make it a parameter"
    )
