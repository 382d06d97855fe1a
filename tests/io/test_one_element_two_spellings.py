"""``q[2]`` and ``q[-1]`` of an array of three are one element: one field, not two.

The refusal of one field feeding two inputs or outputs compared the indices as written, so
``--map u=q[2] --map y1=q[-1]`` read one element as an input and an output (a perfect,
meaningless fit) without a word.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import polars as pl
import pytest

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, load_signals
from hybridlog.io.mapping import parse_maps, resolve_signal_map
from hybridlog.io.message_paths import from_the_start
from hybridlog.io.source import FieldKey
from hybridlog.io.tables import TableSource
from tests.support.logfiles import Channel, cdr, ros2_store, write_mcap

SPEC = SignalSpec(inputs=("u",), outputs=("y1", "y2"), mode_ids=("a",), dt=1.0, states=())


@pytest.mark.parametrize("kind", ["list", "array"])
def test_a_negative_index_of_a_parquet_list_is_the_element_it_counts_to(
    tmp_path: Path, kind: str
) -> None:
    n = 12
    frame = pl.DataFrame(
        {
            "t": np.arange(n, dtype=np.float64),
            "q": [[float(i), 2.0 * i, 3.0 * i] for i in range(n)],
        },
        schema_overrides={"q": pl.Array(pl.Float64, 3)} if kind == "array" else None,
    )
    log = tmp_path / "q.parquet"
    frame.write_parquet(log)
    with pytest.raises(LogError, match=r"'q\[2\]' and 'q\[-1\]' name one column"):
        load_signals(log, SPEC, ReadOptions(maps=("u=q[2]", "y1=q[-1]", "y2=q[0]")))
    aligned = load_signals(log, SPEC, ReadOptions(maps=("u=q[1]", "y1=q[-1]", "y2=q[-3]")))
    np.testing.assert_array_equal(aligned.outputs[:, 0], 3.0 * np.arange(n))
    np.testing.assert_array_equal(aligned.outputs[:, 1], np.arange(n))
    with TableSource(log, ReadOptions()) as source:
        assert source.field_key("q[-1]") == source.field_key("q[2]") == ("q", (2,))


def test_a_negative_index_beyond_a_parquet_list_is_out_of_range(tmp_path: Path) -> None:
    # 'q[-5]' beside 'q[1]' on lists of three was refused as one element "where the array
    # holds 4", which no row's list does, not as the index out of range it is
    n = 12
    frame = pl.DataFrame({"t": np.arange(n, dtype=np.float64), "q": [[1.0, 2.0, 3.0]] * n})
    log = tmp_path / "q.parquet"
    frame.write_parquet(log)
    said = r"input 'u' \(column 'q\[-5\]', from --map u=q\[-5\]\): index out of range \(the lists"
    with pytest.raises(LogError, match=said):
        load_signals(log, SPEC, ReadOptions(maps=("u=q[-5]", "y1=q[1]", "y2=q[0]")))


def test_a_negative_index_of_a_fixed_size_message_array_counts_from_its_start() -> None:
    defs = ros2_store().fielddefs
    assert from_the_start(defs, "sensor_msgs/msg/Imu", ("orientation_covariance", -1)) == (
        "orientation_covariance",
        8,
    )
    # a sequence's length is known only per message: the index stays as written
    assert from_the_start(defs, "sensor_msgs/msg/JointState", ("position", -1)) == (
        "position",
        -1,
    )


def _keys(name: str) -> FieldKey:
    topic, _, rest = name.partition(".")
    return topic, tuple(int(s) if s.lstrip("-").isdigit() else s for s in rest.split("."))


@pytest.mark.parametrize(
    ("second", "refused"),
    [
        ("/j.position.-1", "3"),
        ("/j.position.-2", "4"),  # any two from both ends meet in messages of some length
        ("/j.position.1", ""),
    ],
)
def test_a_sequence_indexed_from_both_ends_is_refused(second: str, refused: str) -> None:
    """In messages whose sequence holds three, ``position[2]`` and ``position[-1]`` are one.

    Its length is known only per message: indices from both ends are refused, naming the
    length at which they meet.
    """
    fields = ("/j.position.2", second, "/j.velocity.0")
    resolve = lambda: resolve_signal_map(  # noqa: E731
        fields,
        source="j.mcap",
        inputs=("u",),
        outputs=("y1", "y2"),
        states=(),
        maps=parse_maps(
            [f"u={fields[0]}", f"y1={second}", f"y2={fields[2]}"],
            inputs=("u",),
            outputs=("y1", "y2"),
            states=(),
        ),
        message_paths=True,
        field_key=_keys,
    )
    if not refused:
        resolve()
        return
    with pytest.raises(
        LogError,
        match=r"index one array from its start and from its end .*"
        rf"one element where the array holds {refused}; count both indices from one end",
    ):
        resolve()


def test_a_message_log_with_a_fixed_size_array_refuses_two_spellings(tmp_path: Path) -> None:
    store = ros2_store()
    imu = store.types["sensor_msgs/msg/Imu"]
    messages = []
    for k in range(6):
        message = imu(
            header=store.types["std_msgs/msg/Header"](
                stamp=store.types["builtin_interfaces/msg/Time"](sec=k, nanosec=0), frame_id="i"
            ),
            orientation=store.types["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
            orientation_covariance=np.arange(9, dtype=np.float64) + k,
            angular_velocity=store.types["geometry_msgs/msg/Vector3"](x=k, y=0.0, z=0.0),
            angular_velocity_covariance=np.zeros(9),
            linear_acceleration=store.types["geometry_msgs/msg/Vector3"](x=0.0, y=k, z=0.0),
            linear_acceleration_covariance=np.zeros(9),
        )
        messages.append((0, k * 10**9, cdr(message, "sensor_msgs/msg/Imu")))
    log = write_mcap(
        tmp_path / "imu.mcap", [Channel("/imu", schema_name="sensor_msgs/msg/Imu")], messages
    )
    maps = ("u=/imu.orientation_covariance[8]", "y1=/imu.orientation_covariance[-1]")
    with pytest.raises(LogError, match=r"name one field"):
        load_signals(log, SPEC, ReadOptions(maps=(*maps, "y2=/imu.angular_velocity.x")))
