"""Inspect counts the values out of range that analyze refuses, with the non-finite ones.

``analyze`` refuses a sample of magnitude 2^480 or more (what corrupt bytes decode to) as it
refuses NaN and inf, and ``--drop-nonfinite`` drops it with them.  ``inspect`` counted NaN
and inf only: a ``float64`` field of 1e300 in a bag or an MCAP file showed ``nonfinite 0``
(messages have no range column; a JSON field of 1e300 still did), a CSV or Parquet column
showed it as its ``max``, and the
user learnt of it from analyze's refusal.  Now inspect's ``nonfinite`` is what
``--drop-nonfinite`` drops, and a column's range that of the values analyze reads.  Files
written by the ``mcap`` writer, rosbags' ROS 1 bag writer and polars.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl
import pytest
from rosbags.rosbag1 import Writer as Ros1Writer

from hybridlog.io import ReadOptions, SignalSpec, format_inspection, inspect_log, load_signals
from tests.support.logfiles import Channel, float_messages, json_bytes, ros1_store, write_mcap

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1",), dt=0.1)
N = 10
TIMES_NS = [1_700_000_000 * 10**9 + k * 10**8 for k in range(N)]
Y = [
    1e300 if k == 4 else -(2.0**480) if k == 6 else float("nan") if k == 8 else float(k)
    for k in range(N)
]


def _mcap(path: Path) -> Path:
    messages = float_messages(TIMES_NS, range(N), 0) + float_messages(TIMES_NS, Y, 1)
    return write_mcap(path, [Channel("/u"), Channel("/y")], sorted(messages, key=lambda m: m[1]))


def _json_mcap(path: Path) -> Path:
    """JSON messages: a NaN is written as null, 1e300 and -2^480 as numbers (counted 0 before)."""
    schema = '{"type": "object", "properties": {"data": {"type": "number"}}}'
    channels = [Channel(t, "json", "Value", "jsonschema", schema) for t in ("/u", "/y")]
    messages = [
        (c, t, json_bytes({"data": None if v != v else v}))
        for c, values in enumerate((range(N), Y))
        for t, v in zip(TIMES_NS, values, strict=True)
    ]
    return write_mcap(path, channels, sorted(messages, key=lambda m: m[1]), profile="")


def _bag(path: Path) -> Path:
    store, msgtype = ros1_store(), "std_msgs/msg/Float64"
    with Ros1Writer(path) as writer:
        u, y = (writer.add_connection(t, msgtype, typestore=store) for t in ("/u", "/y"))
        for k, t in enumerate(TIMES_NS):
            for connection, value in ((u, float(k)), (y, Y[k])):
                message = store.types[msgtype](data=value)
                writer.write(connection, t, store.serialize_ros1(message, msgtype))
    return path


def _table(path: Path) -> Path:
    frame = pl.DataFrame(
        {"t": [k * 0.1 for k in range(N)], "u": [float(k) for k in range(N)], "y": Y}
    )
    frame.write_csv(path) if path.suffix == ".csv" else frame.write_parquet(path)
    return path


LOGS: dict[str, tuple[str, Callable[[Path], Path]]] = {
    "mcap": ("log.mcap", _mcap),
    "json mcap": ("log.mcap", _json_mcap),
    "ros1 bag": ("log.bag", _bag),
    "csv": ("log.csv", _table),
    "parquet": ("log.parquet", _table),
}


@pytest.mark.parametrize("kind", list(LOGS))
def test_inspect_counts_what_drop_nonfinite_drops(kind: str, tmp_path: Path) -> None:
    name, write = LOGS[kind]
    log = write(tmp_path / name)
    info = inspect_log(log)
    entries: list[dict[str, Any]] = (
        info["columns"] if "columns" in info else [v for t in info["topics"] for v in t["values"]]
    )
    y = next(e for e in entries if e["name"] in ("y", "/y.data"))
    assert (y["count"], y["nonfinite"]) == (N, 3)  # 1e300, -2^480 and NaN
    if "min" in y:  # a column's range: the values analyze reads
        assert (y["min"], y["max"]) == (0.0, 9.0)
    assert f"  {y['name']}: 3 of {N}" in format_inspection(info)
    notes: dict[str, Any] = {}
    maps = () if "columns" in info else ("u=/u.data", "y=/y.data")
    signals = load_signals(log, SPEC, ReadOptions(maps=maps, drop_nonfinite=True), notes=notes)
    dropped = (notes["nonfinite_dropped"], notes["out_of_range_dropped"])
    assert [list(d.values()) for d in dropped] == [[1], [2]]
    assert np.isfinite(signals.outputs).all()
