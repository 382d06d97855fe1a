"""``unknown-mode`` applies the transition rules with ``when`` by the logged commands.

Paper 002 eq. (4): ``h(•k)[x̂_i] = P_T(m_i | x̂_j(k-1), u_d(k-1)) h(k-1)[x̂_j]``: the commands
at step k-1 select the transition probabilities into step k.  The estimator read no command
from a log: the rules with ``when`` were skipped (a note said so), so a commanded switch was
followed only as far as the rules without ``when`` allowed.
"""

import dataclasses
import math
import re

import numpy as np
import pytest

from hybridlog.errors import LogError
from hybridlog.estimators.cpha.options import UnknownModeOptions
from hybridlog.estimators.cpha.unknown_mode import command_values, make_tracker, run_unknown_mode
from hybridlog.io import ReadOptions, SignalSpec, load_signals
from hybridlog.jobs.simulate import simulate_log
from hybridlog.model.loader import load_model, parse_model
from hybridlog.signals import AlignedSignals
from tests.support.cli import run_main

# One component, two modes that differ by the input: a (x held), b (x grows by u).  Out of
# a, b has probability 0.7 per step while cmd = 1, else 0.1.
TINY = """
name = "tiny"
dt = 1.0
states = ["x"]
inputs = ["u"]
outputs = ["y"]
commands = ["cmd"]

[noise]
process = 0.5
measurement = 0.25

[initial]
state = [0.0]
covariance = 1.0

[components.c]
unknown = 0.0
initial = "a"

[components.c.modes.a]
equations = ["x[k] = x[k-1]", "y = x"]

[components.c.modes.b]
equations = ["x[k] = x[k-1] + u[k-1]", "y = x"]

[[components.c.transitions]]
from = "a"
when = {cmd = 1}
to = {b = 0.7}

[[components.c.transitions]]
from = "a"
to = {b = 0.1}
"""


def tiny_signals(commands):
    return AlignedSignals(
        "tiny.csv",
        np.array([0.0, 1.0]),
        ("u",),
        ("y",),
        np.array([[1.0], [1.0]]),
        np.array([[0.0], [0.4]]),
        command_names=("cmd",),
        commands=np.array(commands, dtype=np.float64).reshape(-1, 1),
    )


def step_one_beliefs(model, signals):
    tracker = make_tracker(model, signals, UnknownModeOptions(beam=4), fresh=True)
    start = tracker.start(model.initial_state.copy(), model.initial_covariance.copy())
    return {h.assignment[0]: math.exp(h.log_belief) for h in tracker.step(start, 1)}


def test_the_command_of_the_step_before_selects_the_transition_probabilities_of_eq_4():
    model = parse_model(TINY)
    # by hand: x(0) = 0, P(0) = 1; predicted P = 1 + 0.5, S = 1.5 + 0.25 = 1.75;
    # y(1) = 0.4: residual 0.4 in a (x held at 0), -0.6 in b (x = 0 + u(0) = 1)
    po = {"a": math.exp(-(0.4**2) / (2 * 1.75)), "b": math.exp(-(0.6**2) / (2 * 1.75))}

    def eq5(prior):
        total = sum(prior[m] * po[m] for m in po)
        return {m: prior[m] * po[m] / total for m in po}

    # u_d(0) = 1 (the rule with when applies), u_d(1) = 0 (must not matter at step 1)
    commanded = step_one_beliefs(model, tiny_signals([1.0, 0.0]))
    assert commanded == pytest.approx(eq5({"a": 0.3, "b": 0.7}), rel=1e-12)
    idle = step_one_beliefs(model, tiny_signals([0.0, 1.0]))
    assert idle == pytest.approx(eq5({"a": 0.9, "b": 0.1}), rel=1e-12)


def test_a_command_a_32_bit_field_rounded_still_matches_its_when_value():
    model = parse_model(TINY.replace("when = {cmd = 1}", "when = {cmd = 0.1}"))
    signals = tiny_signals([float(np.float32(0.1)), 0.0])
    _, values = command_values(model, signals)
    assert values is not None and values[0, 0] == 0.1
    assert step_one_beliefs(model, signals)["b"] > 0.5


def test_a_log_without_a_command_a_rule_needs_is_refused_naming_command_and_component():
    model = parse_model(TINY)
    signals = dataclasses.replace(tiny_signals([0.0, 0.0]), command_names=(), commands=None)
    with pytest.raises(LogError) as raised:
        run_unknown_mode(model, signals, UnknownModeOptions(beam=4))
    assert re.fullmatch(
        r"tiny\.csv: estimator 'unknown-mode' needs the command 'cmd' in the log, which a "
        r"transition rule of component 'c' reads \(<model>: components\.c\.transitions\[0\]"
        r"\.when\): .*--map cmd=FIELD or \[signals\]",
        str(raised.value),
    )


