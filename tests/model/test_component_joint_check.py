"""A ``[components]`` model means one thing to every estimator: its joint modes are checked
when the file is read (:mod:`hybridlog.model.component_structure`), and a known mode gives
every state of its component (:func:`hybridlog.model.component_loader._refuse_missing_states`).

Before, ``unknown-mode`` checked a joint mode only when its tracker first visited it (a file
passed on a log that never reached the bad joint mode, and was refused by ``imm`` and
``models FILE``), and held a state a known mode gave no difference equation, which ``imm``
and ``simulate`` refused.
"""

from pathlib import Path

import pytest

from hybridlog.errors import ModelError
from hybridlog.model.component_structure import MAX_CHECKED_JOINT_MODES
from hybridlog.model.loader import parse_model
from tests.estimators.test_cpha_structure import PAPER_EXAMPLE

SECOND_MODE = PAPER_EXAMPLE.replace(
    "[components.A3]",
    '[components.A2.modes.m22]\nequations = ["xc1[k] = 0.5*xc1[k-1] + wc1[k-1]", "yc1 = xc1"]'
    "\n\n[components.A3]",
)
"""Paper 002's example with a second mode of A2, which a log may never reach."""

UNGIVEN_IN_M22 = SECOND_MODE.replace(
    '"xc1[k] = 0.5*xc1[k-1] + wc1[k-1]", "yc1 = xc1"',
    '"xc1[k] = 0.5*xc1[k-1] + wc1[k-1]", "yc1 = xc1 + wc2"',
).replace('variables = ["wc1"]', 'variables = ["wc1", "wc2"]')

NO_STATE_IN_M22 = SECOND_MODE.replace(
    '"xc1[k] = 0.5*xc1[k-1] + wc1[k-1]", "yc1 = xc1"', '"yc1 = xc1"'
)


def test_a_joint_mode_no_log_reaches_is_checked_when_the_file_is_read() -> None:
    parse_model(SECOND_MODE)
    with pytest.raises(
        ModelError,
        match=r"^<model>: components\.A2\.modes\.m22\.equations\[1\]: uses 'wc2', which no "
        r"equation of the joint mode m11\|m22\|m31 determines",
    ):
        parse_model(UNGIVEN_IN_M22)


def test_unknown_mode_refuses_it_before_any_log_is_read(tmp_path: Path) -> None:
    # unknown-mode ran the file on a log that stayed in m21 (imm refused it, after the log)
    from hybridlog.jobs.analysis import analyze

    model = tmp_path / "m.toml"
    model.write_text(UNGIVEN_IN_M22, encoding="utf-8")
    log = tmp_path / "broken.csv"
    log.write_text("t,uc1,yc1,yc2\n0,1,2\n", encoding="utf-8")  # a log error, if read first
    with pytest.raises(ModelError, match=r"m\.toml: components\.A2\.modes\.m22\.equations\[1\]"):
        analyze(log, model, estimator="unknown-mode", out_dir=tmp_path / "out")


def test_a_known_mode_without_a_state_s_difference_equation_is_refused() -> None:
    # unknown-mode held xc1 in m22, imm refused "nothing determines xc1", simulate refused
    # only a schedule reaching m22
    with pytest.raises(ModelError) as refused:
        parse_model(NO_STATE_IN_M22, origin="m.toml")
    assert str(refused.value) == (
        "m.toml: components.A2.modes.m22: no difference equation for the state 'xc1' of "
        "component 'A2', which its mode 'm21' gives: a known mode gives every state of its "
        "component (write xc1[k] = xc1[k-1] to keep it; only the unknown mode leaves it "
        "undetermined, paper 002 §3)"
    )


def test_a_known_joint_mode_without_an_output_s_equation_is_refused() -> None:
    # a sensor-off mode of A3: unknown-mode left yc2 unexplained (as if A3 were unknown),
    # imm refused 'nothing determines yc2', simulate refused only a schedule reaching it
    sensor_off = SECOND_MODE.replace(
        "[components.A2.modes.m22]",
        '[components.A3.modes.m32]\nequations = ["xc2[k] = xc3[k-1] + yc1[k-1]", '
        '"xc3[k] = 0.4*xc2[k-1] + 0.5*uc1[k-1]"]\n\n[components.A2.modes.m22]',
    )
    with pytest.raises(ModelError) as refused:
        parse_model(sensor_off, origin="m.toml")
    assert str(refused.value) == (
        "m.toml: components.A3.modes.m32: no equation of the joint mode m11|m21|m32 gives the "
        "output 'yc2', which components.A3.modes.m31 gives: a known joint mode gives every "
        "output (only the unknown mode leaves one unexplained, paper 002 §3); write its "
        "sensor's equation in this mode"
    )


