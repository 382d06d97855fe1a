"""Estimator options: read from type hints, validated, described; errors name the culprit."""

import dataclasses
import json
import typing
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import pytest

from hybridlog.cluster.subtractive import METHODS
from hybridlog.errors import ModelError, OptionError
from hybridlog.estimators import ESTIMATORS
from hybridlog.estimators.options import (
    OptionSource,
    closest,
    describe_options,
    format_options,
    option,
    options_dict,
    parse_options,
)
from hybridlog.estimators.registry import prepare, reference_markdown
from hybridlog.model.loader import load_model


@dataclass(frozen=True)
class Toy:
    count: int = option(3, "a whole number", range=(1, 10))
    gain: float = option(0.5, "a number", range=(0.0, 1.0))
    on: bool = option(True, "a switch")
    label: str = option("", "any text")
    shape: Literal["round", "square"] = option("round", "one of two")
    limit: float | None = option(None, "a number or none", range=(0.0, 5.0))
    size: int | None = option(None, "a whole number or none")


def parse(**values):
    return parse_options(Toy, values, estimator="toy")


@pytest.mark.parametrize(
    ("name", "raw", "value"),
    [
        ("count", "4", 4),
        ("count", 4, 4),
        ("count", 4.0, 4),  # TOML `count = 4.0`
        ("count", " 7 ", 7),
        ("gain", "0.25", 0.25),
        ("gain", 1, 1.0),
        ("on", "false", False),
        ("on", " true ", True),
        ("on", False, False),
        ("label", " a b ", "a b"),
        ("shape", "square", "square"),
        ("limit", "none", None),
        ("limit", "2.5", 2.5),
        ("size", "None", None),
        ("size", "12", 12),
    ],
)
def test_values_are_read_by_their_type_hint(name, raw, value):
    parsed = getattr(parse(**{name: raw}), name)
    assert parsed == value and type(parsed) is type(value)


@pytest.mark.parametrize(
    ("name", "raw", "reason"),
    [
        ("count", "3.5", "expected a whole number, got '3.5'"),
        ("count", True, "expected a whole number, got 'true'"),
        ("count", "many", "expected a whole number, got 'many'"),
        ("count", "11", "11 is outside [1, 10]"),
        ("count", "none", "expected a whole number, got 'none'"),
        # Python's int() and float() read these; a typo must not run another analysis
        ("count", "1_0", "expected a whole number, got '1_0'"),
        ("count", "٣", "expected a whole number, got '٣'"),
        ("count", "0x3", "expected a whole number, got '0x3'"),
        ("count", 3.5, "expected a whole number, got '3.5'"),
        ("gain", "0_5", "expected a finite number, got '0_5'"),
        ("gain", "٠.٥", "expected a finite number, got '٠.٥'"),
        ("gain", "\u00a00.5", "expected a finite number, got '\\xa00.5'"),
        ("gain", "nan", "expected a finite number, got 'nan'"),
        ("gain", "inf", "expected a finite number, got 'inf'"),
        ("gain", "-Infinity", "expected a finite number, got '-Infinity'"),
        ("gain", "1e999", "expected a finite number, got '1e999'"),
        ("gain", "-0.1", "-0.1 is outside [0, 1]"),
        ("gain", [1], "expected a finite number, got an array"),
        ("on", "maybe", "expected true or false, got 'maybe'"),
        # the TOML spellings only, for --set as in a model file
        ("on", "yes", "expected true or false, got 'yes'"),
        ("on", "1", "expected true or false, got '1'"),
        ("on", "True", "expected true or false, got 'True'"),
        ("on", 1, "expected true or false, got '1'"),
        ("label", 5, "expected text (a TOML string, in quotes), got '5'"),
        ("shape", "oval", "'oval' is not one of round, square"),
        ("limit", "6", "6 is outside [0, 5]"),
        ("limit", "", "got an empty value: write a value, or none"),
    ],
)
def test_bad_values_are_one_line_naming_estimator_and_option(name, raw, reason):
    with pytest.raises(OptionError) as caught:
        parse(**{name: raw})
    assert str(caught.value) == f"toy option '{name}': {reason}"


def test_a_toml_integer_beyond_floats_is_not_a_finite_number():
    """``gain = 1000…0`` (400 digits) in a model file: float() raised OverflowError."""
    with pytest.raises(OptionError, match=r"^toy option 'gain': expected a finite number, got"):
        parse(gain=10**400)


def test_unknown_names_list_the_options_and_suggest_the_closest():
    with pytest.raises(OptionError, match=r"toy has no option 'gian' \(options: count, gain, on,"):
        parse(gian="1")
    with pytest.raises(OptionError, match="did you mean 'gain'"):
        parse(gian="1")
    with pytest.raises(OptionError) as caught:
        parse(zzzz="1")
    assert "did you mean" not in str(caught.value)


