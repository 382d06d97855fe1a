"""A topic whose every message has one and the same time is refused, naming the other time.

An MCAP writer that never sets the log time leaves it 0 in every message.  Read as times,
20 such messages were "19 message(s) have the same log time as the one before", and the
remedy offered, ``--sort``, kept the last message alone (one sample of twenty) -- where
the messages' ``header.stamp`` held their times all along.  Likewise a publisher that
stamps every message alike under ``--time header``.  Files written by other tools' writers.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap_ros2.writer import Writer as Ros2McapWriter
from rosbags.rosbag1 import Writer as Ros1Writer
from rosbags.typesys import Stores, get_typestore

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, load_signals
from hybridlog.signals import AlignedSignals
from tests.support.logfiles import STAMPED_DEFINITION

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1", "2"), dt=0.1)
N = 20
MAPS = ("u=/u.x", "y=/y.x")


def _mcap(path: Path, log_ns: list[int], stamp_ns: list[int]) -> Path:
    with path.open("wb") as stream:
        writer = Ros2McapWriter(stream)
        schema = writer.register_msgdef("my_pkg/msg/Stamped", STAMPED_DEFINITION)
        for k in range(N):
            stamp = {"sec": stamp_ns[k] // 10**9, "nanosec": stamp_ns[k] % 10**9}
            for topic, value in (("/u", float(k)), ("/y", -float(k))):
                message = {"header": {"stamp": stamp, "frame_id": ""}, "x": value}
                writer.write_message(topic, schema, message, log_time=log_ns[k])
        writer.finish()
    return path


def load(log: Path, *maps: str, **options: Any) -> AlignedSignals:
    return load_signals(log, SPEC, ReadOptions(maps=maps or MAPS, **options))


@pytest.mark.parametrize("sort", [False, True])
def test_log_times_never_set_point_to_the_header_stamps(tmp_path: Path, sort: bool) -> None:
    steps = [10**9 + k * 10**8 for k in range(N)]
    log = _mcap(tmp_path / "unset.mcap", [0] * N, steps)
    with pytest.raises(LogError) as error:
        load(log, sort=sort)
    assert str(error.value) == (
        f"{log}: topic '/u': all {N} messages have the same log time, t=0 s: the recorder did "
        "not set log times; --time header reads each message's header.stamp instead"
    )
    signals = load_signals(log, SPEC, ReadOptions(maps=MAPS, time="header"))
    assert signals.n_samples == N
    np.testing.assert_array_equal(signals.outputs[:, 0], -np.arange(N, dtype=float))


def test_one_stamp_on_every_message_points_to_the_log_times(tmp_path: Path) -> None:
    steps = [10**9 + k * 10**8 for k in range(N)]
    log = _mcap(tmp_path / "constant.mcap", steps, [5 * 10**9] * N)
    with pytest.raises(LogError, match=r"same header\.stamp, t=5 s: .*; use --time log$"):
        load(log, time="header", sort=True)
    assert load_signals(log, SPEC, ReadOptions(maps=MAPS)).n_samples == N


def test_without_a_header_no_other_time_is_offered(tmp_path: Path) -> None:
    store = get_typestore(Stores.ROS1_NOETIC)
    msgtype = "std_msgs/msg/Float64"
    log = tmp_path / "unset.bag"
    with Ros1Writer(log) as writer:
        connections = [writer.add_connection(t, msgtype, typestore=store) for t in ("/u", "/y")]
        for k in range(N):
            for connection, value in zip(connections, (float(k), -float(k)), strict=True):
                message = store.types[msgtype](data=value)
                writer.write(connection, 7 * 10**9, store.serialize_ros1(message, msgtype))
    with pytest.raises(LogError) as error:
        load(log, "u=/u.data", "y=/y.data", sort=True)
    assert str(error.value).endswith(
        f"topic '/u': all {N} messages have the same log time, t=7 s: the recorder did not "
        "set log times"
    )


def test_two_messages_at_one_time_are_still_a_repeat_sort_resolves(tmp_path: Path) -> None:
    # Not the case above: a topic of messages at several times, two of them alike.
    steps = [10**9 + k * 10**8 for k in range(N)]
    steps[5] = steps[4]
    log = _mcap(tmp_path / "repeat.mcap", steps, steps)
    with pytest.raises(LogError, match=r"1 message\(s\) have the same log time as the one"):
        load(log)
    signals = load(log, sort=True)  # the grid point of the message dropped is bridged
    assert signals.outputs[4, 0] == -5.0 and signals.outputs[5, 0] == -5.0
