"""A ROS 1 bag's index is read for the topics read only, in rosbags' own order.

rosbags' reader made an index entry (three Python integers) for every message of the bag
when it opened it: a 3.8 GB bag of 4.4·10^6 messages, eight of its 32 topics mapped, took
7.4 s and 761 MB before a message was read.  Counted here: the entries made.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from rosbags.rosbag1 import Reader, Writer
from rosbags.rosbag1 import reader as rosbags_reader
from rosbags.typesys import Stores, get_typestore

from hybridlog.io import ros1_index
from hybridlog.io.formats import open_log

STORE = get_typestore(Stores.ROS1_NOETIC)
FLOAT64 = "std_msgs/msg/Float64"


def float64(value: float) -> bytes:
    message = STORE.types[FLOAT64](data=value)
    return bytes(STORE.serialize_ros1(message, FLOAT64))


def write_bag(path: Path, messages: list[tuple[str, int, float]]) -> Path:
    with Writer(path) as writer:
        writer.chunk_threshold = 256  # several chunks
        connections: dict[str, Any] = {}
        for topic, time_ns, value in messages:
            if topic not in connections:
                connections[topic] = writer.add_connection(topic, FLOAT64, typestore=STORE)
            writer.write(connections[topic], time_ns, float64(value))
    return path


def test_entries_are_made_for_the_topics_read_only(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    made: list[int] = []

    class Counted(rosbags_reader.IndexData):
        def __new__(cls, *entry: int) -> Any:
            made.append(entry[0])
            return super().__new__(cls, *entry)

    monkeypatch.setattr(rosbags_reader, "IndexData", Counted)
    monkeypatch.setattr(ros1_index, "IndexData", Counted)
    messages = [("/u", k * 10**9, float(k)) for k in range(10)]
    messages += [("/camera", k * 10**7, 0.0) for k in range(1000)]
    log = write_bag(tmp_path / "log.bag", sorted(messages, key=lambda m: m[1]))
    with open_log(log) as source:
        assert source.topics["/camera"].count == 1000  # counted without an entry
        series = source.read(["/u.data"]).numeric["/u.data"]
    assert series.values.tolist() == [float(k) for k in range(10)]
    assert len(made) == 10


def test_messages_come_in_the_order_rosbags_gives(tmp_path: Path) -> None:
    # out of time order within a topic, equal times across topics and within one
    messages = [("/a", 5, 1.0), ("/b", 5, 2.0), ("/a", 3, 3.0), ("/b", 1, 4.0), ("/a", 5, 5.0)]
    messages += [("/a", 9 - k % 7, float(k)) for k in range(60)]
    messages += [("/b", k % 4, float(k)) for k in range(60)]
    log = write_bag(tmp_path / "log.bag", messages)

    def read(kind: type[Reader], topics: set[str]) -> list[tuple[str, int, bytes]]:
        with kind(log) as reader:
            chosen = [c for c in reader.connections if c.topic in topics]
            return [(c.topic, t, data) for c, t, data in reader.messages(chosen)]

    for topics in ({"/a"}, {"/a", "/b"}):
        assert read(ros1_index.Ros1Reader, topics) == read(Reader, topics)
    with ros1_index.Ros1Reader(log) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        assert len(reader.chunk_infos) > 2
    assert counts == {"/a": 63, "/b": 62}
