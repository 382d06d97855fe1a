"""``--out x.db3 --format ros2-sqlite3`` made a folder ``x.db3/`` holding ``x.db3.db3``.

A ROS 2 bag is a folder whose storage file is named after it; a folder named like a log file
is refused before anything is simulated, naming the folder to give.  ``--out x.db3`` without
``--format`` (a bare ``.db3`` is read, never written alone) says the same.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hybridlog.errors import OptionError
from hybridlog.io.bag_writers import check_log_target


@pytest.mark.parametrize(
    ("name", "chosen", "written"),
    [
        ("x.db3", "ros2-sqlite3", "x/x.db3"),
        ("x.mcap", "ros2-mcap", "x/x.mcap"),
        ("run.csv", "ros2-mcap", "run/run.mcap"),
        ("x.DB3", None, "x/x.db3"),
    ],
)
def test_a_bag_folder_named_like_a_log_file_is_refused(
    tmp_path: Path, name: str, chosen: str | None, written: str
) -> None:
    with pytest.raises(OptionError) as info:
        check_log_target(tmp_path / name, format=chosen)
    message = str(info.value)
    assert message.startswith(f"{tmp_path / name}: a ROS 2 ")
    assert message.endswith(f"writes {tmp_path / written}")
    assert not (tmp_path / name).exists()


@pytest.mark.parametrize("name", ["run", "run_v2", "run.d"])
def test_a_bag_folder_named_without_a_log_suffix_is_written(tmp_path: Path, name: str) -> None:
    assert check_log_target(tmp_path / name, format="ros2-sqlite3") == "ros2-sqlite3"
