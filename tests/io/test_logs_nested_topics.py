"""A path on topics that nest names the one field it means, or is refused.

A robot's recorder can hold ``/robot`` (an ``Odometry``) and ``/robot/pose`` (a
``PoseStamped``); an MCAP file of another tool can hold ``/a`` and ``/a.b``.  Then
``/robot/pose/pose/position/x`` is field ``pose.pose.position.x`` of ``/robot`` and field
``pose.position.x`` of ``/robot/pose`` alike.  It was read from the longest topic without a
word, whichever the user meant; a path that fitted only the shorter topic was refused as a
field the longer one lacks; ``inspect`` listed ``/a.b.v`` twice.  A path that fits two
topics is now refused naming both (Foxglove's ``/robot/pose.pose`` names ``/robot/pose``
alone: the ``/field`` alias counts only where that form fits no topic), a topic in double
quotes (``"/a.b".v``) names that topic exactly, and ``inspect`` lists such fields so.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from hybridlog.cli import main
from hybridlog.io import ReadOptions, open_log
from hybridlog.io.message_paths import PathError, split_paths
from tests.support.logfiles import ros2_store

STEPS = 20


def odometry_bag(path: Path) -> Path:
    """``/robot`` Odometry (x = k), ``/robot/pose`` PoseStamped (x = -k), as a recorder writes."""
    from rosbags.rosbag2 import Writer

    store = ros2_store()
    types = store.types
    header = types["std_msgs/msg/Header"]
    stamp = types["builtin_interfaces/msg/Time"]
    point, quaternion = types["geometry_msgs/msg/Point"], types["geometry_msgs/msg/Quaternion"]
    pose_type = types["geometry_msgs/msg/Pose"]
    vector = types["geometry_msgs/msg/Vector3"]

    def pose(x: float) -> Any:
        return pose_type(
            position=point(x=x, y=0.0, z=0.0), orientation=quaternion(x=0.0, y=0.0, z=0.0, w=1.0)
        )

    with Writer(path, version=9) as writer:
        odom = writer.add_connection("/robot", "nav_msgs/msg/Odometry", typestore=store)
        stamped = writer.add_connection(
            "/robot/pose", "geometry_msgs/msg/PoseStamped", typestore=store
        )
        for k in range(STEPS):
            t = 10**9 + k * 10**8
            head = header(stamp=stamp(sec=t // 10**9, nanosec=t % 10**9), frame_id="odom")
            twist = types["geometry_msgs/msg/Twist"](
                linear=vector(x=0.0, y=0.0, z=0.0), angular=vector(x=0.0, y=0.0, z=0.0)
            )
            message = types["nav_msgs/msg/Odometry"](
                header=head,
                child_frame_id="base",
                pose=types["geometry_msgs/msg/PoseWithCovariance"](
                    pose=pose(float(k)), covariance=np.full(36, 0.5 * k)
                ),
                twist=types["geometry_msgs/msg/TwistWithCovariance"](
                    twist=twist, covariance=np.zeros(36)
                ),
            )
            writer.write(odom, t, store.serialize_cdr(message, "nav_msgs/msg/Odometry"))
            on_pose = types["geometry_msgs/msg/PoseStamped"](header=head, pose=pose(-float(k)))
            data = store.serialize_cdr(on_pose, "geometry_msgs/msg/PoseStamped")
            writer.write(stamped, t + 1000, data)
    return path


def dotted_mcap(path: Path) -> Path:
    """MCAP JSON topics ``/a`` ({"b": {"v": -k}}) and ``/a.b`` ({"v": k}), with schemas."""
    from mcap.writer import Writer

    def schema(properties: dict[str, Any]) -> bytes:
        return json.dumps({"type": "object", "properties": properties}).encode()

    number = {"type": "number"}
    with path.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="", library="test")
        outer = writer.register_schema(
            "Outer", "jsonschema", schema({"b": {"type": "object", "properties": {"v": number}}})
        )
        inner = writer.register_schema("Inner", "jsonschema", schema({"v": number}))
        a = writer.register_channel("/a", "json", outer)
        ab = writer.register_channel("/a.b", "json", inner)
        for k in range(STEPS):
            t = 10**9 + k * 10**8
            writer.add_message(a, t, json.dumps({"b": {"v": -k}}).encode(), t)
            writer.add_message(ab, t + 1, json.dumps({"v": k}).encode(), t + 1)
        writer.finish()
    return path


def values(log: Path, path: str) -> list[float]:
    with open_log(log, ReadOptions()) as source:
        return [float(v) for v in source.read([path]).numeric[path].values]


def test_a_path_that_fits_two_nested_topics_is_refused_naming_both(tmp_path: Path) -> None:
    log = odometry_bag(tmp_path / "bag")
    with open_log(log, ReadOptions()) as source:
        problem = source.explain_missing("/robot/pose/pose/position/x", numeric=True)
    assert problem is not None
    assert "names 2 fields" in problem
    assert "'pose.position.x' of topic '/robot/pose'" in problem
    assert "'pose.pose.position.x' of topic '/robot'" in problem
    assert '"/robot".pose.pose.position.x' in problem


def test_a_quoted_topic_reads_that_topic(tmp_path: Path) -> None:
    log = odometry_bag(tmp_path / "bag")
    ks = [float(k) for k in range(STEPS)]
    assert values(log, '"/robot".pose.pose.position.x') == ks
    assert values(log, '"/robot/pose".pose.position.x') == [-k for k in ks]
    # Foxglove's form names one topic: the /field alias does not make it ambiguous
    assert values(log, "/robot.pose.pose.position.x") == ks
    assert values(log, "/robot/pose.pose.position.x") == [-k for k in ks]


def test_a_path_that_fits_only_the_shorter_topic_reads_it(tmp_path: Path) -> None:
    log = odometry_bag(tmp_path / "bag")
    # PoseStamped has no covariance; Odometry's pose has
    assert values(log, "/robot/pose/covariance[1]") == [0.5 * k for k in range(STEPS)]


def test_dotted_mcap_topics_are_told_apart(tmp_path: Path) -> None:
    log = dotted_mcap(tmp_path / "dotted.mcap")
    with open_log(log, ReadOptions()) as source:
        problem = source.explain_missing("/a.b.v", numeric=True)
    assert problem is not None and '"/a.b".v' in problem and '"/a".b.v' in problem
    assert values(log, '"/a.b".v') == [float(k) for k in range(STEPS)]
    assert values(log, '"/a".b.v') == [-float(k) for k in range(STEPS)]


def test_a_text_field_of_the_topic_named_is_not_passed_over_for_a_number(
    tmp_path: Path,
) -> None:
    # '/a' ({"b": {"v": k}}) and '/a/b' ({"v": "text"}): Foxglove's '/a/b.v' names the text
    # of '/a/b', and '/a/b/v' both fields; as an input either was read from '/a' (.b.v)
    # without a word, the text reading being dropped for not being a number
    from mcap.writer import Writer

    def schema(properties: dict[str, Any]) -> bytes:
        return json.dumps({"type": "object", "properties": properties}).encode()

    log = tmp_path / "nested.mcap"
    with log.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="", library="test")
        nested = {"b": {"type": "object", "properties": {"v": {"type": "number"}}}}
        outer = writer.register_schema("Outer", "jsonschema", schema(nested))
        inner = writer.register_schema("Inner", "jsonschema", schema({"v": {"type": "string"}}))
        a = writer.register_channel("/a", "json", outer)
        ab = writer.register_channel("/a/b", "json", inner)
        for k in range(STEPS):
            writer.add_message(a, k, json.dumps({"b": {"v": k}}).encode(), k)
            writer.add_message(ab, k, json.dumps({"v": "text"}).encode(), k)
        writer.finish()
    with open_log(log, ReadOptions()) as source:
        assert (
            source.explain_missing("/a/b.v", numeric=True) == "'/a/b.v' is a string, not a number"
        )
        both = source.explain_missing("/a/b/v", numeric=True)
        assert both is not None and "names 2 fields" in both
        assert source.explain_missing('"/a"/b/v', numeric=True) is None
        assert source.explain_missing("/a.b.v", numeric=True) is None


def test_the_cli_refuses_an_ambiguous_map_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = dotted_mcap(tmp_path / "dotted.mcap")
    with pytest.raises(SystemExit) as exit_:
        main(
            [
                "analyze",
                str(log),
                "--model",
                "three_tank_hstf",
                *("--map", 'u="/a".b.v', "--map", "y1=/a.b.v"),
                *("--map", 'y2="/a.b".v', "--map", 'y3="/a.b".v'),
                "--out",
                str(tmp_path / "out"),
            ]
        )
    assert exit_.value.code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert "'/a.b.v' names 2 fields" in err
    assert not (tmp_path / "out").exists()


def test_inspect_lists_a_path_two_topics_make_with_its_topic_quoted(tmp_path: Path) -> None:
    log = dotted_mcap(tmp_path / "dotted.mcap")
    with open_log(log, ReadOptions()) as source:
        fields = source.fields()
        described = source.describe()
    assert sorted(fields) == ['"/a".b.v', '"/a.b".v']
    listed = {
        t["name"]: (t["fields"], [v["name"] for v in t["values"]]) for t in described["topics"]
    }
    assert listed == {"/a": (['"/a".b.v'], ['"/a".b.v']), "/a.b": (['"/a.b".v'], ['"/a.b".v'])}


def test_every_path_inspect_lists_reads_its_own_topic(tmp_path: Path) -> None:
    # JSON topics without schema fields: '/a' ({"v": k}), '/a.v' ({"v": -k}) and '' ({"v": 2k}).
    # inspect listed /a's field as '/a.v', which --map reads as the whole of topic '/a.v'
    # (refused), and the field of topic '' as '.v', which names no topic.
    from mcap.writer import Writer

    log = tmp_path / "dotted.mcap"
    with log.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="", library="test")
        schema = writer.register_schema("Any", "jsonschema", b"{}")
        scales = {"/a": 1, "/a.v": -1, "": 2}
        channels = {name: writer.register_channel(name, "json", schema) for name in scales}
        for k in range(STEPS):
            for name, scale in scales.items():
                data = json.dumps({"v": scale * k}).encode()
                writer.add_message(channels[name], k * 10**8, data, k * 10**8)
        writer.finish()
    with open_log(log, ReadOptions()) as source:
        described = source.describe()
    listed = {t["name"]: t["fields"] for t in described["topics"]}
    assert listed == {"": ['"".v'], "/a": ['"/a".v'], "/a.v": ["/a.v.v"]}
    for name, scale in scales.items():
        (path,) = listed[name]
        assert values(log, path) == [float(scale * k) for k in range(STEPS)]


def test_quoted_topics_split_exactly() -> None:
    topics = ["/a", "/a.b", "/x[0]"]
    assert [(p.topic, p.steps) for p in split_paths("/a.b.v", topics)] == [
        ("/a.b", ("v",)),
        ("/a", ("b", "v")),
    ]
    assert [(p.topic, p.steps) for p in split_paths('"/a".b.v', topics)] == [("/a", ("b", "v"))]
    assert [(p.topic, p.steps) for p in split_paths('"/x[0]"[1]', topics)] == [("/x[0]", (1,))]


def test_a_longer_topic_whose_rest_is_no_steps_leaves_the_shorter_reading() -> None:
    # '/u/data' on MCAP topics '/u/' and '/u' was refused: "cannot read 'data' after the
    # topic" '/u/', the alias reading of '/u' never tried
    assert [(p.topic, p.steps) for p in split_paths("/u/data", ["/u/", "/u"])] == [
        ("/u", ("data",))
    ]
    with pytest.raises(PathError, match=r"cannot read 'data\[0\]x\]' after the topic"):
        split_paths("/u/data[0]x]", ["/u/", "/u"])
