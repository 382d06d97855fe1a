"""Inspect names every value ``analyze`` refuses as not held by a float64, in every format.

Inspect parsed a table's columns, and counted a message log's values, on its own: a CSV cell
or Parquet ``int64`` of 9007199254740993 (2^53 + 1), an ``int64``/``uint64`` field of a bag
or MCAP file or a JSON integer beyond 2^53 was shown as a range (``max 9.0072e+15``) with no
word, and ``analyze`` then refused the log naming the line, row or message.  Each is now in
inspect's ``problems`` in the words of analyze's error, before the user maps it.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import polars as pl
import pytest

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, format_inspection, inspect_log, load_signals
from tests.io.test_integers_beyond_float64 import (
    BIG,
    MAPS,
    MESSAGE_LOGS,
    SPEC,
    TIMES,
    Writer,
    ints,
    write_csv,
)


def csv_log(path: Path) -> tuple[Path, ReadOptions]:
    return write_csv(path / "log.csv", [str(v) for v in ints(BIG)]), ReadOptions()


def csv_overflow(path: Path) -> tuple[Path, ReadOptions]:
    cells = ["1e400" if v == BIG else str(v) for v in ints(BIG)]
    return write_csv(path / "log.csv", cells), ReadOptions()


def parquet_log(path: Path) -> tuple[Path, ReadOptions]:
    frame = pl.DataFrame({"t": TIMES, "u": ints(BIG), "y": TIMES})
    frame.write_parquet(path / "log.parquet")
    return path / "log.parquet", ReadOptions()


Make = Callable[[Path], tuple[Path, ReadOptions]]


def message_log(write: Writer, name: str, msgtype: str, value: int) -> Make:
    def made(path: Path) -> tuple[Path, ReadOptions]:
        return write(path / name, msgtype, ints(value)), MAPS

    return made


LOGS: list[tuple[str, Make]] = [
    ("csv", csv_log),
    ("csv-overflow", csv_overflow),
    ("parquet", parquet_log),
    *(
        (f"{kind}-{msgtype.rsplit('/', 1)[1]}", message_log(write, name, msgtype, value))
        for kind, write, name in MESSAGE_LOGS
        for msgtype, value in [("std_msgs/msg/Int64", -BIG), ("std_msgs/msg/UInt64", 2**64 - 1)]
    ),
]


@pytest.mark.parametrize("make", [m[1] for m in LOGS], ids=[m[0] for m in LOGS])
def test_inspect_names_the_value_analyze_refuses(tmp_path: Path, make: Make) -> None:
    path, options = make(tmp_path)
    with pytest.raises(LogError) as refused:
        load_signals(path, SPEC, options)
    said = str(refused.value).removeprefix(f"{path}: ").removeprefix(f"{path}, ")
    # analyze names the input the field feeds, which inspect does not know
    said = said.replace("input 'u' (field '/u.data', from --map u=/u.data)", "'/u.data'")
    info = inspect_log(path)
    assert said in info["problems"]
    assert f"  {said}" in format_inspection(info).splitlines()


def test_values_a_float64_holds_are_no_problem(tmp_path: Path) -> None:
    _, write, name = MESSAGE_LOGS[-1]  # JSON: an integer of 2^63 is held exactly
    held = write(tmp_path / name, "std_msgs/msg/UInt64", ints(2**63))
    assert inspect_log(held)["problems"] == []
    path = write_csv(tmp_path / "log.csv", [str(2**60) for _ in TIMES])
    assert inspect_log(path)["problems"] == []
