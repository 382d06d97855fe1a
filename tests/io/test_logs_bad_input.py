"""Bad logs, each a real file: exit code 2, one line naming the problem, no output directory.

Every case runs ``hybridlog analyze`` through ``main`` (the error → exit-code mapping) on a
file written by a real writer and then damaged the way logs get damaged: cut off, recorder
killed, bytes flipped, index records lost, definitions missing.
"""

from __future__ import annotations

import gc
import json
import os
import sqlite3
import struct
import sys
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from hybridlog.cli import main
from hybridlog.errors import LogError
from hybridlog.io import inspect_log
from hybridlog.io.bag_writers import write_log
from tests.support.logfiles import (
    Channel,
    Record,
    drop_chunk_index,
    find,
    flip_byte,
    float64_cdr,
    float_messages,
    header_scene_records,
    statistics_of,
    tank_run,
    write_mcap,
    write_mcap_json,
    write_msg_dir,
)


def run(args: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    capsys.readouterr()
    try:
        main(args)
        code = 0
    except SystemExit as exit_:
        code = int(exit_.code or 0)
    return code, capsys.readouterr().err


def refused(
    log: Path, capsys: pytest.CaptureFixture[str], *fragments: str, extra: tuple[str, ...] = ()
) -> str:
    """Analyse ``log`` and check the refusal: exit 2, one line, the fragments, no output."""
    out = log.parent / "report_out"
    code, err = run(
        ["analyze", str(log), "--model", "three_tank_hstf", "--out", str(out), *extra], capsys
    )
    assert code == 2, err
    assert err.count("\n") == 1 and err.startswith("hybridlog: error: "), err
    assert "Traceback" not in err
    for fragment in fragments:
        assert fragment in err, (fragment, err)
    assert not out.exists()
    assert not list(log.parent.glob(".report_out*"))
    return err


def accepted(log: Path, capsys: pytest.CaptureFixture[str], *extra: str) -> dict[str, Any]:
    out = log.parent / "report_ok"
    code, err = run(
        ["analyze", str(log), "--model", "three_tank_hstf", "--out", str(out), *extra], capsys
    )
    assert code == 0, err
    report: dict[str, Any] = json.loads((out / "report.json").read_text())
    return report


def simulated(path: Path, **options: Any) -> Path:
    return write_log(path, tank_run().columns, truth=("mode", "x1", "x2", "x3"), **options)


def killed_recording(
    path: Path, *, profile: str = "ros2", keep: int = 4, finish: bool = False
) -> Path:
    """An MCAP whose recorder died: chunks flushed, no summary and no footer."""
    run_ = tank_run()
    columns = run_.columns
    channels = [Channel(f"/{name}") for name in ("u", "y1", "y2", "y3")]
    times = run_.time_ns.tolist()
    messages = []
    for k, t in enumerate(times[: keep * 10]):
        for j, name in enumerate(("u", "y1", "y2", "y3")):
            messages.append((j, t, float64_cdr(float(columns[name][k]))))
    return write_mcap(path, channels, messages, profile=profile, chunk_size=2000, finish=finish)


# ------------------------------------------------------------------ MCAP framing


def test_truncated_mcap_is_refused_with_the_readable_count_and_recovered_on_request(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = killed_recording(tmp_path / "cut.mcap", keep=9, finish=True)
    data = log.read_bytes()
    log.write_bytes(data[: len(data) // 3])
    err = refused(log, capsys, "unfinished MCAP file", "messages are readable", "--recover")
    readable = int(err.split(");")[1].split("messages")[0])
    assert 0 < readable < 360
    report = accepted(log, capsys, "--recover")
    assert report["reading"]["recovered"] is True
    assert report["reading"]["messages_readable"] == readable
    assert "cut off" in report["reading"]["stopped_at"]
    assert 0 < report["samples"] <= readable // 4


def test_killed_recorder_is_refused_and_recovered(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = killed_recording(tmp_path / "killed.mcap")
    refused(log, capsys, "unfinished MCAP file", "no closing magic", "160 messages are readable")
    report = accepted(log, capsys, "--recover")
    assert report["reading"]["messages_readable"] == 160
    assert report["samples"] == 40
    assert report["modes"]["accuracy"] is None  # no truth topics were recorded


def test_inspect_shows_what_an_unfinished_mcap_holds(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = killed_recording(tmp_path / "killed.mcap")
    capsys.readouterr()
    main(["inspect", str(log), "--json"])  # returns: inspect describes, it does not refuse
    info = json.loads(capsys.readouterr().out)
    assert info["messages"] == 160
    assert [t["count"] for t in info["topics"]] == [40, 40, 40, 40]
    assert any("unfinished MCAP file" in p for p in info["problems"])
    assert info["reading"]["recovered"] is True


@pytest.mark.parametrize("name", ["empty.mcap", "empty.bag", "empty.db3", "empty.csv"])
def test_empty_files(name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / name
    log.write_bytes(b"")
    refused(log, capsys, name, "empty file")


@pytest.mark.parametrize("profile", ["ros2", ""])
def test_a_log_time_beyond_int64_names_the_topic(
    profile: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """MCAP log times are uint64: one past 2^63 was an unexpected OverflowError."""
    run_ = tank_run()
    channels = [Channel(f"/{name}") for name in ("u", "y1", "y2", "y3")]
    messages = [
        (j, t if (k, j) != (7, 1) else 2**64 - 1, float64_cdr(float(run_.columns[name][k])))
        for k, t in enumerate(run_.time_ns.tolist())
        for j, name in enumerate(("u", "y1", "y2", "y3"))
    ]
    log = write_mcap(tmp_path / "late.mcap", channels, messages, profile=profile)
    refused(log, capsys, "topic '/y1': a message's log time, 18446744073709551615 ns, is after")


@pytest.mark.parametrize("name", ["pipe.csv", "pipe.mcap"])
def test_a_pipe_is_refused_at_once_not_waited_on(
    name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Opening a FIFO blocks until a writer comes: hybridlog hung; a batch hashed it first."""
    from hybridlog.jobs.batch import run_batch

    log = tmp_path / name
    os.mkfifo(log)
    refused(log, capsys, name, "not a regular file (a pipe, device or socket)")
    (tmp_path / "zero.csv").symlink_to("/dev/zero")
    refused(tmp_path / "zero.csv", capsys, "zero.csv: not a regular file")
    outcome = run_batch([log], "three_tank_hstf", out_dir=tmp_path / "batch", estimator="imm")
    (failed,) = outcome.logs
    assert failed.status == "failed" and "not a regular file" in (failed.error or "")


@pytest.mark.parametrize(
    ("name", "kind"),
    [
        ("junk.mcap", "an MCAP file"),
        ("junk.bag", "a ROS 1 bag"),
        ("junk.db3", "a ROS 2 sqlite3 bag"),
    ],
)
def test_wrong_magic(
    name: str, kind: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = tmp_path / name
    log.write_bytes(b"this is not a log file at all\n" * 10)
    refused(log, capsys, f"not {kind} (wrong magic bytes)")


def test_mcap_content_under_another_suffix_is_read_as_mcap(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = simulated(tmp_path / "run.mcap")
    renamed = log.rename(tmp_path / "run.bag")
    assert accepted(renamed, capsys)["samples"] == 91


# ------------------------------------------------------------------ CRCs and indexes


def _crc_damaged(path: Path, profile: str) -> Path:
    times = list(range(0, 91 * 10**9, 10**9))
    values = np.linspace(0.0, 9.0, 91)
    channels = [Channel("/u"), Channel("/y1"), Channel("/y2"), Channel("/y3")]
    messages = []
    for t, v in zip(times, values, strict=True):
        messages += [(j, t, float64_cdr(float(v))) for j in range(4)]
    if profile == "":
        channels = [
            Channel(c.topic, "json", "std_msgs/msg/Float64", "jsonschema", "{}") for c in channels
        ]
        messages = [(j, t, json.dumps({"data": 1.0}).encode()) for j, t, _ in messages]
    write_mcap(path, channels, messages, profile=profile, chunk_size=4000)
    flip_byte(path, find(path, b"\x05", find(path, b"\x06", 8) + 60) + 30)  # inside a chunk
    return path


@pytest.mark.parametrize("profile", ["ros2", ""])
def test_chunk_crc_mismatch_is_caught(
    profile: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = _crc_damaged(tmp_path / "crc.mcap", profile)
    refused(log, capsys, "CRC mismatch")


def test_data_section_crc_mismatch_is_caught(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = simulated(tmp_path / "data.mcap")  # hybridlog writes data-section CRCs
    flip_byte(log, 200)
    refused(log, capsys, "CRC mismatch in the MCAP data section")


@pytest.mark.parametrize("profile", ["ros2", ""])
def test_an_index_that_hides_messages_is_caught(
    profile: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = _crc_damaged(tmp_path / "whole.mcap", profile)
    log.unlink()
    times = list(range(0, 91 * 10**9, 10**9))
    channels = [Channel("/u"), Channel("/y1"), Channel("/y2"), Channel("/y3")]
    if profile == "":
        channels = [
            Channel(c.topic, "json", "std_msgs/msg/Float64", "jsonschema", "{}") for c in channels
        ]
        messages = [(j, t, json.dumps({"data": 1.0}).encode()) for t in times for j in range(4)]
    else:
        messages = [(j, t, float64_cdr(1.0)) for t in times for j in range(4)]
    whole = write_mcap(
        tmp_path / "whole.mcap", channels, messages, profile=profile, chunk_size=4000
    )
    statistics = statistics_of(whole)
    assert statistics is not None and statistics.message_count == 364
    damaged = drop_chunk_index(whole, tmp_path / "hidden.mcap", which=1)
    refused(damaged, capsys, "messages found but the file's index lists 91", "--recover")
    report = accepted(damaged, capsys, "--recover")
    assert report["samples"] == 91


# ------------------------------------------------------------------ channels and types


def _with_channel(path: Path, channel: Channel | None, data: bytes, profile: str = "ros2") -> Path:
    times = list(range(0, 20 * 10**9, 10**9))
    channels: list[Channel | None] = [Channel("/u"), Channel("/y1"), Channel("/y2"), channel]
    messages = []
    for t in times:
        messages += [(0, t, float64_cdr(20.0)), (1, t, float64_cdr(1.0)), (2, t, float64_cdr(2.0))]
        messages.append((3, t, data))
    return write_mcap(path, channels, messages, profile=profile)


@pytest.mark.parametrize("profile", ["ros2", ""])
def test_schemaless_channel(
    profile: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = _with_channel(tmp_path / "schemaless.mcap", None, float64_cdr(3.0), profile)
    refused(
        log, capsys, "'/schemaless'", "schemaless channel", extra=("--map", "y3=/schemaless.data")
    )


def test_unsupported_encoding(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    channel = Channel("/y3", "protobuf", "pkg.Level", "protobuf", "")
    log = _with_channel(tmp_path / "proto.mcap", channel, b"\x08\x01", profile="")
    refused(log, capsys, "'/y3'", "message encoding 'protobuf' is not supported")


@pytest.mark.parametrize("profile", ["ros2", ""])
def test_undecodable_messages_name_the_message(
    profile: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = _with_channel(
        tmp_path / "garbage.mcap", Channel("/y3"), b"\x00\x01\x00\x00\x01\x02", profile
    )
    refused(log, capsys, "'/y3' (std_msgs/msg/Float64)", "logged at t=0 s cannot be decoded")


def test_type_without_definition_suggests_msg_dir(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    channel = Channel("/y3", "cdr", "tank_msgs/msg/Level", "empty", "")
    data = float64_cdr(3.0)  # tank_msgs/Level is one float64 'cm': the same bytes
    log = _with_channel(tmp_path / "custom.mcap", channel, data)
    refused(
        log,
        capsys,
        "'tank_msgs/msg/Level' has no definition",
        "--msg-dir",
        extra=("--map", "y3=/y3.cm"),
    )
    folder = write_msg_dir(tmp_path / "msgs", "tank_msgs", "Level", "float64 cm\n")
    report = accepted(log, capsys, "--map", "y3=/y3.cm", "--msg-dir", str(folder))
    assert report["samples"] == 20
    # the .msg file itself given: it exists, so "no such folder" sent the user looking
    file = folder / "tank_msgs" / "msg" / "Level.msg"
    message = refused(log, capsys, extra=("--map", "y3=/y3.cm", "--msg-dir", str(file)))
    assert message == (f"hybridlog: error: --msg-dir {file}: a file, not a folder of .msg files\n")


def test_bag_without_definitions_takes_msg_dir(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # ROS 2 bags recorded before Iron store no message definitions; standard types are
    # known, a custom one needs --msg-dir.
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.LATEST)
    store.register(get_types_from_msg("float64 cm\n", "tank_msgs/msg/Level"))
    bag = tmp_path / "old_bag"
    with Writer(bag, version=9) as writer:
        topics = {
            name: writer.add_connection(name, "std_msgs/msg/Float64", typestore=store)
            for name in ("/u", "/y1", "/y2")
        }
        level = writer.add_connection("/y3", "tank_msgs/msg/Level", typestore=store)
        for k in range(20):
            for connection in topics.values():
                writer.write(connection, k * 10**9, float64_cdr(float(k)))
            writer.write(level, k * 10**9, float64_cdr(float(k)))
    with sqlite3.connect(bag / "old_bag.db3") as connection:
        connection.execute("delete from message_definitions")
    connection.close()
    refused(
        bag,
        capsys,
        "'tank_msgs/msg/Level' has no definition",
        "--msg-dir",
        extra=("--map", "y3=/y3.cm"),
    )
    folder = write_msg_dir(tmp_path / "msgs", "tank_msgs", "Level", "float64 cm\n")
    report = accepted(bag, capsys, "--map", "y3=/y3.cm", "--msg-dir", str(folder))
    assert report["samples"] == 20


def test_ros1_profile_in_a_ros2_bag_folder(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bag = simulated(tmp_path / "bag", format="ros2-mcap")
    inner = bag / "bag.mcap"
    inner.unlink()
    simulated(inner, encoding="ros1")
    refused(bag, capsys, "profile is not 'ros2'", "open the .mcap file itself")
    assert accepted(inner, capsys)["samples"] == 91


# ------------------------------------------------------------------ bags


def test_truncated_ros1_bag(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = simulated(tmp_path / "cut.bag")
    data = log.read_bytes()
    log.write_bytes(data[: len(data) // 2])
    refused(log, capsys, "cut.bag")


def test_a_ros1_topic_name_that_is_not_utf8_is_named_not_called_a_cut_index(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # rosbags' writer, the topic's bytes then made invalid UTF-8: refused as "its index
    # cannot be read (the file is cut off or corrupt; `rosbag reindex` may rebuild it)"
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    number = store.types["std_msgs/msg/Float64"]
    log = tmp_path / "names.bag"
    with Writer(log) as writer:
        connections = [
            writer.add_connection(topic, "std_msgs/msg/Float64", typestore=store)
            for topic in ("/u", "/yQ")
        ]
        for k in range(10):
            for connection in connections:
                data = store.serialize_ros1(number(data=float(k)), "std_msgs/msg/Float64")
                writer.write(connection, 10**9 + k * 10**8, data)
    log.write_bytes(log.read_bytes().replace(b"/yQ", b"/y\xff"))
    message = refused(log, capsys, "names.bag", "'topic' is missing or not UTF-8 text")
    assert "reindex" not in message


@pytest.mark.parametrize("chunked", [True, False])
def test_an_mcap_topic_name_that_is_not_utf8_is_said_so(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], chunked: bool
) -> None:
    # the mcap library's writer, a topic's bytes not UTF-8 (as a C++ recorder may write
    # them): "damaged MCAP file (''utf-8' codec can't decode byte 0xff in position 2: ...')"
    import mcap.data_stream
    from mcap.writer import Writer

    def raw_text(self: Any, value: str) -> None:
        data = value.encode("utf-8", "surrogateescape")
        self.write4(len(data))
        self.write(data)

    log = tmp_path / "names.mcap"
    with pytest.MonkeyPatch.context() as patch, log.open("wb") as handle:
        patch.setattr(mcap.data_stream.RecordBuilder, "write_prefixed_string", raw_text)
        writer = Writer(handle, use_chunking=chunked)
        writer.start()
        schema = writer.register_schema("x", "jsonschema", b'{"type": "object"}')
        channels = [writer.register_channel(t, "json", schema) for t in ("/u", "/y\udcff")]
        for k in range(10):
            for channel in channels:
                data = json.dumps({"x": float(k)}).encode()
                writer.add_message(channel, 10**9 + k * 10**8, data, 10**9 + k * 10**8)
        writer.finish()
    message = refused(log, capsys, "names.mcap", "(text in it is not UTF-8: byte 0xff)")
    assert "codec" not in message


def test_unindexed_ros1_bag(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = simulated(tmp_path / "open.bag")
    at = find(log, b"index_pos=") + len(b"index_pos=")
    data = bytearray(log.read_bytes())
    data[at : at + 8] = struct.pack("<Q", 0)
    log.write_bytes(bytes(data))
    refused(log, capsys, "not indexed", "rosbag reindex")


def test_malformed_db3(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "other.db3"
    with sqlite3.connect(log) as connection:
        connection.execute("create table notes (text)")
    connection.close()
    refused(log, capsys, "not a readable ROS 2 bag database")


def test_bag_folder_without_metadata(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bag = simulated(tmp_path / "bag", format="ros2-sqlite3")
    (bag / "metadata.yaml").unlink()
    refused(bag, capsys, "needs metadata.yaml", "bag.db3")
    assert accepted(bag / "bag.db3", capsys)["samples"] == 91


@pytest.mark.parametrize(
    ("field", "value", "said"),
    [
        ("name", 3, "topic #1: its name is 3, not text"),
        ("name", None, "topic #1: its name is None, not text"),
        ("type", True, "topic '/u': its type is True, not text"),
        ("message_count", "many", "topic '/u': its message count is 'many', not a whole number"),
    ],
)
def test_a_metadata_topic_field_of_another_kind_names_it(
    field: str, value: object, said: str, tmp_path: Path
) -> None:
    """YAML types a topic's name, type and count by how they are written (fuzzx's find)."""
    bag = simulated(tmp_path / "bag", format="ros2-sqlite3")
    metadata = bag / "metadata.yaml"
    document = yaml.safe_load(metadata.read_text())
    entry = document["rosbag2_bagfile_information"]["topics_with_message_count"][0]
    (entry if field == "message_count" else entry["topic_metadata"])[field] = value
    metadata.write_text(yaml.safe_dump(document))
    with pytest.raises(LogError) as refusal:
        inspect_log(bag)
    assert str(refusal.value) == f"{bag}: metadata.yaml: {said}"


@pytest.mark.parametrize("opened", ["bag", "bag/bag.db3"])
def test_a_db3_topic_name_stored_as_a_blob_is_refused(opened: str, tmp_path: Path) -> None:
    simulated(tmp_path / "bag", format="ros2-sqlite3")
    with sqlite3.connect(tmp_path / "bag" / "bag.db3") as connection:
        connection.execute("update topics set name = x'2f75' where name = '/u'")
    connection.close()
    with pytest.raises(LogError) as refusal:
        inspect_log(tmp_path / opened)
    assert str(refusal.value) == f"{tmp_path / opened}: topic #1: its name is b'/u', not text"


def _float_bag(bag: Path) -> tuple[Any, Any]:
    """A ROS 2 sqlite3 bag of 10 messages on ``/u`` and ``/y`` (Float64), by rosbags; its types."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    number = store.types["std_msgs/msg/Float64"]
    with Writer(bag, version=8, storage_plugin=StoragePlugin.SQLITE3) as writer:
        connections = [
            writer.add_connection(topic, "std_msgs/msg/Float64", typestore=store)
            for topic in ("/u", "/y")
        ]
        for k in range(10):
            for connection in connections:
                data = store.serialize_cdr(number(data=float(k)), "std_msgs/msg/Float64")
                writer.write(connection, 10**9 + k * 10**8, data)
    return store, number


@pytest.mark.parametrize(
    ("stored", "said"),
    [("'abc'", "text ('abc')"), ("12", "a number ('12')"), ("NULL", "NULL")],
)
@pytest.mark.parametrize("opened", ["bag", "bag/bag.db3"])
def test_a_db3_message_stored_as_other_than_bytes_is_refused(
    stored: str, said: str, opened: str, tmp_path: Path
) -> None:
    # rosbags' writer; a sqlite3 column holds anything, and rosbags hands it on as it is:
    # text, a number or NULL for a message's data was a TypeError (a traceback)
    from hybridlog.io import ReadOptions, SignalSpec, load_signals

    _float_bag(tmp_path / "bag")
    with sqlite3.connect(tmp_path / "bag" / "bag.db3") as connection:
        # without the NOT NULL of rosbags' table, as another tool may make it
        connection.executescript(
            "create table copied as select * from messages; drop table messages; "
            f"alter table copied rename to messages; update messages set data = {stored} "
            "where id = 5"
        )
    connection.close()
    expected = (
        f"{tmp_path / opened}: topic '/u': the message logged at t=1.2 s is {said}, not "
        "serialised bytes"
    )
    spec = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1",), dt=0.1)
    with pytest.raises(LogError) as refusal:
        load_signals(tmp_path / opened, spec, ReadOptions(maps=("u=/u.data", "y=/y.data")))
    assert str(refusal.value) == expected
    assert (
        expected.removeprefix(f"{tmp_path / opened}: ")
        in inspect_log(tmp_path / opened)["problems"][0]
    )


@pytest.mark.parametrize("opened", ["bag", "bag/bag.db3"])
def test_a_db3_whose_write_ahead_log_holds_messages_is_refused(opened: str, tmp_path: Path) -> None:
    # rosbags' writer, then messages written as a recorder with SQLite's write-ahead log
    # does (rosbag2's 'resilient' preset) and not yet checkpointed: rosbags opens the file
    # immutable, so the 10 messages of the first second were read and the rest left out.
    from hybridlog.io import ReadOptions, SignalSpec, load_signals

    store, number = _float_bag(tmp_path / "bag")
    spec = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1",), dt=0.1)
    options = ReadOptions(maps=("u=/u.data", "y=/y.data"))
    database = tmp_path / "bag" / "bag.db3"
    recorder = sqlite3.connect(database)  # still recording: its log not checkpointed
    try:
        recorder.execute("pragma journal_mode=wal")
        recorder.execute("pragma wal_autocheckpoint=0")
        for k in range(10, 30):
            for topic_id in (1, 2):
                data = store.serialize_cdr(number(data=float(k)), "std_msgs/msg/Float64")
                recorder.execute(
                    "insert into messages (topic_id, timestamp, data) values (?, ?, ?)",
                    (topic_id, 10**9 + k * 10**8, bytes(data)),
                )
            recorder.commit()
        with pytest.raises(LogError) as refusal:
            load_signals(tmp_path / opened, spec, options)
        message = str(refusal.value)
        assert message.startswith(f"{database}: bag.db3-wal beside it holds writes not yet in")
        assert f"sqlite3 {database} 'PRAGMA wal_checkpoint(TRUNCATE)'" in message
        with pytest.raises(LogError, match=r"bag\.db3-wal beside it"):
            inspect_log(tmp_path / opened)
    finally:
        recorder.close()  # the last connection checkpoints the log into the database
    assert not (tmp_path / "bag" / "bag.db3-wal").exists()
    signals = load_signals(tmp_path / opened, spec, options)
    np.testing.assert_array_equal(signals.inputs[:, 0], np.arange(30.0))


def test_folder_that_is_no_bag(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "empty_dir").mkdir()
    err = refused(tmp_path / "empty_dir", capsys, "is not a ROS 2 bag")
    assert "batch" not in err
    # a folder of logs given to analyze: the error says what reads one
    runs = tmp_path / "runs"
    runs.mkdir()
    for name in ("a.csv", "b.PARQUET", "notes.txt"):
        (runs / name).write_text("")
    refused(runs, capsys, "is not a ROS 2 bag", f"it holds 2 log files: 'hybridlog batch {runs}'")
    # a link loop named like a log (ELOOP from is_file) lost the hint and left the folder's
    # listing open: "ResourceWarning: unclosed scandir iterator" on the terminal
    (runs / "loop.csv").symlink_to("loop.csv")
    unraisable: list[object] = []
    monkeypatch.setattr(sys, "unraisablehook", unraisable.append)
    with warnings.catch_warnings():
        warnings.simplefilter("always", ResourceWarning)
        refused(runs, capsys, f"it holds 2 log files: 'hybridlog batch {runs}'")
        gc.collect()
    assert unraisable == []


# ------------------------------------------------------------------ paths and values


def test_missing_topic_or_field_lists_the_closest(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = simulated(tmp_path / "run.mcap")
    refused(log, capsys, "no topic for '/y7.data'", "'/y1'", extra=("--map", "y1=/y7.data"))
    refused(log, capsys, "has no field 'dat'", "closest: 'data'", extra=("--map", "y1=/y1.dat"))
    refused(log, capsys, ".data is a float64; it has no [0]", extra=("--map", "y1=/y1.data[0]"))
    refused(log, capsys, "names a whole message", "/y1.data", extra=("--map", "y1=/y1"))


def test_path_into_text_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = simulated(tmp_path / "run.bag")
    refused(
        log,
        capsys,
        "'/truth/mode.data'",
        "is a string, not a number",
        extra=("--map", "y1=/truth/mode.data"),
    )


def test_header_time_going_backwards_needs_sort(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    records = header_scene_records()
    levels = [i for i, r in enumerate(records) if r.topic == "/levels"]
    victim = records[levels[40]]
    records[levels[40]] = Record(
        victim.topic, victim.kind, victim.log_ns, victim.value, victim.stamp_ns - 1_500_000_000
    )
    log = write_mcap_json(tmp_path / "back.mcap", records)
    maps = (
        "--map",
        "u=/pump/cmd.data",
        "--map",
        "y1=/levels.point.x",
        "--map",
        "y2=/levels.point.y",
        "--map",
        "y3=/level3.data",
    )
    refused(
        log,
        capsys,
        "'/levels': header.stamp goes backwards",
        "--sort",
        extra=("--time", "header", *maps),
    )
    report = accepted(log, capsys, "--time", "header", "--sort", *maps)
    assert report["reading"]["sorted"] == {"/levels": 1}


def test_repeated_log_times_need_sort(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    times = [t * 10**9 for t in range(30)]
    channels = [Channel("/u"), Channel("/y1"), Channel("/y2"), Channel("/y3")]
    messages = []
    for j in range(4):
        messages += float_messages(times, np.full(30, 20.0), channel=j)
    messages.append((1, times[10], float64_cdr(99.0)))  # a second /y1 message at t = 10 s
    log = write_mcap(tmp_path / "twice.mcap", channels, sorted(messages, key=lambda m: m[1]))
    refused(log, capsys, "'/y1': 1 message(s) have the same log time", "t=10 s", "--sort")
    report = accepted(log, capsys, "--sort")
    assert report["reading"]["duplicates_dropped"] == {"/y1": 1}


def test_nonfinite_samples_name_time_and_signal(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    columns = dict(tank_run().columns)
    y2 = columns["y2"].copy()
    y2[17] = np.nan
    y2[30] = np.inf
    columns["y2"] = y2
    log = write_log(tmp_path / "nan.mcap", columns, truth=("mode", "x1", "x2", "x3"))
    refused(log, capsys, "field '/y2.data'", "nan for output 'y2' at t=17 s")
    report = accepted(log, capsys, "--drop-nonfinite")
    assert report["reading"]["nonfinite_dropped"] == {"/y2.data": 2}
    assert report["samples"] == 91
