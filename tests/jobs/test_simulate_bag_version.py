"""ROS 2 bags from ``simulate`` have ``metadata.yaml`` version 8, which Humble's ``ros2 bag`` reads.

rosbags writes version 9 by default; rosbag2 of Humble (and Iron) reads a topic's
``offered_qos_profiles`` as a string, and version 9 writes it as a YAML list, so Humble's
``ros2 bag info``/``play`` failed with "yaml-cpp: ... bad conversion".  Version 8 writes the
string (empty: the default QoS) and every later distribution reads it too.
"""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from click.testing import CliRunner
from rosbags.rosbag2 import Reader

from hybridlog.cli import cli
from hybridlog.io.bag_writers import written_by_hybridlog


@pytest.mark.parametrize("storage", ["ros2-sqlite3", "ros2-mcap"])
def test_ros2_bags_have_metadata_humble_reads(storage: str, tmp_path: Path) -> None:
    bag = tmp_path / "run"
    result = CliRunner().invoke(
        cli,
        ["simulate", "three_tank_hstf", "--out", str(bag), "--format", storage, "--steps", "20"],
    )
    assert result.exit_code == 0, result.output
    info = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["version"] == 8
    topics = info["topics_with_message_count"]
    assert {t["topic_metadata"]["name"] for t in topics} >= {"/u", "/truth/mode", "/truth/x1"}
    for topic in topics:
        # what rosbag2 of Humble reads with .as<std::string>() (a list is "bad conversion")
        assert isinstance(topic["topic_metadata"]["offered_qos_profiles"], str)
        assert topic["message_count"] == 21
    assert written_by_hybridlog(bag)  # --force still knows it as ours
    with Reader(bag) as reader:
        assert {c.topic for c in reader.connections} == {
            t["topic_metadata"]["name"] for t in topics
        }
        assert reader.message_count == 21 * len(topics)
        assert sum(1 for _ in reader.messages()) == reader.message_count
