"""A Parquet decimal time column is read to the nanosecond as written, not as a float64.

Unix times in a decimal column stepping by 100 ns (as a database export writes them) were
read through a float64, which holds 238 ns there, and refused as "float64 seconds ... too
coarse": digits the column holds, and a type it does not have.
"""

from __future__ import annotations

from decimal import Decimal
from pathlib import Path

import numpy as np
import polars as pl
import pytest

from hybridlog.errors import LogError
from hybridlog.io import SignalSpec, inspect_log, load_signals

N = 40
EPOCH = Decimal(1_700_000_000)


def _log(path: Path, times: list[Decimal], scale: int = 9) -> Path:
    n = len(times)
    values = np.arange(n, dtype=float)
    t = pl.Series("t", times, dtype=pl.Decimal(38, scale))
    pl.DataFrame({"t": t, "u": values, "y": 10 * values}).write_parquet(path)
    return path


def test_unix_times_a_hundred_nanoseconds_apart(tmp_path: Path) -> None:
    log = _log(tmp_path / "fast.parquet", [EPOCH + Decimal(k) / 10**7 for k in range(N)])
    spec = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1",), dt=1e-7)
    aligned = load_signals(log, spec)
    assert aligned.inputs[:, 0].tolist() == list(range(N))
    assert aligned.outputs[:, 0].tolist() == [10.0 * k for k in range(N)]
    described = inspect_log(log)
    assert described["problems"] == []
    (time,) = [c for c in described["columns"] if c["name"] == "t"]
    assert (time["sample_time"], time["min_step"], time["max_step"]) == (1e-7, 1e-7, 1e-7)


def test_digits_below_the_nanosecond_are_rounded(tmp_path: Path) -> None:
    times = [Decimal("0.0000000019"), Decimal("1.0000000004"), Decimal("2")]
    log = _log(tmp_path / "fine.parquet", times, scale=10)
    spec = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1",), dt=1.0)
    aligned = load_signals(log, spec)
    assert aligned.time.tolist() == [2e-9, 1.000000002, 2.000000002]


def test_a_decimal_time_beyond_the_grid_is_refused_naming_its_row(tmp_path: Path) -> None:
    log = _log(tmp_path / "far.parquet", [Decimal(0), Decimal(1), Decimal(9_300_000_000)], 3)
    spec = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1",), dt=1.0)
    with pytest.raises(LogError, match=r"row 3, column 't': time 9.3e\+09 is beyond the 9.2e\+09"):
        load_signals(log, spec)
