"""A JSON key (or Parquet struct field) holding ``.``, ``/``, ``[`` or ``]`` is quoted, and mapped.

An MCAP file of JSON messages ``{"a.b": 1.5, "c[0]": 2, "y": [...]}`` was listed by ``inspect``
as the fields ``/s.a.b`` and ``/s.c[0]``, and mapping what it listed was refused: "none of the
messages of topic '/s' has field 'a.b'; closest: 'a.b'" (the path read as key ``a``, then
``b``; ``c[0]`` as element 0 of ``c``).  Such a key is now listed quoted (``/s."a.b"``), a
quoted step reads the key as written, and the refusal of the unquoted path shows the quoted
spelling.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl
import pytest
from mcap.writer import Writer

from hybridlog.cli import main
from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, inspect_log, load_signals
from hybridlog.io.message_paths import format_steps, split_path

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1",), dt=1.0)
N = 12
SCHEMA = {
    "type": "object",
    "properties": {
        "a.b": {"type": "number"},
        "c[0]": {"type": "number"},
        "d/e": {"type": "number"},
        "y": {"type": "number"},
    },
}


def _write(path: Path, schema: dict[str, Any] | None) -> Path:
    with path.open("wb") as stream:
        writer = Writer(stream)
        writer.start()
        schema_id = (
            writer.register_schema("S", "jsonschema", json.dumps(schema).encode())
            if schema is not None
            else 0
        )
        channel = writer.register_channel("/s", "json", schema_id)
        for k in range(N):
            message = {"a.b": 0.5 * k, "c[0]": 2.0 * k, "d/e": -1.0 * k, "y": 10.0 + k}
            writer.add_message(channel, k * 10**9, json.dumps(message).encode(), k * 10**9)
        writer.finish()
    return path


def test_a_quoted_step_is_one_key() -> None:
    path = split_path('/s."a.b"', ["/s"])
    assert path.steps == ("a.b",)
    assert split_path('/s."c[0]"', ["/s"]).steps == ("c[0]",)
    assert format_steps(("a.b", "q", 1)) == '."a.b".q[1]'
    assert split_path('/s." u "', ["/s"]).steps == (" u ",)
    assert format_steps((" u ",)) == '." u "'


@pytest.mark.parametrize("schema", [SCHEMA, None], ids=["schema", "schemaless"])
def test_inspect_lists_such_keys_quoted(tmp_path: Path, schema: dict[str, Any] | None) -> None:
    log = _write(tmp_path / "log.mcap", schema)
    (topic,) = inspect_log(log)["topics"]
    assert {'."a.b"', '."c[0]"', '."d/e"', ".y"} <= {f.removeprefix("/s") for f in topic["fields"]}


@pytest.mark.parametrize("schema", [SCHEMA, None], ids=["schema", "schemaless"])
@pytest.mark.parametrize(("field", "scale"), [("a.b", 0.5), ("c[0]", 2.0), ("d/e", -1.0)])
def test_a_quoted_key_reads_its_values(
    tmp_path: Path, schema: dict[str, Any] | None, field: str, scale: float
) -> None:
    log = _write(tmp_path / "log.mcap", schema)
    signals = load_signals(log, SPEC, ReadOptions(maps=(f'u=/s."{field}"', "y=/s.y")))
    np.testing.assert_array_equal(signals.inputs[:, 0], scale * np.arange(N))


@pytest.mark.parametrize("schema", [SCHEMA, None], ids=["schema", "schemaless"])
def test_the_unquoted_path_is_refused_showing_the_quoted_key(
    tmp_path: Path, schema: dict[str, Any] | None
) -> None:
    log = _write(tmp_path / "log.mcap", schema)
    with pytest.raises(LogError) as info:
        load_signals(log, SPEC, ReadOptions(maps=("u=/s.a.b", "y=/s.y")))
    assert "'\"a.b\"'" in str(info.value)


def _cli(args: list[str]) -> int:
    try:
        main(args)
    except SystemExit as exit_:
        return int(exit_.code or 0)
    return 0


def test_the_cli_lists_and_reads_a_quoted_key(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = _write(tmp_path / "log.mcap", None)
    assert _cli(["inspect", str(log)]) == 0
    assert '/s."a.b"' in [line.strip() for line in capsys.readouterr().out.splitlines()]
    out = tmp_path / "out"
    maps = ['u=/s."a.b"', 'y1=/s."c[0]"', 'y2=/s."d/e"', "y3=/s.y"]
    args = ["analyze", str(log), "--model", "three_tank_hstf", "--out", str(out)]
    assert _cli(args + [arg for m in maps for arg in ("--map", m)]) == 0
    fields = json.loads((out / "report.json").read_text())["reading"]["fields"]
    assert fields["u"]["field"] == '/s."a.b"'


def test_a_parquet_struct_field_with_a_dot_is_listed_quoted_and_read(tmp_path: Path) -> None:
    log = tmp_path / "log.parquet"
    rows = [{"a.b": 0.5 * k, "y": 10.0 + k} for k in range(N)]
    pl.DataFrame({"t": np.arange(N, dtype=np.float64), "m": rows}).write_parquet(log)
    names = [column["name"] for column in inspect_log(log)["columns"]]
    assert 'm."a.b"' in names
    signals = load_signals(log, SPEC, ReadOptions(maps=('u=m."a.b"', "y=m.y")))
    np.testing.assert_array_equal(signals.inputs[:, 0], 0.5 * np.arange(N))
    with pytest.raises(LogError) as info:
        load_signals(log, SPEC, ReadOptions(maps=("u=m.a.b", "y=m.y")))
    assert "fields: '\"a.b\"'" in str(info.value)


# keys whose listed path named nothing: "" was listed /s. (refused: "cannot read '.'"),
# a"b as /s."a"b" (refused: "cannot read 'b\"'"), " as /s.""" (read as nothing either)
ODD_KEYS = ["", 'a"b', '"', "a\\b.c", '\\"']


@pytest.mark.parametrize("key", ODD_KEYS)
def test_every_key_spelled_as_a_step_reads_back_as_that_key(key: str) -> None:
    spelled = format_steps((key, "v"))
    assert split_path("/s" + spelled, ["/s"]).steps == (key, "v")


def test_a_quoted_step_written_before_escapes_reads_as_it_did() -> None:
    # a backslash before anything but " and \ is itself
    assert split_path('/s."a\\b.c"', ["/s"]).steps == ("a\\b.c",)


def test_inspect_lists_keys_with_quotes_or_empty_as_paths_that_read(tmp_path: Path) -> None:
    log = tmp_path / "log.mcap"
    with log.open("wb") as stream:
        writer = Writer(stream)
        writer.start()
        channel = writer.register_channel("/s", "json", 0)
        for k in range(N):
            message = {key: float(i * N + k) for i, key in enumerate(ODD_KEYS)} | {"y": 1.0}
            writer.add_message(channel, k * 10**9, json.dumps(message).encode(), k * 10**9)
        writer.finish()
    (topic,) = inspect_log(log)["topics"]
    listed = [f for f in topic["fields"] if f != "/s.y"]
    assert len(listed) == len(ODD_KEYS)
    for i, field in enumerate(listed):
        signals = load_signals(log, SPEC, ReadOptions(maps=(f"u={field}", "y=/s.y")))
        np.testing.assert_array_equal(signals.inputs[:, 0], i * N + np.arange(N), err_msg=field)
