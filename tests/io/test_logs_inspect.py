"""``hybridlog inspect`` and ``hybridlog simulate`` for every log format."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl
import pytest
from click.testing import CliRunner

from hybridlog.cli import cli, main
from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, format_inspection, inspect_log, load_signals
from hybridlog.io.bag_writers import write_log
from hybridlog.io.source import seconds_to_ns
from hybridlog.io.summary import round_span, seconds_resolution_ns
from tests.support.logfiles import (
    MAPS,
    SCENE_WRITERS,
    Channel,
    Record,
    float64_cdr,
    float_messages,
    scene,
    tank_run,
    write_mcap,
)

# --out name and extra simulate options, per format
FORMATS = {
    "mcap": ("run.mcap", []),
    "mcap-json": ("run_json.mcap", ["--encoding", "json"]),
    "mcap-ros1": ("run_ros1.mcap", ["--encoding", "ros1"]),
    "bag": ("run.bag", []),
    "ros2-sqlite3": ("run_sqlite", ["--format", "ros2-sqlite3"]),
    "ros2-mcap": ("run_mcap", ["--format", "ros2-mcap"]),
}
TOPICS = ["/truth/mode", "/truth/x1", "/truth/x2", "/truth/x3", "/u", "/y1", "/y2", "/y3"]


def run_main(args: list[str]) -> int:
    try:
        main(args)
    except SystemExit as exit_:
        return int(exit_.code or 0)
    return 0


def invoke(args: list[str]) -> Any:
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0, result.output
    return result


def gapped_log(path: Path, **options: Any) -> Path:
    """The tank run without the samples from 41 s to 49 s (a 10 s gap in every topic)."""
    columns = tank_run().columns
    keep = (columns["t"] <= 40) | (columns["t"] >= 50)
    cut = {
        name: values[keep]
        if isinstance(values, np.ndarray)
        else [v for v, k in zip(values, keep, strict=True) if k]
        for name, values in columns.items()
    }
    return write_log(path, cut, truth=("mode", "x1", "x2", "x3"), **options)


@pytest.mark.parametrize("name", list(FORMATS))
def test_simulate_writes_and_inspect_describes_every_format(name: str, tmp_path: Path) -> None:
    out, extra = FORMATS[name]
    invoke(["simulate", "three_tank_hstf", "--out", str(tmp_path / out), "--steps", "60", *extra])
    info = json.loads(invoke(["inspect", str(tmp_path / out), "--json"]).output)
    assert info["messages"] == 8 * 61
    assert [t["name"] for t in info["topics"]] == TOPICS
    by_name = {t["name"]: t for t in info["topics"]}
    assert by_name["/truth/mode"]["type"] == "std_msgs/msg/String"
    assert by_name["/y1"]["type"] == "std_msgs/msg/Float64"
    assert by_name["/y1"]["fields"] == ["/y1.data"]
    for topic in info["topics"]:
        assert topic["count"] == topic["indexed_count"] in (61, None)
        assert topic["rate_hz"] == pytest.approx(1.0)
        assert (topic["start"], topic["end"], topic["gap_count"]) == (0.0, 60.0, 0)
    assert info["time"] == {"start": 0.0, "end": 60.0, "duration": 60.0}
    assert info["problems"] == []
    text = invoke(["inspect", str(tmp_path / out)]).output
    assert "8 topics" in text and "/truth/x3" in text and "/u.data" in text


@pytest.mark.parametrize("options", [{}, {"format": "ros2-sqlite3"}])
def test_inspect_reports_gaps_per_topic(options: dict[str, str], tmp_path: Path) -> None:
    log = gapped_log(tmp_path / ("gap.mcap" if not options else "gap"), **options)
    info = json.loads(invoke(["inspect", str(log), "--json"]).output)
    for topic in info["topics"]:
        assert topic["gap_count"] == 1
        assert topic["gaps"] == [{"start": 40.0, "end": 50.0, "duration": 10.0}]
    text = invoke(["inspect", str(log)]).output
    assert "/y2: 40 s to 50 s (10 s)" in text


def test_gapped_log_is_refused_or_split(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = gapped_log(tmp_path / "gap.mcap")
    out = tmp_path / "report"
    args = ["analyze", str(log), "--model", "three_tank_hstf", "--out", str(out)]
    assert run_main(args) == 2
    assert "from t=40 s to t=50 s" in capsys.readouterr().err
    assert run_main([*args, "--split-gaps"]) == 0
    report = json.loads((out / "report.json").read_text())
    assert report["reading"]["segments"] == [
        {"start": 0.0, "end": 40.0, "duration": 40.0},
        {"start": 50.0, "end": 90.0, "duration": 40.0},
    ]
    assert report["reading"]["analysed_segment"] == 0
    assert (report["t_start"], report["t_end"], report["samples"]) == (0.0, 40.0, 41)


def test_simulate_refuses_what_it_cannot_write(tmp_path: Path) -> None:
    runner = CliRunner()
    cases = [
        (["--out", str(tmp_path / "run.txt")], "cannot tell the log format"),
        (["--out", str(tmp_path / "run.csv"), "--encoding", "json"], "only an MCAP file"),
        (["--out", str(tmp_path / "run.csv"), "--format", "parquet"], "must be named *.parquet"),
    ]
    for args, message in cases:
        result = runner.invoke(cli, ["simulate", "three_tank_hstf", *args])
        assert result.exit_code != 0
        assert message in str(result.exception) + result.output
    existing = tmp_path / "exists.mcap"
    existing.write_bytes(b"mine")
    result = runner.invoke(cli, ["simulate", "three_tank_hstf", "--out", str(existing)])
    assert result.exit_code != 0 and existing.read_bytes() == b"mine"
    forced = [*("simulate", "three_tank_hstf", "--out", str(existing)), "--steps", "5", "--force"]
    result = runner.invoke(cli, forced)  # not even with --force: the user's file
    assert result.exit_code != 0 and existing.read_bytes() == b"mine"
    existing.unlink()
    invoke(forced)  # a new file, then one hybridlog wrote: replaced
    invoke(forced)
    assert existing.read_bytes().startswith(b"\x89MCAP0\r\n")
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == [
        ".exists.mcap.hybridlog"
    ]


def test_simulated_topics_hold_the_columns(tmp_path: Path) -> None:
    from rosbags.highlevel import AnyReader

    bag = write_log(tmp_path / "run.bag", tank_run().columns, truth=("mode", "x1", "x2", "x3"))
    columns = tank_run().columns
    with AnyReader([bag]) as reader:
        values: dict[str, list[Any]] = {}
        for connection, _, raw in reader.messages():
            values.setdefault(connection.topic, []).append(
                reader.deserialize(raw, connection.msgtype).data
            )
    np.testing.assert_array_equal(values["/y2"], columns["y2"])
    np.testing.assert_array_equal(values["/truth/x3"], columns["x3"])
    assert values["/truth/mode"] == list(columns["mode"])


def test_table_options(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    frame = pl.DataFrame({"t": [0.0, 2.0, 1.0, 3.0, 3.0], "u": [1.0] * 5, "y1": [1.0, 2, 3, 4, 5]})
    frame = frame.with_columns(y2=pl.col("y1"), y3=pl.col("y1"))
    log = tmp_path / "unordered.csv"
    frame.write_csv(log)
    out = tmp_path / "report"
    args = ["analyze", str(log), "--model", "three_tank_hstf", "--out", str(out)]
    for extra, code, message in (
        ([], 2, "time goes backwards"),
        (["--time", "header"], 2, "its time column is the only time"),
        (["--sort"], 0, ""),
    ):
        assert run_main([*args, *extra]) == code
        assert message in capsys.readouterr().err
    report = json.loads((out / "report.json").read_text())
    assert report["reading"]["sorted"] == {"rows_out_of_order": 1}
    assert report["reading"]["rows_combined"] == 1
    assert report["reading"]["duplicates_dropped"] == 1
    assert "values_superseded" not in report["reading"]
    assert report["samples"] == 4


# ------------------------------------------------------------------ timing and non-finite values

# 20 samples over 9 s: four bursts of five samples 1 ms apart, 3 s between the bursts
BURSTS = np.concatenate([start + np.arange(5) * 1e-3 for start in (0.0, 3.0, 6.0, 8.996)])


@pytest.mark.parametrize("suffix", [".csv", ".parquet", ".mcap", ".bag"])
def test_bursty_timing_reports_the_mean_rate_and_the_spread_of_steps(
    suffix: str, tmp_path: Path
) -> None:
    log = write_log(tmp_path / f"bursts{suffix}", {"t": BURSTS, "y": np.ones(20)})
    info = inspect_log(log)
    for steps in info.get("topics", [info]):
        assert steps["rate_hz"] == pytest.approx(19 / 9)  # not 1 / (1 ms)
        assert steps["sample_time"] == pytest.approx(1e-3)
        assert steps["min_step"] == pytest.approx(1e-3)
        assert steps["max_step"] == pytest.approx(2.996)
        assert steps["regular"] is False
        assert steps["gap_count"] == 3
    for column in info.get("columns", []):
        assert column["rate_hz"] == pytest.approx(19 / 9)
    text = format_inspection(info)
    assert "1000 Hz" not in text.replace("median step 0.001 s (1000 Hz)", "")
    assert "median step 0.001 s (1000 Hz), steps 0.001 s to 2.996 s" in text
    if "topics" in info:
        assert "irregular timing" in text
    else:
        assert "(9 s), 2.11111 Hz on average\ntiming irregular: median step" in text


def test_regular_timing_keeps_its_sample_time(tmp_path: Path) -> None:
    log = write_log(tmp_path / "even.csv", {"t": np.arange(11) * 0.1, "y": np.ones(11)})
    info = inspect_log(log)
    assert info["rate_hz"] == pytest.approx(10.0)
    assert (info["sample_time"], info["min_step"], info["max_step"]) == (0.1, 0.1, 0.1)
    assert info["regular"] is True
    assert "(1 s), sample time 0.1 s (10 Hz)" in format_inspection(info)


# a 100 Hz log stamped in Unix time, 0.51 s without a row after the 50th
UNIX_TIMES = np.concatenate([1.7e9 + np.arange(50) * 0.01, 1.7e9 + 1.0 + np.arange(20) * 0.01])


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_steps_of_unix_times_hold_only_the_digits_the_times_do(suffix: str, tmp_path: Path) -> None:
    """Float64 seconds near 1.7e9 are 238 ns apart: the steps read 0.00999999 s, the gap
    0.50999999 s and the span 1.18999999 s, differences of the floats to the nanosecond.
    Rounded to the microsecond the times resolve, they are 0.01 s, 0.51 s and 1.19 s."""
    log = write_log(tmp_path / f"unix{suffix}", {"t": UNIX_TIMES, "y": np.ones(70)})
    info = inspect_log(log)
    for steps in (info, *info["columns"]):
        assert (steps["sample_time"], steps["min_step"], steps["max_step"]) == (0.01, 0.01, 0.51)
        assert steps["rate_hz"] == 69 / 1.19
        assert [gap["duration"] for gap in steps["gaps"]] == [0.51]
    assert info["time"]["duration"] == 1.19
    text = format_inspection(info)
    assert "(1.19 s), 57.9832 Hz on average" in text
    assert "median step 0.01 s (100 Hz), steps 0.01 s to 0.51 s" in text
    assert "1700000000.49 s to 1700000001 s (0.51 s)" in text
    assert "1700000000  1700000001.19" in text  # the time column's range, not 1.7e+09
    assert "0.0099999" not in text and "0.5099999" not in text


def test_steps_of_small_times_and_of_nanoseconds_are_kept_whole(tmp_path: Path) -> None:
    """Times that resolve the nanosecond lose nothing to the rounding: a 7 ns step of a
    table stays 7 ns, and a message log's integer nanoseconds are exact at Unix times."""
    fine = 12.0 + np.arange(4) * 7e-9
    table = write_log(tmp_path / "fine.parquet", {"t": fine, "y": np.ones(4)})
    assert inspect_log(table)["sample_time"] == 7e-9
    bag = write_log(tmp_path / "unix.mcap", {"t": UNIX_TIMES, "y": np.ones(70)})
    topic = inspect_log(bag)["topics"][0]
    stamps = seconds_to_ns(UNIX_TIMES)
    assert topic["duration"] == int(stamps[-1] - stamps[0]) / 1e9
    assert topic["max_step"] == int(stamps[50] - stamps[49]) / 1e9


