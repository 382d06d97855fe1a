"""Two transition rules that tie (neither more specific where both apply) are refused.

Out of a mode the most specific matching rule applies (the mode's own before ``*``, then
more ``when`` conditions).  ``from = "closed", when = {a = 1}`` and ``from = "closed",
when = {b = 1}`` both apply while ``a = 1`` and ``b = 1``, with one condition each: the
first in the file was taken, silently, so the order of two tables in the file changed what
the component did when both commands were given.
"""

import pytest

from hybridlog.errors import ModelError
from hybridlog.model.loader import parse_model

MODEL = """
name = "ties"
dt = 1.0
states = ["x"]
outputs = ["y"]
commands = ["a", "b"]

[noise]
process = 0.1
measurement = 0.1

[initial]
state = [0.0]
covariance = 1.0

[components.valve]
unknown = 0.0
initial = "closed"

[components.valve.modes.open]
equations = ["x[k] = 0.5*x[k-1] + 1", "y = x"]

[components.valve.modes.closed]
equations = ["x[k] = 0.5*x[k-1]", "y = x"]
"""


def rule(source: str, when: str, to: str) -> str:
    return f'\n[[components.valve.transitions]]\nfrom = "{source}"\n{when}\nto = {{{to}}}\n'


def test_two_rules_from_one_mode_that_hold_together_with_as_many_conditions_are_refused():
    text = MODEL + rule("closed", "when = {a = 1}", "open = 0.9")
    text += rule("closed", "when = {b = 1}", "open = 0.1")
    with pytest.raises(ModelError) as raised:
        parse_model(text)
    message = str(raised.value)
    assert "components.valve.transitions[1]: ties with components.valve.transitions[0]" in message
    assert "from 'closed' while a = 1 and b = 1" in message
    assert "add a rule from 'closed' with when = {a = 1, b = 1}" in message


def test_two_star_rules_tie_out_of_a_mode_without_a_rule_of_its_own():
    text = MODEL + rule("*", "when = {a = 1}", "open = 0.9")
    text += rule("*", "when = {b = 0.25}", "closed = 0.9")
    text += rule("open", "when = {a = 1, b = 0.25}", "closed = 0.5")
    with pytest.raises(ModelError, match=r"both apply from 'closed' while a = 1 and b = 0\.25"):
        parse_model(text)
    # each mode's own rule for the case settles it
    parse_model(text + rule("closed", "when = {a = 1}", "open = 0.5"))


@pytest.mark.parametrize(
    "rules",
    [
        # a rule with both conditions says what happens when both hold
        [
            ("closed", "a = 1", "open = 0.9"),
            ("closed", "b = 1", "open = 0.1"),
            ("closed", "a = 1, b = 1", "open = 0.5"),
        ],
        # exclusive: never both
        [("closed", "a = 1", "open = 0.9"), ("closed", "a = 0", "open = 0.1")],
        [("closed", "a = 1, b = 0", "open = 0.9"), ("closed", "a = 1, b = 1", "open = 0.1")],
        # the same targets: either is the same
        [("closed", "a = 1", "open = 0.9"), ("closed", "b = 1", "open = 0.9")],
        # more conditions, or the mode's own, are more specific
        [("closed", "a = 1", "open = 0.9"), ("closed", "a = 1, b = 1", "open = 0.1")],
        [("*", "a = 1", "open = 0.9"), ("closed", "b = 1", "open = 0.1")],
        # other modes
        [("closed", "a = 1", "open = 0.9"), ("open", "b = 1", "closed = 0.1")],
    ],
)
def test_rules_one_of_which_is_the_most_specific_wherever_both_apply_are_accepted(rules):
    text = MODEL + "".join(rule(s, f"when = {{{w}}}", t) for s, w, t in rules)
    model = parse_model(text)
    (valve,) = model.components
    assert len(valve.rules) == len(rules)


def test_a_star_rule_every_mode_s_own_rule_shadows_is_refused():
    # the commanded close never applied: each mode's fault rule comes first
    text = MODEL + rule("*", "when = {a = 0}", "closed = 0.9")
    text += rule("open", "", "closed = 0.001") + rule("closed", "when = {a = 0}", "open = 0.001")
    with pytest.raises(ModelError) as raised:
        parse_model(text)
    assert str(raised.value).endswith(
        "components.valve.transitions[0]: never applies: a mode's own rule comes before '*', "
        "and every mode has one that holds wherever this one does (open: "
        "components.valve.transitions[1]; closed: components.valve.transitions[2]); give "
        "those rules this rule's `when` conditions and more, or write this rule for each mode"
    )
    # a mode without a rule of its own, or whose own rule needs another command: applies
    parse_model(
        MODEL + rule("*", "when = {a = 0}", "closed = 0.9") + rule("open", "", "closed = 0.001")
    )
    parse_model(
        MODEL
        + rule("*", "when = {a = 0}", "closed = 0.9")
        + rule("open", "when = {b = 1}", "closed = 0.001")
        + rule("closed", "", "open = 0.001")
    )


def test_two_when_values_one_logged_value_would_match_are_refused():
    # a logged value within 1e-6 (relative) of a when value counts as it: 0.1 and
    # 0.1000001 were both matched by a logged 0.10000005, which took the last one
    text = MODEL + rule("closed", "when = {a = 0.1}", "open = 0.9")
    text += rule("open", "when = {a = 0.1000001}", "closed = 0.9")
    with pytest.raises(ModelError) as raised:
        parse_model(text)
    assert (
        "components.valve.transitions[1].when.a: 0.1000001 is within 1e-06 (relative) of "
        "0.1 (components.valve.transitions[0].when.a)" in str(raised.value)
    )
    parse_model(text.replace("0.1000001", "0.100003"))
    parse_model(text.replace("0.1000001", "0.1"))
