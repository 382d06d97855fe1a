"""A JSON schema's ``properties`` list some of an object's keys, not all of them.

JSON Schema closes an object only with ``"additionalProperties": false``.  A topic whose
schema listed ``w`` while its messages held ``v`` too (an older schema, a logger that added
a field) had ``v`` left out of ``inspect``'s fields, and ``--map y=/y.v`` was refused with
"the message has no field 'v'; fields: 'w'", which every message contradicts.  The messages
now decide where the schema does not close the object.

What a schema says through a local ``$ref`` (``#/definitions/P``, ``#/$defs/P``) is read
too: a key ``required`` there was read from the messages that carry it, as an optional one.
A schema that is not JSON, or not an object, was passed over in silence; ``inspect`` now
says so (the messages are read as they are).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, inspect_log, load_signals
from tests.support.logfiles import Channel, write_mcap

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("a",), dt=0.1)


def _log(path: Path, schema: dict[str, Any] | str) -> Path:
    text = schema if isinstance(schema, str) else json.dumps(schema)
    channels = [
        Channel("/u", encoding="json", schema_encoding="none"),
        Channel("/y", "json", "Y", "jsonschema", text),
    ]
    messages = [
        (channel, 10**9 + k * 10**8, json.dumps(message).encode())
        for k in range(10)
        for channel, message in ((0, {"u": float(k)}), (1, {"v": -2.0 * k, "w": 1.0}))
    ]
    return write_mcap(path, channels, messages, profile="")


LISTS_W = {"type": "object", "properties": {"w": {"type": "number"}}}


def test_a_key_the_schema_does_not_list_is_listed_and_read(tmp_path: Path) -> None:
    log = _log(tmp_path / "open.mcap", LISTS_W)
    (_, topic) = inspect_log(log)["topics"]
    assert topic["fields"] == ["/y.w", "/y.v"]
    signals = load_signals(log, SPEC, ReadOptions(maps=("u=/u.u", "y=/y.v")))
    assert signals.outputs[:, 0].tolist() == [-2.0 * k for k in range(10)]


def test_a_closed_object_still_refuses_a_key_it_does_not_list(tmp_path: Path) -> None:
    log = _log(tmp_path / "closed.mcap", {**LISTS_W, "additionalProperties": False})
    with pytest.raises(LogError, match="has no field 'v'; fields: 'w'"):
        load_signals(log, SPEC, ReadOptions(maps=("u=/u.u", "y=/y.v")))
    (_, topic) = inspect_log(log)["topics"]
    assert topic["fields"] == ["/y.w"]  # not a key analyze refuses


@pytest.mark.parametrize("definitions", ["definitions", "$defs"])
def test_a_key_required_through_a_reference_is_required(definitions: str, tmp_path: Path) -> None:
    # what the schema says of ``/y.p.v`` is in the definition ``p``'s ``$ref`` names
    point = {"type": "object", "properties": {"v": {"type": "number"}}, "required": ["v"]}
    schema = {
        "type": "object",
        definitions: {"P": point},
        "properties": {"p": {"$ref": f"#/{definitions}/P"}},
    }
    channels = [
        Channel("/u", encoding="json", schema_encoding="none"),
        Channel("/y", "json", "Y", "jsonschema", json.dumps(schema)),
    ]
    messages = [
        (channel, 10**9 + k * 10**8, json.dumps(message).encode())
        for k in range(10)
        for channel, message in ((0, {"u": float(k)}), (1, {"p": {"v": 1.0} if k != 4 else {}}))
    ]
    log = write_mcap(tmp_path / "ref.mcap", channels, messages, profile="")
    with pytest.raises(LogError, match=r"no field 'v', which the topic's JSON schema lists as"):
        load_signals(log, SPEC, ReadOptions(maps=("u=/u.u", "y=/y.p.v")))


@pytest.mark.parametrize(
    ("text", "said"),
    [
        ("{not json", "its JSON schema is not JSON (Expecting property name"),
        ("[1]", "its JSON schema is a JSON array, not an object"),
        ("true", None),
    ],
)
def test_a_schema_passed_over_is_said_so(text: str, said: str | None, tmp_path: Path) -> None:
    log = _log(tmp_path / "unread.mcap", text)
    problems = inspect_log(log)["problems"]
    if said is None:
        assert problems == []
    else:
        (problem,) = problems
        assert problem.startswith(f"topic '/y' (Y): {said}")
        assert problem.endswith("passed over, the messages read as they are")
    signals = load_signals(log, SPEC, ReadOptions(maps=("u=/u.u", "y=/y.v")))
    assert signals.outputs[:, 0].tolist() == [-2.0 * k for k in range(10)]