def test_spans_are_rounded_to_the_resolution_of_the_times() -> None:
    assert seconds_resolution_ns(np.array([1.7e9])) == pytest.approx(238.4, abs=0.1)
    assert seconds_resolution_ns(np.array([1.7e9], dtype=np.float32), np.float32) == 128e9
    assert seconds_resolution_ns(np.array([-3.0, 2.0])) == 1.0
    assert round_span(9_999_990, 238.4) == 0.01
    assert round_span(9_999_990, 1000.0) == 0.01
    assert round_span(9_999_990, 1.0) == 0.00999999
    assert round_span(1_190_000_238, 238.4) == 1.19


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_table_columns_count_nonfinite_values_apart(suffix: str, tmp_path: Path) -> None:
    n = 8
    y = np.arange(n, dtype=float)
    y[[2, 5]] = np.nan
    y[6] = -np.inf
    columns = {"t": np.arange(n) * 0.1, "u": np.where(np.arange(n) == 3, np.inf, 1.0), "y": y}
    log = write_log(tmp_path / f"log{suffix}", columns)
    if suffix == ".parquet":  # an empty cell (null) is no sample; NaN is a sample
        frame = pl.read_parquet(log).with_columns(
            y=pl.when(pl.int_range(pl.len()) == 7).then(None).otherwise(pl.col("y"))
        )
        frame.write_parquet(log)
    else:
        log.write_text(log.read_text().replace("\n0.7000000000000001,1.0,7.0\n", "\n0.7,1.0,\n"))
    info = inspect_log(log)
    by_name = {c["name"]: c for c in info["columns"]}
    assert [(by_name[c]["count"], by_name[c]["nonfinite"]) for c in ("t", "u", "y")] == [
        (8, 0),
        (8, 1),
        (7, 3),
    ]
    assert (by_name["y"]["min"], by_name["y"]["max"]) == (0.0, 4.0)
    # analyze refuses the same samples inspect counts (and counts them when dropping them)
    spec = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("a",), dt=0.1)
    notes: dict[str, Any] = {}
    load_signals(log, spec, ReadOptions(drop_nonfinite=True), notes=notes)
    assert notes["nonfinite_dropped"] == {"u": 1, "y": 3}
    text = format_inspection(info)
    assert "column  dtype    count  nonfinite  min  max" in text
    assert "non-finite values (NaN, inf; analyze refuses them" in text
    assert "  u: 1 of 8\n  y: 3 of 7" in text


