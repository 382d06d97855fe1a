"""ROS 1's ``time`` and ``duration`` fields read with ROS 1's integer types.

``ros::Time`` holds ``uint32_t sec, nsec`` and ``ros::Duration`` ``int32_t sec, nsec``;
rosbags decodes both as ROS 2's ``builtin_interfaces`` types (``int32 sec, uint32
nanosec``).  ``ros::TIME_MAX`` (4294967295 s, what "never" is written as) and every stamp
past January 2038 read negative, and a duration of -5 ns read 4294967291 ns, silently.
rosbags' serialiser takes ROS 2's types, so the bits are written as their ROS 2 values here
(-1 for 4294967295 s): the bytes a ROS 1 publisher of these times sends.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from mcap.writer import Writer as McapWriter
from rosbags.rosbag1 import Writer as BagWriter
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from hybridlog.io import ReadOptions, SignalSpec, load_signals

TYPE = "tp/msg/Times"
STEPS = 10
STAMP_SEC = 2**31 + 5  # 2038-01-19T03:14:13Z


def _messages() -> tuple[list[tuple[int, bytes]], str]:
    store = get_typestore(Stores.ROS1_NOETIC)
    store.register(get_types_from_msg("Header header\ntime t\nduration d\nfloat64 x\n", TYPE))
    types = store.types
    time, duration = types["builtin_interfaces/msg/Time"], types["builtin_interfaces/msg/Duration"]
    messages = []
    for k in range(STEPS):
        message = types[TYPE](
            header=types["std_msgs/msg/Header"](
                seq=k, stamp=time(sec=STAMP_SEC - 2**32, nanosec=k * 10**8), frame_id=""
            ),
            t=time(sec=-1, nanosec=999_999_999),  # ros::TIME_MAX
            d=duration(sec=-1, nanosec=2**32 - 5),  # -1 s and -5 ns
            x=float(k),
        )
        messages.append((10**9 + k * 10**8, bytes(store.serialize_ros1(message, TYPE))))
    return messages, store.generate_msgdef(TYPE)[0]


def _bag(path: Path) -> Path:
    messages, _ = _messages()
    store = get_typestore(Stores.ROS1_NOETIC)
    store.register(get_types_from_msg("Header header\ntime t\nduration d\nfloat64 x\n", TYPE))
    with BagWriter(path) as writer:
        connection = writer.add_connection("/t", TYPE, typestore=store)
        for t, data in messages:
            writer.write(connection, t, data)
    return path


def _mcap(path: Path) -> Path:
    messages, definition = _messages()
    with path.open("wb") as stream:
        writer = McapWriter(stream)
        writer.start(profile="ros1", library="test")
        schema = writer.register_schema("tp/Times", "ros1msg", definition.encode())
        channel = writer.register_channel("/t", "ros1", schema)
        for t, data in messages:
            writer.add_message(channel, t, data, t)
        writer.finish()
    return path


@pytest.mark.parametrize("log", ["times.bag", "times.mcap"])
def test_ros1_times_read_with_ros1_integer_types(log: str, tmp_path: Path) -> None:
    path = (_bag if log.endswith(".bag") else _mcap)(tmp_path / log)
    spec = SignalSpec(inputs=("u",), outputs=("t", "d", "s"), mode_ids=("1",), dt=0.1)
    maps = ("u=/t.x", "t=/t.t.sec", "d=/t.d.nanosec", "s=/t.header.stamp.sec")
    outputs = load_signals(path, spec, ReadOptions(maps=maps)).outputs
    np.testing.assert_array_equal(outputs, np.tile([2.0**32 - 1, -5.0, STAMP_SEC], (STEPS, 1)))
    stamped = load_signals(path, spec, ReadOptions(maps=maps, time="header"))
    np.testing.assert_array_equal(stamped.time, STAMP_SEC + np.arange(STEPS) / 10)