def test_a_name_wrong_only_in_case_is_suggested():
    """``--set RHO=0.5`` suggested nothing: the likeness was case-sensitive."""
    with pytest.raises(OptionError, match=r"did you mean 'gain'\?$"):
        parse(GAIN="1")
    with pytest.raises(OptionError, match=r"did you mean 'label'\?$"):
        parse(Lable="x")
    assert closest("A", ["a2", "a"]) == "; did you mean 'a'?"


def test_errors_name_where_the_value_came_from():
    with pytest.raises(OptionError, match=r"^--set count=0: toy option 'count': 0 is outside"):
        parse_options(
            Toy,
            {"count": "0"},
            estimator="toy",
            sources={"count": OptionSource.command_line("--set", "count", "0")},
        )
    source = OptionSource.model_file("m/bad.toml", "toy", "count")
    with pytest.raises(ModelError, match=r"^m/bad.toml: estimators.toy.count: toy option 'count'"):
        parse_options(Toy, {"count": 0}, estimator="toy", sources={"count": source})
    unknown = OptionSource.model_file("m/bad.toml", "toy", "cnt")
    with pytest.raises(ModelError, match=r"^m/bad.toml: estimators.toy.cnt: toy has no option"):
        parse_options(Toy, {"cnt": 0}, estimator="toy", sources={"cnt": unknown})


def test_long_or_binary_values_are_quoted_short():
    with pytest.raises(OptionError) as caught:
        parse(count="\x00" * 16_000)
    message = str(caught.value)
    assert len(message) < 200 and "\n" not in message and "\\x00" in message


@pytest.mark.parametrize(
    "hint",
    [list[int], dict[str, int], int | str, int | str | None, Literal["a", 1], bytes],
)
def test_unsupported_option_types_are_refused_when_declared(hint):
    cls = dataclasses.make_dataclass("Bad", [("x", hint, option(None, "x"))], frozen=True)
    with pytest.raises(TypeError, match=r"Bad\.x"):
        parse_options(cls, {}, estimator="bad")


def test_options_must_be_frozen_and_described():
    loose = dataclasses.make_dataclass("Loose", [("x", int, option(1, "x"))])
    with pytest.raises(TypeError, match="frozen"):
        parse_options(loose, {}, estimator="loose")
    mute = dataclasses.make_dataclass("Mute", [("x", int, 1)], frozen=True)
    with pytest.raises(TypeError, match=r"Mute.x: an estimator option needs a help text"):
        describe_options(mute)


def test_description_and_text_come_from_the_one_definition():
    infos = {i.name: i for i in describe_options(Toy)}
    assert list(infos) == [f.name for f in dataclasses.fields(Toy)]
    assert (infos["count"].type, infos["count"].default, infos["count"].constraint) == (
        "int",
        3,
        "in [1, 10]",
    )
    assert infos["shape"].type == "round|square"
    assert infos["limit"].type == "float or none"
    text = format_options(describe_options(Toy)).splitlines()
    assert len(text) == len(infos)
    assert text[0].split() == ["count=3", "int,", "in", "[1,", "10]", "a", "whole", "number"]
    assert text[3].startswith('label=""') and text[5].startswith("limit=none")


@pytest.mark.parametrize("name", list(ESTIMATORS))
def test_every_option_of_every_estimator_has_one_line_help(name):
    estimator = ESTIMATORS[name]
    infos = estimator.describe_options()
    assert infos, name
    for info in infos:
        assert info.help.strip() and "\n" not in info.help and len(info.help) <= 100, info
    text = estimator.help_text()
    assert text.startswith(f"{name}: {estimator.summary}") and "needs: " in text
    for info in infos:
        assert f"\n{info.name}=" in text


@pytest.mark.parametrize("name", list(ESTIMATORS))
def test_defaults_round_trip_through_json(name):
    estimator = ESTIMATORS[name]
    defaults = estimator.options_type()
    back = json.loads(json.dumps(options_dict(defaults)))
    assert estimator.parse_options(back) == defaults
    as_text = {k: "none" if v is None else json.dumps(v).strip('"') for k, v in back.items()}
    assert estimator.parse_options(as_text) == defaults


def test_integer_options_are_real_ints():
    kmeans = ESTIMATORS["kmeans"]
    options = kmeans.parse_options({"clusters": "3", "restarts": "4", "seed": 7.0})
    assert (options.clusters, options.restarts, options.seed) == (3, 4, 7)
    assert all(type(v) is int for v in (options.clusters, options.restarts, options.seed))
    with pytest.raises(OptionError, match="kmeans option 'restarts': expected a whole number"):
        kmeans.parse_options({"restarts": "2.5"})


