"""What logs written by other tools got wrong, one class of defect per test (issue 7).

Every file here is written by another tool's writer -- rosbags' ROS 2 bag writer, the
``mcap`` writer -- and then, where the defect needs it, edited the way real files differ:

- a stored definition that does not describe the bytes (rosbag2's ``talker.db3`` stores the
  placeholder ``uint8 level`` for ``rcl_interfaces/msg/Log``): refused, never decoded into
  wrong numbers -- by the batch decoder and by the one-by-one fallback alike;
- a definition rosbags cannot parse (ROS 2 Jazzy service events store the ``.srv`` text with
  ``---``) beside good topics: only that topic is marked, the others are read;
- a bag whose ``metadata.yaml`` gives other QoS profiles than its storage file: topics are
  matched by name and type, and ``inspect`` says the two disagree;
- QoS profiles rosbags cannot parse (a YAML scalar, a profile without ``deadline``): a ros2
  MCAP file is read by the mcap reader; a ROS 2 bag, which only rosbags reads, is refused
  naming the topic and what its profiles hold;
- hints: ``--recover`` is suggested only where it would read messages.
"""

from __future__ import annotations

import dataclasses
import json
import re
import shutil
import sqlite3
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from hybridlog.cli import main
from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, format_inspection, inspect_log, load_signals
from hybridlog.report.reading_notes import log_reading_notes
from tests.support.logfiles import (
    EVENT_TYPE,
    LOG_TYPE,
    NS,
    PLACEHOLDER,
    event_stream,
    float64_cdr,
    forget_type_hashes,
    good_streams,
    msgdef,
    reliable_qos,
    rosout_stream,
    write_msg_dir,
    write_streams_bag,
    write_streams_mcap,
)


def load(log: Path, y: str = "/y.data") -> Any:
    return load_signals(
        log,
        SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("a",), dt=1.0),
        ReadOptions(maps=("u=/u.data", f"y={y}")),
    )


def check_good_topics(log: Path, steps: int = 30) -> None:
    signals = load(log)
    np.testing.assert_array_equal(signals.inputs[:, 0], np.arange(steps, dtype=float))
    np.testing.assert_array_equal(signals.outputs[:, 0], 2.0 * np.arange(steps))


