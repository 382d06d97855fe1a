"""One rule reads an option's value, from a model file's TOML and from ``--set`` text alike.

``--set smooth=yes`` and ``--set smooth=1`` were accepted where ``smooth = 1`` in the model
file was refused and ``smooth = "true"`` (a string) accepted; ``beam = 3.0`` was accepted and
``--set beam=2.0`` refused; ``beam = true`` was said to be ``'True'``.  A bad value of another
estimator's table passed without a word (``transition_stay = 7`` under ``[estimators.imm]``
with ``--estimator hstf``), and a key the model leaves unread was kept silently.
"""

import tomllib
from dataclasses import dataclass
from typing import Literal

import pytest

from hybridlog.errors import ModelError, OptionError
from hybridlog.estimators.options import OptionSource, option, parse_options
from hybridlog.estimators.registry import prepare
from hybridlog.jobs.overrides import parse_sets, prepare_estimators
from hybridlog.model.loader import load_model, parse_model
from tests.support.paths import ROOT

TANK_TEXT = (ROOT / "hybridlog/model/builtin/three_tank_hstf.toml").read_text()
SAMPLE = ROOT / "sample_logs" / "three_tank_hstf.csv"

ONE_MODE = """
name = "one_mode"
dt = 1.0
states = ["x1"]
inputs = ["u"]
outputs = ["y"]
[modes.a]
f = ["x1 + u"]
h = ["x1"]
[noise]
process = 0.1
measurement = 0.1
[initial]
state = [1.0]
covariance = 1.0
"""


@dataclass(frozen=True)
class Toy:
    count: int = option(3, "a whole number", range=(1, 10))
    gain: float = option(0.5, "a number", range=(0.0, 1.0))
    on: bool = option(True, "a switch")
    label: str = option("", "any text")
    shape: Literal["round", "square"] = option("round", "one of two")
    size: int | None = option(None, "a whole number or none")


def from_file(name, toml):
    """``name = <toml>`` under ``[estimators.toy]`` of ``m.toml``: the value or the error."""
    value = tomllib.loads(f"v = {toml}")["v"]
    source = OptionSource.model_file("m.toml", "toy", name)
    try:
        return getattr(
            parse_options(Toy, {name: value}, estimator="toy", sources={name: source}), name
        )
    except ModelError as err:
        return str(err).removeprefix(f"m.toml: estimators.toy.{name}: ")


def from_set(name, text):
    """``--set <name>=<text>``: the value or the error."""
    source = OptionSource.command_line("--set", name, text)
    try:
        return getattr(
            parse_options(Toy, {name: text}, estimator="toy", sources={name: source}), name
        )
    except OptionError as err:
        return str(err).removeprefix(f"--set {name}={text}: ")


@pytest.mark.parametrize(
    ("name", "spelled", "value"),
    [
        ("count", "2", 2),
        ("count", "2.0", 2),  # an integral number is that whole number, both ways
        ("count", "1e1", 10),
        ("count", "2.5", "toy option 'count': expected a whole number, got '2.5'"),
        ("count", "true", "toy option 'count': expected a whole number, got 'true'"),
        ("gain", "1", 1.0),
        ("gain", "0.25", 0.25),
        ("on", "true", True),
        ("on", "false", False),
        ("on", "1", "toy option 'on': expected true or false, got '1'"),
        # a TOML string is a string, quoted in the file or on the command line
        (
            "on",
            '"true"',
            "toy option 'on': expected true or false, got the string 'true': "
            "write it without quotes",
        ),
        ("shape", '"square"', "square"),
        ("label", '"a b"', "a b"),
        ("size", '"none"', None),
    ],
)
def test_a_value_means_the_same_in_a_model_file_and_on_the_command_line(name, spelled, value):
    got = (from_file(name, spelled), from_set(name, spelled))
    assert got == (value, value)
    assert all(type(g) is type(value) for g in got)