def test_chiu_method_choices_are_the_clustering_methods():
    hints = typing.get_type_hints(ESTIMATORS["chiu"].options_type)
    assert typing.get_args(hints["method"]) == METHODS


def test_the_estimator_reference_in_docs_is_generated_from_the_registry():
    written = (Path(__file__).resolve().parents[2] / "docs" / "estimators.md").read_text()
    assert written == reference_markdown(), (
        "run: python -m hybridlog.estimators > docs/estimators.md"
    )


@dataclass(frozen=True)
class Listed:
    rates: str = option("-1", "numbers by commas", items=float)
    lags: str = option("0,1", "whole numbers by commas", items=int)
    ids: str = option("", "ids by commas", items=str)


def test_a_list_option_takes_a_toml_array_from_a_model_file():
    sources = {k: OptionSource.model_file("m.toml", "toy", k) for k in ("rates", "lags", "ids")}
    given = {"rates": [-1, -2.5], "lags": [0, 2.0], "ids": ["b", "a"]}
    built = parse_options(Listed, given, estimator="toy", sources=sources)
    assert (built.rates, built.lags, built.ids) == ("-1.0,-2.5", "0,2", "b,a")
    one = parse_options(Listed, {"rates": -3}, estimator="toy", sources=sources)
    assert one.rates == "-3.0"
    for name, raw, why in [
        ("rates", [1, float("nan")], "item 2 of the array: expected a finite number, got 'nan'"),
        ("lags", [0, 1.5], "item 2 of the array: expected a whole number, got '1.5'"),
        ("ids", ["a", 2], "item 2 of the array: expected text (a TOML string, in quotes), got '2'"),
        ("ids", ["a,b"], "item 1 of the array: 'a,b' is no single item"),
        ("ids", 3, "expected an array of strings or their text separated by commas, got '3'"),
        ("lags", True, "expected an array of whole numbers or their text"),
    ]:
        with pytest.raises(ModelError, match=rf"^m\.toml: estimators\.toy\.{name}: toy option"):
            parse_options(Listed, {name: raw}, estimator="toy", sources=sources)
        with pytest.raises(ModelError) as caught:
            parse_options(Listed, {name: raw}, estimator="toy", sources=sources)
        assert why in str(caught.value)
    # --set keeps its text form: the text is the list
    assert parse_options(Listed, {"rates": "-1,-2"}, estimator="toy").rates == "-1,-2"
    assert describe_options(Listed)[0].type == "list of float"


def test_a_list_of_whole_numbers_reads_integral_items_alike_from_text_and_array():
    # lags = [0, 2.0] was "0,2", but --set lags=0,2.0 (and the model file's text "0,2.0")
    # reached the option's check as written and was refused ("'2.0' is not a whole number")
    file = {"lags": OptionSource.model_file("m.toml", "toy", "lags")}
    assert parse_options(Listed, {"lags": [0, 2.0]}, estimator="toy", sources=file).lags == "0,2"
    assert parse_options(Listed, {"lags": "0,2.0"}, estimator="toy", sources=file).lags == "0,2"
    for text in ("0,2.0", "0,2e0", "0.0,2", "0,2"):
        assert parse_options(Listed, {"lags": text}, estimator="toy").lags == "0,2"
    cart = load_model("double_cart_case1")
    chiu = prepare(cart, "chiu", {"output_lags": "0,1.0", "input_lags": "1e0"}).options
    assert (chiu.output_lags, chiu.input_lags) == ("0,1", "1")
    # any other item is left as written, for the option's check to refuse in its words
    assert parse_options(Listed, {"lags": "0,1.5"}, estimator="toy").lags == "0,1.5"
    with pytest.raises(OptionError, match=r"'1\.5' is not a whole number"):
        prepare(cart, "chiu", {"output_lags": "0,1.5"})


def test_the_list_options_of_the_estimators_are_marked():
    listed = {
        (name, info.name): info.type
        for name, entry in ESTIMATORS.items()
        for info in describe_options(entry.options_type)
        if info.type.startswith("list of")
    }
    assert listed == {
        ("chiu", "output_lags"): "list of int",
        ("chiu", "input_lags"): "list of int",
        ("chiu", "cluster_modes"): "list of str",
        ("kmeans", "output_lags"): "list of int",
        ("kmeans", "input_lags"): "list of int",
        ("kmeans", "cluster_modes"): "list of str",
        ("switching-observer", "eigenvalues"): "list of float",
    }


def test_items_are_declared_only_on_text_options():
    with pytest.raises(TypeError, match="items= is float, int or str, of a str option"):
        option(1.0, "a number", items=float)
