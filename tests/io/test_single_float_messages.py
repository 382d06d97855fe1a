"""``std_msgs/Float64`` topics read a batch at a time (``io/fixed_messages.py``), bit for bit.

rosbags' deserialiser was called once per message for topics whose messages are each one
``float64`` at a fixed place, about a third of the reading of a log of such topics; a batch
of them is now one NumPy array.  The numbers are rosbags' own bits (NaN payload, -0.0,
subnormals, infinities), and a batch with a message of another layout (big-endian, padded,
short) goes through the deserialiser as before: read as rosbags reads it, or named.
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag1 import Writer as Ros1Writer
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.store import Typestore

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, load_signals, topic_reader

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1", "2"), dt=0.1)
MAPS = ("u=/u.data", "y=/y.data")
NAN_WITH_PAYLOAD = struct.unpack("<d", struct.pack("<Q", 0x7FF8_0000_DEAD_BEEF))[0]
SPECIAL = [-0.0, 5e-324, 1.7976931348623157e308, float("inf"), NAN_WITH_PAYLOAD, 0.1]
N = 20
U = [float(k) for k in range(N)]
Y = [SPECIAL[k % len(SPECIAL)] if k % 3 else 0.5 * k for k in range(N)]


def _bits(values: np.ndarray | list[float]) -> list[int]:
    bits: list[int] = (
        np.ascontiguousarray(values, dtype=np.float64).view(np.uint64).ravel().tolist()
    )
    return bits


def _ros2_bag(folder: Path, y_data: list[bytes] | None = None) -> Path:
    store = get_typestore(Stores.ROS2_HUMBLE)
    number = store.types["std_msgs/msg/Float64"]
    writer = Writer(folder, version=8, storage_plugin=StoragePlugin.MCAP)
    with writer:
        u, y = (
            writer.add_connection(t, "std_msgs/msg/Float64", typestore=store) for t in ("/u", "/y")
        )
        for k in range(N):
            time = 1_000_000_000 + k * 100_000_000
            writer.write(u, time, store.serialize_cdr(number(data=U[k]), "std_msgs/msg/Float64"))
            data = store.serialize_cdr(number(data=Y[k]), "std_msgs/msg/Float64")
            writer.write(y, time, bytes(data) if y_data is None else y_data[k])
    return folder


def _ros1_bag(path: Path) -> Path:
    store = get_typestore(Stores.ROS1_NOETIC)
    number = store.types["std_msgs/msg/Float64"]
    with Ros1Writer(path) as writer:
        u, y = (
            writer.add_connection(t, "std_msgs/msg/Float64", typestore=store) for t in ("/u", "/y")
        )
        for k in range(N):
            time = 1_000_000_000 + k * 100_000_000
            writer.write(u, time, store.serialize_ros1(number(data=U[k]), "std_msgs/msg/Float64"))
            writer.write(y, time, store.serialize_ros1(number(data=Y[k]), "std_msgs/msg/Float64"))
    return path


def _read_both_ways(log: Path, monkeypatch: pytest.MonkeyPatch) -> tuple[list[str], list[int]]:
    """The deserialiser's calls and the signals' bits; asserts they match the old reading's."""
    options = ReadOptions(maps=MAPS, drop_nonfinite=True)
    with monkeypatch.context() as old:
        old.setattr(topic_reader, "single_floats", lambda *args: None)  # message by message
        before = load_signals(log, SPEC, options)
    calls = _counting(monkeypatch)
    signals = load_signals(log, SPEC, options)
    for new, old_values in ((signals.inputs, before.inputs), (signals.outputs, before.outputs)):
        assert _bits(new) == _bits(old_values)
    return calls, _bits(signals.outputs)


def _counting(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """Record each call of rosbags' deserialisers (CDR and ROS 1) by the message type."""
    calls: list[str] = []
    for name in ("deserialize_cdr", "deserialize_ros1"):
        original = getattr(Typestore, name)

        def counted(self: Typestore, rawdata: bytes, typename: str, _f=original) -> object:
            calls.append(typename)
            return _f(self, rawdata, typename)

        monkeypatch.setattr(Typestore, name, counted)
    return calls


@pytest.mark.parametrize("kind", ["ros2-mcap", "ros1-bag"])
def test_float64_topics_are_read_without_the_deserialiser(
    kind: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    log = _ros2_bag(tmp_path / "bag") if kind == "ros2-mcap" else _ros1_bag(tmp_path / "a.bag")
    calls, _ = _read_both_ways(log, monkeypatch)
    assert calls == []  # each message was deserialised before


def test_another_layout_in_a_batch_is_deserialised_as_before(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    store = get_typestore(Stores.ROS2_HUMBLE)
    little = [
        bytes(
            store.serialize_cdr(store.types["std_msgs/msg/Float64"](data=v), "std_msgs/msg/Float64")
        )
        for v in Y
    ]
    mixed = list(little)
    mixed[4] = b"\x00\x00\x00\x00" + struct.pack(">d", Y[4])  # big-endian CDR
    mixed[7] = little[7] + b"\x00"  # padded by one byte, which rosbags accepts
    calls, _ = _read_both_ways(_ros2_bag(tmp_path / "bag", mixed), monkeypatch)
    assert calls.count("std_msgs/msg/Float64") == N  # /y's batch, message by message

    short = list(little)
    short[5] = little[5][:10]
    with pytest.raises(LogError, match=r"topic '/y'.*t=1\.5 s cannot be decoded"):
        load_signals(_ros2_bag(tmp_path / "short", short), SPEC, ReadOptions(maps=MAPS))
