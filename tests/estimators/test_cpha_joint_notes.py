"""imm on a components model's joint modes says which transition rules it did not apply.

Its Markov matrix is fixed, so the rules with ``when`` (commanded switches) are left out:
on a commanded valve's log imm followed the valve only as far as the fault rules allowed,
and its report said nothing of the rules it dropped.
"""

import dataclasses

import pytest

from hybridlog.estimators import prepare
from hybridlog.io import SignalSpec, load_signals
from hybridlog.jobs.simulate import simulate_log
from hybridlog.model.loader import load_model
from tests.estimators.test_cpha_commands import VALVE


@pytest.fixture(scope="module")
def valve(tmp_path_factory):
    root = tmp_path_factory.mktemp("valve")
    model_file = root / "valve.toml"
    model_file.write_text(VALVE.replace("steps = 200", "steps = 60"))
    log = root / "valve.csv"
    simulate_log(model_file, log, seed=1)
    model = load_model(model_file)
    return model, load_signals(log, SignalSpec.of(model))


def rule_notes(result):
    return [n for n in result.notes if "not applied" in n]


@pytest.mark.parametrize("options", [{}, {"smooth": "true"}])
def test_imm_names_the_rules_with_when_it_did_not_apply(valve, options):
    model, signals = valve
    result = prepare(model, "imm", options).run(model, signals)
    (note,) = rule_notes(result)
    assert "imm runs on the joint modes" in note and "reads no command (cmd)" in note
    assert note.endswith(
        "left out: components.valve.transitions[0], components.valve.transitions[1] "
        "(unknown-mode applies them by the logged commands)"
    )
    if result.post_processing is not None:
        assert rule_notes(result.post_processing.filtered) == [note]


def test_chunks_and_a_model_without_when_carry_no_more_than_the_one_note(valve):
    model, signals = valve
    prepared = prepare(model, "imm", {})
    chunks = list(prepared.stream(model, signals, rows=16))
    assert len(chunks) > 1 and all(len(rule_notes(c)) == 1 for c in chunks)
    valve_c, sensor = model.components
    plain = dataclasses.replace(
        model,
        components=(
            dataclasses.replace(valve_c, rules=tuple(r for r in valve_c.rules if not r.when)),
            sensor,
        ),
    )
    assert rule_notes(prepare(plain, "imm", {}).run(plain, signals)) == []


TANKS = """
dt = 1.0
states = ["h1", "h2"]
inputs = ["q"]
outputs = ["y1", "y2"]
variables = ["f12"]
commands = ["vcmd"]

[parameters]
a = 0.1

[noise]
process = [1e-4, 1e-4]
measurement = [1e-3, 1e-3]

[initial]
state = [1.0, 0.5]
covariance = [0.1, 0.1]

[components.tank1]
unknown = 0.001
initial = "ok"
[components.tank1.modes.ok]
equations = ["h1[k] = h1[k-1] + 0.1*q[k-1] - f12[k-1]", "y1 = h1"]
[components.tank1.modes.leak]
equations = ["h1[k] = h1[k-1] + 0.1*q[k-1] - f12[k-1] - 0.05*h1[k-1]", "y1 = h1"]
[[components.tank1.transitions]]
from = "ok"
to = {leak = 0.001}
[[components.tank1.transitions]]
from = "unknown"
to = {ok = 0.45, leak = 0.45}

[components.valve]
unknown = 0.001
initial = "open"
[components.valve.modes.open]
equations = ["f12 = a*(h1 - h2)"]
[components.valve.modes.closed]
equations = ["f12 = 0"]
[[components.valve.transitions]]
from = "*"
when = {vcmd = 1}
to = {open = 0.9}
[[components.valve.transitions]]
from = "*"
when = {vcmd = 0}
to = {closed = 0.9}
[[components.valve.transitions]]
from = "unknown"
to = {open = 0.45, closed = 0.45}

[components.tank2]
unknown = 0.001
initial = "ok"
[components.tank2.modes.ok]
equations = ["h2[k] = h2[k-1] + f12[k-1] - 0.05*h2[k-1]", "y2 = h2"]
[[components.tank2.transitions]]
from = "unknown"
to = {ok = 0.9}

[simulation]
steps = 300
[simulation.parameters]
leak_at = 150
[simulation.modes]
tank1 = "ok, leak@leak_at"
valve = "open, closed@100, open@200"
[simulation.commands]
vcmd = "1, 0@100, 1@200"
[simulation.controller]
inputs = {q = "1.0"}
"""


def test_a_failed_run_on_the_joint_modes_names_the_rules_it_left_out(tmp_path):
    """A valve commanded shut, which only rules with ``when`` allow, ended imm with
    "cannot explain the log ... an outlier, a stuck or offset sensor, another plant's log
    ...?" and no word of the rules it had dropped: a failed run writes no report notes."""
    from hybridlog.errors import DivergenceError

    model_file = tmp_path / "tanks.toml"
    model_file.write_text(TANKS, encoding="utf-8")
    log = tmp_path / "tanks.csv"
    simulate_log(model_file, log, seed=1)
    model = load_model(model_file)
    signals = load_signals(log, SignalSpec.of(model))
    prepared = prepare(model, "imm", {})
    for run in (
        lambda: prepared.run(model, signals),
        lambda: list(prepared.stream(model, signals)),
    ):
        with pytest.raises(DivergenceError) as caught:
            run()
        message = str(caught.value)
        assert "imm cannot explain the log at t = " in message
        assert message.endswith(
            "left out: components.valve.transitions[0], components.valve.transitions[1] "
            "(unknown-mode applies them by the logged commands))"
        )
