"""Which time each topic has, and stamps set by another clock than the recorder's.

``inspect`` listed log times only: a topic whose ``header.stamp`` counted simulated time
from 0 beside log times of 1.7e9 s (or the reverse) looked like every other, and
``analyze --time header`` then aligned it 1.7e9 s away from the topics stamped by the
recorder's clock, holding an input's last sample over the whole log with no word of why.
Now ``inspect`` gives each topic's stamps and their offset from its log time, names in its
problems what ``--time header`` refuses or reads on another clock, and ``analyze`` records
the mapped topics' offsets and warns when they disagree.  Files written by other tools'
writers (``mcap-ros2-support``, rosbags' ROS 1 bag writer, the ``mcap`` writer for JSON).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from mcap.writer import Writer as McapWriter
from mcap_ros2.writer import Writer as Ros2McapWriter
from rosbags.rosbag1 import Writer as Ros1Writer
from rosbags.typesys import Stores, get_typestore

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, inspect_log, load_signals
from hybridlog.io.inspect import format_inspection
from hybridlog.report.reading_notes import log_reading_notes
from tests.support.logfiles import STAMPED_DEFINITION

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1", "2"), dt=0.1)
N = 20
LOGGED = [10**9 + k * 10**8 for k in range(N)]  # log times 1 s to 2.9 s
UNIX = 1_700_000_000 * 10**9
Stamps = list[tuple[int, int]]  # (sec, nanosec) per message


def _near(delay_ns: int = 9_000_000) -> Stamps:
    """Stamps ``delay_ns`` before the log times: the recorder's clock."""
    return [divmod(t - delay_ns, 10**9) for t in LOGGED]


def _unix() -> Stamps:
    """Stamps on a Unix clock beside log times of 1 s on: 1.7e9 s apart."""
    return [divmod(UNIX + t, 10**9) for t in LOGGED]


def _ros2_mcap(path: Path, u: Stamps, y: Stamps) -> Path:
    with path.open("wb") as stream:
        writer = Ros2McapWriter(stream)
        schema = writer.register_msgdef("my_pkg/msg/Stamped", STAMPED_DEFINITION)
        for k, log_ns in enumerate(LOGGED):
            for topic, stamps in (("/u", u), ("/y", y)):
                sec, nanosec = stamps[k]
                message = {"header": {"stamp": {"sec": sec, "nanosec": nanosec}}, "x": float(k)}
                writer.write_message(topic, schema, message, log_time=log_ns)
        writer.finish()
    return path


