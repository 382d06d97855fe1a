"""A Parquet timestamp whose zone is a fixed offset (``+05:30``) is read, in UTC.

pyarrow writes a ``datetime.timezone`` or pandas' ``FixedOffset`` as the zone ``+05:30``,
which polars 2.1 does not know: it panicked reading the file's schema, and hybridlog refused
a valid log as "not a readable Parquet file (damaged? ...)".  polars cannot write such a
zone, so the test writes ``Poland`` (as long) and puts ``+05:30`` in its place in the Arrow
schema the file carries, as pyarrow writes it.
"""

from __future__ import annotations

import base64
from pathlib import Path

import numpy as np
import polars as pl

from hybridlog.io import ReadOptions, SignalSpec, inspect_log, load_signals

SPEC = SignalSpec(inputs=("u",), outputs=("y",), states=("x",), mode_ids=("1", "2"), dt=0.1)
START_NS = 1_700_000_000 * 10**9
N = 20


def _varint(data: bytes, at: int) -> tuple[int, int]:
    value = shift = 0
    while True:
        byte = data[at]
        value |= (byte & 0x7F) << shift
        at += 1
        if byte < 0x80:
            return value, at
        shift += 7


def fixed_offset_log(path: Path, unit: str) -> Path:
    stamps = pl.Series("t", [START_NS + k * 100_000_000 for k in range(N)])
    t = stamps.cast(pl.Datetime("ns", "Poland")).dt.cast_time_unit(unit)  # type: ignore[arg-type]
    frame = pl.DataFrame({"t": t, "u": np.sin(np.arange(N)), "y": np.cos(np.arange(N))})
    frame.write_parquet(path)
    data = path.read_bytes()
    key = data.index(b"ARROW:schema") + len(b"ARROW:schema")
    assert data[key] == 0x18  # thrift compact: the next field, binary
    length, start = _varint(data, key + 1)
    schema = base64.b64decode(data[start : start + length])
    assert schema.count(b"Poland") == 1
    patched = base64.b64encode(schema.replace(b"Poland", b"+05:30"))
    path.write_bytes(data[:start] + patched + data[start + length :])
    return path


def test_a_fixed_offset_zone_is_read_in_utc(tmp_path: Path) -> None:
    for unit in ("ms", "us", "ns"):
        log = fixed_offset_log(tmp_path / f"{unit}.parquet", unit)
        info = inspect_log(log)
        assert info["problems"] == []
        assert "+05:30" in info["columns"][0]["dtype"]
        assert info["time"]["start"] == START_NS / 1e9
        signals = load_signals(log, SPEC, ReadOptions())
        expected = (START_NS + 100_000_000 * np.arange(N)) / 1e9
        assert np.array_equal(signals.time, expected), unit
        assert np.array_equal(signals.inputs[:, 0], np.sin(np.arange(N)))
        assert np.array_equal(signals.outputs[:, 0], np.cos(np.arange(N)))
