"""An array read by index has one length in every message of its topic, or is refused.

A robot's ``/joint_states`` often has two publishers: the arm's driver (three joints) and the
gripper's (one).  ``--map y=/joint_states.position[0]`` read the arm's first joint from one
message and the gripper from the next, one series of two signals, without a word (a Parquet
list read by index was already held to one length in every row).  Such a path is now refused
naming the topic, the array, both lengths and both messages, whichever way the messages are
read: numbers streamed as decoded, in parts with ``header.stamp``, JSON; ``inspect`` names
such arrays (of numbers, of text, of messages: ``/tf.transforms[]``) under ``problems``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, inspect_log, open_log
from tests.support.logfiles import msgdef

MS = 1_000_000


def joint_states(path: Path, gripper_every: int = 5) -> Path:
    """``/joint_states`` from an arm (3 joints, every 10 ms) and a gripper (1 joint, sometimes)."""
    from mcap_ros2.writer import Writer

    with path.open("wb") as stream:
        writer = Writer(stream)
        schema = writer.register_msgdef(
            "sensor_msgs/msg/JointState", msgdef("sensor_msgs/msg/JointState")
        )

        def write(t: int, names: list[str], positions: list[float]) -> None:
            header = {"stamp": {"sec": t // 10**9, "nanosec": t % 10**9}, "frame_id": ""}
            message = {"header": header, "name": names, "position": positions}
            message |= {"velocity": [], "effort": []}
            writer.write_message("/joint_states", schema, message, log_time=t, publish_time=t)

        for k in range(20):
            t = 10**9 + k * 10 * MS
            write(t, ["j0", "j1", "j2"], [0.1 * k, 1.0, 2.0])
            if k % gripper_every == gripper_every - 1:
                write(t + MS, ["finger"], [0.04])
        writer.finish()
    return path


def read(log: Path, path: str, **options: Any) -> list[float]:
    with open_log(log, ReadOptions(**options)) as source:
        return [float(v) for v in source.read([path]).numeric[path].values]


@pytest.mark.parametrize("time", ["log", "header"])
def test_an_index_into_arrays_of_two_lengths_is_refused(tmp_path: Path, time: str) -> None:
    log = joint_states(tmp_path / "arm.mcap")
    with pytest.raises(LogError) as err:
        read(log, "/joint_states.position[0]", time=time)
    message = str(err.value)
    assert message.startswith(f"{log}: '/joint_states.position[0]': topic '/joint_states'")
    assert ": .position holds 1 element in the message logged at" in message
    assert "t=1.041 s, but 3 elements in the topic's first, logged at t=1 s" in message
    # read for a model's signal, named as the mapping names a field (FieldError)
    from hybridlog.io.load import SignalSpec, load_signals

    spec = SignalSpec(inputs=(), outputs=("y",), mode_ids=(), dt=0.01)
    maps = ("y=/joint_states.position[0]",)
    with pytest.raises(LogError) as err:
        load_signals(log, spec, ReadOptions(maps=maps, time=time))
    assert str(err.value).startswith(
        f"{log}: output 'y' (field '/joint_states.position[0]', from --map "
        "y=/joint_states.position[0]): topic '/joint_states' (sensor_msgs/msg/JointState): "
        ".position holds 1 element"
    ), str(err.value)


def test_arrays_of_one_length_still_read(tmp_path: Path) -> None:
    log = joint_states(tmp_path / "arm.mcap", gripper_every=10**6)
    assert read(log, "/joint_states.position[-3]")[:3] == pytest.approx([0.0, 0.1, 0.2])


def sparse_json(path: Path, odd: int | None) -> Path:
    """JSON `/s`: `{"q": [k, 0]}`, each third `{"other": 1}`; `q` at `odd` one element."""
    from mcap.writer import Writer

    with path.open("wb") as stream:
        writer = Writer(stream)
        writer.start()
        schema = writer.register_schema("S", "jsonschema", b'{"type": "object"}')
        channel = writer.register_channel("/s", "json", schema)
        for k in range(12):
            message: dict[str, Any] = {"q": [float(k), 0.0]} if k % 3 else {"other": 1}
            if k == odd:
                message = {"q": [float(k)]}
            t = 10**9 + k * 10 * MS
            writer.add_message(channel, t, json.dumps(message).encode(), t)
        writer.finish()
    return path


def test_a_json_array_left_out_of_some_messages_is_no_other_length(tmp_path: Path) -> None:
    assert read(sparse_json(tmp_path / "s.mcap", None), "/s.q[0]") == [1, 2, 4, 5, 7, 8, 10, 11]
    with pytest.raises(LogError, match=r"\.q holds 1 element in the message logged at t=1\.07 s"):
        read(sparse_json(tmp_path / "odd.mcap", 7), "/s.q[0]")


def tf_messages(path: Path, one: bool = False) -> Path:
    """``/tf`` from two broadcasters: one transform (odom), then two (base, camera).

    ``one``: from the second broadcaster alone (two transforms in every message).
    """
    from mcap_ros2.writer import Writer

    def transform(frame: str, t: int) -> dict[str, Any]:
        header = {"stamp": {"sec": t // 10**9, "nanosec": t % 10**9}, "frame_id": "map"}
        pose = {"translation": {"x": 1.0, "y": 0.0, "z": 0.0}}
        pose["rotation"] = {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}
        return {"header": header, "child_frame_id": frame, "transform": pose}

    with path.open("wb") as stream:
        writer = Writer(stream)
        schema = writer.register_msgdef("tf2_msgs/msg/TFMessage", msgdef("tf2_msgs/msg/TFMessage"))
        for k in range(10):
            t = 10**9 + k * 10 * MS
            frames = ["odom"] if k % 2 and not one else ["base", "camera"]
            message = {"transforms": [transform(frame, t) for frame in frames]}
            writer.write_message("/tf", schema, message, log_time=t, publish_time=t)
        writer.finish()
    return path


def test_inspect_names_the_arrays_an_index_cannot_read(tmp_path: Path) -> None:
    said = "its messages hold 1 to 3 elements: analyze refuses an index into it"
    problems = inspect_log(joint_states(tmp_path / "arm.mcap"))["problems"]
    assert [p.split(":")[0] for p in problems if said in p] == [
        "'/joint_states.name[]'",
        "'/joint_states.position[]'",
    ]
    assert inspect_log(joint_states(tmp_path / "one.mcap", gripper_every=10**6))["problems"] == []
    problems = inspect_log(tf_messages(tmp_path / "tf.mcap"))["problems"]
    assert problems == [
        "'/tf.transforms[]': its messages hold 1 to 2 elements: analyze refuses an index into "
        "it (one index names one signal only in arrays of one length in every message; two "
        "publishers on one topic?)"
    ]
    with pytest.raises(LogError, match=r"\.transforms holds 1 element in the message logged"):
        read(tmp_path / "tf.mcap", "/tf.transforms[0].transform.translation.x")


def test_inspect_shows_each_array_s_length_and_a_few_names(tmp_path: Path) -> None:
    """inspect listed ``/joint_states.position[]`` with no length and ``name[]`` with no
    value: which indexes a path may take, and which one is joint ``j2``, could not be seen.
    An array of one length in every message now has it, and a few short texts their first
    message's values; one whose length differs has none (its problem says why)."""
    from hybridlog.io.inspect import format_inspection

    info = inspect_log(joint_states(tmp_path / "one.mcap", gripper_every=10**6))
    assert info["topics"][0]["arrays"] == [
        {"name": "/joint_states.name[]", "elements": 3, "first": ["j0", "j1", "j2"]},
        {"name": "/joint_states.position[]", "elements": 3},
        {"name": "/joint_states.velocity[]", "elements": 0},
        {"name": "/joint_states.effort[]", "elements": 0},
    ]
    text = format_inspection(info)
    assert "  /joint_states.name[]                3 elements: 'j0', 'j1', 'j2' (the first " in (
        text
    )
    assert "  /joint_states.position[]            3 elements\n" in text
    two = inspect_log(joint_states(tmp_path / "two.mcap"))["topics"][0]["arrays"]
    assert [a["name"] for a in two] == ["/joint_states.velocity[]", "/joint_states.effort[]"]
    tf = inspect_log(tf_messages(tmp_path / "tf.mcap", one=True))
    assert tf["topics"][0]["arrays"] == [{"name": "/tf.transforms[]", "elements": 2}]
    assert "/tf.transforms[].transform.translation.x  transforms[]: 2 elements" in (
        format_inspection(tf)
    )


def test_an_index_out_of_range_names_the_symbol_and_its_map(tmp_path: Path) -> None:
    """An index past a topic's arrays read ``'/joint_states.position[3]': .position[3]: ...``,
    without the ``output 'y' (field ..., from --map ...)`` a field the schema lacks is named
    by: found only in the messages' values, it is named by the same words now."""
    from hybridlog.io.load import SignalSpec, load_signals

    log = joint_states(tmp_path / "arm.mcap", gripper_every=10**6)
    spec = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=(), dt=0.01)
    maps = ("u=/joint_states.position[0]", "y=/joint_states.position[3]")
    with pytest.raises(LogError) as err:
        load_signals(log, spec, ReadOptions(maps=maps))
    assert str(err.value) == (
        f"{log}: output 'y' (field '/joint_states.position[3]', from --map "
        "y=/joint_states.position[3]): .position[3]: index out of range (the array has 3 "
        "elements) in the message logged at t=1 s"
    )
