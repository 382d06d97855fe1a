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
