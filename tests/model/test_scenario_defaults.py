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


SAME_STEP = """
dt = 1.0
states = ["x1"]
inputs = ["u1"]
outputs = ["y1"]

[noise]
process = [1e-4]
measurement = [1e-2]

[initial]
state = [0.0]

[components.c]
unknown = 0.001
initial = "see"

[components.c.modes.see]
equations = ["x1[k] = 0.9*x1[k-1] + u1[k-1]", "y1 = x1"]

[components.c.modes.blind]
equations = ["x1[k] = 0.9*x1[k-1] + u1[k-1]", "y1 = u1"]

[simulation]
steps = 20

[simulation.modes]
c = "see, blind@5"

[simulation.controller]
inputs = {{u1 = "{control}"}}
"""


@pytest.mark.parametrize(
    ("control", "said"),
    [
        ("1 - 0.5*y1", ", from them (an algebraic loop)"),
        # a constant input was "an algebraic loop through the controller" too
        ("0.1", "; the controller reads no output: give u1 under [simulation.inputs]"),
    ],
)
def test_an_output_of_a_controlled_input_of_its_own_step_is_refused_for_its_cause(
    control: str, said: str, tmp_path: Path
) -> None:
    path = tmp_path / "same_step.toml"
    path.write_text(SAME_STEP.format(control=control), encoding="utf-8")
    with pytest.raises(ModelError) as caught:
        simulate_components(load_model(path))
    message = str(caught.value)
    assert message.startswith(
        f"{path}: simulation.controller.inputs.u1: in the joint mode blind the output 'y1' "
        "depends on u1 at the same step, which the controller computes after the outputs"
    )
    assert said in message