def cli_error(args: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    capsys.readouterr()
    with pytest.raises(SystemExit) as exit_:
        main(args)
    err = capsys.readouterr().err
    assert exit_.value.code == 2, err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err


# ------------------------------------------------------------------ definitions that lie


def _placeholder_log(kind: str, folder: Path) -> Path:
    streams = [*good_streams(), rosout_stream(PLACEHOLDER)]
    if kind == "mcap, rosbags reader":
        return write_streams_mcap(folder / "talker.mcap", streams)
    if kind == "mcap, mcap reader":  # no repeated channels: read with the mcap library
        return write_streams_mcap(
            folder / "talker.mcap", streams, repeat_channels=False, repeat_schemas=False
        )
    bag = write_streams_bag(folder / "talker", streams)
    forget_type_hashes(bag / "talker.db3")  # as in rosbag2's talker.db3: nothing to compare
    return bag if kind == "bag folder" else bag / "talker.db3"


PLACEHOLDER_LOGS = ["mcap, rosbags reader", "mcap, mcap reader", "bag folder", "bare db3"]


@pytest.mark.parametrize("kind", PLACEHOLDER_LOGS)
def test_a_definition_that_does_not_fit_the_bytes_is_refused(kind: str, tmp_path: Path) -> None:
    log = _placeholder_log(kind, tmp_path)
    info = inspect_log(log)
    rosout = next(t for t in info["topics"] if t["name"] == "/rosout")
    assert (rosout["type"], rosout["count"]) == (LOG_TYPE, 30)
    assert "/rosout.level" in rosout["fields"]  # the placeholder is all the file says
    with pytest.raises(LogError) as error:
        load(log, "/rosout.level")
    message = str(error.value)
    assert message.startswith(f"{log}: topic '/rosout' ({LOG_TYPE})"), message
    assert "cannot be decoded" in message
    assert "size mismatch" in message
    check_good_topics(log)


def test_a_definition_that_does_not_fit_its_type_hash_marks_the_topic(tmp_path: Path) -> None:
    # The same bag with the hashes rosbag2 (Iron and later) stores: caught before any read.
    log = write_streams_bag(tmp_path / "talker", [*good_streams(), rosout_stream(PLACEHOLDER)])
    info = inspect_log(log)
    assert {t["name"]: t["count"] for t in info["topics"]} == {"/u": 30, "/y": 30, "/rosout": 30}
    assert len(info["problems"]) == 1
    assert "'/rosout'" in info["problems"][0]
    assert "does not match its type hash" in info["problems"][0]
    with pytest.raises(LogError, match=r"'/rosout'.*does not match its type hash"):
        load(log, "/rosout.level")
    check_good_topics(log)


def test_the_true_definition_decodes_the_true_level(tmp_path: Path) -> None:
    # The control: the same bytes with rcl_interfaces/msg/Log's real definition.
    log = write_streams_mcap(
        tmp_path / "talker.mcap", [*good_streams(), rosout_stream(msgdef(LOG_TYPE))]
    )
    assert set(load(log, "/rosout.level").outputs[:, 0]) == {20.0}


# ------------------------------------------------------------------ one undecodable schema


def _event_log(kind: str, folder: Path) -> Path:
    streams = [*good_streams(), event_stream()]
    if kind == "mcap, rosbags reader":
        return write_streams_mcap(folder / "events.mcap", streams)
    if kind == "mcap, mcap reader":
        return write_streams_mcap(folder / "events.mcap", streams, repeat_channels=False)
    return write_streams_bag(folder / "events", streams, "mcap" if "mcap" in kind else "sqlite3")


@pytest.mark.parametrize(
    "kind", ["mcap, rosbags reader", "mcap, mcap reader", "bag folder sqlite3", "bag folder mcap"]
)
def test_a_service_event_schema_marks_only_its_topic(kind: str, tmp_path: Path) -> None:
    log = _event_log(kind, tmp_path)
    info = inspect_log(log)
    topics = {t["name"]: t for t in info["topics"]}
    assert {name: t["count"] for name, t in topics.items()} == {
        "/u": 30,
        "/y": 30,
        "/add_two_ints/_service_event": 30,
    }
    assert topics["/add_two_ints/_service_event"]["type"] == EVENT_TYPE
    assert info["messages"] == 90
    assert len(info["problems"]) == 1, info["problems"]
    assert info["problems"][0].startswith(f"topic '/add_two_ints/_service_event' ({EVENT_TYPE}):")
    assert "definition cannot be parsed" in info["problems"][0]
    check_good_topics(log)


def test_mapping_the_undecodable_topic_is_a_one_line_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = _event_log("bag folder sqlite3", tmp_path)
    err = cli_error(
        [
            "analyze",
            str(log),
            "--model",
            "three_tank_hstf",
            "--map",
            "u=/add_two_ints/_service_event.request[0].a",
            "--out",
            str(tmp_path / "out"),
        ],
        capsys,
    )
    assert "'/add_two_ints/_service_event'" in err and "cannot be parsed" in err
    assert not (tmp_path / "out").exists()


# ------------------------------------------------------------------ metadata vs storage


def _edit(path: Path, old: str, new: str) -> None:
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new))


@pytest.mark.parametrize("where", ["metadata.yaml, sqlite3", "metadata.yaml, mcap", "db3 column"])
def test_bag_topics_are_matched_by_name_and_type_not_qos(where: str, tmp_path: Path) -> None:
    storage = "mcap" if "mcap" in where else "sqlite3"
    bag = write_streams_bag(tmp_path / "bag", good_streams(), storage, qos=[reliable_qos()])
    if where == "db3 column":
        with sqlite3.connect(bag / "bag.db3") as connection:
            connection.execute(
                "update topics set offered_qos_profiles = "
                "replace(offered_qos_profiles, 'depth: 10', 'depth: 1')"
            )
        connection.close()
    else:
        _edit(bag / "metadata.yaml", "reliability: reliable", "reliability: best_effort")
    info = inspect_log(bag)
    assert {t["name"]: t["count"] for t in info["topics"]} == {"/u": 30, "/y": 30}
    assert info["problems"] == []
    remarks = info["reading"]["metadata"]
    assert remarks == [
        f"topic {name!r}: metadata.yaml and the storage file give different QoS profiles "
        "(topics are matched by name and type)"
        for name in ("/u", "/y")
    ]
    assert "metadata.yaml and the storage file give different QoS" in format_inspection(info)
    check_good_topics(bag)


