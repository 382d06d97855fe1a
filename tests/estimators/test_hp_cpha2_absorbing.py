"""A component whose ``unknown`` mode no rule leaves is named, with a warning when it matters.

Without a ``from = "unknown"`` rule a trajectory that enters ``unknown`` stays, and by the
upper bound ``P_O = 1`` of its dropped filters it outscores a well-fitting mode after a few
dozen samples: on a log the model fits, the report had the component unknown on most samples
and said nothing about why.
"""

import numpy as np

from hybridlog.estimators.cpha.unknown_mode import UnknownModeOptions, run_unknown_mode
from hybridlog.model.loader import parse_model
from hybridlog.signals import AlignedSignals

MODEL = """
name = "absorbing"
dt = 1.0
states = ["x1"]
inputs = ["u1"]
outputs = ["y1"]
commands = ["cmd"]

[noise]
process = [0.01]
measurement = [0.01]

[initial]
state = [0.0]
covariance = 1.0

[components.plant]
unknown = 0.001
initial = "a"

[components.plant.modes.a]
equations = ["x1[k] = 0.8*x1[k-1] + 0.2*u1[k-1]", "y1 = x1"]
"""

LEAVING = """
[[components.plant.transitions]]
from = "unknown"
to = {a = 0.5}
"""

LEAVING_ON_COMMAND = """
[[components.plant.transitions]]
from = "unknown"
when = {cmd = 1}
to = {a = 0.5}
"""


def signals(model, n, *, command=0.0):
    """``n`` samples the mode fits (the model's own noise)."""
    rng = np.random.default_rng(1)
    u = 1.0 + 0.5 * np.sin(np.arange(n) / 9.0)
    x, ys = 0.0, []
    for k in range(n):
        if k > 0:
            x = 0.8 * x + 0.2 * u[k - 1] + rng.normal(0.0, 0.1)
        ys.append(x + rng.normal(0.0, 0.1))
    t = np.arange(n, dtype=np.float64)
    commands = np.full((n, 1), command) if "when" in model.source else None
    names = ("cmd",) if commands is not None else ()
    return AlignedSignals(
        "log.csv",
        t,
        model.inputs,
        model.outputs,
        u[:, None],
        np.array(ys)[:, None],
        command_names=names,
        commands=commands,
    )


def absorbing_notes(result):
    return [note for note in result.notes if "absorbing" in note]


def test_an_absorbing_unknown_the_estimate_sits_in_is_a_warning_naming_the_component():
    model = parse_model(MODEL, origin="absorbing.toml")
    result = run_unknown_mode(model, signals(model, 200), UnknownModeOptions())
    unknown = result.mode_ids.index("unknown")
    assert np.mean(result.modes == unknown) > 0.5  # the mechanism the note explains
    [note] = absorbing_notes(result)
    assert note.startswith("WARNING: component plant is reported in its unknown mode on ")
    assert 'no transition rule has from = "unknown"' in note
    assert "[[components.plant.transitions]]" in note and "\n" not in note


def test_an_absorbing_unknown_not_sat_in_is_a_note():
    model = parse_model(MODEL, origin="absorbing.toml")
    result = run_unknown_mode(model, signals(model, 6), UnknownModeOptions())
    [note] = absorbing_notes(result)
    assert note.startswith("component plant: its unknown mode is absorbing, no rule leaves it")


def test_no_note_with_a_rule_leaving_unknown_or_without_the_unknown_mode():
    model = parse_model(MODEL, origin="absorbing.toml")
    off = run_unknown_mode(model, signals(model, 60), UnknownModeOptions(unknown_mode=False))
    assert not absorbing_notes(off)
    leaving = parse_model(MODEL + LEAVING, origin="leaving.toml")
    result = run_unknown_mode(leaving, signals(leaving, 200), UnknownModeOptions())
    assert not absorbing_notes(result)
    assert np.mean(result.modes == result.mode_ids.index("a")) > 0.9


def test_a_rule_leaving_unknown_under_a_command_the_log_never_gives_is_named():
    model = parse_model(MODEL + LEAVING_ON_COMMAND, origin="on_command.toml")
    never = run_unknown_mode(model, signals(model, 40, command=0.0), UnknownModeOptions())
    [note] = absorbing_notes(never)
    assert "components.plant.transitions[0]" in note and "no step of this log had" in note
    given = run_unknown_mode(model, signals(model, 40, command=1.0), UnknownModeOptions())
    assert not absorbing_notes(given)


def sticky_notes(result):
    return [note for note in result.notes if "stays there with probability" in note]


def test_an_unknown_left_too_rarely_the_estimate_sits_in_is_a_warning_naming_the_threshold():
    """Leaving ``unknown`` with probability 0.2 (staying 0.8, above e^(-1/2) for the one
    output its filter checks) kept a well-fitting component unknown on most of the log, with
    no word: only a rule that never leaves was named.  Leaving with 0.5 is enough here."""
    sticky = parse_model(MODEL + LEAVING.replace("0.5", "0.2"), origin="sticky.toml")
    result = run_unknown_mode(sticky, signals(sticky, 200), UnknownModeOptions())
    assert np.mean(result.modes == result.mode_ids.index("unknown")) > 0.25
    [note] = sticky_notes(result)
    assert note.startswith("WARNING: component plant is reported in its unknown mode on ")
    assert "stays there with probability 0.8 a step, above e^(-n/2) = 0.61 for the n = 1 " in note
    assert "0.39 for one, 0.63 for two" in note and "\n" not in note
    leaving = parse_model(MODEL + LEAVING, origin="leaving.toml")
    assert not sticky_notes(run_unknown_mode(leaving, signals(leaving, 200), UnknownModeOptions()))