def nonfinite_scene() -> list[Record]:
    """The recorded scene with NaN in two points, +inf in a state array, -inf in an input."""
    records = scene(tank_run())
    levels = [i for i, r in enumerate(records) if r.topic == "/levels"]
    states = [i for i, r in enumerate(records) if r.topic == "/sim/state"]
    inputs = [i for i, r in enumerate(records) if r.topic == "/pump/cmd"]
    for i in levels[10], levels[40]:
        records[i] = dataclasses.replace(records[i], value=(np.nan, records[i].value[1]))
    x1, _, x3 = records[states[50]].value
    records[states[50]] = dataclasses.replace(records[states[50]], value=[x1, np.inf, x3])
    records[inputs[3]] = dataclasses.replace(records[inputs[3]], value=-np.inf)
    return records


@pytest.mark.parametrize("writer", list(SCENE_WRITERS))
def test_message_fields_count_nonfinite_values_apart(writer: str, tmp_path: Path) -> None:
    name, write = SCENE_WRITERS[writer]
    log = write(tmp_path / name, nonfinite_scene())
    info = inspect_log(log)
    json.dumps(info, allow_nan=False)
    topics = {t["name"]: t for t in info["topics"]}
    assert {name: t["nonfinite"] for name, t in topics.items()} == {
        "/chatter": 0,
        "/imu": 0,
        "/level3": 0,
        "/levels": 2,
        "/pump/cmd": 1,
        "/sim/mode": 0,
        "/sim/state": 1,
    }
    values = {v["name"]: v for t in info["topics"] for v in t["values"]}
    assert values["/levels.point.x"] == {"name": "/levels.point.x", "count": 91, "nonfinite": 2}
    assert values["/levels.point.y"]["nonfinite"] == 0
    assert values["/sim/state.data[]"] == {
        "name": "/sim/state.data[]",
        "count": 273,
        "nonfinite": 1,
    }
    assert values["/pump/cmd.data"] == {"name": "/pump/cmd.data", "count": 19, "nonfinite": 1}
    assert topics["/levels"]["count"] == 91  # messages, NaN or not
    # the samples analyze would refuse, one mapped path each
    spec = SignalSpec(
        states=("x1", "x2", "x3"),
        inputs=("u",),
        outputs=("y1", "y2", "y3"),
        mode_ids=("1", "2", "3"),
        dt=1.0,
    )
    notes: dict[str, Any] = {}
    maps = tuple(m for m in MAPS if m != "--map")
    load_signals(log, spec, ReadOptions(maps=maps, drop_nonfinite=True), notes=notes)
    assert notes["nonfinite_dropped"] == {
        "/pump/cmd.data": 1,
        "/levels.point.x": 2,
        "/sim/state.data[1]": 1,
    }


