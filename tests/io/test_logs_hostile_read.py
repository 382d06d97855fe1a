"""Logs of other tools that a hostile user brought, one defect per test.

Every file is written here by another tool's writer (rosbags' ROS 1 bag writer, the
``mcap_ros2`` writer, polars' CSV and Parquet writers, or plain text), never by hybridlog's.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl
import pytest
from mcap.writer import Writer as McapWriter
from mcap_ros2.writer import Writer as Ros2McapWriter
from rosbags.rosbag1 import Writer as Ros1Writer
from rosbags.typesys import Stores, get_typestore

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, inspect_log, load_signals
from tests.support.logfiles import STAMPED_DEFINITION

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1", "2"), dt=0.1)
N = 40


def load(log: Path, *maps: str, **options: Any) -> Any:
    return load_signals(log, SPEC, ReadOptions(maps=maps, **options))


# ------------------------------------------------------------------ header stamps never set


def _ros2_mcap_with_stamps(path: Path, stamps_ns: list[int]) -> Path:
    with path.open("wb") as stream:
        writer = Ros2McapWriter(stream)
        schema = writer.register_msgdef("my_pkg/msg/Stamped", STAMPED_DEFINITION)
        for k, stamp in enumerate(stamps_ns):
            log_time = 2_000_000_000 + k * 100_000_000
            for topic, value in (("/u", float(k)), ("/y", -float(k))):
                message = {
                    "header": {
                        "stamp": {"sec": stamp // 10**9, "nanosec": stamp % 10**9},
                        "frame_id": "",
                    },
                    "x": value,
                }
                writer.write_message(topic, schema, message, log_time=log_time)
        writer.finish()
    return path


def _ros1_bag_with_stamps(path: Path, stamps_ns: list[int]) -> Path:
    store = get_typestore(Stores.ROS1_NOETIC)
    point_stamped = store.types["geometry_msgs/msg/PointStamped"]
    header = store.types["std_msgs/msg/Header"]
    time = store.types["builtin_interfaces/msg/Time"]
    point = store.types["geometry_msgs/msg/Point"]
    with Ros1Writer(path) as writer:
        connections = [
            writer.add_connection(topic, "geometry_msgs/msg/PointStamped", typestore=store)
            for topic in ("/u", "/y")
        ]
        for k, stamp in enumerate(stamps_ns):
            log_time = 2_000_000_000 + k * 100_000_000
            for connection, value in zip(connections, (float(k), -float(k)), strict=True):
                message = point_stamped(
                    header=header(
                        seq=k, stamp=time(sec=stamp // 10**9, nanosec=stamp % 10**9), frame_id=""
                    ),
                    point=point(x=value, y=0.0, z=0.0),
                )
                data = store.serialize_ros1(message, "geometry_msgs/msg/PointStamped")
                writer.write(connection, log_time, data)
    return path


_WRITERS = {
    "ros2 mcap": (_ros2_mcap_with_stamps, "stamped.mcap", ("u=/u.x", "y=/y.x")),
    "ros1 bag": (_ros1_bag_with_stamps, "stamped.bag", ("u=/u.point.x", "y=/y.point.x")),
}


@pytest.mark.parametrize("kind", sorted(_WRITERS))
@pytest.mark.parametrize("sort", [False, True])
def test_header_stamps_never_set_are_refused_with_the_remedy(
    tmp_path: Path, kind: str, sort: bool
) -> None:
    # Read as times, N zero stamps were "the same header.stamp as the one before", and
    # the remedy offered, --sort, kept one message of each topic.
    write, name, maps = _WRITERS[kind]
    log = write(tmp_path / name, [0] * N)
    with pytest.raises(LogError) as error:
        load(log, *maps, time="header", sort=sort)
    message = str(error.value)
    assert f"topic '/u': header.stamp is 0 in {N} of {N} messages" in message
    assert "(first logged at t=2 s)" in message and "use --time log" in message
    assert "--sort" not in message and "\n" not in message
    signals = load(log, *maps)  # the log times are good
    np.testing.assert_array_equal(signals.outputs[:, 0], -np.arange(N, dtype=float))


@pytest.mark.parametrize("kind", sorted(_WRITERS))
def test_one_stamp_of_zero_is_a_time_like_any_other(tmp_path: Path, kind: str) -> None:
    # simulated time starting at 0: only the first message is stamped 0
    write, name, maps = _WRITERS[kind]
    log = write(tmp_path / name, [k * 100_000_000 for k in range(N)])
    signals = load(log, *maps, time="header")
    np.testing.assert_allclose(signals.time, 0.1 * np.arange(N), atol=1e-12)
    np.testing.assert_array_equal(signals.outputs[:, 0], -np.arange(N, dtype=float))


def test_a_stamp_of_zero_between_negative_and_positive_stamps_is_a_time(tmp_path: Path) -> None:
    # A clock counting from an event passes through 0 once, in order: the zero was refused
    # as "the publisher did not set it" (ROS 2 stamps are signed; ROS 1's are not).
    stamps = [(k - N // 2) * 100_000_000 for k in range(N)]
    log = _ros2_mcap_with_stamps(tmp_path / "stamped.mcap", stamps)
    signals = load(log, "u=/u.x", "y=/y.x", time="header")
    np.testing.assert_allclose(signals.time, 0.1 * (np.arange(N) - N // 2), atol=1e-12)
    np.testing.assert_array_equal(signals.outputs[:, 0], -np.arange(N, dtype=float))
    assert not any("header.stamp is 0" in p for p in inspect_log(log)["problems"])
    # a zero after positive stamps is still one the publisher did not set
    late = [(k + 1) * 100_000_000 for k in range(N - 1)] + [0]
    with pytest.raises(LogError, match=f"header.stamp is 0 in message {N} of {N}"):
        load(
            _ros2_mcap_with_stamps(tmp_path / "late.mcap", late), "u=/u.x", "y=/y.x", time="header"
        )


# ------------------------------------------------------------------ times in another unit


@pytest.mark.parametrize(("suffix", "scale"), [("csv", 10**9), ("parquet", 10**6)])
def test_a_time_column_in_nanoseconds_or_milliseconds_is_named_as_such(
    tmp_path: Path, suffix: str, scale: int
) -> None:
    # 1.7e18 is a finite number: "is not a finite number of seconds" sent the user looking
    # for NaN in a column that has none
    frame = pl.DataFrame(
        {
            "t": 1_700_000_000 * scale + np.arange(N, dtype=np.int64) * (scale // 10),
            "u": np.arange(N, dtype=float),
            "y": -np.arange(N, dtype=float),
        }
    )
    log = tmp_path / f"epoch.{suffix}"
    frame.write_csv(log) if suffix == "csv" else frame.write_parquet(log)
    with pytest.raises(LogError) as error:
        load(log)
    where = "line 2" if suffix == "csv" else "row 1"
    assert str(error.value) == (
        f"{log}, {where}, column 't': time {1.7e9 * scale:g} is beyond the 9.2e+09 s the "
        "nanosecond grid holds (times are in seconds: a column of milliseconds or nanoseconds?)"
    )
    assert "finite" not in str(inspect_log(log)["problems"])


# ------------------------------------------------------------------ CSV of other separators


@pytest.mark.parametrize(("separator", "word"), [(";", "semicolons"), ("\t", "tabs")])
def test_a_csv_separated_otherwise_than_by_commas_is_named_so(
    tmp_path: Path, separator: str, word: str
) -> None:
    # was "no column for input 'u' ... available: 't;u;y'", and for tabs "column 1 of the
    # header ... is not printable text (a zeroed or binary file?)"
    frame = pl.DataFrame({"t": 0.1 * np.arange(N), "u": np.zeros(N), "y": np.ones(N)})
    log = tmp_path / "excel.csv"
    frame.write_csv(log, separator=separator)
    header = repr(separator.join(frame.columns))
    expected = (
        f"{log}, line 1: the header {header} is separated by {word}; hybridlog reads "
        "comma-separated CSV (and a point as the decimal separator): convert the file"
    )
    for read in (load, inspect_log):
        with pytest.raises(LogError) as error:
            read(log)
        assert str(error.value) == expected


# ------------------------------------------------------------------ Parquet booleans


def test_a_parquet_boolean_column_reads_as_0_and_1_like_a_message_bool(tmp_path: Path) -> None:
    # a valve's open/closed input: a ROS bool or a JSON boolean read as 0 and 1, the same
    # column in Parquet was refused ("has type Boolean, expected a number")
    opened = np.arange(N) % 3 == 0
    log = tmp_path / "valve.parquet"
    pl.DataFrame(
        {"t": 0.1 * np.arange(N), "open": opened, "y": -np.arange(N, dtype=float)}
    ).write_parquet(log)
    signals = load(log, "u=open")
    np.testing.assert_array_equal(signals.inputs[:, 0], opened.astype(float))
    column = {c["name"]: c for c in inspect_log(log)["columns"]}["open"]
    assert (column["nonfinite"], column["min"], column["max"]) == (0, 0.0, 1.0)
    # a time column stays a number proper
    pl.DataFrame({"t": opened, "u": np.zeros(N), "y": np.zeros(N)}).write_parquet(log)
    with pytest.raises(LogError, match=r"column 't' has type Boolean, expected seconds as "):
        load(log)


# ------------------------------------------------------------------ one topic, two schemas


def test_a_topic_of_two_schemas_names_both_with_their_counts(tmp_path: Path) -> None:
    # inspect's table shows the first channel's type; the problem said only "has channels
    # with different schemas or encodings", so 20 messages of /y were of a type never named
    log = tmp_path / "two.mcap"
    with log.open("wb") as stream:
        writer = McapWriter(stream)
        writer.start("x", "test")
        number = {"type": "object", "properties": {"data": {"type": "number"}}}
        text = {"type": "object", "properties": {"data": {"type": "string"}}}
        schema_ids = {
            name: writer.register_schema(
                name=name, encoding="jsonschema", data=json.dumps(schema).encode()
            )
            for name, schema in (("Number", number), ("Text", text))
        }
        channels = {
            key: writer.register_channel(
                topic=topic, message_encoding="json", schema_id=schema_ids[name]
            )
            for key, topic, name in (
                ("Number", "/y", "Number"),
                ("Text", "/y", "Text"),
                ("u", "/u", "Number"),
            )
        }
        for k in range(N):
            t = 10**9 + k * 10**8
            kind = "Number" if k < 30 else "Text"
            value: object = float(k) if kind == "Number" else str(k)
            for channel, data in ((channels[kind], value), (channels["u"], float(k))):
                message = json.dumps({"data": data}).encode()
                writer.add_message(channel, log_time=t, publish_time=t, data=message)
        writer.finish()
    problem = (
        "topic '/y' (Number): has channels with different schemas or encodings: "
        "'Number' in 'json' (30 messages), 'Text' in 'json' (10 messages)"
    )
    assert inspect_log(log)["problems"] == [problem]
    with pytest.raises(LogError) as error:
        load(log, "u=/u.data", "y=/y.data")
    assert str(error.value).endswith(problem)


# ------------------------------------------------------------------ fields are not columns


def test_errors_of_alignment_call_a_message_path_a_field_not_a_column(tmp_path: Path) -> None:
    # "truth.mode (column '/mode.data') has no samples" of a bag, which has no columns
    store = get_typestore(Stores.ROS1_NOETIC)
    number, text = store.types["std_msgs/msg/Float64"], "std_msgs/msg/Float64"
    log = tmp_path / "gappy.bag"
    with Ros1Writer(log) as writer:
        u = writer.add_connection("/u", text, typestore=store)
        y = writer.add_connection("/y", text, typestore=store)
        writer.add_connection("/mode", "std_msgs/msg/String", typestore=store)  # no messages
        for k in range(N):
            t = 10**9 + k * 10**8
            writer.write(u, t, store.serialize_ros1(number(data=float(k)), text))
            if not 10 <= k < 20:
                writer.write(y, t, store.serialize_ros1(number(data=-float(k)), text))
    with pytest.raises(LogError) as error:
        load(log, "u=/u.data", "y=/y.data", "truth.mode=/mode.data", max_gap=10.0)
    assert str(error.value) == (
        f"{log}: truth.mode (field '/mode.data', from --map truth.mode=/mode.data) has no samples"
    )
    with pytest.raises(LogError) as error:
        load(log, "u=/u.data", "y=/y.data")
    assert str(error.value) == (
        f"{log}: gap in output 'y' (field '/y.data'): no sample from t=1.9 s to t=3 s "
        "(1.1 s > max_gap 0.5 s); --max-gap SECONDS accepts longer gaps, --split-gaps analyses "
        "the longest piece between them"
    )


# ------------------------------------------------------------------ names polars would glob


def _tables(folder: Path, name: str, sign: float = -1.0) -> list[Path]:
    """``name`` as a CSV and a Parquet log written by polars (through files Python opens)."""
    y = sign * np.arange(N)
    frame = pl.DataFrame({"t": np.arange(N) * 0.1, "u": np.arange(N) * 1.0, "y": y})
    paths = []
    for suffix in (".csv", ".parquet"):
        path = Path(os.fsdecode(os.fsencode(folder) + b"/" + os.fsencode(name) + suffix.encode()))
        with path.open("wb") as stream:
            frame.write_csv(stream) if suffix == ".csv" else frame.write_parquet(stream)
        paths.append(path)
    return paths


@pytest.mark.parametrize(
    "name", ["run[1]", "run?", "run*", "run\udcff"], ids=["brackets", "?", "*", "not UTF-8"]
)
def test_a_log_s_name_is_a_name_not_a_pattern(tmp_path: Path, name: str) -> None:
    """polars globbed the path it was given (run[1].csv matched nothing, run?.csv any run1.csv)
    and took no name that is not UTF-8 (an unexpected TypeError)."""
    _tables(tmp_path, "run1", sign=1.0)  # what run?, run* and run[1] match as patterns
    for log in _tables(tmp_path, name):
        signals = load(log)
        np.testing.assert_array_equal(signals.outputs[:, 0], -np.arange(N))
        info = inspect_log(log)
        assert {c["name"] for c in info["columns"]} == {"t", "u", "y"}


def test_simulate_s_writer_takes_a_name_that_is_not_utf8(tmp_path: Path) -> None:
    from hybridlog.io.writers import write_table

    for suffix in (".csv", ".parquet"):
        path = tmp_path / f"sim\udcff{suffix}"
        write_table(path, {"t": np.arange(3.0), "y": np.ones(3)})
        with path.open("rb") as stream:
            frame = pl.read_csv(stream) if suffix == ".csv" else pl.read_parquet(stream)
        assert frame["y"].to_list() == [1.0, 1.0, 1.0]


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_a_process_without_sys_stderr_reads_tables(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, suffix: str
) -> None:
    # sys.stderr is None where descriptor 2 was closed at the start: every log of
    # 'batch --jobs 2 2>&-' failed in its worker on "'NoneType' object has no attribute 'flush'"
    frame = pl.DataFrame({"t": np.arange(N) * 0.1, "u": np.zeros(N), "y": np.ones(N)})
    log = tmp_path / f"run{suffix}"
    frame.write_csv(log) if suffix == ".csv" else frame.write_parquet(log)
    monkeypatch.setattr("sys.stderr", None)
    assert load(log).outputs.tolist() == [[1.0]] * N
