"""An integer beyond 2^53 that a float64 cannot hold is refused where it is, in every format.

A CSV integer cell, a Parquet ``int64``/``uint64``/decimal column and an ``int64``/``uint64``
field of a ROS 1 or ROS 2 bag or an MCAP file (CDR or JSON) mapped to a signal became a
float64: 9007199254740993 (2^53 + 1) was read as 9007199254740992 and 2^64 - 1 as 2^64,
their last digits lost without a word.  Each is now one error naming the file, the column
(or topic and field) and the line, row or message time.  A number beyond 2^53 that a float64
holds exactly (2^60), or one written as a float, is read as it is; true modes are labels, so
mode ids beyond 2^53 stay distinct in every format (their digits are the label).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from decimal import Decimal
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl
import pytest

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, load_signals
from tests.support.logfiles import Channel, ros1_store, ros2_store, write_mcap

BIG = 2**53 + 1
HELD = 2**53
SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1", "2"), dt=0.1)
STEPS = 8
TIMES = [0.1 * k for k in range(STEPS)]
BAD_STEP = 3


def ints(bad: int) -> list[int]:
    return [bad if k == BAD_STEP else k for k in range(STEPS)]


def reason(value: int, held: int) -> str:
    return (
        f"{value} is an integer beyond 2\\^53, which a float64 cannot hold "
        f"\\(it would read as {held}\\)"
    )


# ------------------------------------------------------------------------------ tables


def write_csv(path: Path, cells: list[str], modes: list[str] | None = None) -> Path:
    lines = ["t,u,y" + (",mode" if modes else "")]
    for k, cell in enumerate(cells):
        lines.append(f"{TIMES[k]:.1f},{cell},{k}" + (f",{modes[k]}" if modes else ""))
    path.write_text("\n".join(lines) + "\n")
    return path


def test_a_csv_integer_cell_beyond_2_53_is_refused_naming_its_line(tmp_path: Path) -> None:
    path = write_csv(tmp_path / "log.csv", [str(v) for v in ints(BIG)])
    with pytest.raises(LogError, match=f"^{path}, line 5, column 'u': {reason(BIG, HELD)}$"):
        load_signals(path, SPEC)


def test_a_negative_csv_integer_names_the_first_line_in_the_file(tmp_path: Path) -> None:
    cells = [str(v) for v in ints(-BIG)]
    cells[6] = str(BIG + 2)  # 2^53 + 3: also lost, later in the file
    path = write_csv(tmp_path / "log.csv", cells)
    with pytest.raises(LogError, match=f"line 5, column 'u': {reason(-BIG, -HELD)}"):
        load_signals(path, SPEC, ReadOptions(sort=True))


@pytest.mark.parametrize(
    "cell", [str(2**60), "9007199254740993.0", "1.2345678901234567e+20", "1e20", "-0"]
)
def test_csv_numbers_a_float64_holds_or_written_as_floats_are_read(
    tmp_path: Path, cell: str
) -> None:
    path = write_csv(tmp_path / "log.csv", [cell if k == BAD_STEP else str(k) for k in range(8)])
    signals = load_signals(path, SPEC)
    assert signals.inputs[BAD_STEP, 0] == float(cell)


@pytest.mark.parametrize(
    ("dtype", "value", "held"),
    [(pl.Int64, BIG, HELD), (pl.Int64, -(2**63) + 1, -(2**63)), (pl.UInt64, 2**64 - 1, 2**64)],
)
def test_a_parquet_integer_beyond_2_53_is_refused_naming_its_row(
    tmp_path: Path, dtype: Any, value: int, held: int
) -> None:
    path = tmp_path / "log.parquet"
    pl.DataFrame({"t": TIMES, "u": pl.Series(ints(value), dtype=dtype), "y": TIMES}).write_parquet(
        path
    )
    with pytest.raises(LogError, match=f"^{path}, row 4, column 'u': {reason(value, held)}$"):
        load_signals(path, SPEC)


def test_a_parquet_decimal_beyond_2_53_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "log.parquet"
    values = [Decimal(k) for k in range(STEPS)]
    values[BAD_STEP] = Decimal("9007199254740993.25")
    u = pl.Series(values, dtype=pl.Decimal(30, 2))
    pl.DataFrame({"t": TIMES, "u": u, "y": TIMES}).write_parquet(path)
    with pytest.raises(LogError, match=r"row 4, column 'u': 9007199254740993\.25 is a decimal"):
        load_signals(path, SPEC)


def test_parquet_integers_a_float64_holds_are_read(tmp_path: Path) -> None:
    path = tmp_path / "log.parquet"
    u = pl.Series(ints(2**63), dtype=pl.UInt64)
    pl.DataFrame({"t": TIMES, "u": u, "y": TIMES}).write_parquet(path)
    assert load_signals(path, SPEC).inputs[BAD_STEP, 0] == 2.0**63


# ---------------------------------------------------------------------- message logs


def ros2_bag(path: Path, msgtype: str, values: list[int], modes: list[int] | None = None) -> Path:
    from rosbags.rosbag2 import StoragePlugin, Writer

    store = ros2_store()
    with Writer(path, version=9, storage_plugin=StoragePlugin.SQLITE3) as writer:
        u = writer.add_connection("/u", msgtype, typestore=store)
        y = writer.add_connection("/y", "std_msgs/msg/Float64", typestore=store)
        m = writer.add_connection("/mode", "std_msgs/msg/UInt64", typestore=store)
        for k, value in enumerate(values):
            ns = 100_000_000 * k
            writer.write(u, ns, store.serialize_cdr(store.types[msgtype](data=value), msgtype))
            float64 = store.types["std_msgs/msg/Float64"](data=float(k))
            writer.write(y, ns, store.serialize_cdr(float64, "std_msgs/msg/Float64"))
            if modes is not None:
                mode = store.types["std_msgs/msg/UInt64"](data=modes[k])
                writer.write(m, ns, store.serialize_cdr(mode, "std_msgs/msg/UInt64"))
    return path


def ros1_bag(path: Path, msgtype: str, values: list[int]) -> Path:
    from rosbags.rosbag1 import Writer

    store = ros1_store()
    with Writer(path) as writer:
        u = writer.add_connection("/u", msgtype, typestore=store)
        y = writer.add_connection("/y", "std_msgs/msg/Float64", typestore=store)
        for k, value in enumerate(values):
            ns = 100_000_000 * k
            writer.write(u, ns, store.serialize_ros1(store.types[msgtype](data=value), msgtype))
            float64 = store.types["std_msgs/msg/Float64"](data=float(k))
            writer.write(y, ns, store.serialize_ros1(float64, "std_msgs/msg/Float64"))
    return path


def cdr_mcap(path: Path, msgtype: str, values: list[int]) -> Path:
    store = ros2_store()
    messages = []
    for k, value in enumerate(values):
        ns = 100_000_000 * k
        data = store.serialize_cdr(store.types[msgtype](data=value), msgtype)
        messages.append((0, ns, bytes(data)))
        float64 = store.types["std_msgs/msg/Float64"](data=float(k))
        messages.append((1, ns, bytes(store.serialize_cdr(float64, "std_msgs/msg/Float64"))))
    channels = [Channel("/u", schema_name=msgtype), Channel("/y")]
    return write_mcap(path, channels, messages)


def json_mcap(path: Path, msgtype: str, values: list[int]) -> Path:
    schema = json.dumps({"type": "object"})
    channels = [
        Channel("/u", "json", msgtype, "jsonschema", schema),
        Channel("/y", "json", "y", "jsonschema", schema),
    ]
    messages = []
    for k, value in enumerate(values):
        ns = 100_000_000 * k
        messages.append((0, ns, json.dumps({"data": value}).encode()))
        messages.append((1, ns, json.dumps({"data": float(k)}).encode()))
    return write_mcap(path, channels, messages, profile="")


Writer = Callable[[Path, str, list[int]], Path]
MESSAGE_LOGS: list[tuple[str, Writer, str]] = [
    ("ros2", ros2_bag, "bag2"),
    ("ros1", ros1_bag, "log.bag"),
    ("mcap-cdr", cdr_mcap, "log.mcap"),
    ("mcap-json", json_mcap, "log.mcap"),
]
MAPS = ReadOptions(maps=("u=/u.data", "y=/y.data"))


@pytest.mark.parametrize(("kind", "write", "name"), MESSAGE_LOGS, ids=[m[0] for m in MESSAGE_LOGS])
@pytest.mark.parametrize(
    ("msgtype", "value", "held"),
    [("std_msgs/msg/Int64", -BIG, -HELD), ("std_msgs/msg/UInt64", 2**64 - 1, 2**64)],
)
def test_a_message_integer_beyond_2_53_is_refused_naming_topic_field_and_time(
    tmp_path: Path, kind: str, write: Writer, name: str, msgtype: str, value: int, held: int
) -> None:
    path = write(tmp_path / name, msgtype, ints(value))
    with pytest.raises(
        LogError,
        match=f"^{path}: input 'u' \\(field '/u.data', from --map u=/u.data\\): the value "
        f"{reason(value, held)} in the message logged "
        "at t=0.3 s$",
    ):
        load_signals(path, SPEC, MAPS)


@pytest.mark.parametrize(("kind", "write", "name"), MESSAGE_LOGS, ids=[m[0] for m in MESSAGE_LOGS])
def test_message_integers_a_float64_holds_are_read(
    tmp_path: Path, kind: str, write: Writer, name: str
) -> None:
    path = write(tmp_path / name, "std_msgs/msg/UInt64", ints(2**63))
    assert load_signals(path, SPEC, MAPS).inputs[BAD_STEP, 0] == 2.0**63


# ---------------------------------------------------------------- mode ids are labels

IDS = (str(2**64 - 1), str(2**64 - 2))
MODE_SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=IDS, dt=0.1)
MODES = [IDS[k % 2] for k in range(STEPS)]


def test_parquet_uint64_mode_ids_beyond_2_53_stay_distinct(tmp_path: Path) -> None:
    path = tmp_path / "log.parquet"
    mode = pl.Series([int(m) for m in MODES], dtype=pl.UInt64)
    pl.DataFrame({"t": TIMES, "u": TIMES, "y": TIMES, "mode": mode}).write_parquet(path)
    truth = load_signals(path, MODE_SPEC).truth_modes
    np.testing.assert_array_equal(truth, [k % 2 for k in range(STEPS)])


@pytest.mark.parametrize("first", ["1.0", IDS[0]])
def test_csv_mode_ids_beyond_2_53_stay_distinct_beside_a_float_id(
    tmp_path: Path, first: str
) -> None:
    spec = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=(*IDS, "1"), dt=0.1)
    path = write_csv(tmp_path / "log.csv", [str(k) for k in range(STEPS)], [first, *MODES[1:]])
    truth = load_signals(path, spec).truth_modes
    assert truth is not None
    np.testing.assert_array_equal(truth[1:], [k % 2 for k in range(1, STEPS)])
    assert truth[0] == (2 if first == "1.0" else 0)


def test_bag_uint64_mode_ids_beyond_2_53_stay_distinct(tmp_path: Path) -> None:
    path = ros2_bag(tmp_path / "bag2", "std_msgs/msg/UInt64", ints(1), [int(m) for m in MODES])
    options = ReadOptions(maps=("u=/u.data", "y=/y.data", "truth.mode=/mode.data"))
    truth = load_signals(path, MODE_SPEC, options).truth_modes
    np.testing.assert_array_equal(truth, [k % 2 for k in range(STEPS)])
