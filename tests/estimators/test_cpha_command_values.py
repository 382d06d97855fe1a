"""unknown-mode's reading of command values a rule's ``when`` does not name.

* The tracker keeps a transition table per source mode and command values: a command
  logged with noise or as a set point (0.37, 0.38, ...) made a table per sample, and a
  long log's run grew by one a step.  Every value no ``when`` names selects the same rules,
  so they share one table now.
* A log whose commands never matched some rule's ``when`` (0/100 for a model's 0/1) had
  those rules quietly never apply; a note now names them and the values the log held.
"""

import dataclasses

import numpy as np

from hybridlog.estimators.cpha.options import UnknownModeOptions
from hybridlog.estimators.cpha.unknown_mode import make_tracker, run_unknown_mode
from hybridlog.model.loader import parse_model
from hybridlog.signals import AlignedSignals
from tests.estimators.test_cpha_commands import TINY

N = 60


def signals(commands) -> AlignedSignals:
    rng = np.random.default_rng(3)
    return AlignedSignals(
        "tiny.csv",
        np.arange(N, dtype=np.float64),
        ("u",),
        ("y",),
        np.ones((N, 1)),
        np.cumsum(rng.normal(0.0, 0.3, size=(N, 1)), axis=0),
        command_names=("cmd",),
        commands=np.asarray(commands, dtype=np.float64).reshape(N, 1),
    )


def run(model, commands):
    tracker = make_tracker(model, signals(commands), UnknownModeOptions(beam=4), fresh=True)
    hypotheses = tracker.start(model.initial_state.copy(), model.initial_covariance.copy())
    for k in range(1, N):
        hypotheses = tracker.step(hypotheses, k)
    return tracker, [(h.assignment, h.log_belief) for h in hypotheses]


def test_values_no_when_names_share_one_transition_table_and_act_alike():
    model = parse_model(TINY)
    noisy = np.random.default_rng(0).uniform(0.2, 0.9, size=N)  # never 1: the rule's value
    noisy[::7] = 1.0
    idle = np.where(noisy == 1.0, 1.0, 0.0)  # the same steps commanded, the rest 0
    noisy_tracker, noisy_end = run(model, noisy)
    _, idle_end = run(model, idle)
    assert noisy_end == idle_end
    # one table out of each source mode per kind of value: cmd = 1, or no rule's value
    assert len(noisy_tracker._successors) <= 2 * 2


def notes_of(model, commands):
    result = run_unknown_mode(model, signals(commands), UnknownModeOptions(beam=4))
    return [n for n in result.notes if "never held" in n]


def test_a_rule_whose_when_never_held_is_noted_with_the_values_the_log_held():
    model = parse_model(TINY)
    percent = np.where(np.arange(N) % 20 < 10, 0.0, 100.0)  # 0/100 for the model's 0/1
    (note,) = notes_of(model, percent)
    assert note.startswith(
        "transition rules whose 'when' never held on this log (the commands of no step "
        "matched): components.c.transitions[0] (cmd = 1); cmd took values no rule names on "
        f"{N - 1} of {N - 1} steps (0 on 30, 100 on 29)"
    )
    assert notes_of(model, np.where(np.arange(N) % 20 < 10, 0.0, 1.0)) == []
    # the command of the last sample selects no transition (eq. (4)): it does not count
    assert len(notes_of(model, np.r_[np.zeros(N - 1), 1.0])) == 1


def test_many_unnamed_values_are_listed_by_count_three_at_most():
    model = parse_model(TINY)
    values = np.r_[np.full(30, 5.0), np.full(20, 7.0), np.arange(N - 50, dtype=np.float64) + 10]
    (note,) = notes_of(model, values)
    assert "(5 on 30, 7 on 20, 10 on 1 and 8 more values)" in note
    plain = dataclasses.replace(
        model,
        components=tuple(
            dataclasses.replace(c, rules=tuple(r for r in c.rules if not r.when))
            for c in model.components
        ),
    )
    assert notes_of(plain, values) == []
