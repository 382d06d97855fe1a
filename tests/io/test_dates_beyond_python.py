"""A time column's date or duration beyond what Python holds is refused naming its row.

The error named the value as Python writes it: a Parquet date in the year 0 (or an ISO
8601 cell ``0000-01-01T00:00:00``) raised ``ValueError: year 0 is out of range``, a
duration of 2^62 ms ``OverflowError``, and a date past the year 262143 made polars panic:
a traceback and exit code 1 from ``inspect`` and ``analyze``, not the one-line error
(``inspect``: a line of its ``problems``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import polars as pl
import pytest

from hybridlog.errors import LogError
from hybridlog.io import SignalSpec, inspect_log, load_signals

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1",), dt=1.0)
YEAR_0_MS = -62_167_219_200_000


def _parquet(path: Path, stored: list[int], dtype: pl.DataType) -> Path:
    n = len(stored)
    t = pl.Series("t", stored).cast(dtype)
    pl.DataFrame({"t": t, "u": np.arange(n, dtype=float), "y": np.ones(n)}).write_parquet(path)
    return path


@pytest.mark.parametrize(
    ("stored", "dtype", "said"),
    [
        ([0, 1000, 2000, 2**62], pl.Datetime("ms"), "row 4, column 't': the date 146140482-04-24"),
        (
            [-(2**62), 0, 1000],
            pl.Datetime("ms", "Europe/Berlin"),
            "row 1, column 't': the date -146136543",
        ),
        (
            [YEAR_0_MS, YEAR_0_MS + 1000],
            pl.Datetime("ms"),
            "row 1, column 't': the date 0000-01-01T00:00:00",
        ),
        ([0, 1000, 2**62], pl.Duration("ms"), "row 3, column 't': the duration 4611686018427388 s"),
    ],
)
def test_a_parquet_time_beyond_python_is_refused_naming_the_row(
    tmp_path: Path, stored: list[int], dtype: pl.DataType, said: str
) -> None:
    log = _parquet(tmp_path / "far.parquet", stored, dtype)
    with pytest.raises(LogError, match="beyond what the nanosecond grid holds") as error:
        load_signals(log, SPEC)
    assert said in str(error.value)
    (problem,) = inspect_log(log)["problems"]
    assert said in problem


def test_an_iso_date_in_the_year_0_is_refused_naming_the_line(tmp_path: Path) -> None:
    log = tmp_path / "far.csv"
    log.write_text("t,u,y\n0000-01-01T00:00:00,0,1\n0000-01-01T00:00:01,1,1\n")
    with pytest.raises(LogError, match="line 2, column 't': the date 0000-01-01T00:00:00"):
        load_signals(log, SPEC)


def test_a_date_python_holds_is_still_written_as_polars_writes_it(tmp_path: Path) -> None:
    log = tmp_path / "old.csv"
    log.write_text("t,u,y\n1600-01-01T00:00:00,0,1\n1600-01-01T00:00:01,1,1\n")
    with pytest.raises(LogError, match="the date '1600-01-01 00:00:00' is beyond"):
        load_signals(log, SPEC)