def test_a_topic_missing_from_the_storage_is_named_without_a_recover_hint(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bag = write_streams_bag(tmp_path / "bag", good_streams())
    with sqlite3.connect(bag / "bag.db3") as connection:
        connection.execute("delete from topics where name = '/y'")
    connection.close()
    info = inspect_log(bag)
    assert {t["name"]: t["count"] for t in info["topics"]} == {"/u": 30, "/y": 0}
    assert info["reading"]["metadata"] == [
        "topic '/y' (std_msgs/msg/Float64) is listed in metadata.yaml with 30 messages but no "
        "storage file holds it"
    ]
    err = cli_error(
        ["analyze", str(bag), "--model", "three_tank_hstf", "--map", "y1=/y.data", "--out",
         str(tmp_path / "out")],
        capsys,
    )  # fmt: skip
    assert "'/y'" in err and "listed in metadata.yaml but in no storage file" in err
    assert "--recover" not in err


# ------------------------------------------------------------------ hints


def test_recover_is_suggested_only_when_it_reads_messages(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    whole = Path(__file__).parents[2] / "sample_logs" / "three_tank_hstf.mcap"
    data = whole.read_bytes()
    args = ["analyze", "--model", "three_tank_hstf"]
    short = tmp_path / "short.mcap"  # 10 % of the file: only its header and first schema
    short.write_bytes(data[: len(data) // 10])
    err = cli_error([*args[:1], str(short), *args[1:], "--out", str(tmp_path / "a")], capsys)
    assert "no message is readable" in err and "--recover cannot help" in err
    cut = tmp_path / "cut.mcap"  # 90 %: most chunks are whole
    cut.write_bytes(data[: len(data) * 9 // 10])
    err = cli_error([*args[:1], str(cut), *args[1:], "--out", str(tmp_path / "b")], capsys)
    readable = int(err.split("); ")[1].split(" messages are readable")[0])
    assert readable > 0 and "--recover analyses them" in err
    capsys.readouterr()
    main([*args[:1], str(cut), *args[1:], "--out", str(tmp_path / "c"), "--recover"])
    report = json.loads((tmp_path / "c" / "report.json").read_text())
    assert report["reading"]["messages_readable"] == readable
    assert report["samples"] > 0


@pytest.mark.parametrize("tenths", [0.3, 1.0])
def test_recover_that_reads_no_message_says_so(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], tenths: float
) -> None:
    # --recover on a file cut off before its first whole chunk read no schema, channel or
    # message, and the error blamed the mapping: "no field for input 'u' ... the log has none".
    data = (Path(__file__).parents[2] / "sample_logs" / "three_tank_hstf.mcap").read_bytes()
    log = tmp_path / "log.mcap"
    log.write_bytes(data[: int(len(data) * tenths / 10)])
    out = tmp_path / "out"
    args = [str(log), "--model", "three_tank_hstf", "--out", str(out), "--recover"]
    err = cli_error(["analyze", *args], capsys)
    assert "--recover reads no message" in err, err
    assert "the log has none" not in err and "\n" not in err.strip()
    assert not out.exists()


def _cut_bag(folder: Path, share: float) -> tuple[Path, Path]:
    """A copy of the sample ROS 2 bag of MCAP storage whose storage file keeps ``share`` of
    its bytes: the bag and that file."""
    sample = Path(__file__).parents[2] / "sample_logs" / "three_tank_hstf_ros2mcap"
    bag = folder / "bag"
    shutil.copytree(sample, bag)
    storage = bag / f"{sample.name}.mcap"
    data = storage.read_bytes()
    storage.write_bytes(data[: int(len(data) * share)])
    return bag, storage


def test_inspect_describes_unfinished_mcap_storage_and_names_no_option_it_lacks(
    tmp_path: Path,
) -> None:
    # inspect has no --recover: it reads an unfinished MCAP file sequentially anyway, and
    # refused a ROS 2 bag whose storage file is unfinished with a hint at --recover.
    bag, storage = _cut_bag(tmp_path, 9 / 10)
    # the commands that read to analyse have --recover
    with pytest.raises(LogError) as error:
        load_signals(bag, SignalSpec(inputs=("u",), outputs=("y1",), mode_ids=("1",), dt=1.0))
    message = str(error.value)
    assert message.startswith(f"{bag}: the bag's MCAP storage file {storage.name} is unfinished")
    assert message.endswith(f"messages are readable: analyse {storage} with --recover")
    bare = tmp_path / "cut.mcap"
    shutil.copyfile(storage, bare)
    for log, inner in ((bag, storage), (bare, bare)):
        info = inspect_log(log)
        assert info["path"] == str(inner) and info["reading"]["recovered"] is True
        assert info["messages"] > 0 and "unfinished" in info["problems"][0]
        assert not any("--" in problem for problem in info["problems"]), info["problems"]


@pytest.mark.parametrize("tenths", [0.3, 1.0])
def test_inspect_of_an_unfinished_mcap_without_a_readable_message_names_no_option_it_lacks(
    tmp_path: Path, tenths: float
) -> None:
    # inspect read such a file on as --recover does, which found no message and failed with
    # "--recover reads no message": an option inspect does not have, never given
    bag, storage = _cut_bag(tmp_path, tenths / 10)
    bare = tmp_path / "cut.mcap"
    shutil.copyfile(storage, bare)
    for log in (bag, bare):
        with pytest.raises(LogError) as error:
            inspect_log(log)
        message = str(error.value)
        assert message.startswith(f"{log}: ") and "unfinished" in message, message
        assert "no message" in message and "--" not in message, message


def test_a_bag_folder_whose_mcap_rosbags_cannot_index_points_to_the_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # rosbags' MCAP storage reader needs channels repeated in the summary; the file itself is
    # read by the mcap library.
    bag = write_streams_bag(tmp_path / "bag", good_streams(), "mcap")
    inner = bag / "bag.mcap"
    inner.unlink()
    write_streams_mcap(inner, good_streams(), repeat_channels=False)
    with pytest.raises(LogError) as error:
        inspect_log(bag)
    message = str(error.value)
    assert "its summary does not repeat the channels" in message
    assert message.endswith(f"analyse the file itself: {inner}")
    check_good_topics(inner)


def test_a_topic_without_messages_missing_from_the_storage_is_no_problem(tmp_path: Path) -> None:
    from tests.support.logfiles import Stream

    quiet = Stream("/quiet", "std_msgs/msg/Float64", msgdef("std_msgs/msg/Float64"), ())
    bag = write_streams_bag(tmp_path / "bag", [*good_streams(), quiet])
    with sqlite3.connect(bag / "bag.db3") as connection:
        connection.execute("delete from topics where name = '/quiet'")
    connection.close()
    info = inspect_log(bag)
    assert {t["name"]: t["count"] for t in info["topics"]} == {"/u": 30, "/y": 30, "/quiet": 0}
    assert info["problems"] == [] and "metadata" not in info["reading"]
    check_good_topics(bag)


# ------------------------------------------------------------------ mixed encodings


@pytest.mark.parametrize(
    ("schema_encoding", "message_encoding", "data"),
    [
        ("jsonschema", "json", b'{"level": 1}'),
        ("protobuf", "protobuf", b"\x08\x01"),
        ("jsonschema", "json", None),  # a channel without messages
    ],
)
def test_a_ros2_mcap_with_a_topic_of_another_encoding_reads_its_cdr_topics(
    schema_encoding: str, message_encoding: str, data: bytes | None, tmp_path: Path
) -> None:
    """rosbags' MCAP reader refuses a whole file for one such channel; hybridlog does not."""
    from mcap.writer import Writer

    log = tmp_path / "mixed.mcap"
    with log.open("wb") as handle:
        writer = Writer(handle)
        writer.start(profile="ros2", library="tests")
        ids = []
        for stream in good_streams():
            schema = writer.register_schema(stream.msgtype, "ros2msg", stream.definition.encode())
            ids.append((writer.register_channel(stream.topic, "cdr", schema), stream.messages))
        other = writer.register_schema("Diagnostics", schema_encoding, b"{}")
        diagnostics = writer.register_channel("/diagnostics", message_encoding, other)
        if data is not None:
            writer.add_message(diagnostics, 5 * 10**9, data, 5 * 10**9)
        for channel, messages in ids:
            for t, payload in messages:
                writer.add_message(channel, t, payload, t)
        writer.finish()
    check_good_topics(log)
    assert "/diagnostics" in format_inspection(inspect_log(log))


def _json_log(path: Path, u_values: list[object], schema: dict[str, Any] | None) -> Path:
    """``/u`` (with ``schema``) and ``/y`` as JSON messages, one per second (``y = 2k``)."""
    from mcap.writer import Writer

    with path.open("wb") as handle:
        writer = Writer(handle)
        writer.start(profile="", library="tests")
        text = json.dumps(schema or {}).encode()
        sid = writer.register_schema("Value", "jsonschema" if schema else "", text)
        u = writer.register_channel("/u", "json", sid)
        y = writer.register_channel("/y", "json", 0)
        for k, value in enumerate(u_values):
            t = k * 10**9
            writer.add_message(u, t, json.dumps({"data": value}).encode(), t)
            writer.add_message(y, t, json.dumps({"data": 2.0 * k}).encode(), t)
        writer.finish()
    return path


NUMBER = {"type": "object", "properties": {"data": {"type": "number"}}}
BOOLEAN = {"type": "object", "properties": {"data": {"type": "boolean"}}}


@pytest.mark.parametrize(
    ("values", "schema", "words"),
    [
        ([0.0, 1.0, True, 3.0], NUMBER, "is a boolean where the messages before held numbers"),
        (
            [True, 1.0, 2.0, 3.0],
            NUMBER,
            r"is a boolean \(true\) where the schema declares a number",
        ),
        ([0.0, 1.0, False, 3.0], None, "is a boolean where the messages before held numbers"),
        ([True, False, 2.0, True], None, "is a number where the messages before held booleans"),
    ],
)
def test_a_json_boolean_among_numbers_is_refused_naming_the_message(
    values: list[object], schema: dict[str, Any] | None, words: str, tmp_path: Path
) -> None:
    """``true`` was read as 1.0 where a number was meant (CSV and Parquet refuse it)."""
    log = _json_log(tmp_path / "u.mcap", values, schema)
    said = rf"input 'u' \(field '/u\.data', from --map u=/u\.data\): the value {words} in the"
    with pytest.raises(LogError, match=said):
        load(log, "/y.data")


@pytest.mark.parametrize("schema", [BOOLEAN, None])
def test_json_booleans_alone_are_read_as_0_and_1(
    schema: dict[str, Any] | None, tmp_path: Path
) -> None:
    log = _json_log(tmp_path / "valve.mcap", [True, False, True, True], schema)
    np.testing.assert_array_equal(load(log, "/y.data").inputs[:, 0], [1.0, 0.0, 1.0, 1.0])


def test_a_json_key_given_twice_is_refused_not_the_last_one_taken(tmp_path: Path) -> None:
    from mcap.writer import Writer

    log = tmp_path / "twice.mcap"
    with log.open("wb") as handle:
        writer = Writer(handle)
        writer.start(profile="", library="tests")
        u = writer.register_channel("/u", "json", 0)
        y = writer.register_channel("/y", "json", 0)
        for k in range(3):
            t = k * 10**9
            writer.add_message(u, t, f'{{"data": {k}.0, "data": 999.0}}'.encode(), t)
            writer.add_message(y, t, f'{{"data": {2 * k}.0}}'.encode(), t)
        writer.finish()
    with pytest.raises(LogError, match=r"t=0 s cannot be decoded \(the key 'data' is given twice"):
        load(log, "/y.data")


# ------------------------------------------------------------------ messages out of order


@pytest.mark.parametrize("chunked", [True, False])
def test_an_mcap_written_newest_first_is_read_in_log_time_order(
    chunked: bool, tmp_path: Path
) -> None:
    # MCAP allows messages in any order; without chunks there is no index to sort them by,
    # and rosbags (which read ros2-profile files) refused such a file as damaged part way
    # through, after inspect had counted the messages read so far.
    log = write_streams_mcap(
        tmp_path / "late.mcap", good_streams(), newest_first=True, use_chunking=chunked
    )
    check_good_topics(log)
    info = inspect_log(log)
    assert [(t["name"], t["count"]) for t in info["topics"]] == [("/u", 30), ("/y", 30)]
    assert info["problems"] == []


def test_a_bag_whose_unchunked_storage_is_out_of_order_names_the_file_to_read(
    tmp_path: Path,
) -> None:
    bag = write_streams_bag(tmp_path / "late", good_streams(), storage="mcap")
    storage = bag / "late.mcap"
    write_streams_mcap(storage, good_streams(), newest_first=True, use_chunking=False)
    with pytest.raises(LogError) as error:
        load(bag)
    assert str(error.value) == (
        f"{bag}: an MCAP storage file of this bag has no chunks and its messages are not in "
        f"log-time order, which rosbags' bag reader cannot read; analyse {storage}"
    )
    check_good_topics(storage)  # the remedy works


def test_a_msg_dir_definition_that_does_not_fit_the_type_hash_is_named_as_such(
    tmp_path: Path,
) -> None:
    # A bag storing the type hash but no definition text: the definition comes from --msg-dir,
    # so the error must point there, not at a "stored" definition the log does not have.
    log = write_streams_bag(tmp_path / "talker", [*good_streams(), rosout_stream("")])
    assert set(load(log, "/rosout.level").outputs[:, 0]) == {20.0}  # the standard type fits
    msg_dir = write_msg_dir(tmp_path / "msgs", "rcl_interfaces", "Log", PLACEHOLDER)
    options = ReadOptions(maps=("u=/u.data", "y=/rosout.level"), msg_dirs=(str(msg_dir),))
    with pytest.raises(LogError) as error:
        load_signals(
            log, SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("a",), dt=1.0), options
        )
    message = str(error.value)
    assert "the log stores no message definition, and the one from --msg-dir" in message
    assert "stored message definition" not in message


def test_a_bag_without_messages_is_listed_not_refused(tmp_path: Path) -> None:
    # rosbags writes one chunk of schemas and channels only, with no message index since
    # there is no message: it was taken for a chunk whose index is missing.
    silent = [dataclasses.replace(s, messages=()) for s in good_streams()]
    bag = write_streams_bag(tmp_path / "silent", silent, storage="mcap")
    info = inspect_log(bag)
    assert info["format"] == "ros2-bag (mcap)"
    assert [(t["name"], t["count"]) for t in info["topics"]] == [("/u", 0), ("/y", 0)]
    assert info["problems"] == []


# ------------------------------------------------------------------ one topic, two definitions


def test_a_bag_topic_whose_connections_differ_in_definition_is_refused(tmp_path: Path) -> None:
    # Two nodes publishing one topic with different versions of a message (fields swapped):
    # every message was decoded with the first connection's definition, so half of /s.a
    # silently read the other node's b.
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    stores = []
    for text in ("float64 a\nfloat64 b\n", "float64 b\nfloat64 a\n"):
        store = get_typestore(Stores.EMPTY)
        store.register(get_types_from_msg(text, "my_pkg/msg/Pair"))
        stores.append(store)
    log = tmp_path / "pairs.bag"
    with Writer(log) as writer:
        old, new = (
            writer.add_connection("/s", "my_pkg/msg/Pair", typestore=store, callerid=node)
            for store, node in zip(stores, ("/old", "/new"), strict=True)
        )
        steady = writer.add_connection("/u", "my_pkg/msg/Pair", typestore=stores[0])
        for k in range(30):
            first = stores[0].types["my_pkg/msg/Pair"](a=float(k), b=-float(k))
            writer.write(steady, k * NS, stores[0].serialize_ros1(first, "my_pkg/msg/Pair"))
            store, connection = (stores[0], old) if k % 3 else (stores[1], new)
            pair = store.types["my_pkg/msg/Pair"](a=float(k), b=-float(k))
            writer.write(connection, k * NS, store.serialize_ros1(pair, "my_pkg/msg/Pair"))
    (problem,) = inspect_log(log)["problems"]
    md5 = "'[0-9a-f]{16}…[0-9a-f]{7}'"  # each connection's MD5 sum, shortened
    assert re.fullmatch(
        rf"topic '/s' \(my_pkg/msg/Pair\): has connections with different definitions of it: "
        rf"{md5} \(20 messages\), {md5} \(10 messages\)",
        problem,
    ), problem
    with pytest.raises(LogError, match="has connections with different definitions"):
        load_signals(
            log,
            SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("a",), dt=1.0),
            ReadOptions(maps=("u=/u.a", "y=/s.a")),
        )


@pytest.mark.parametrize("profile", ["", "ros2"])
def test_one_schema_recorded_twice_is_one_definition(profile: str, tmp_path: Path) -> None:
    # A writer may record the same schema under two ids (one per channel): the mcap reader
    # refused /y as "has channels with different schemas: 'std_msgs/msg/Float64' in 'cdr'
    # (15 messages), 'std_msgs/msg/Float64' in 'cdr' (15 messages)".
    from mcap.writer import Writer

    log = tmp_path / "twice.mcap"
    definition = msgdef("std_msgs/msg/Float64").encode()
    with log.open("wb") as handle:
        writer = Writer(handle)
        writer.start(profile=profile, library="tests")
        first, second = (
            writer.register_schema("std_msgs/msg/Float64", "ros2msg", definition) for _ in "ab"
        )
        u = writer.register_channel("/u", "cdr", first)
        ys = [writer.register_channel("/y", "cdr", schema) for schema in (first, second)]
        for k in range(30):
            writer.add_message(u, k * NS, float64_cdr(float(k)), k * NS)
            writer.add_message(ys[k % 2], k * NS, float64_cdr(2.0 * k), k * NS)
        writer.finish()
    assert inspect_log(log)["problems"] == []
    check_good_topics(log)


@pytest.mark.parametrize("profile", ["", "ros2"])  # the mcap reader, rosbags
@pytest.mark.parametrize(
    ("second", "problem"),
    [("# the level\nfloat64   data  # m\n\n", False), ("float32 data\n", True)],
)
def test_schemas_of_a_topic_differing_only_in_comments_are_one_definition(
    profile: str, second: str, problem: bool, tmp_path: Path
) -> None:
    # Two recorders may store one .msg with other comments or layout: the same definition.
    from mcap.writer import Writer

    log = tmp_path / "layouts.mcap"
    with log.open("wb") as handle:
        writer = Writer(handle)
        writer.start(profile=profile, library="tests")
        first, other = (
            writer.register_schema("std_msgs/msg/Float64", "ros2msg", text.encode())
            for text in ("float64 data\n", second)
        )
        u = writer.register_channel("/u", "cdr", first)
        ys = [writer.register_channel("/y", "cdr", schema) for schema in (first, other)]
        for k in range(30):
            writer.add_message(u, k * NS, float64_cdr(float(k)), k * NS)
            writer.add_message(ys[k % 2], k * NS, float64_cdr(2.0 * k), k * NS)
        writer.finish()
    problems = inspect_log(log)["problems"]
    if problem:
        assert len(problems) == 1 and "'/y'" in problems[0], problems
        assert "different" in problems[0], problems
    else:
        assert problems == []
        check_good_topics(log)


@pytest.mark.parametrize("profile", ["", "ros2"])  # the mcap reader, rosbags
def test_a_ros1_style_type_name_in_a_ros2_schema_is_read_by_either_reader(
    profile: str, tmp_path: Path
) -> None:
    # A schema named std_msgs/Float64 (ROS 1's spelling) with a ROS 2 definition: the
    # mcap reader read it, while the same file through rosbags (a ros2 profile) was refused
    # as "type 'std_msgs/Float64' has no definition in the log", which the log has.
    log = _float64_mcap(tmp_path / "ros1_names.mcap", profile, "std_msgs/Float64", {})
    assert inspect_log(log)["problems"] == []
    check_good_topics(log)


def _float64_mcap(log: Path, profile: str, schema_name: str, metadata: dict[str, str]) -> Path:
    """``/u`` and ``/y`` of ``schema_name`` (a ROS 2 ``float64 data``), written by mcap's writer."""
    from mcap.writer import Writer

    with log.open("wb") as handle:
        writer = Writer(handle)
        writer.start(profile=profile, library="tests")
        schema = writer.register_schema(schema_name, "ros2msg", b"float64 data\n")
        u, y = (writer.register_channel(t, "cdr", schema, metadata) for t in ("/u", "/y"))
        for k in range(30):
            writer.add_message(u, k * NS, float64_cdr(float(k)), k * NS)
            writer.add_message(y, k * NS, float64_cdr(2.0 * k), k * NS)
        writer.finish()
    return log


@pytest.mark.parametrize(
    "qos", ["x", "- a\n- b", "history: 1", "- [unclosed", "- history: keep_last\n  depth: 1"]
)
def test_channel_qos_rosbags_cannot_parse_does_not_refuse_the_file(
    qos: str, tmp_path: Path
) -> None:
    # A ros2 MCAP whose channels' offered_qos_profiles metadata is not a YAML list of
    # profiles (a YAML scalar, a list of text, a broken document): rosbags raised on opening
    # it ("cannot open the mcap file (string indices must be integers ...)") though the
    # mcap library reads it and hybridlog never uses the QoS.
    log = _float64_mcap(
        tmp_path / "qos.mcap", "ros2", "std_msgs/msg/Float64", {"offered_qos_profiles": qos}
    )
    assert inspect_log(log)["problems"] == []
    check_good_topics(log)


QOS_HELD = {
    "x": "the text 'x'",
    "- a\n- b": "a list whose item 1 is the text 'a'",
    "history: 1": "a mapping (history)",
    "- [unclosed": "text that is not YAML (expected ',' or ']', but got '<stream end>': "
    "'- [unclosed')",
    "- history: keep_last\n  depth: 1": "a profile without 'deadline'",
}


def _qos_refusal(log: Path, topic: str, place: str, held: str) -> str:
    return (
        f"{log}: rosbags, which reads ROS 2 bags, cannot open it: the QoS profiles of topic "
        f"{topic!r} {place} hold {held}, not a YAML list of complete profiles"
    )


def _set_db3_qos(db3: Path, qos: str, topic: str | None = None) -> None:
    with sqlite3.connect(db3) as connection:
        connection.execute(
            "update topics set offered_qos_profiles = ? where ? is null or name = ?",
            (qos, topic, topic),
        )
    connection.close()


@pytest.mark.parametrize("qos", QOS_HELD)
def test_a_db3_whose_qos_rosbags_cannot_parse_is_refused_naming_the_topic(
    qos: str, tmp_path: Path
) -> None:
    # rosbags raised on opening it: "cannot open the ros2-db3 file (string indices must be
    # integers, not 'str)", naming no topic (and the library's closing quote cut off).
    db3 = write_streams_bag(tmp_path / "bag", good_streams(), qos=[reliable_qos()]) / "bag.db3"
    _set_db3_qos(db3, qos)
    with pytest.raises(LogError) as error:
        inspect_log(db3)
    assert str(error.value) == _qos_refusal(db3, "/u", "in its topics table", QOS_HELD[qos])


def _drop_deadline_of_y(metadata: Path) -> None:
    text = metadata.read_text()
    y = text.index("name: /y")
    deadline = "        deadline:\n          nsec: 854775807\n          sec: 9223372036\n"
    start = text.index(deadline, y)
    metadata.write_text(text[:start] + text[start + len(deadline) :])


@pytest.mark.parametrize(
    "where", ["metadata.yaml, sqlite3", "metadata.yaml, mcap", "db3 of a bag folder"]
)
def test_a_bag_folder_whose_qos_rosbags_cannot_parse_is_refused_naming_the_topic(
    where: str, tmp_path: Path
) -> None:
    # rosbags said "Invalid bag metadata: string indices must be integers, not 'str'.", "A
    # metadata key is missing KeyError('deadline')." or "Could not load YAML from
    # offered_qos_profiles: ...", naming no topic.
    storage = "mcap" if "mcap" in where else "sqlite3"
    bag = write_streams_bag(tmp_path / "bag", good_streams(), storage, qos=[reliable_qos()])
    if where == "db3 of a bag folder":
        _set_db3_qos(bag / "bag.db3", "- [unclosed", topic="/y")
        place, held = "in the topics table of bag.db3", QOS_HELD["- [unclosed"]
    else:
        _drop_deadline_of_y(bag / "metadata.yaml")
        place, held = "in metadata.yaml", "a profile without 'deadline'"
    with pytest.raises(LogError) as error:
        load(bag)
    assert str(error.value) == _qos_refusal(bag, "/y", place, held)


def test_a_bag_whose_qos_rosbags_cannot_parse_exits_2_naming_the_topic(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    db3 = write_streams_bag(tmp_path / "bag", good_streams()) / "bag.db3"
    _set_db3_qos(db3, "x")
    err = cli_error(["inspect", str(db3)], capsys)
    refusal = _qos_refusal(db3, "/u", "in its topics table", QOS_HELD["x"])
    assert err == f"hybridlog: error: {refusal}\n"


def test_a_definition_encoding_rosbags_does_not_read_is_named(tmp_path: Path) -> None:
    # rosbags raises KeyError('ros2foo') on an unknown definition encoding: it read "cannot
    # open the ros2-db3 file ('ros2foo')" (its text once shown stripped of its quotes, as
    # "string indices must be integers, not 'str" was).
    db3 = write_streams_bag(tmp_path / "bag", good_streams()) / "bag.db3"
    with sqlite3.connect(db3) as connection:
        connection.execute("update message_definitions set encoding = 'ros2foo'")
    connection.close()
    with pytest.raises(LogError) as error:
        inspect_log(db3)
    assert str(error.value) == (
        f"{db3}: a topic's message definition is stored in the encoding 'ros2foo', which "
        "rosbags does not read (ros2msg or ros2idl)"
    )


def test_a_schema_named_without_its_package_is_named_so_not_said_undefined(
    tmp_path: Path,
) -> None:
    # It was "type 'Float64' has no definition in the log or the standard types", though
    # the schema holds one: rosbags parses it as msg/Float64.
    log = tmp_path / "bare_name.mcap"
    streams = [dataclasses.replace(s, msgtype="Float64") for s in good_streams()]
    write_streams_mcap(log, streams)
    problems = inspect_log(log)["problems"]
    assert len(problems) == 2, problems
    assert "defines 'msg/Float64', not its type 'Float64': a ROS type is named" in problems[0]


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_a_storage_file_metadata_yaml_does_not_list_is_named_not_passed_over(
    storage: str, tmp_path: Path
) -> None:
    bag = write_streams_bag(tmp_path / "bag", good_streams(), storage)
    suffix = ".db3" if storage == "sqlite3" else ".mcap"
    shutil.copy(bag / f"bag{suffix}", bag / f"bag_1{suffix}")  # a split file copied in
    (bag / "bag.db3-wal").write_bytes(b"")  # sqlite's journal: no storage file
    (bag / "notes.txt").write_text("mine\n")
    info = inspect_log(bag)
    assert info["reading"]["unlisted_files"] == [f"bag_1{suffix}"]
    assert "metadata.yaml does not list (their messages are not read" in format_inspection(info)
    notes: dict[str, Any] = {}
    load_signals(
        bag,
        SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("a",), dt=1.0),
        ReadOptions(maps=("u=/u.data", "y=/y.data")),
        notes=notes,
    )
    assert notes["unlisted_files"] == [f"bag_1{suffix}"]
    assert [n for n in log_reading_notes(notes) if "does not list" in n] == [
        "WARNING: the bag folder holds storage files its metadata.yaml does not list, whose "
        f"messages are not read: bag_1{suffix} (list them in metadata.yaml, or analyse each "
        "file itself)"
    ]
    (bag / f"bag_1{suffix}").unlink()
    assert "unlisted_files" not in inspect_log(bag)["reading"]
    # a suffix in capitals is one too (suffixes are read so everywhere): it was passed over
    shutil.copy(bag / f"bag{suffix}", bag / f"BAG_2{suffix.upper()}")
    assert inspect_log(bag)["reading"]["unlisted_files"] == [f"BAG_2{suffix.upper()}"]