def _ros1_bag(path: Path, u: Stamps, y: Stamps) -> Path:
    store = get_typestore(Stores.ROS1_NOETIC)
    types, msgtype = store.types, "geometry_msgs/msg/PointStamped"
    with Ros1Writer(path) as writer:
        connections = [writer.add_connection(t, msgtype, typestore=store) for t in ("/u", "/y")]
        for k, log_ns in enumerate(LOGGED):
            for connection, stamps in zip(connections, (u, y), strict=True):
                sec, nanosec = stamps[k]
                message = types[msgtype](
                    header=types["std_msgs/msg/Header"](
                        seq=k,
                        stamp=types["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec),
                        frame_id="",
                    ),
                    point=types["geometry_msgs/msg/Point"](x=float(k), y=0.0, z=0.0),
                )
                writer.write(connection, log_ns, store.serialize_ros1(message, msgtype))
    return path


def _json_mcap(path: Path, u: Stamps, y: Stamps) -> Path:
    """JSON topics without a schema listing their fields."""
    with path.open("wb") as stream:
        writer = McapWriter(stream)
        writer.start()
        schema = writer.register_schema("Stamped", "jsonschema", b"{}")
        channels = [writer.register_channel(t, "json", schema) for t in ("/u", "/y")]
        for k, log_ns in enumerate(LOGGED):
            for channel, stamps in zip(channels, (u, y), strict=True):
                sec, nsec = stamps[k]
                data = json.dumps({"header": {"stamp": {"sec": sec, "nsec": nsec}}, "x": k})
                writer.add_message(channel, log_ns, data.encode(), log_ns)
        writer.finish()
    return path


WRITERS = {"ros2 mcap": _ros2_mcap, "ros1 bag": _ros1_bag, "json mcap": _json_mcap}
SUFFIX = {"ros2 mcap": ".mcap", "ros1 bag": ".bag", "json mcap": ".mcap"}


@pytest.mark.parametrize("kind", list(WRITERS))
def test_inspect_gives_each_topics_stamps_and_names_another_clock(
    kind: str, tmp_path: Path
) -> None:
    log = WRITERS[kind](tmp_path / f"clocks{SUFFIX[kind]}", _near(), _unix())
    info = inspect_log(log)
    stamps = {t["name"]: t["header_stamp"] for t in info["topics"]}
    assert stamps["/u"] == {"start": 0.991, "end": 2.891, "offset": -0.009, "count": N}
    assert stamps["/y"] == {
        "start": 1700000001.0,
        "end": 1700000002.9,
        "offset": 1700000000.0,
        "count": N,
    }
    assert info["problems"] == [
        "topic '/y': header.stamp is 1700000000 s after its log time (the median over 20 "
        "messages): another clock than the recorder's stamped it (simulated time, another "
        "machine's); --time header aligns the topic on that clock"
    ]
    text = format_inspection(info)
    assert (
        "header.stamp (what --time header reads; the times above are log times):\n"
        "  /u: 0.991 s to 2.891 s, -0.009 s from its log time (median)\n"
        "  /y: 1700000001 s to 1700000002.9 s, +1700000000 s from its log time (median)\n"
    ) in text


def test_a_topic_without_a_header_is_named_and_has_no_stamps(tmp_path: Path) -> None:
    log = tmp_path / "mixed.mcap"
    with log.open("wb") as stream:
        writer = Ros2McapWriter(stream)
        stamped = writer.register_msgdef("my_pkg/msg/Stamped", STAMPED_DEFINITION)
        plain = writer.register_msgdef("std_msgs/msg/Float64", "float64 data")
        for k, log_ns in enumerate(LOGGED):
            sec, nanosec = divmod(log_ns, 10**9)
            message = {"header": {"stamp": {"sec": sec, "nanosec": nanosec}}, "x": 1.0}
            writer.write_message("/y", stamped, message, log_time=log_ns)
            writer.write_message("/u", plain, {"data": float(k)}, log_time=log_ns)
        writer.finish()
    info = inspect_log(log)
    assert [t["header_stamp"] for t in info["topics"]] == [
        None,
        {"start": 1.0, "end": 2.9, "offset": 0.0, "count": N},
    ]
    assert info["problems"] == []
    assert (
        "  /y: 1 s to 2.9 s, 0 s from its log time (median)\n"
        "  without a usable header.stamp (--time header refuses them): /u"
    ) in format_inspection(info)


def test_inspect_names_the_stamps_time_header_refuses(tmp_path: Path) -> None:
    unset = [(0, 0)] * N
    backwards = _near()
    backwards[7], backwards[8] = backwards[8], backwards[7]
    log = _ros2_mcap(tmp_path / "refused.mcap", unset, backwards)
    assert inspect_log(log)["problems"] == [
        "topic '/u': header.stamp is 0 in 20 of 20 messages (first logged at t=1 s): the "
        "publisher did not set it; use --time log",
        "topic '/y': header.stamp goes backwards in 1 of 20 messages in log-time order (first "
        "t=1.691 s in the message logged at t=1.8 s, after t=1.791 s): --time header refuses "
        "the topic unless --sort",
    ]
    carried = _near()
    carried[4] = (1, 1_500_000_000)  # nanoseconds not carried into the seconds
    log = _ros2_mcap(tmp_path / "carried.mcap", _near(), carried)
    info = inspect_log(log)
    assert info["problems"] == [
        "topic '/y': header.stamp has nanosec = 1500000000, not a fraction of a second "
        "(sec = 1; nanosec is 0 to 999999999) in the message logged at t=1.4 s (--time "
        "header refuses the topic)"
    ]
    assert info["topics"][1]["header_stamp"]["count"] == 4  # those read before it


def test_topics_stamped_by_clocks_that_disagree_are_warned_of(tmp_path: Path) -> None:
    log = _ros2_mcap(tmp_path / "clocks.mcap", _near(), _unix())
    notes: dict[str, object] = {}
    signals = load_signals(
        log, SPEC, ReadOptions(maps=("u=/u.x", "y=/y.x"), time="header"), notes=notes
    )
    assert signals.n_samples == N
    assert notes["stamp_offsets"] == {"/u": -0.009, "/y": 1700000000.0}
    warnings = [n for n in log_reading_notes(notes) if "header stamps" in n]
    assert warnings == [
        "WARNING: --time header: the topics' header stamps disagree by 1700000000.009 s "
        "against their log times (stamp minus log time, the median: '/y' +1700000000 s, "
        "'/u' -0.009 s): different clocks stamped them (simulated time, another machine's), "
        "and their samples are aligned that far apart; --time log aligns them as they were "
        "recorded"
    ]
    # a delay that differs between topics by less than a second is no other clock
    log = _ros2_mcap(tmp_path / "delays.mcap", _near(), _near(300_000_000))
    notes = {}
    load_signals(log, SPEC, ReadOptions(maps=("u=/u.x", "y=/y.x"), time="header"), notes=notes)
    assert notes["stamp_offsets"] == {"/u": -0.009, "/y": -0.3}
    assert not [n for n in log_reading_notes(notes) if "header stamps" in n]


def test_signals_apart_by_their_clocks_are_refused_naming_the_clocks(tmp_path: Path) -> None:
    """The input on a Unix clock, the output on the recorder's: 1.7e9 s apart, no overlap.

    The refusal named the two times only ("signals do not overlap in time"), not the clocks
    that put them apart, nor that --time log reads them as recorded.
    """
    log = _ros2_mcap(tmp_path / "apart.mcap", _unix(), _near())
    options = ReadOptions(maps=("u=/u.x", "y=/y.x"), time="header")
    with pytest.raises(LogError) as caught:
        load_signals(log, SPEC, options)
    message = str(caught.value)
    assert message.startswith(f"{log}: signals do not overlap in time ('/u.x' starts at t=")
    assert message.endswith(
        "; --time header: the topics' header stamps disagree by 1700000000.009 s against their "
        "log times (stamp minus log time, the median: '/u' +1700000000 s, '/y' -0.009 s): "
        "different clocks stamped them (simulated time, another machine's); --time log aligns "
        "them as they were recorded"
    )
    assert "\n" not in message
    signals = load_signals(log, SPEC, ReadOptions(maps=("u=/u.x", "y=/y.x")))  # as recorded
    assert signals.n_samples == N


def test_stamps_going_backwards_name_both_messages(tmp_path: Path) -> None:
    """A log time left 0 puts its message first: its stamp is the one out of place."""
    log = tmp_path / "unset_log_time.mcap"
    with log.open("wb") as stream:
        writer = Ros2McapWriter(stream)
        schema = writer.register_msgdef("my_pkg/msg/Stamped", STAMPED_DEFINITION)
        for k, log_ns in enumerate(LOGGED):
            sec, nanosec = divmod(log_ns, 10**9)
            for topic in ("/u", "/y"):
                message = {"header": {"stamp": {"sec": sec, "nanosec": nanosec}}, "x": 1.0}
                writer.write_message(topic, schema, message, log_time=0 if k == 7 else log_ns)
        writer.finish()
    with pytest.raises(LogError) as error:
        load_signals(log, SPEC, ReadOptions(maps=("u=/u.x", "y=/y.x"), time="header"))
    assert str(error.value) == (
        f"{log}: topic '/u': header.stamp goes backwards (t=1 s in the message logged at "
        "t=1 s, after t=1.7 s in the one logged at t=0 s); --sort puts messages in time order"
    )
    signals = load_signals(
        log, SPEC, ReadOptions(maps=("u=/u.x", "y=/y.x"), time="header", sort=True)
    )
    np.testing.assert_array_equal(signals.time, np.arange(10, 30) / 10)
