"""A joint mode named like ``unknown-mode``'s ``p_unknown.<component>`` column is refused.

The timeline has ``p_<joint mode>`` per joint mode kept and ``p_unknown.<component>`` per
component: a mode id ``unknown.A`` of a one-component model ``A`` gave two columns one name,
and ``analyze`` ended in "unexpected ResultShapeError ... (a bug ...)" once the mode was kept.
"""

import pytest

from hybridlog.errors import ModelError
from hybridlog.model.loader import parse_model

HEAD = """
name = "column_names"
dt = 1.0
states = ["x1", "x2"]
outputs = ["y1", "y2"]

[noise]
process = 0.01
measurement = 0.04

[initial]
state = [0.0, 0.0]
covariance = 1.0
"""


def _component(name: str, mode: str, state: str, output: str) -> str:
    return f"""
[components."{name}"]
unknown = 0.01
initial = "{mode}"

[components."{name}".modes."{mode}"]
equations = ["{state}[k] = 0.5*{state}[k-1]", "{output} = {state}"]

[components."{name}".modes.other]
equations = ["{state}[k] = 0.9*{state}[k-1]", "{output} = {state}"]
"""


ONE = HEAD.replace('"x1", "x2"', '"x1"').replace('"y1", "y2"', '"y1"').replace("0.0, 0.0", "0.0")


def test_a_mode_named_unknown_dot_its_component_is_refused_naming_it():
    with pytest.raises(ModelError) as caught:
        parse_model(ONE + _component("A", "unknown.A", "x1", "y1"))
    message = str(caught.value)
    assert ": components.A.modes.'unknown.A': the joint mode 'unknown.A' " in message
    assert "p_unknown.A" in message and "\n" not in message


def test_mode_ids_joined_by_a_bar_that_spell_the_column_are_refused():
    # components A and "B|C": the joint mode unknown.B|C is p_unknown.B|C, B|C's column
    text = HEAD + _component("A", "unknown.B", "x1", "y1") + _component("B|C", "C", "x2", "y2")
    with pytest.raises(ModelError, match=r": components\.A\.modes\.'unknown\.B': the joint mode"):
        parse_model(text)


def test_a_mode_named_unknown_dot_something_else_is_accepted():
    model = parse_model(ONE + _component("A", "unknown.Z", "x1", "y1"))
    assert model.components[0].mode_ids == ("unknown.Z", "other")


def test_a_component_named_like_another_ones_filtered_column_is_named_plainly(tmp_path):
    # kbest writes mode.A_filtered (the filter's mode of A) beside component A_filtered's
    # mode.A_filtered; the refusal read "the filter's the estimator's column 'mode.A'"
    from hybridlog.jobs.analysis import analyze

    text = HEAD + _component("A", "a", "x1", "y1") + _component("A_filtered", "b", "x2", "y2")
    model = tmp_path / "m.toml"
    model.write_text(text, encoding="utf-8")
    log = tmp_path / "log.csv"
    rows = ["t,y1,y2", *(f"{k},{0.5**k},{0.9**k}" for k in range(40))]
    log.write_text("\n".join(rows) + "\n", encoding="utf-8")
    out = tmp_path / "out"
    with pytest.raises(ModelError) as caught:
        analyze(log, model, estimator="unknown-mode", out_dir=out, mode_sequence="kbest")
    assert str(caught.value).startswith(
        "the timeline table: two columns would be named 'mode.A_filtered': the filter's column "
        "'mode.A' and the estimator's column 'mode.A_filtered'; "
    )
    assert not out.exists()
