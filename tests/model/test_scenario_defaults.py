"""What a components scenario leaves out is refused by ``simulate``, never guessed.

A command ``[simulation.commands]`` did not give was logged as 0 at every step (a value the
file never gave, which ``unknown-mode`` then reads as the command: ``when = {cmd = 0}``), and
a component ``[simulation.modes]`` did not name played the first of its modes that tied for
most likely in ``initial`` (its first mode under the default, uniform ``initial``; a known
mode where ``initial`` says the component starts ``unknown``), which the log then called the
true mode.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hybridlog.errors import ModelError
from hybridlog.model.builtins import builtin_text
from hybridlog.model.loader import load_model
from hybridlog.simulate_components import simulate_components


def _variant(tmp_path: Path, old: str, new: str) -> Path:
    text = builtin_text("bioplex_pgc")
    assert text.count(old) == 1
    path = tmp_path / "bioplex_variant.toml"
    path.write_text(text.replace(old, new), encoding="utf-8")
    return path


def test_a_command_the_scenario_does_not_give_is_refused(tmp_path: Path) -> None:
    path = _variant(tmp_path, 'light_cmd = "1"\n', "")
    with pytest.raises(ModelError) as caught:
        simulate_components(load_model(path), steps=3)
    message = str(caught.value)
    assert message.startswith(f"{path}: simulation.commands.light_cmd: no value of the command")
    assert 'write light_cmd = "VALUE"' in message and "\n" not in message


@pytest.mark.parametrize(
    ("initial", "shown"),
    [
        ('initial = "full"', None),  # one most likely known mode: played, as before
        ("initial = {off = 0.5, full = 0.5}", "off 0.5, full 0.5, half 0"),
        ("initial = {unknown = 1.0}", "unknown 1, off 0"),
    ],
)
def test_a_component_without_a_schedule_needs_one_most_likely_mode(
    initial: str, shown: str | None, tmp_path: Path
) -> None:
    text = builtin_text("bioplex_pgc")
    old_initial = 'unknown = 1e-4\ninitial = "full"'
    old_schedule = 'ls = "full, one_bank_out@light_fault, full@light_repair"\n'
    assert text.count(old_initial) == 1 and text.count(old_schedule) == 1
    path = tmp_path / "ls.toml"
    path.write_text(
        text.replace(old_initial, f"unknown = 1e-4\n{initial}").replace(old_schedule, ""),
        encoding="utf-8",
    )
    model = load_model(path)
    if shown is None:
        assert set(simulate_components(model, steps=3).modes["ls"]) == {"full"}
        return
    with pytest.raises(ModelError) as caught:
        simulate_components(model, steps=3)
    message = str(caught.value)
    assert message.startswith(f"{path}: simulation.modes.ls: no mode to simulate component 'ls'")
    assert f"(components.ls.initial: {shown}" in message
    assert 'write ls = "MODE"' in message and "\n" not in message
