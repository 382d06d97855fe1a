"""``--time header`` takes a stamp only when its fields are a time.

A stamp is seconds and a fraction of a second in nanoseconds (ROS's ``Time``: nanosec from 0
to 999999999).  A publisher that did not carry into the seconds writes 10 s and 1.5e9 ns,
which was read as 11.5 s: 0.6 s after its neighbours, refused as a gap in an output or,
with ``--sort``, moved without a word.  Whether such a stamp means the sum is a guess
(here 9 s and 1.9e9 ns, whose sum fits, is refused all the same); a JSON stamp of ``true``
seconds was read as 1 s.  Each file is written by another tool's writer.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from mcap.writer import Writer as McapWriter
from mcap_ros2.writer import Writer as Ros2McapWriter
from rosbags.rosbag1 import Writer as Ros1Writer
from rosbags.typesys import Stores, get_typestore

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, load_signals
from tests.support.logfiles import STAMPED_DEFINITION

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1", "2"), dt=0.1)
N = 20
BAD = 9  # the message whose nanoseconds did not carry: 10 s and 1.5e9 ns


def _stamp(k: int) -> tuple[int, int]:
    """Sec and nanosec of message ``k``: 0.1 s apart from 10 s, one not carried."""
    if k == BAD:
        return 9, 1_900_000_000
    return (100 + k) // 10, (100 + k) % 10 * 100_000_000


def _ros2_mcap(path: Path) -> tuple[Path, tuple[str, ...]]:
    with path.open("wb") as stream:
        writer = Ros2McapWriter(stream)
        schema = writer.register_msgdef("my_pkg/msg/Stamped", STAMPED_DEFINITION)
        for k in range(N):
            sec, nanosec = _stamp(k)
            for topic, value in (("/u", float(k)), ("/y", -float(k))):
                message = {"header": {"stamp": {"sec": sec, "nanosec": nanosec}}, "x": value}
                writer.write_message(topic, schema, message, log_time=k * 100_000_000)
        writer.finish()
    return path, ("u=/u.x", "y=/y.x")


def _ros1_bag(path: Path) -> tuple[Path, tuple[str, ...]]:
    store = get_typestore(Stores.ROS1_NOETIC)
    types = store.types
    msgtype = "geometry_msgs/msg/PointStamped"
    with Ros1Writer(path) as writer:
        connections = [writer.add_connection(t, msgtype, typestore=store) for t in ("/u", "/y")]
        for k in range(N):
            sec, nanosec = _stamp(k)
            stamp = types["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec)
            for connection, value in zip(connections, (float(k), -float(k)), strict=True):
                message = types[msgtype](
                    header=types["std_msgs/msg/Header"](seq=k, stamp=stamp, frame_id=""),
                    point=types["geometry_msgs/msg/Point"](x=value, y=0.0, z=0.0),
                )
                writer.write(connection, k * 100_000_000, store.serialize_ros1(message, msgtype))
    return path, ("u=/u.point.x", "y=/y.point.x")


def _json_mcap(path: Path, bad: dict[str, object] | None) -> tuple[Path, tuple[str, ...]]:
    """JSON topics ``/u``, ``/y``; message ``BAD`` stamped ``bad`` (no header: ``None``)."""
    with path.open("wb") as stream:
        writer = McapWriter(stream)
        writer.start()
        schema = writer.register_schema("Stamped", "jsonschema", b"{}")
        channels = [writer.register_channel(t, "json", schema) for t in ("/u", "/y")]
        for k in range(N):
            sec, nsec = _stamp(k)
            stamp = bad if k == BAD else {"sec": sec, "nsec": nsec}
            for channel, value in zip(channels, (k, -k), strict=True):
                document = (
                    {"x": value} if stamp is None else {"header": {"stamp": stamp}, "x": value}
                )
                data = json.dumps(document).encode()
                writer.add_message(channel, k * 100_000_000, data, k * 100_000_000)
        writer.finish()
    return path, ("u=/u.x", "y=/y.x")


@pytest.mark.parametrize("sort", [False, True])
@pytest.mark.parametrize("kind", ["ros2 mcap", "ros1 bag", "json mcap"])
def test_nanoseconds_of_a_second_or_more_are_refused_naming_the_message(
    kind: str, sort: bool, tmp_path: Path
) -> None:
    if kind == "ros2 mcap":
        log, maps = _ros2_mcap(tmp_path / "stamped.mcap")
        field = "nanosec"
    elif kind == "ros1 bag":
        log, maps = _ros1_bag(tmp_path / "stamped.bag")
        field = "nanosec"
    else:
        log, maps = _json_mcap(tmp_path / "stamped.mcap", {"sec": 9, "nsec": 1_900_000_000})
        field = "nsec"
    with pytest.raises(LogError) as error:
        load_signals(log, SPEC, ReadOptions(maps=maps, time="header", sort=sort))
    message = str(error.value)
    assert f"header.stamp has {field} = 1900000000, not a fraction of a second" in message
    assert "in the message logged at t=0.9 s" in message and "\n" not in message
    # the log times are good
    signals = load_signals(log, SPEC, ReadOptions(maps=maps))
    assert signals.n_samples == N


@pytest.mark.parametrize(
    ("stamp", "said"),
    [({"sec": True, "nsec": 0}, "not a time stamp"), ({"sec": 10, "nsec": -1}, "nsec = -1")],
)
def test_a_json_stamp_of_booleans_or_negative_nanoseconds_is_refused(
    stamp: dict[str, object], said: str, tmp_path: Path
) -> None:
    log, maps = _json_mcap(tmp_path / "stamped.mcap", stamp)
    with pytest.raises(LogError, match=said):
        load_signals(log, SPEC, ReadOptions(maps=maps, time="header", sort=True))


def test_a_message_without_a_stamp_is_named_in_a_sentence(tmp_path: Path) -> None:
    # It read 'header.stamp the message has no field 'header'; fields: ...'.
    log, maps = _json_mcap(tmp_path / "stamped.mcap", None)
    with pytest.raises(LogError) as error:
        load_signals(log, SPEC, ReadOptions(maps=maps, time="header"))
    assert "topic '/u' (Stamped): header.stamp: the message has no field 'header'" in str(
        error.value
    )
