"""A message that cannot be read is named by its own log time, wherever it is in the topic.

Messages are decoded a few hundred at a time inside batches of up to 65,536
(:mod:`hybridlog.io.topic_reader`); the failing message's position must survive both levels, for
every way a message can fail: undecodable bytes (rosbags refuses them), a number path, a label
path and ``header.stamp``.  Library calls on files written by the ``mcap`` library's writer.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, load_signals
from hybridlog.io.topic_reader import DECODED_AT_ONCE
from tests.support.logfiles import Channel, float64_cdr, write_mcap

COUNT = 3 * DECODED_AT_ONCE + 17
"""Messages per topic: more than three decoding chunks, the last one short."""
STEP_NS = 10_000_000
SPEC = SignalSpec(inputs=("u",), outputs=("y1", "y2"), mode_ids=("a", "b"), dt=0.01)
REQUIRED = {
    "type": "object",
    "properties": {"mode": {"type": "string"}, "level": {"type": "number"}},
    "required": ["mode", "level"],
}
"""Fields every message must carry (a JSON message without a field is otherwise no sample
of it, a sparse logger's message: ``tests/io/test_logs_sparse_json.py``)."""
JSON = Channel("/m", "json", "demo/Mode", "jsonschema", json.dumps(REQUIRED))


def _log(path: Path, channel: Channel, payload: dict[int, bytes], default: bytes) -> Path:
    """/u, /y1, /y2 (CDR Float64) and ``channel``, whose message ``k`` is ``payload.get(k)``."""
    channels: list[Channel | None] = [Channel("/u"), Channel("/y1"), Channel("/y2"), channel]
    messages = []
    for k in range(COUNT):
        t = k * STEP_NS
        messages += [(0, t, float64_cdr(1.0)), (1, t, float64_cdr(2.0)), (2, t, float64_cdr(3.0))]
        messages.append((3, t, payload.get(k, default)))
    return write_mcap(path, channels, messages, profile="", chunk_size=64 * 1024)


def _json(value: object) -> bytes:
    return json.dumps(value).encode()


def _named_time(error: LogError) -> float:
    found = re.search(r"logged at t=([0-9.]+) s", str(error))
    assert found, str(error)
    return float(found.group(1))


ROWS = [0, DECODED_AT_ONCE - 1, DECODED_AT_ONCE, 2 * DECODED_AT_ONCE + 5, COUNT - 1]


@pytest.mark.parametrize("row", ROWS)
def test_undecodable_message_is_named(row: int, tmp_path: Path) -> None:
    log = _log(
        tmp_path / "bad.mcap", Channel("/y3"), {row: b"\x00\x01\x00\x00\x01"}, float64_cdr(4.0)
    )
    with pytest.raises(LogError, match="cannot be decoded") as caught:
        load_signals(log, SPEC, ReadOptions(maps=("y2=/y3.data",)))
    assert _named_time(caught.value) == pytest.approx(row * STEP_NS / 1e9)


@pytest.mark.parametrize("row", ROWS)
@pytest.mark.parametrize(
    ("target", "bad"),
    [
        ("y2=/m.level", {"mode": "a"}),  # a number path, the message lacks a required field
        ("y2=/m.level", {"mode": "a", "level": "high"}),  # ... or holds no number there
        ("truth.mode=/m.mode", {"level": 1.0}),  # a label path, it lacks a required field
    ],
)
def test_unreadable_path_names_the_message(
    row: int, target: str, bad: dict[str, object], tmp_path: Path
) -> None:
    good = _json({"mode": "a", "level": 1.0})
    log = _log(tmp_path / "path.mcap", JSON, {row: _json(bad)}, good)
    with pytest.raises(LogError, match=re.escape(repr(target.split("=")[1]))) as caught:
        load_signals(log, SPEC, ReadOptions(maps=(target,)))
    assert _named_time(caught.value) == pytest.approx(row * STEP_NS / 1e9)


@pytest.mark.parametrize("row", ROWS)
def test_missing_header_stamp_names_the_message(row: int, tmp_path: Path) -> None:
    def stamped(k: int) -> bytes:
        stamp = {"sec": k // 100, "nsec": (k % 100) * STEP_NS}
        return _json({"header": {"stamp": stamp}, "v": 1, "w": 2, "z": 3})

    payload = {k: stamped(k) for k in range(COUNT)}
    payload[row] = _json({"header": {}, "v": 1, "w": 2, "z": 3})
    channel = Channel("/s", "json", "demo/Stamped", "jsonschema", json.dumps({"type": "object"}))
    log = _log(tmp_path / "stamp.mcap", channel, payload, b"")
    with pytest.raises(LogError, match=r"header\.stamp") as caught:
        load_signals(log, SPEC, ReadOptions(maps=("u=/s.v", "y1=/s.w", "y2=/s.z"), time="header"))
    assert _named_time(caught.value) == pytest.approx(row * STEP_NS / 1e9)


def test_values_across_chunks_are_in_order(tmp_path: Path) -> None:
    """Numbers and labels read in several chunks come back whole and in message order."""
    payload = {k: _json({"mode": "ab"[(k // 700) % 2], "level": float(k)}) for k in range(COUNT)}
    log = _log(tmp_path / "ok.mcap", JSON, payload, b"")
    signals = load_signals(log, SPEC, ReadOptions(maps=("y2=/m.level", "truth.mode=/m.mode")))
    np.testing.assert_array_equal(signals.outputs[:, 1], np.arange(COUNT, dtype=float))
    assert signals.truth_modes is not None
    expected = np.array([(k // 700) % 2 for k in range(COUNT)])
    np.testing.assert_array_equal(np.asarray(signals.truth_modes), expected)