def test_undecodable_messages_leave_their_values_uncounted(tmp_path: Path) -> None:
    messages = [(0, k * 10**8, float64_cdr(float(k))) for k in range(5)]
    messages.append((1, 0, b"\x00\x01\x00\x00\x01"))  # four bytes short of a Float64
    log = write_mcap(tmp_path / "bad.mcap", [Channel("/y"), Channel("/u")], messages)
    info = inspect_log(log)
    topics = {t["name"]: t for t in info["topics"]}
    assert (topics["/u"]["count"], topics["/u"]["nonfinite"], topics["/u"]["values"]) == (
        1,
        None,
        None,
    )
    assert topics["/y"]["nonfinite"] == 0
    (problem,) = info["problems"]
    assert problem.startswith("topic '/u' (std_msgs/msg/Float64): the message logged at t=0 s")
    assert "cannot be decoded" in problem


def test_inspect_shows_irregular_timing_and_nonfinite_values(tmp_path: Path) -> None:
    y = np.ones(20)
    y[[4, 11]] = np.nan
    log = write_log(tmp_path / "bursts.mcap", {"t": BURSTS, "y": y})
    text = invoke(["inspect", str(log)]).output
    assert "topic  type                  count  nonfinite  rate_hz  gaps" in text
    assert "/y     std_msgs/msg/Float64  20     2          2.11111  3" in text
    assert "irregular timing (rate_hz is the mean rate over the topic's span):\n" in text
    assert "  /y: median step 0.001 s (1000 Hz), steps 0.001 s to 2.996 s\n" in text
    assert "non-finite values (NaN, inf; analyze refuses them in a mapped signal unless " in text
    assert "  /y.data: 2 of 20\n" in text


