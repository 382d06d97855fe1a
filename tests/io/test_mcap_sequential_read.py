"""The sequential read of an MCAP file (``--recover``, unfinished files): its data section only.

Found by comparing ``--recover`` with an independent reference (the ``mcap`` library's
``StreamReader`` up to the first bad record, its messages written again into a whole file
and read normally) on 3,000 damaged copies of the sample logs and of files the ``mcap``
writer made chunked, unchunked, lz4 and zstd:

- a damaged summary section (a flipped byte under its CRC, an offset outside the file)
  refused the whole file, ``--recover`` too, although its data section, every message, was
  whole: ``--recover`` now reads it, and the refusal without it says so;
- the sequential read went on past the data section's end into the summary, whose repeated
  channels replaced the data section's (a flipped byte there turned ``cdr`` into ``cdv``);
- a message naming a channel not recorded before it (a flipped id) ended the messages read
  for the estimate there, while ``messages_readable`` counted on past it and ``stopped_at``
  said the data section ended: the report claimed 2,408 messages read where 917 were.
"""

from __future__ import annotations

import io
import struct
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.writer import Writer

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, inspect_log, load_signals
from hybridlog.io.mcap_reader import UnfinishedLogError
from hybridlog.model.cache import load_model
from tests.support.paths import SAMPLE_LOGS

SAMPLE = SAMPLE_LOGS / "three_tank_hstf.mcap"
FOOTER = 1 + 8 + 8 + 8 + 4  # opcode, length, summary start, summary offset start, CRC


@pytest.fixture(scope="module")
def spec() -> SignalSpec:
    return SignalSpec.of(load_model("three_tank_hstf"))


def read(path: Path, spec: SignalSpec, recover: bool) -> tuple[Any, dict[str, Any]]:
    notes: dict[str, Any] = {}
    return load_signals(path, spec, ReadOptions(recover=recover), notes=notes), notes


def same(a: Any, b: Any) -> None:
    for name in ("time", "inputs", "outputs", "truth_modes", "truth_states"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


def rewritten(path: Path, **writer_options: Any) -> bytes:
    """The sample's messages written again by the ``mcap`` writer with ``writer_options``."""
    buffer = io.BytesIO()
    writer = Writer(buffer, **writer_options)
    writer.start(profile="ros2", library="tests")
    with SAMPLE.open("rb") as handle:
        reader = make_reader(handle)
        summary = reader.get_summary()
        assert summary is not None
        schemas = {
            s.id: writer.register_schema(s.name, s.encoding, s.data)
            for s in summary.schemas.values()
        }
        channels = {
            c.id: writer.register_channel(
                c.topic, c.message_encoding, schemas[c.schema_id], c.metadata
            )
            for c in summary.channels.values()
        }
        for _, channel, message in reader.iter_messages(log_time_order=False):
            writer.add_message(
                channels[channel.id], message.log_time, message.data, message.publish_time
            )
    writer.finish()
    path.write_bytes(buffer.getvalue())
    return buffer.getvalue()


def summary_start(data: bytes) -> int:
    start: int = struct.unpack_from("<Q", data, len(data) - 8 - FOOTER + 9)[0]
    return start


@pytest.mark.parametrize("damage", ["summary byte", "summary offset"])
def test_a_damaged_summary_is_read_with_recover_and_said_so_without(
    damage: str, tmp_path: Path, spec: SignalSpec
) -> None:
    whole = tmp_path / "whole.mcap"
    data = bytearray(rewritten(whole, chunk_size=4000))
    start = summary_start(bytes(data))
    if damage == "summary byte":
        data[start + 40] ^= 0x10  # under the summary CRC
        finding = "damaged MCAP summary section (CRC mismatch: stored 0x"
    else:  # the footer's summary start, beyond the file's end
        struct.pack_into("<Q", data, len(data) - 8 - FOOTER + 9, len(data) * 2)
        finding = f"damaged MCAP summary section (its footer's summary offset {len(data) * 2} is"
    damaged = tmp_path / "damaged.mcap"
    damaged.write_bytes(bytes(data))

    with pytest.raises(UnfinishedLogError) as refusal:
        read(damaged, spec, recover=False)
    message = str(refusal.value)
    assert message.startswith(f"{damaged}: {finding}") and "\n" not in message, message
    assert message.endswith(
        "2408 messages are readable, up to the end of the data section; --recover analyses them"
    ), message

    recovered, notes = read(damaged, spec, recover=True)
    same(recovered, read(whole, spec, recover=False)[0])
    assert notes["messages_readable"] == 2408
    assert notes["stopped_at"] == "the end of the data section"


def test_the_summary_s_channels_do_not_replace_the_data_section_s(
    tmp_path: Path, spec: SignalSpec
) -> None:
    """A summary without CRC whose repeated channel says ``cdv``: the data section's rules."""
    whole = tmp_path / "whole.mcap"
    data = bytearray(rewritten(whole, chunk_size=4000))
    start = summary_start(bytes(data))
    at = data.index(b"cdr", start)
    data[at + 2 : at + 3] = b"v"
    struct.pack_into("<I", data, len(data) - 8 - 4, 0)  # no summary CRC: nothing to tell
    damaged = tmp_path / "damaged.mcap"
    damaged.write_bytes(bytes(data))
    recovered, notes = read(damaged, spec, recover=True)
    same(recovered, read(whole, spec, recover=False)[0])
    assert notes["messages_readable"] == 2408


def test_a_message_of_a_channel_never_recorded_ends_the_read_for_every_count(
    tmp_path: Path, spec: SignalSpec
) -> None:
    whole = tmp_path / "whole.mcap"
    data = bytearray(rewritten(whole, use_chunking=False))
    # the 918th message record (opcode 0x05): its channel id, the first field, made 262
    at = 8
    messages = 0
    while True:
        opcode, length = struct.unpack_from("<BQ", data, at)
        if opcode == 0x05:
            messages += 1
            if messages == 918:
                struct.pack_into("<H", data, at + 9, 262)
                break
        at += 9 + length
    damaged = tmp_path / "damaged.mcap"
    damaged.write_bytes(bytes(data))
    recovered, notes = read(damaged, spec, recover=True)
    assert notes["messages_readable"] == 917
    assert notes["stopped_at"] == "a damaged record ('no channel record found with id 262')"
    assert recovered.time[-1] == 114.0  # message 918 is at 114.5 s: the read stopped there
    with pytest.raises(LogError, match="no channel record found with id 262"):
        read(damaged, spec, recover=False)


def test_a_channel_naming_a_schema_never_recorded_is_refused_naming_its_topic(
    tmp_path: Path,
) -> None:
    # the mcap writer takes any schema id: a recorder that numbered its schemas wrongly
    path = tmp_path / "unknown_schema.mcap"
    with path.open("wb") as handle:
        writer = Writer(handle)
        writer.start(profile="", library="tests")
        channel = writer.register_channel("/odom", "ros1", 42)
        writer.add_message(channel, 10**9, struct.pack("<d", 1.0), 10**9)
        writer.finish()
    with pytest.raises(LogError, match=r"schema record found with id 42, .* topic '/odom' names"):
        inspect_log(path)
