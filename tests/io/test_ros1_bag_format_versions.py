"""A ROS 1 bag of another format version than 2.0 is refused as what it is.

rosbags reads format 2.0 only.  A bag of format 1.2 (``#ROSBAG V1.2``, written by ROS's
first releases) failed the 2.0 magic bytes and was refused as "not a ROS 1 bag (wrong magic
bytes)": untrue, and no hint of how to read it.  It is named with its version and the
``rosbag filter`` command that rewrites it as 2.0, whatever its suffix.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from rosbags.rosbag1 import Writer
from rosbags.typesys import Stores, get_typestore

from hybridlog.errors import LogError
from hybridlog.io import inspect_log


def _bag_of_version(path: Path, version: bytes) -> Path:
    """A bag rosbags writes, its version line (13 bytes, as 2.0's) made ``version``'s."""
    store = get_typestore(Stores.ROS1_NOETIC)
    float64 = store.types["std_msgs/msg/Float64"]
    with Writer(path) as writer:
        connection = writer.add_connection("/y", "std_msgs/msg/Float64", typestore=store)
        for k in range(3):
            writer.write(
                connection,
                k * 10**8,
                store.serialize_ros1(float64(data=1.0), "std_msgs/msg/Float64"),
            )
    data = path.read_bytes()
    assert data.startswith(b"#ROSBAG V2.0\n")
    path.write_bytes(b"#ROSBAG V" + version + b"\n" + data[13:])
    return path


@pytest.mark.parametrize("name", ["old.bag", "old.mcap"])
def test_a_bag_of_format_1_2_is_named_with_its_version(tmp_path: Path, name: str) -> None:
    bag = _bag_of_version(tmp_path / name, b"1.2")
    with pytest.raises(LogError) as error:
        inspect_log(bag)
    assert str(error.value) == (
        f"{bag}: a ROS 1 bag of format version 1.2, which hybridlog does not read (rosbags "
        f"reads version 2.0, the one rosbag record writes); ROS 1's `rosbag filter {name} "
        "new.bag True` rewrites it as version 2.0"
    )


def test_text_that_only_looks_like_a_version_line_is_wrong_magic(tmp_path: Path) -> None:
    bag = tmp_path / "junk.bag"
    bag.write_bytes(b"#ROSBAG Vx.y\n" + b"\0" * 64)
    with pytest.raises(LogError, match=r"junk\.bag: not a ROS 1 bag \(wrong magic bytes\)$"):
        inspect_log(bag)