def _chain(n: int, *, shared: bool, bad: int | None = None) -> str:
    """``n`` components of two modes each, every one using ``w`` when ``shared``."""
    states = ", ".join(f'"x{i}"' for i in range(n))
    outputs = ", ".join(f'"y{i}"' for i in range(n))
    drive = " + w[k-1]" if shared else ""
    lines = [
        'name = "chain"',
        "dt = 1.0",
        f"states = [{states}]",
        'inputs = ["u"]',
        f"outputs = [{outputs}]",
        'variables = ["w", "v"]',
        "[noise]",
        f"process = {[0.01] * n}",
        f"measurement = {[0.1] * n}",
        "[initial]",
        f"state = {[0.0] * n}",
        "covariance = 1.0",
        "[components.source]",
        "unknown = 0.01",
        '[components.source.modes.low]\nequations = ["w = u", "v = w"]',
        # no v, which mode b of component `bad` uses
        '[components.source.modes.high]\nequations = ["w = 2*u"]',
    ]
    for i in range(n):
        lines += [
            f"[components.c{i}]",
            "unknown = 0.01",
            f'[components.c{i}.modes.a]\nequations = ["x{i}[k] = 0.5*x{i}[k-1]{drive}", '
            f'"y{i} = x{i}"]',
            f'[components.c{i}.modes.b]\nequations = ["x{i}[k] = 0.9*x{i}[k-1]{drive}", '
            f'"y{i} = x{i}{" + v" if i == bad else ""}"]',
        ]
    return "\n".join(lines) + "\n"


def test_independent_components_are_checked_group_by_group() -> None:
    # 2**17 joint modes, past the bound, but groups of two and of four: all checked
    assert MAX_CHECKED_JOINT_MODES < 2**17
    assert parse_model(_chain(16, shared=False)).diagnoses == ()
    with pytest.raises(
        ModelError,
        match=r"components\.c7\.modes\.b\.equations\[1\]: uses 'v', which no equation of the "
        r"joint mode high(\|a){7}\|b(\|a){8} determines",
    ):
        parse_model(_chain(16, shared=False, bad=7))


def test_a_group_past_the_bound_is_said_not_checked() -> None:
    model = parse_model(_chain(16, shared=True))
    (note,) = model.diagnoses
    assert note.startswith("NOTE: components: the joint modes of source, c0, c1, ")
    assert "(131,072 joint modes) are more than 16,384 a group" in note  # digits grouped
    assert "unknown-mode first reaches it" in note


def test_the_batched_check_agrees_with_the_matching_at_every_joint_mode() -> None:
    # _first_incomplete answers what causal_graph and undetermined_use would, each joint
    # mode a block of one matching: alone, and as the first wrong one of a batch
    import itertools

    from hybridlog.model.builtins import builtin_text
    from hybridlog.model.component_structure import (
        ComponentNames,
        _first_incomplete,
        _Part,
        causal_graph,
        undetermined_use,
    )

    text = builtin_text("bioplex_pgc")
    for model in (parse_model(text), parse_model(SECOND_MODE)):
        names = ComponentNames(model.states, model.inputs, model.outputs, model.variables)
        matchable = frozenset(model.outputs) | frozenset(model.variables)
        joint, expected = [], []
        for modes in itertools.product(*(c.mode_ids for c in model.components)):
            # and with one component's equations left out: complete and incomplete ones
            for left_out in range(-1, len(modes)):
                chosen = [
                    c.equations(m)
                    for j, (c, m) in enumerate(zip(model.components, modes, strict=True))
                    if j != left_out
                ]
                equations = [e for group in chosen for e in group]
                _, determined_by, unmatched = causal_graph(names, equations)
                expected.append(
                    not unmatched and undetermined_use(names, equations, determined_by) is None
                )
                joint.append([_Part.of(group, matchable) for group in chosen])
        assert set(expected) == {True, False}
        order = sorted(matchable)
        for parts, complete in zip(joint, expected, strict=True):
            assert (_first_incomplete([parts], frozenset(), order) is None) == complete
        for start in range(0, len(joint), 7):  # a wrong one after complete ones
            first = next((i for i, ok in enumerate(expected[start:]) if not ok), None)
            assert _first_incomplete(joint[start:], frozenset(), order) == first


def test_models_file_says_a_group_was_not_checked(tmp_path: Path) -> None:
    from hybridlog.jobs.model_description import check_and_describe

    path = tmp_path / "chain.toml"
    path.write_text(_chain(16, shared=True), encoding="utf-8")
    described = check_and_describe(path).splitlines()
    (line,) = [n for n in described if "joint modes of" in n]
    assert line.startswith("NOTE: components: the joint modes of source, c0, ")
    # the count of imm's refusal grouped as the note's (it was 131072 beside 131,072)
    (default,) = [n for n in described if n.startswith("default_estimator:")]
    assert default.endswith("at most 256; the model has 131,072: analyze needs --estimator")


def test_the_model_files_page_says_known_modes_are_checked_when_the_file_is_read() -> None:
    # the page said unknown-mode refused a joint mode "it reaches", and nothing of a known
    # mode's states or outputs, or of the bound past which a group is left to unknown-mode
    page = (Path(__file__).resolve().parents[2] / "docs" / "model_files.md").read_text()
    text = " ".join(page.split())
    assert "checked for when the file is read" in text
    assert "gives every state of its component a difference equation" in text
    assert f"more than {MAX_CHECKED_JOINT_MODES:,} joint modes" in text
