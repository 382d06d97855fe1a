"""ROS 2's ``byte`` is an octet, 0 to 255; ROS 1's is a (deprecated) ``int8``.

In ROS 2 a ``byte`` field (IDL ``octet``) is ``unsigned char`` in C++ and ``bytes`` in
Python: a ``std_msgs/msg/Byte`` of 200 is the octet 0xC8.  rosbags decodes ``byte`` as
``int8`` in both ROS versions, and the value read was -56, silently.  The bags here are
written with rosbags' writers, whose serialiser takes the octet 0xC8 as the ``int8`` -56:
the bytes a ROS 2 publisher of 200 sends.  A ROS 1 ``byte`` keeps reading as ``int8``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag1 import Writer as Ros1Writer
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Ros2Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from hybridlog.io import ReadOptions, SignalSpec, load_signals

TYPE = "tp/msg/Octets"
DEFINITION = "byte b\nbyte[] sequence\nbyte[2] pair\nchar c\nfloat64 x\n"
STEPS = 10
OCTET = 0xC8  # 200, the int8 -56


def _write(path: Path, ros: str) -> Path:
    store = get_typestore(Stores.ROS2_HUMBLE if ros != "ros1" else Stores.ROS1_NOETIC)
    store.register(get_types_from_msg(DEFINITION, TYPE))
    octets = store.types[TYPE]
    signed = OCTET - 256
    messages = [
        octets(
            b=signed if k % 2 else 5,
            sequence=np.array([signed, 7], dtype=np.int8),
            pair=np.array([1, signed], dtype=np.int8),
            c=OCTET,
            x=float(k),
        )
        for k in range(STEPS)
    ]
    if ros == "ros1":
        with Ros1Writer(path) as writer:
            connection = writer.add_connection("/o", TYPE, typestore=store)
            for k, message in enumerate(messages):
                writer.write(connection, 10**9 + k * 10**8, store.serialize_ros1(message, TYPE))
        return path
    storage = StoragePlugin.SQLITE3 if ros == "ros2-sqlite3" else StoragePlugin.MCAP
    with Ros2Writer(path, version=8, storage_plugin=storage) as writer:
        connection = writer.add_connection("/o", TYPE, typestore=store)
        for k, message in enumerate(messages):
            writer.write(connection, 10**9 + k * 10**8, store.serialize_cdr(message, TYPE))
    return path


def _read(log: Path) -> np.ndarray:
    spec = SignalSpec(inputs=("u",), outputs=("b", "s", "p", "c"), mode_ids=("1",), dt=0.1)
    maps = ("u=/o.x", "b=/o.b", "s=/o.sequence[0]", "p=/o.pair[1]", "c=/o.c")
    return load_signals(log, spec, ReadOptions(maps=maps)).outputs


@pytest.mark.parametrize("ros", ["ros2-sqlite3", "ros2-mcap"])
def test_a_ros2_byte_reads_as_an_octet(ros: str, tmp_path: Path) -> None:
    outputs = _read(_write(tmp_path / "bag", ros))
    np.testing.assert_array_equal(outputs[:, 0], np.where(np.arange(STEPS) % 2, OCTET, 5))
    np.testing.assert_array_equal(outputs[:, 1:], np.full((STEPS, 3), float(OCTET)))


def test_a_ros1_byte_still_reads_as_int8(tmp_path: Path) -> None:
    outputs = _read(_write(tmp_path / "bag.bag", "ros1"))
    signed = OCTET - 256
    np.testing.assert_array_equal(outputs[:, 0], np.where(np.arange(STEPS) % 2, signed, 5))
    np.testing.assert_array_equal(outputs[:, 1:3], np.full((STEPS, 2), float(signed)))
    np.testing.assert_array_equal(outputs[:, 3], np.full(STEPS, float(OCTET)))  # char: uint8