def test_every_field_of_a_large_message_is_listed_and_counted(tmp_path: Path) -> None:
    """A message of 80 float64 fields (a PX4 status has as many): inspect listed 64 of them
    and counted NaN in those only, so a field full of NaN past the 64th showed nonfinite 0."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    text = "\n".join(f"float64 f{i}" for i in range(80))
    store = get_typestore(Stores.LATEST)
    store.register(get_types_from_msg(text, "my_msgs/msg/Big"))
    big = store.types["my_msgs/msg/Big"]
    messages = [
        (
            0,
            k * 10**8,
            bytes(
                store.serialize_cdr(
                    big(**{f"f{i}": np.nan if i == 70 else float(k) for i in range(80)}),
                    "my_msgs/msg/Big",
                )
            ),
        )
        for k in range(10)
    ]
    channel = Channel("/big", schema_name="my_msgs/msg/Big", schema_text=text)
    info = inspect_log(write_mcap(tmp_path / "big.mcap", [channel], messages))
    (topic,) = info["topics"]
    assert topic["fields"] == [f"/big.f{i}" for i in range(80)]
    assert topic["nonfinite"] == 10
    assert {"name": "/big.f70", "count": 10, "nonfinite": 10} in topic["values"]
    assert "  /big.f70: 10 of 10" in format_inspection(info).splitlines()


def test_a_topic_published_twice_per_step_still_shows_its_gaps(tmp_path: Path) -> None:
    """Every message sent twice, and a 10.1 s hole: the median step was 0 (as many repeats as
    steps), so no step was a gap and inspect showed 'gaps 0', 'median step 0 s'."""
    times = [k * 10**8 for k in (*range(20), *range(121, 140)) for _ in range(2)]
    log = write_mcap(tmp_path / "twice.mcap", [Channel("/y")], float_messages(times, times))
    (topic,) = inspect_log(log)["topics"]
    assert topic["sample_time"] == pytest.approx(0.1)
    assert (topic["min_step"], topic["regular"]) == (0.0, False)
    assert topic["gap_count"] == 1
    assert topic["gaps"] == [{"start": 1.9, "end": 12.1, "duration": pytest.approx(10.2)}]


def test_samples_all_at_one_time_have_no_sample_time(tmp_path: Path) -> None:
    """Three messages (or rows) logged at one time have no step forward: inspect gave them a
    sample time of 0 s, called regular, and the text 'sample time 0 s (- Hz)'."""
    same = write_mcap(tmp_path / "same.mcap", [Channel("/y")], float_messages([5] * 3, [0] * 3))
    (topic,) = inspect_log(same)["topics"]
    assert (topic["sample_time"], topic["regular"], topic["rate_hz"]) == (None, None, None)
    assert (topic["min_step"], topic["max_step"], topic["repeated"]) == (0.0, 0.0, 2)
    assert topic["gap_count"] == 0
    table = tmp_path / "same.csv"
    table.write_text("t,y\n1,1\n1,2\n1,3\n")
    info = inspect_log(table)
    assert (info["sample_time"], info["regular"], info["repeated"]) == (None, None, 2)
    text = format_inspection(info)
    assert "time: column 't', 1 s to 1 s (0 s)" in text.split("\n")
    assert "sample time" not in text


def test_repeated_log_times_that_analyze_refuses_are_shown(tmp_path: Path) -> None:
    """inspect called a topic sent twice per step merely irregular; analyze refused it."""
    times = [k * 10**8 for k in range(20) for _ in range(2)]
    channels = [Channel("/y"), Channel("/u")]
    messages = [*float_messages(times, times), *float_messages(times[::2], times[::2], 1)]
    log = write_mcap(tmp_path / "twice.mcap", channels, sorted(messages, key=lambda m: m[1]))
    info = inspect_log(log)
    assert {t["name"]: t["repeated"] for t in info["topics"]} == {"/u": 0, "/y": 20}
    text = format_inspection(info)
    assert (
        "repeated log times (analyze refuses them unless --sort, which keeps the last):\n"
        "  /y: 20 messages at the time of the one before\n"
    ) in text
    assert "/u: 0" not in text
    spec = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("a",), dt=0.1)
    with pytest.raises(LogError, match="20 message"):
        load_signals(log, spec, ReadOptions(maps=("u=/u.data", "y=/y.data")))
    table = write_log(tmp_path / "even.csv", {"t": np.arange(5) * 0.1, "y": np.ones(5)})
    assert inspect_log(table)["repeated"] == 0


def tf_message(store: Any, stamp: int, xs: list[float]) -> bytes:
    """A ``tf2_msgs/msg/TFMessage`` of one transform per ``xs`` (its translation.x)."""
    types = store.types
    transforms = [
        types["geometry_msgs/msg/TransformStamped"](
            header=types["std_msgs/msg/Header"](
                stamp=types["builtin_interfaces/msg/Time"](sec=stamp, nanosec=0), frame_id="map"
            ),
            child_frame_id=f"link{i}",
            transform=types["geometry_msgs/msg/Transform"](
                translation=types["geometry_msgs/msg/Vector3"](x=x, y=0.0, z=0.0),
                rotation=types["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
            ),
        )
        for i, x in enumerate(xs)
    ]
    message = types["tf2_msgs/msg/TFMessage"](transforms=transforms)
    return bytes(store.serialize_cdr(message, "tf2_msgs/msg/TFMessage"))


def test_nonfinite_values_inside_arrays_of_messages_are_counted(tmp_path: Path) -> None:
    """/tf with a NaN translation in one transform: inspect showed nonfinite 0, counting
    only leaves outside arrays of messages."""
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.LATEST)
    messages = [
        (0, k * 10**8, tf_message(store, k, [1.0, np.nan if k in (3, 7) else float(k)]))
        for k in range(10)
    ]
    channel = Channel("/tf", schema_name="tf2_msgs/msg/TFMessage")
    info = inspect_log(write_mcap(tmp_path / "tf.mcap", [channel], messages))
    json.dumps(info, allow_nan=False)
    (topic,) = info["topics"]
    assert topic["nonfinite"] == 2
    values = {v["name"]: v for v in topic["values"]}
    assert values["/tf.transforms[].transform.translation.x"] == {
        "name": "/tf.transforms[].transform.translation.x",
        "count": 20,
        "nonfinite": 2,
    }
    assert values["/tf.transforms[].transform.rotation.w"]["count"] == 20
    text = format_inspection(info).splitlines()
    assert "  /tf.transforms[].transform.translation.x: 2 of 20" in text


def json_mcap(path: Path, documents: list[Any], schema: dict[str, Any] | None = None) -> Path:
    """An MCAP of one JSON topic ``/j``, a message per document, 0.1 s apart."""
    channel = Channel(
        "/j",
        encoding="json",
        schema_name="j",
        schema_encoding="jsonschema",
        schema_text=json.dumps(schema or {}),
    )
    messages = [(0, k * 10**8, json.dumps(d).encode()) for k, d in enumerate(documents)]
    return write_mcap(path, [channel], messages)


def test_nonfinite_values_inside_json_arrays_of_objects_are_counted(tmp_path: Path) -> None:
    """NaN in ``poses[1].x`` and 10 levels down: inspect counted numbers 8 levels deep at
    most, and none inside arrays of objects."""
    deep: Any = float("nan")
    for level in range(10):
        deep = {f"l{level}": deep}
    documents = [
        {"poses": [{"x": 1.0}, {"x": float("nan") if k == 2 else 2.0}], "deep": deep}
        for k in range(4)
    ]
    info = inspect_log(json_mcap(tmp_path / "j.mcap", documents))
    json.dumps(info, allow_nan=False)
    (topic,) = info["topics"]
    values = {v["name"]: (v["count"], v["nonfinite"]) for v in topic["values"]}
    assert values["/j.poses[].x"] == (8, 1)
    deep_path = "/j.deep" + "".join(f".l{level}" for level in reversed(range(10)))
    assert values[deep_path] == (4, 4)
    assert topic["nonfinite"] == 5
    assert info["problems"] == []


def test_json_nested_past_the_guard_is_reported(tmp_path: Path) -> None:
    """A pathological nesting is a problem of the topic, its values not counted."""
    from hybridlog.io.json_schemas import MAX_JSON_DEPTH

    deep: Any = [1.0]
    for _ in range(MAX_JSON_DEPTH + 5):
        deep = [deep]
    schema: Any = {"type": "number"}
    for _ in range(MAX_JSON_DEPTH + 5):
        schema = {"type": "object", "properties": {"a": schema}}
    info = inspect_log(json_mcap(tmp_path / "deep.mcap", [{"v": deep}] * 2, schema))
    (topic,) = info["topics"]
    assert topic["values"] is None and topic["nonfinite"] is None
    schema_problem, message_problem = info["problems"]
    assert schema_problem.startswith(
        f"topic '/j' (j): its JSON schema nests deeper than {MAX_JSON_DEPTH} levels at '.a.a."
    )
    assert message_problem.startswith(
        f"topic '/j' (j): the message logged at t=0 s nests deeper than {MAX_JSON_DEPTH} "
        "levels at '.v[][]"
    )
    assert "values are not counted" in message_problem


def test_whole_message_hints_and_fields_name_what_the_topic_has(tmp_path: Path) -> None:
    """'/tf' mapped as a whole: the hint said 'e.g. /tf.data', a field TFMessage lacks, and
    inspect listed no field of /tf (nor of a JSON topic without a schema) but the bare topic."""
    from rosbags.typesys import Stores, get_typestore

    from hybridlog.io.formats import open_log
    from hybridlog.io.message_paths import PathError

    store = get_typestore(Stores.LATEST)
    messages = [(0, k * 10**8, tf_message(store, k, [float(k)])) for k in range(3)]
    tf = write_mcap(
        tmp_path / "tf.mcap", [Channel("/tf", schema_name="tf2_msgs/msg/TFMessage")], messages
    )
    (topic,) = inspect_log(tf)["topics"]
    assert "/tf.transforms[].transform.translation.x" in topic["fields"]
    assert "/tf" not in topic["fields"]
    with open_log(tf) as source, pytest.raises(PathError) as info:
        source.resolve("/tf", "number")
    assert "e.g. /tf.transforms[0].transform.translation.x (" in str(info.value)
    assert ".data" not in str(info.value)
    source_path = source.resolve("/tf.transforms[0].transform.translation.x", "number")
    assert source_path.steps == ("transforms", 0, "transform", "translation", "x")

    documents = [{"pose": {"x": 1.0, "frame": "map"}, "ok": True, "w": [1, 2]}] * 3
    schemaless = json_mcap(tmp_path / "j.mcap", documents)
    (topic,) = inspect_log(schemaless)["topics"]
    assert topic["fields"] == ["/j.pose.x", "/j.pose.frame", "/j.ok", "/j.w[]"]
    with open_log(schemaless) as source, pytest.raises(PathError) as info:
        source.resolve("/j", "number")
    assert "the topic has no JSON schema listing them" in str(info.value)

    # a JSON schema's arrays of objects are listed as a ROS message's arrays of messages are
    point = {"type": "object", "properties": {"x": {"type": "number"}}}
    schema = {"type": "object", "properties": {"poses": {"type": "array", "items": point}}}
    with_schema = json_mcap(tmp_path / "js.mcap", [{"poses": [{"x": 1.0}]}] * 3, schema)
    (topic,) = inspect_log(with_schema)["topics"]
    assert topic["fields"] == ["/j.poses[].x"]
    with open_log(with_schema) as source, pytest.raises(PathError) as info:
        source.resolve("/j", "number")
    assert str(info.value).endswith("add a field, e.g. /j.poses[0].x")
    assert source.resolve("/j.poses[0].x", "number").steps == ("poses", 0, "x")
