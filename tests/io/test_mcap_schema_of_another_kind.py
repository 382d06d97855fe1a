"""A CDR channel whose schema in the log is not a ROS definition (jsonschema, protobuf).

rosbags cannot decode CDR without a ROS definition, so the topic is undecodable; it was
said to have "no definition in the log", of a log that holds a schema for it.  The error
now names the schema's encoding.  A standard type needs no definition from the log.
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest
from mcap.writer import Writer

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, load_signals

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1", "2"), dt=0.1)
MAPS = ("u=/u.data", "y=/y.data")


def _log(
    path: Path, type_name: str, schema_encoding: str, data: bytes = b'{"type": "object"}'
) -> Path:
    with path.open("wb") as handle:
        writer = Writer(handle)
        writer.start(profile="", library="tests")
        schema = writer.register_schema(type_name, schema_encoding, data)
        u, y = (writer.register_channel(t, "cdr", schema) for t in ("/u", "/y"))
        for k in range(20):
            for channel, value in ((u, float(k)), (y, -1.5 * k)):
                data = b"\x00\x01\x00\x00" + struct.pack("<d", value)
                writer.add_message(channel, 10**9 + k * 10**8, data, 10**9 + k * 10**8)
        writer.finish()
    return path


@pytest.mark.parametrize("kind", ["jsonschema", "protobuf"])
def test_the_schema_s_encoding_is_named(kind: str, tmp_path: Path) -> None:
    log = _log(tmp_path / "log.mcap", "my_pkg/msg/T", kind)
    with pytest.raises(LogError) as error:
        load_signals(log, SPEC, ReadOptions(maps=MAPS))
    message = str(error.value)
    assert "topic '/u' (my_pkg/msg/T)" in message and "pass --msg-dir" in message
    assert message.endswith(f"(the log's schema for it is '{kind}', not a ROS message definition)")


def test_a_binary_protobuf_schema_is_named_too(tmp_path: Path) -> None:
    """A protobuf schema is a binary FileDescriptorSet (a length of 128 or more: ``\\x95\\x01``),
    seldom UTF-8: it was "its schema is not UTF-8 text", which named no cause either."""
    data = b"\n\x95\x01\n\tT.proto\x12\x06my_pkg"
    log = _log(tmp_path / "log.mcap", "my_pkg/msg/T", "protobuf", data)
    with pytest.raises(LogError) as error:
        load_signals(log, SPEC, ReadOptions(maps=MAPS))
    message = str(error.value)
    assert "topic '/u' (my_pkg/msg/T)" in message
    assert message.endswith("(the log's schema for it is 'protobuf', not a ROS message definition)")


@pytest.mark.parametrize(
    ("kind", "data"), [("jsonschema", b'{"type": "object"}'), ("protobuf", b"\n\x95\x01\n")]
)
def test_a_standard_type_reads_whatever_its_schema(kind: str, data: bytes, tmp_path: Path) -> None:
    """A binary schema of another kind was "not UTF-8 text" of a type rosbags defines."""
    log = _log(tmp_path / "log.mcap", "std_msgs/msg/Float64", kind, data)
    signals = load_signals(log, SPEC, ReadOptions(maps=MAPS))
    np.testing.assert_array_equal(signals.outputs[:, 0], -1.5 * np.arange(20))
