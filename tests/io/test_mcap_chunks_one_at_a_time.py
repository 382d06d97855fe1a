"""A chunked MCAP file read by the mcap library holds one chunk at a time.

``SeekingReader.iter_messages(log_time_order=False)`` queues each chunk's messages behind
the chunks still to read, so it read every chunk of the file before it yielded a message:
``analyze`` of a 77 MB file of 2.9·10^6 messages took 1.2 GB, ``inspect`` of a 1.9 GB file
5.1 GB.  Counted here: the chunks read when the first message comes.
"""

from __future__ import annotations

import struct
from pathlib import Path

import pytest
from mcap import records
from mcap.writer import Writer

from hybridlog.io.formats import open_log
from hybridlog.io.mcap_reader import McapSource


def chunked_mcap(path: Path, count: int) -> Path:
    with path.open("wb") as handle:
        writer = Writer(handle, chunk_size=64)
        writer.start(profile="", library="test")  # not ros2: the mcap library reads it
        schema = writer.register_schema("std_msgs/msg/Float64", "ros2msg", b"float64 data")
        channels = [writer.register_channel(topic, "cdr", schema) for topic in ("/u", "/camera")]
        for k in range(count):
            data = b"\x00\x01\x00\x00" + struct.pack("<d", float(k))
            for channel in channels:
                writer.add_message(channel, log_time=k * 10**8, data=data, publish_time=0)
        writer.finish()
    return path


def test_the_first_message_comes_after_its_chunk_alone(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    read: list[int] = []
    chunk_read = records.Chunk.read

    def counted(stream: object) -> records.Chunk:
        read.append(1)
        return chunk_read(stream)

    monkeypatch.setattr(records.Chunk, "read", staticmethod(counted))
    log = chunked_mcap(tmp_path / "log.mcap", 40)
    with open_log(log) as source:
        assert isinstance(source, McapSource)
        first = next(source._messages({"/u"}))
        assert first[:2] == ("/u", 0)
        assert len(read) == 1
        values = source.read(["/u.data"]).numeric["/u.data"].values
    assert values.tolist() == [float(k) for k in range(40)]
    assert len(read) > 20  # the file's many chunks