@pytest.mark.parametrize(
    ("name", "toml", "reason"),
    [
        # TOML has booleans and numbers: a string is not one (it was read as text)
        ("on", '"true"', "expected true or false, got the string 'true': write it without quotes"),
        ("on", '"yes"', "expected true or false, got the string 'yes'"),
        ("count", '"4"', "expected a whole number, got the string '4': write it without quotes"),
        ("count", "true", "expected a whole number, got 'true'"),  # not Python's 'True'
        ("label", "5", "expected text (a TOML string, in quotes), got '5'"),
        ("label", "false", "expected text (a TOML string, in quotes), got 'false'"),
        ("on", "{a = 1}", "expected true or false, got a table"),  # not {'a': 1}
        ("count", "[true]", "expected a whole number, got an array"),
    ],
)
def test_a_model_file_value_must_be_of_the_option_type(name, toml, reason):
    assert from_file(name, toml) == f"toy option '{name}': {reason}"


@pytest.mark.parametrize(
    ("name", "text", "value"),
    [
        ("on", "yes", "toy option 'on': expected true or false, got 'yes'"),
        ("on", "True", "toy option 'on': expected true or false, got 'True'"),
        ("on", "0", "toy option 'on': expected true or false, got '0'"),
        ("label", "5", "5"),  # a string option takes the text as it is, quotes optional
        ("label", "0,1", "0,1"),
        ("shape", "square", "square"),
        ("size", "none", None),
        ("count", "1_0", "toy option 'count': expected a whole number, got '1_0'"),
    ],
)
def test_set_text_is_read_as_the_toml_value_it_spells(name, text, value):
    assert from_set(name, text) == value


def test_every_table_is_validated_whichever_estimator_runs(tmp_path, hybridlog_main):
    path = tmp_path / "tank.toml"
    path.write_text(f"{TANK_TEXT}\n[estimators.imm]\ntransition_stay = 7\n")
    out = tmp_path / "out"
    for estimator in ("hstf", "imm"):
        code, error = hybridlog_main(
            [
                "analyze",
                str(SAMPLE),
                "--model",
                str(path),
                "--estimator",
                estimator,
                "--out",
                str(out),
            ]
        )
        assert code == 2 and not out.exists()
        assert error.strip() == (
            f"hybridlog: error: {path}: estimators.imm.transition_stay: imm option "
            "'transition_stay': 7 is outside [0, 1]"
        )


def test_a_key_the_model_leaves_unread_is_refused_as_a_misspelt_key_is(tmp_path):
    path = tmp_path / "one.toml"
    path.write_text(f"{ONE_MODE}\n[estimators.hstf]\ntheta = 0.9\n")
    model = load_model(path)
    for estimator in ("hstf", "imm"):
        with pytest.raises(ModelError) as caught:
            prepare(model, estimator)
        assert str(caught.value) == (
            f"{path}: estimators.hstf.theta: hstf option 'theta' has no effect: one_mode has "
            "one mode, and θ decides between modes (eq. (40)); remove the key"
        )
    path.write_text(f"{ONE_MODE}\n[estimators.imm]\ntransition_stay = 0.9\n")
    with pytest.raises(ModelError, match=r"estimators\.imm\.transition_stay: .* no effect"):
        prepare(load_model(path), "imm")


def test_a_file_default_that_another_option_enables_stays():
    """``beam = 50`` in the file is the default for ``--mode-sequence kbest``, not an error."""
    model = parse_model(f"{TANK_TEXT}\n[estimators.imm]\nbeam = 50\n", origin="m.toml")
    _, kbest = parse_sets(["mode_sequence=kbest"], "three_tank_hstf")
    (prepared,) = prepare_estimators(model, ["imm"], kbest)
    assert (prepared.options.beam, prepared.options.mode_sequence) == (50, "kbest")
    (alone,) = prepare_estimators(model, ["imm"], parse_sets([], "three_tank_hstf")[1])
    assert alone.options.beam == 50  # kept, unread by argmax
    _, beam_set = parse_sets(["beam=5"], "three_tank_hstf")
    with pytest.raises(OptionError, match=r"^--set beam=5: has no effect on estimator 'imm'"):
        prepare_estimators(model, ["imm"], beam_set)


@pytest.mark.parametrize("text", ["", " "])
def test_an_empty_value_of_an_optional_option_is_refused_not_read_as_none(text):
    # `--set size=$SIZE` with SIZE unset ran the option's default without a word; so did
    # size = "" in a model file
    reason = "toy option 'size': got an empty value: write a value, or none"
    assert from_set("size", text) == reason
    assert from_file("size", f'"{text}"') == reason
    assert from_set("size", "None") is None and from_file("size", '"none"') is None