VALVE = """
name = "commanded_valve"
dt = 1.0
states = ["x"]
inputs = ["u"]
outputs = ["y"]
commands = ["cmd"]

[noise]
process = 0.01
measurement = 0.01

[initial]
state = [0.0]
covariance = 1.0

[components.valve]
unknown = 0.0
initial = "closed"

[components.valve.modes.open]
equations = ["x[k] = 0.5*x[k-1] + 0.1*u[k-1]"]

[components.valve.modes.closed]
equations = ["x[k] = 0.5*x[k-1]"]

[[components.valve.transitions]]
from = "closed"
when = {cmd = 1}
to = {open = 0.95}

[[components.valve.transitions]]
from = "open"
when = {cmd = 0}
to = {closed = 0.95}

[[components.valve.transitions]]
from = "*"
to = {open = 0.001, closed = 0.001}

[components.sensor]
unknown = 0.0
initial = "ok"

[components.sensor.modes.ok]
equations = ["y = x"]

[components.sensor.modes.biased]
equations = ["y = x + 0.5"]

[[components.sensor.transitions]]
from = "ok"
to = {biased = 0.001}

[[components.sensor.transitions]]
from = "biased"
to = {ok = 0.01}

[simulation]
steps = 200

[simulation.inputs]
u = "1.0"

[simulation.modes]
valve = "closed, open@20, closed@60, open@100, closed@140"
sensor = "ok, biased@160, ok@180"

[simulation.commands]
cmd = "0, 1@19, 0@59, 1@99, 0@139"
"""


@pytest.fixture(scope="module")
def valve_log(tmp_path_factory):
    root = tmp_path_factory.mktemp("valve")
    model_file = root / "valve.toml"
    model_file.write_text(VALVE)
    log = root / "valve.csv"
    simulate_log(model_file, log, seed=1)
    return model_file, log


def valve_accuracy(model, signals):
    result = run_unknown_mode(model, signals, UnknownModeOptions(beam=8))
    (column,) = [c for c in result.timeline_columns if c.name == "mode.valve"]
    truth = signals.truth_components["valve"]
    estimated = np.array(column.labels)[column.values]
    return float(np.mean(estimated == np.array(truth.labels)[truth.codes]))


def test_the_commanded_switches_are_followed_with_the_rules_applied(valve_log):
    model_file, log = valve_log
    model = load_model(model_file)
    signals = load_signals(log, SignalSpec.of(model))
    assert signals.command_names == ("cmd",)
    assert signals.commands is not None and signals.commands[19:21, 0].tolist() == [1.0, 1.0]
    # the same model without its rules with `when`: what the estimator applied before
    valve, sensor = model.components
    unruled = dataclasses.replace(
        model,
        source="",
        components=(
            dataclasses.replace(valve, rules=tuple(r for r in valve.rules if not r.when)),
            sensor,
        ),
    )
    applied, skipped = valve_accuracy(model, signals), valve_accuracy(unruled, signals)
    # four switches, each commanded: followed at once with the rules, some steps late
    # without (a 0.1 change of the input's gain against noise of standard deviation 0.1)
    assert applied >= 0.99
    assert skipped < 0.9


def test_a_command_is_mapped_like_an_input_and_reported_in_the_fields_read(valve_log, tmp_path):
    model_file, log = valve_log
    renamed = tmp_path / "renamed.csv"
    text = log.read_text(encoding="utf-8")
    renamed.write_text(text.replace(",cmd,", ",valve_cmd,", 1), encoding="utf-8")
    model = load_model(model_file)
    notes: dict[str, object] = {}
    signals = load_signals(
        renamed, SignalSpec.of(model), ReadOptions(maps=("cmd=valve_cmd",)), notes=notes
    )
    assert notes["fields"]["cmd"] == {"field": "valve_cmd", "from": "--map"}
    assert signals.input_names == ("u",) and signals.inputs.shape[1] == 1
    assert signals.commands is not None and signals.commands[:, 0].max() == 1.0
    with_signals = model_file.read_text() + '\n[signals]\ncmd = "valve_cmd"\n'
    mapped = tmp_path / "mapped.toml"
    mapped.write_text(with_signals)
    notes = {}
    load_signals(renamed, SignalSpec.of(load_model(mapped)), notes=notes)
    assert notes["fields"]["cmd"] == {"field": "valve_cmd", "from": "[signals]"}


def test_the_cli_refuses_a_log_without_the_command_in_one_line(valve_log, tmp_path, capsys):
    model_file, log = valve_log
    lines = log.read_text(encoding="utf-8").splitlines()
    drop = lines[0].split(",").index("cmd")
    stripped = tmp_path / "no_cmd.csv"
    stripped.write_text(
        "\n".join(",".join(c for i, c in enumerate(ln.split(",")) if i != drop) for ln in lines)
        + "\n",
        encoding="utf-8",
    )
    out = tmp_path / "report"
    args = ["analyze", str(stripped), "--model", str(model_file), "--out", str(out)]
    code, printed = run_main([*args, "--estimator", "unknown-mode"], capsys)
    assert code == 2 and not out.exists()
    (line,) = printed.strip().splitlines()
    assert "the command 'cmd' in the log, which a transition rule of component 'valve'" in line
    assert "components.valve.transitions[0].when" in line
