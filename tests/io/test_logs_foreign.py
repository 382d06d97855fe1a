"""Logs written by other tools are analysed like hybridlog's own.

The same tank run is recorded as a robot would (see ``logfiles.scene``): unrelated topics,
outputs logged 4 ms after the step, the input published only every 5 s, one output topic at
four times the rate, the true mode as an ``Int32`` and the true states in an array.  Each
file is written with another library's own writer -- rosbags (ROS 1 bag, ROS 2 bags with
sqlite3 and MCAP storage), ``mcap`` (JSON; CDR without a profile), ``mcap-ros2-support``
and ``mcap-ros1-support`` -- and its analysis must equal that of the run's CSV.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl
import pytest
from click.testing import CliRunner

from hybridlog.cli import cli, main
from hybridlog.io import ReadOptions, SignalSpec, load_signals
from hybridlog.io.writers import write_table
from tests.support.logfiles import (
    MAPS,
    OUTPUT_DELAY_NS,
    SCENE_WRITERS,
    header_scene_records,
    scene,
    tank_run,
    write_mcap_json,
    write_ros2_bag,
)

SAME = ("samples", "dt", "outputs", "mse", "vaf", "states")

WRITERS = SCENE_WRITERS


def run_cli(args: list[str]) -> int:
    try:
        main(args)
    except SystemExit as exit_:
        return int(exit_.code or 0)
    return 0


def analyse(log: Path, out: Path, *extra: str) -> dict[str, Any]:
    code = run_cli(
        [
            "analyze",
            str(log),
            "--model",
            "three_tank_hstf",
            "--estimator",
            "hstf",
            "--out",
            str(out),
            *extra,
        ]
    )
    assert code == 0
    report: dict[str, Any] = json.loads((out / "report.json").read_text())
    return report


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict[str, Any], pl.DataFrame]:
    folder = tmp_path_factory.mktemp("reference")
    run = tank_run()
    write_table(folder / "run.csv", run.columns)
    report = analyse(folder / "run.csv", folder / "report")
    return report, pl.read_csv(folder / "report" / "timeline.csv")


@pytest.mark.parametrize("writer", list(WRITERS))
def test_logs_of_other_writers_are_analysed_like_the_csv(
    writer: str, reference: tuple[dict[str, Any], pl.DataFrame], tmp_path: Path
) -> None:
    name, write = WRITERS[writer]
    log = write(tmp_path / name, scene(tank_run()))
    report = analyse(log, tmp_path / "report", *MAPS)
    expected, expected_timeline = reference
    for key in SAME:
        assert report[key] == expected[key], key
    for key in ("accuracy", "confusion", "detection_delay_s", "dwell_s"):
        assert report["modes"][key] == expected["modes"][key], key
    assert report["t_start"] == pytest.approx(expected["t_start"] + OUTPUT_DELAY_NS / 1e9)
    timeline = pl.read_csv(tmp_path / "report" / "timeline.csv")
    assert timeline.drop("t").equals(expected_timeline.drop("t"))
    np.testing.assert_allclose(timeline["t"] - expected_timeline["t"], OUTPUT_DELAY_NS / 1e9)


def test_header_time_takes_the_stamps_not_the_log_time(tmp_path: Path) -> None:
    log = write_mcap_json(tmp_path / "stamped.mcap", header_scene_records())
    model = SignalSpec(
        states=("x1", "x2", "x3"),
        inputs=("u",),
        outputs=("y1", "y2", "y3"),
        mode_ids=("1", "2", "3"),
        dt=1.0,
    )
    maps = tuple(m for m in MAPS if m != "--map")
    by_log = load_signals(log, model, ReadOptions(maps=maps))
    by_header = load_signals(log, model, ReadOptions(maps=maps, time="header"))
    np.testing.assert_allclose(by_log.time - by_header.time, 0.009)
    np.testing.assert_array_equal(by_log.outputs, by_header.outputs)
    np.testing.assert_array_equal(by_log.truth_modes, by_header.truth_modes)


def test_inspect_lists_every_topic_of_a_foreign_bag(tmp_path: Path) -> None:
    log = write_ros2_bag(tmp_path / "bag", scene(tank_run()), "sqlite3")
    result = CliRunner().invoke(cli, ["inspect", str(log), "--json"])
    assert result.exit_code == 0, result.output
    info = json.loads(result.output)
    topics = {t["name"]: t for t in info["topics"]}
    assert set(topics) == {
        "/pump/cmd",
        "/sim/mode",
        "/sim/state",
        "/levels",
        "/level3",
        "/chatter",
        "/imu",
    }
    assert topics["/levels"]["type"] == "geometry_msgs/msg/PointStamped"
    assert topics["/levels"]["count"] == 91
    assert topics["/level3"]["rate_hz"] == pytest.approx(4.0)
    assert topics["/pump/cmd"]["rate_hz"] == pytest.approx(0.2)
    assert "/levels.point.x" in topics["/levels"]["fields"]
    assert "/sim/state.data[]" in topics["/sim/state"]["fields"]
    assert topics["/levels"]["header_stamp"]["offset"] == 0.0
    # the scene's IMU stamps five messages a step alike, the first five at 0 s
    assert info["problems"] == [
        "topic '/imu': header.stamp is 0 in 5 of 455 messages (first logged at t=0 s): the "
        "publisher did not set it; use --time log"
    ]


def _signals(log: Path) -> Any:
    return load_signals(
        log,
        SignalSpec(
            states=("x1", "x2", "x3"),
            inputs=("u",),
            outputs=("y1", "y2", "y3"),
            mode_ids=("1", "2", "3"),
            dt=1.0,
        ),
        ReadOptions(maps=tuple(m for m in MAPS if m != "--map")),
    )


@pytest.mark.parametrize(
    "writer", ["rosbags ROS 2 mcap", "mcap CDR, no profile", "mcap-ros1-support"]
)
def test_small_batches_read_the_same(
    writer: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Labels and values of one topic are merged over many batches without a seam.
    from hybridlog.io import messages

    name, write = WRITERS[writer]
    log = write(tmp_path / name, scene(tank_run()))
    plain = _signals(log)
    monkeypatch.setattr(messages, "BATCH_MESSAGES", 7)
    batched = _signals(log)
    np.testing.assert_array_equal(batched.time, plain.time)
    np.testing.assert_array_equal(batched.inputs, plain.inputs)
    np.testing.assert_array_equal(batched.outputs, plain.outputs)
    np.testing.assert_array_equal(batched.truth_modes, plain.truth_modes)
    np.testing.assert_array_equal(batched.truth_states, plain.truth_states)


def test_only_mapped_topics_are_decoded(tmp_path: Path) -> None:
    from hybridlog.errors import LogError
    from hybridlog.io.mcap_reader import McapSource, check_mcap
    from tests.support.logfiles import Channel, json_bytes, json_message, write_mcap

    records = scene(tank_run())
    topics = sorted({r.topic for r in records})
    channels = [Channel(t, "json", "x", "jsonschema", "{}") for t in [*topics, "/junk"]]
    messages = [(topics.index(r.topic), r.log_ns, json_bytes(json_message(r))) for r in records]
    messages += [(len(topics), r.log_ns, b"{not json") for r in records[::50]]
    log = write_mcap(
        tmp_path / "junk.mcap", channels, sorted(messages, key=lambda m: m[1]), profile=""
    )
    signals = _signals(log)  # never decodes /junk
    assert signals.n_samples == 91
    with (
        McapSource(log, check_mcap(log)) as source,
        pytest.raises(LogError, match="cannot be decoded"),
    ):
        source.read(["/junk.data"])
