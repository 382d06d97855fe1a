"""Topics whose names start alike: fields listed as ``--map`` takes them, at any topic count.

A recorder's ``/imu`` beside ``/imu_raw`` (``/odom`` beside ``/odometry``, ``/t1`` beside
``/t10``) made ``inspect`` list every array field of the shorter topic with its topic in
quotes (``"/imu".orientation_covariance[]``), as if another topic read it: the check of
which topic ``--map`` reads a path on was given the listed ``[]``, which is no index, and
took the failed parse for another topic.  The same check compared each such topic with every
other, and the MCAP reader looked each message's topic up in a list of the topics read: a
file of 20,000 topics took 50 s to inspect.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import hybridlog.io.message_topics as message_topics
from hybridlog.io import ReadOptions, inspect_log, open_log
from hybridlog.io.message_paths import MessagePath
from tests.support.logfiles import NS, ros2_store

STEPS = 5


def imu_bag(path: Path, storage: str) -> Path:
    """``/imu`` and ``/imu_raw`` (``sensor_msgs/msg/Imu``), covariance[0] = k and -k."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    store = ros2_store()
    types = store.types
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    with Writer(path, version=8, storage_plugin=plugin) as writer:
        connections = {
            name: writer.add_connection(name, "sensor_msgs/msg/Imu", typestore=store)
            for name in ("/imu", "/imu_raw")
        }
        for k in range(STEPS):
            t = NS + k * NS // 10
            stamp = types["builtin_interfaces/msg/Time"](sec=t // NS, nanosec=t % NS)
            vector = types["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
            for sign, name in ((1, "/imu"), (-1, "/imu_raw")):
                covariance = np.array([float(sign * k)] + [0.0] * 8)
                message = types["sensor_msgs/msg/Imu"](
                    header=types["std_msgs/msg/Header"](stamp=stamp, frame_id="imu"),
                    orientation=types["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
                    orientation_covariance=covariance,
                    angular_velocity=vector,
                    angular_velocity_covariance=np.zeros(9),
                    linear_acceleration=vector,
                    linear_acceleration_covariance=np.zeros(9),
                )
                data = store.serialize_cdr(message, "sensor_msgs/msg/Imu")
                writer.write(connections[name], t, bytes(data))
    return path


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_array_fields_of_a_topic_another_extends_are_listed_plainly(
    storage: str, tmp_path: Path
) -> None:
    log = imu_bag(tmp_path / "bag", storage)
    info = inspect_log(log)
    listed = {t["name"]: t["fields"] for t in info["topics"]}
    quoted = [f for fields in listed.values() for f in fields if f.startswith('"')]
    assert quoted == []
    assert "/imu.orientation_covariance[]" in listed["/imu"]
    assert "/imu_raw.orientation_covariance[]" in listed["/imu_raw"]
    names = [v["name"] for t in info["topics"] for v in t["values"]]
    assert "/imu.orientation_covariance[]" in names
    with open_log(log, ReadOptions()) as source:
        assert "/imu.orientation_covariance[]" in source.fields()
        reading = source.read(
            ["/imu.orientation_covariance[0]", "/imu_raw.orientation_covariance[0]"]
        )
    assert reading.numeric["/imu.orientation_covariance[0]"].values.tolist() == list(range(STEPS))
    assert reading.numeric["/imu_raw.orientation_covariance[0]"].values.tolist() == [
        -k for k in range(STEPS)
    ]


def test_a_path_two_nested_topics_make_is_still_quoted() -> None:
    # '/a' + '.b[]' and '/a.b' + '[]' spell one path: both keep their topic in quotes
    shared = message_topics.shared_paths({"/a": [".b[]", ".c"], "/a.b": ["[]"]})
    assert shared == {"/a.b[]"}
    assert message_topics.spelt_path("/a", ".b[]", shared) == '"/a".b[]'
    assert message_topics.spelt_path("/a.b", "[]", shared) == '"/a.b"[]'
    assert message_topics.spelt_path("/a", ".c", shared) == "/a.c"


def test_which_topic_reads_a_path_is_found_among_the_topics_that_start_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Topics ``/t0`` ... ``/t1999``: each check is given the topics its path can start with."""
    seen: list[int] = []
    split = message_topics.split_paths

    def counting(text: str, topics: Any) -> list[MessagePath]:
        seen.append(len(topics))
        return split(text, topics)

    monkeypatch.setattr(message_topics, "split_paths", counting)
    count = 2000
    shared = message_topics.shared_paths({f"/t{i}": [".v", ".w[]"] for i in range(count)})
    assert shared == set()
    # /t1 is extended by /t10 ... /t1999 (1111 topics), /t10 by 111 ...: 6,000 in all,
    # where comparing each path with every topic made 4.4 million
    assert 0 < sum(seen) <= 10 * count


def test_an_mcap_reader_looks_topics_up_in_a_set(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """Readers test ``channel.topic in topics`` per message or channel: a list made it quadratic.

    A chunked file is read chunk by chunk by ``_chunked_messages``, others by the library.
    """
    from mcap.reader import SeekingReader
    from mcap.writer import Writer

    from hybridlog.io import mcap_reader

    log = tmp_path / "many.mcap"
    with log.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="", library="test")
        schema = writer.register_schema("Any", "jsonschema", b"{}")
        for i in range(50):
            channel = writer.register_channel(f"/t{i}", "json", schema)
            writer.add_message(channel, i, json.dumps({"v": i}).encode(), i)
        writer.finish()
    given: list[Any] = []
    iterate = SeekingReader.iter_messages

    def recording(self: SeekingReader, topics: Any = None, **options: Any) -> Any:
        given.append(topics)
        return iterate(self, topics, **options)

    chunked = mcap_reader._chunked_messages

    def chunks_recording(handle: Any, summary: Any, topics: Any) -> Any:
        given.append(topics)
        return chunked(handle, summary, topics)

    monkeypatch.setattr(SeekingReader, "iter_messages", recording)
    monkeypatch.setattr(mcap_reader, "_chunked_messages", chunks_recording)
    info = inspect_log(log)
    assert info["messages"] == 50 and len(info["topics"]) == 50
    assert given and all(isinstance(t, (set, frozenset)) for t in given)
