"""Signal mapping rules (SPEC §5), without files."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from hybridlog.errors import LogError, OptionError
from hybridlog.io import ReadOptions, SignalSpec, load_signals
from hybridlog.io.mapping import (
    SignalMap,
    column_topic,
    default_fields,
    parse_maps,
    resolve_signal_map,
)

SYMBOLS: dict[str, Any] = {"inputs": ("u1", "u2"), "outputs": ("y",), "states": ("h1", "h2")}


def test_parse_maps() -> None:
    parsed = parse_maps([" y = /level.data ", "truth.mode=/truth/mode.data"], **SYMBOLS)
    assert parsed == {"y": " /level.data ", "truth.mode": "/truth/mode.data"}
    fields = ("u1", "u2", "/level.data", "/truth/mode.data")
    chosen = resolve_signal_map(fields, source="log.csv", maps=parsed, **SYMBOLS)
    assert chosen.outputs == {"y": "/level.data"}


@pytest.mark.parametrize(
    ("maps", "pattern"),
    [
        (["y"], "expected SYMBOL=PATH"),
        (["=col"], "expected SYMBOL=PATH"),
        (["y="], "expected SYMBOL=PATH"),
        (["h1=col"], r"unknown symbol 'h1'; valid symbols: u1, u2, y, truth.mode, truth.h1"),
        (["truth.h3=col"], "unknown symbol 'truth.h3'"),
        (["y=a", "y=b"], "'y' is mapped twice"),
    ],
)
def test_parse_maps_rejects(maps: list[str], pattern: str) -> None:
    with pytest.raises(OptionError, match=pattern):
        parse_maps(maps, **SYMBOLS)


@pytest.mark.parametrize(
    ("maps", "pattern"),
    [
        # every message naming the path echoed it whole: --map u1=<3,000 characters> gave
        # a line cut at 1,000 in the middle of the path
        ([f"u1={'x' * 3000}"], r"^--map 'u1=x+…x+': the path has 3,000 characters; at most 255"),
        ([f"u1={'x' * 256}"], r"^--map 'u1=x+…x+': the path has 256 characters; at most 255"),
        (["x" * 3000], r"^--map 'x+…x+': expected SYMBOL=PATH"),
        ([f"{'x' * 3000}=y"], r"^--map 'x+…x+=y': unknown symbol 'x+…x+';"),
    ],
)
def test_parse_maps_rejects_a_long_path_and_shows_long_text_cut(
    maps: list[str], pattern: str
) -> None:
    with pytest.raises(OptionError, match=pattern) as refused:
        parse_maps(maps, **SYMBOLS)
    assert len(str(refused.value)) < 300


def test_resolution_order() -> None:
    fields = ("u1", "u2", "cmd2", "y", "level", "mode", "phase", "h2", "tank1")
    chosen = resolve_signal_map(
        fields,
        source="log.csv",
        signals={"u2": "cmd2", "u1": "/cmd/u1.data"},
        truth={"mode": "phase", "h1": "/truth/h1"},
        maps={"y": "level", "truth.h1": "tank1"},
        **SYMBOLS,
    )
    assert chosen == SignalMap(
        inputs={"u1": "u1", "u2": "cmd2"},
        outputs={"y": "level"},
        truth_mode="phase",
        truth_states={"h1": "tank1", "h2": "h2"},
        origins={
            "u1": "default",
            "u2": "[signals]",
            "y": "--map",
            "truth.mode": "[truth]",
            "truth.h1": "--map",
            "truth.h2": "default",
        },
    )


def test_truth_is_optional() -> None:
    chosen = resolve_signal_map(("u1", "u2", "y"), source="log.csv", **SYMBOLS)
    assert chosen.truth_mode is None
    assert chosen.truth_states == {}


def test_missing_input_names_what_was_looked_for() -> None:
    with pytest.raises(LogError) as info:
        resolve_signal_map(
            ("u_1", "u2", "y"), source="log.csv", signals={"u1": "/cmd.data"}, **SYMBOLS
        )
    message = str(info.value)
    assert message.startswith("log.csv: no column for input 'u1'")
    assert "'/cmd.data' and 'u1'" in message
    assert "closest: 'u_1'" in message


def test_mapped_truth_must_exist() -> None:
    with pytest.raises(
        LogError,
        match=r"truth.mode \(column 'phse', from --map .*\): no column 'phse'; closest: 'phase'",
    ):
        resolve_signal_map(
            ("u1", "u2", "y", "phase"), source="log.csv", maps={"truth.mode": "phse"}, **SYMBOLS
        )


def test_ground_truth_without_samples_is_no_truth_unless_mapped(tmp_path: Path) -> None:
    """An empty ``mode`` column refused the log ('truth.mode (column 'mode') has no
    samples') while an empty state column was no truth; and ``--map truth.x=x`` to an
    empty column gave a report without its RMSE instead of an error."""
    log = tmp_path / "log.csv"
    log.write_text("t,u,y,mode,x,z\n" + "".join(f"{k / 10},{k},{k},,,{k}\n" for k in range(20)))
    spec = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("a", "b"), dt=0.1, states=("x", "z"))
    notes: dict[str, Any] = {}
    aligned = load_signals(log, spec, notes=notes)
    assert aligned.truth_modes is None
    assert aligned.truth_states is not None
    assert np.isnan(aligned.truth_states[:, 0]).all()
    np.testing.assert_array_equal(aligned.truth_states[:, 1], np.arange(20))
    assert notes["truth_without_samples"] == ["truth.mode (column 'mode')", "truth.x (column 'x')"]
    for symbol, column in (("truth.mode", "mode"), ("truth.x", "x")):
        options = ReadOptions(maps=(f"{symbol}={column}",))
        with pytest.raises(LogError) as error:
            load_signals(log, spec, options)
        assert str(error.value) == (
            f"{log}: {symbol} (column {column!r}, from --map {symbol}={column}) has no samples"
        )


def test_a_state_named_like_mode_is_read_as_a_number() -> None:
    """A state ``modes``: its truth ``truth.modes`` was checked as a label (its name starts
    with ``truth.mode``), so a text field by the default name was taken and the log then
    refused as 'is a string, not a number', where a state ``x`` had no truth."""
    text = {"/truth/mode.data", "/truth/modes.data", "/truth/x.data"}
    fields = ("/u.data", "/y.data", *sorted(text))

    def explain(name: str, numeric: bool) -> str | None:
        if name not in fields:
            return f"{name!r}: no such field"
        return f"{name!r} is a string, not a number" if numeric and name in text else None

    chosen = resolve_signal_map(
        fields,
        source="log.bag",
        inputs=("u",),
        outputs=("y",),
        states=("modes", "x"),
        message_paths=True,
        explain=explain,
    )
    assert chosen.truth_mode == "/truth/mode.data"
    assert chosen.truth_states == {}


def test_a_field_emptied_by_drop_nonfinite_says_so(tmp_path: Path) -> None:
    """'output 'y' (column 'y') has no samples' of a column of three NaN and inf."""
    log = tmp_path / "log.csv"
    log.write_text("t,u,y,x,w\n0,1,nan,nan,2\n0.1,1,inf,1e500,2\n0.2,1,nan,nan,2\n")
    spec = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("a",), dt=0.1, states=("x",))
    dropped = "--drop-nonfinite dropped all 3 (NaN, infinite, or out of range: |value| >= 2^480)"
    for maps, message in (
        ((), f"output 'y' (column 'y') has no usable samples: {dropped}"),
        (("u=y", "y=u"), f"input 'u' (column 'y') has no usable samples: {dropped}"),
        (
            ("y=w", "truth.x=x"),
            f"truth.x (column 'x', from --map truth.x=x) has no usable samples: {dropped}",
        ),
    ):
        with pytest.raises(LogError) as error:
            load_signals(log, spec, ReadOptions(maps=maps, drop_nonfinite=True))
        assert str(error.value) == f"{log}: {message}"
    notes: dict[str, Any] = {}
    aligned = load_signals(log, spec, ReadOptions(maps=("y=w",), drop_nonfinite=True), notes=notes)
    assert aligned.truth_states is None
    assert notes["truth_without_samples"] == ["truth.x (column 'x')"]


def test_a_column_named_with_spaces_can_be_mapped(tmp_path: Path) -> None:
    """A header 't, u, y' named columns ' u' and ' y': the error suggested ' u', and
    --map 'u= u' was stripped to 'u', so no --map could name the column.  The names are now
    read without the spaces around them (test_io_tables.py), found by default and by --map.
    """
    log = tmp_path / "log.csv"
    log.write_text("t, u, y\n" + "".join(f"{k / 10},{k},{2 * k}\n" for k in range(10)))
    spec = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("a",), dt=0.1)
    np.testing.assert_array_equal(load_signals(log, spec).inputs[:, 0], np.arange(10))
    aligned = load_signals(log, spec, ReadOptions(maps=("u= u", "y = y")))
    np.testing.assert_array_equal(aligned.inputs[:, 0], np.arange(10))
    np.testing.assert_array_equal(aligned.outputs[:, 0], 2 * np.arange(10))
    with pytest.raises(LogError, match=r"output 'y' \(column 'z', from --map y=z\): no column 'z'"):
        load_signals(log, spec, ReadOptions(maps=("u= u", "y= z ")))


# --- default topics are ROS names (hybridlog simulate writes them so) -----------------------

_RMW_FULL_TOPIC = re.compile(r"(/[A-Za-z_][A-Za-z0-9_]*)+")  # rmw_validate_full_topic_name


@pytest.mark.parametrize(
    ("column", "truth", "topic"),
    [
        ("u1", False, "/u1"),
        ("x1", True, "/truth/x1"),
        ("mode", True, "/truth/mode"),
        ("mode.fr1", True, "/truth/mode/fr1"),
        ("mode.fr-1", True, "/truth/mode/fr_1"),
        ("mode.1st", True, "/truth/mode/_1st"),
        ("mode.fr.1", True, "/truth/mode/fr_1"),
        ("θ", True, "/truth/theta"),
        ("Ω_é", False, "/Omega_e"),
        ("温度", True, None),
    ],
)
def test_column_topics_are_ros_names(column: str, truth: bool, topic: str | None) -> None:
    assert column_topic(column, truth=truth) == topic


@given(st.text(max_size=30), st.booleans())
def test_column_topic_is_a_ros_name_or_none(column: str, truth: bool) -> None:
    topic = column_topic(column, truth=truth)
    assert topic is None or _RMW_FULL_TOPIC.fullmatch(topic) is not None


def test_default_topics_new_then_old_and_never_another_symbols() -> None:
    chosen = default_fields(
        ["u", "truth.mode.fr1", "truth.θ", "truth.φ", "truth.theta", "truth.ψ"],
        message_paths=True,
    )
    assert chosen["u"] == ("/u.data",)
    assert chosen["truth.mode.fr1"] == ("/truth/mode/fr1.data", "/truth/mode.fr1.data")
    # θ's ROS name is theta's topic: θ is looked for only where older versions wrote it
    assert chosen["truth.θ"] == ("/truth/θ.data",)
    assert chosen["truth.theta"] == ("/truth/theta.data",)
    assert chosen["truth.ψ"] == ("/truth/psi.data", "/truth/ψ.data")
    assert default_fields(["truth.mode.fr1"], message_paths=False) == {
        "truth.mode.fr1": ("mode.fr1",)
    }


def test_an_old_topic_name_is_found_when_the_new_is_missing() -> None:
    chosen = resolve_signal_map(
        ("/u.data", "/y.data", "/truth/φ.data", "/truth/mode.data"),
        source="old.mcap",
        inputs=("u",),
        outputs=("y",),
        states=("φ",),
        message_paths=True,
        field_word="field",
    )
    assert chosen.truth_states == {"φ": "/truth/φ.data"}
    newer = resolve_signal_map(
        ("/u.data", "/y.data", "/truth/φ.data", "/truth/phi.data"),
        source="new.mcap",
        inputs=("u",),
        outputs=("y",),
        states=("φ",),
        message_paths=True,
        field_word="field",
    )
    assert newer.truth_states == {"φ": "/truth/phi.data"}
