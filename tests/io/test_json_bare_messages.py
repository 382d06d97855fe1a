"""A JSON topic whose messages are bare values (``1.5``, not ``{"v": 1.5}``) is named so.

Schemaless JSON channels (schema id 0) may carry any JSON value.  Such a topic was listed
with its count and no field, no problem said; mapping a field of it said "the message has
no field 'v'; the log has none", as if the messages were objects without keys.  A bare
value is now refused where it is decoded, naming the topic, the message's time and what it
is; a top-level array is still read by index.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, inspect_log, load_signals
from tests.support.logfiles import Channel, write_mcap

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("a",), dt=0.1)
SCHEMALESS = [
    Channel("/u", encoding="json", schema_encoding="none"),
    Channel("/y", encoding="json", schema_encoding="none"),
]


def _log(path: Path, y_message: object) -> Path:
    messages = [
        (channel, 10**9 + k * 10**8, json.dumps(message).encode())
        for k in range(10)
        for channel, message in ((0, {"v": float(k)}), (1, y_message))
    ]
    return write_mcap(path, SCHEMALESS, messages, profile="")


@pytest.mark.parametrize(
    ("message", "kind"), [(2.5, "number"), ("2.5", "string"), (True, "boolean"), (None, "null")]
)
def test_bare_values_are_refused_naming_the_topic_and_what_they_are(
    message: object, kind: str, tmp_path: Path
) -> None:
    log = _log(tmp_path / "bare.mcap", message)
    why = f"the message is a bare {kind}, not a JSON object or array"
    (problem,) = inspect_log(log)["problems"]
    assert problem.startswith("topic '/y' (no type): the message logged at t=1 s cannot be")
    assert why in problem
    with pytest.raises(LogError, match=rf"topic '/y' .*t=1 s cannot be decoded \({why}"):
        load_signals(log, SPEC, ReadOptions(maps=("u=/u.v", "y=/y.v")))


def test_a_top_level_array_is_still_read_by_index(tmp_path: Path) -> None:
    log = _log(tmp_path / "array.mcap", [3.5, -1.0])
    assert inspect_log(log)["problems"] == []
    signals = load_signals(log, SPEC, ReadOptions(maps=("u=/u.v", "y=/y[0]")))
    assert signals.outputs[:, 0].tolist() == [3.5] * 10
