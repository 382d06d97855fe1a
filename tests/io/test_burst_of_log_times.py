"""Messages a recorder took in a burst, at one log time, point to their header stamps.

``rosbag record`` can give a burst of queued messages one log time while each message's
``header.stamp`` still tells them apart.  The refusal offered only ``--sort``, which keeps the
last of each time (9 of 10 such messages dropped, and then a gap); it now names
``--time header`` too where the topic's messages carry stamps, as the refusal of a topic whose
log times never change did.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, open_log
from tests.support.logfiles import msgdef

MS = 1_000_000


def burst(path: Path, msgtype: str) -> Path:
    """20 messages every 10 ms, the 5th to 9th logged at the 5th's time; stamps all distinct."""
    from mcap_ros2.writer import Writer

    with path.open("wb") as stream:
        writer = Writer(stream)
        schema = writer.register_msgdef(msgtype, msgdef(msgtype))
        for k in range(20):
            t = 10**9 + k * 10 * MS
            stamp = {"sec": t // 10**9, "nanosec": t % 10**9}
            message = (
                {"header": {"stamp": stamp, "frame_id": ""}, "point": {"x": k, "y": 0, "z": 0}}
                if msgtype.endswith("PointStamped")
                else {"data": float(k)}
            )
            logged = 10**9 + (4 if 4 <= k < 9 else k) * 10 * MS
            writer.write_message("/y", schema, message, log_time=logged, publish_time=logged)
        writer.finish()
    return path


@pytest.mark.parametrize(
    ("msgtype", "path", "hint"),
    [
        ("geometry_msgs/msg/PointStamped", "/y.point.x", True),
        ("std_msgs/msg/Float64", "/y.data", False),
    ],
)
def test_a_burst_of_one_log_time_names_the_stamps_where_there_are_some(
    tmp_path: Path, msgtype: str, path: str, hint: bool
) -> None:
    log = burst(tmp_path / "burst.mcap", msgtype)
    with open_log(log, ReadOptions()) as source, pytest.raises(LogError) as err:
        source.read([path])
    message = str(err.value)
    assert "4 message(s) have the same log time as the one before (first at t=1.04 s)" in message
    stamps = ", or --time header reads each message's header.stamp instead"
    assert message.endswith("--sort keeps the last of each" + (stamps if hint else "")), message
    if hint:
        with open_log(log, ReadOptions(time="header")) as source:
            assert source.read([path]).numeric[path].values.tolist() == list(range(20))
