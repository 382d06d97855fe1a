"""``hybridlog inspect`` and ``hybridlog simulate`` for every log format."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl
import pytest
from click.testing import CliRunner

from hybridlog.cli import cli, main
from hybridlog.io.bag_writers import write_log
from tests.support.logfiles import tank_run

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
        (["--out", str(tmp_path / "run.csv"), "--encoding", "json"], "only MCAP files"),
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
    assert report["reading"]["duplicates_dropped"] == 1
    assert report["samples"] == 4
