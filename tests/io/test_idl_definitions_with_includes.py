"""IDL message definitions as rosidl generates them, ``#include`` lines and all, are read.

rosbag2 stores a type defined in IDL as its ``.idl`` files, each in an ``IDL:`` section,
exactly as rosidl wrote them: every file that uses another type includes its file
(``#include "std_msgs/msg/Header.idl"``).  rosbags' IDL parser knows no preprocessor lines
and refused each such definition ("could not parse"), so every topic of the log was
undecodable.  The included types are sections of the same definition, so the lines are
blanked before parsing (:func:`hybridlog.io.definitions.parse_definition`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from mcap.writer import Writer as McapWriter
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as BagWriter
from rosbags.typesys import Stores, get_typestore

from hybridlog.io import ReadOptions, SignalSpec, inspect_log, load_signals

TYPE = "geometry_msgs/msg/PointStamped"
STORE = get_typestore(Stores.ROS2_HUMBLE)
GENERATED = (
    "// generated from rosidl_adapter/resource/msg.idl.em\n"
    "// with input from {name}.msg\n"
    "// generated code does not contain a copyright notice\n\n"
)
POINT_STAMPED = GENERATED.format(name=TYPE) + (
    '#include "geometry_msgs/msg/Point.idl"\n'
    '#include "std_msgs/msg/Header.idl"\n\n'
    "module geometry_msgs {\n  module msg {\n"
    '    @verbatim (language="comment", text=\n'
    '      "This represents a Point with reference coordinate frame and timestamp")\n'
    "    struct PointStamped {\n"
    "      std_msgs::msg::Header header;\n\n"
    "      geometry_msgs::msg::Point point;\n"
    "    };\n  };\n};\n"
)
POINT = GENERATED.format(name="geometry_msgs/msg/Point") + (
    "\nmodule geometry_msgs {\n  module msg {\n"
    "    struct Point {\n      double x;\n\n      double y;\n\n      double z;\n    };\n"
    "  };\n};\n"
)
HEADER = GENERATED.format(name="std_msgs/msg/Header") + (
    '#include "builtin_interfaces/msg/Time.idl"\n\n'
    "module std_msgs {\n  module msg {\n"
    '    @verbatim (language="comment", text=\n'
    '      "Standard metadata for higher-level stamped data types." "\\n"\n'
    '      "in a particular coordinate frame.")\n'
    "    struct Header {\n"
    "      builtin_interfaces::msg::Time stamp;\n\n"
    "      string frame_id;\n"
    "    };\n  };\n};\n"
)
TIME = GENERATED.format(name="builtin_interfaces/msg/Time") + (
    "\nmodule builtin_interfaces {\n  module msg {\n"
    "    struct Time {\n      int32 sec;\n\n      uint32 nanosec;\n    };\n  };\n};\n"
)
SECTIONS = (
    (TYPE, POINT_STAMPED),
    ("geometry_msgs/msg/Point", POINT),
    ("std_msgs/msg/Header", HEADER),
    ("builtin_interfaces/msg/Time", TIME),
)
DEFINITION = "".join(f"{'=' * 80}\nIDL: {name}\n{text}" for name, text in SECTIONS)
STEPS = 20


def _messages() -> list[tuple[int, str, bytes]]:
    types = STORE.types
    messages = []
    for k in range(STEPS):
        t = 10**9 + k * 10**8
        for topic, value in (("/u", float(k)), ("/y", k + 0.5)):
            message = types[TYPE](
                header=types["std_msgs/msg/Header"](
                    stamp=types["builtin_interfaces/msg/Time"](
                        sec=t // 10**9, nanosec=t % 10**9 + 1000
                    ),
                    frame_id="map",
                ),
                point=types["geometry_msgs/msg/Point"](x=value, y=0.0, z=0.0),
            )
            messages.append((t, topic, bytes(STORE.serialize_cdr(message, TYPE))))
    return messages


def _mcap(path: Path, profile: str) -> Path:
    with path.open("wb") as stream:
        writer = McapWriter(stream)
        writer.start(profile=profile, library="test")
        schema = writer.register_schema(TYPE, "ros2idl", DEFINITION.encode())
        channels = {topic: writer.register_channel(topic, "cdr", schema) for topic in ("/u", "/y")}
        for t, topic, data in _messages():
            writer.add_message(channels[topic], t, data, t)
        writer.finish()
    return path


def _bag(path: Path, storage: StoragePlugin) -> Path:
    digest = STORE.hash_rihs01(TYPE)
    with BagWriter(path, version=8, storage_plugin=storage) as writer:
        connections = {
            topic: writer.add_connection(topic, TYPE, msgdef=DEFINITION, rihs01=digest)
            for topic in ("/u", "/y")
        }
        for t, topic, data in _messages():
            writer.write(connections[topic], t, data)
    return path


@pytest.mark.parametrize(
    "log",
    ["mcap-ros2", "mcap-no-profile", "bag-sqlite3", "bag-mcap"],
)
def test_idl_definitions_with_include_lines_are_read(log: str, tmp_path: Path) -> None:
    path = {
        "mcap-ros2": lambda: _mcap(tmp_path / "idl.mcap", "ros2"),
        "mcap-no-profile": lambda: _mcap(tmp_path / "idl.mcap", ""),
        "bag-sqlite3": lambda: _bag(tmp_path / "bag", StoragePlugin.SQLITE3),
        "bag-mcap": lambda: _bag(tmp_path / "bag", StoragePlugin.MCAP),
    }[log]()
    info = inspect_log(path)
    assert not info.get("problems"), info.get("problems")
    spec = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1",), dt=0.1)
    for time in ("log", "header"):
        options = ReadOptions(maps=("u=/u.point.x", "y=/y.point.x"), time=time)
        signals = load_signals(path, spec, options)
        offset = 1000 if time == "header" else 0  # the stamps are 1 µs after the log times
        times_ns = 10**9 + np.arange(STEPS) * 10**8 + offset
        np.testing.assert_array_equal(signals.time, times_ns / 1e9)
        np.testing.assert_array_equal(signals.inputs[:, 0], np.arange(STEPS, dtype=float))
        np.testing.assert_array_equal(signals.outputs[:, 0], np.arange(STEPS) + 0.5)
