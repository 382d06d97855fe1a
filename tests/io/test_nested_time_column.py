"""A Parquet time column that is a struct or a list is refused as such, naming the file.

A ROS-style stamp written as a struct (``t = {sec, nsec}``), or a list column named ``t``,
raised an unexpected ``PathError`` ("'t' is a struct ...; name a field, e.g. t.sec", no
file named; ``analyze`` called it a bug), where ``inspect`` said what the column is.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import polars as pl
import pytest

from hybridlog.errors import LogError
from hybridlog.io import SignalSpec, inspect_log, load_signals

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1",), dt=1.0)
N = 6


@pytest.mark.parametrize(
    ("name", "time", "kind"),
    [
        ("t", pl.Series([{"sec": k, "nsec": 0} for k in range(N)]), "Struct"),
        ("time", pl.Series([{"sec": k, "nsec": 0} for k in range(N)]), "Struct"),
        ("t", pl.Series([[float(k)] for k in range(N)]), "List(Float64)"),
    ],
)
def test_a_nested_time_column_is_refused_as_inspect_says(
    tmp_path: Path, name: str, time: pl.Series, kind: str
) -> None:
    log = tmp_path / "stamped.parquet"
    values = np.arange(N, dtype=float)
    pl.DataFrame({name: time, "u": values, "y": values}).write_parquet(log)
    with pytest.raises(LogError) as error:
        load_signals(log, SPEC)
    said = str(error.value)
    assert said.startswith(f"{log}: column '{name}' has type {kind}")
    assert "expected seconds as numbers, a Datetime or Duration" in said
    (problem,) = inspect_log(log)["problems"]
    assert problem == said.removeprefix(f"{log}: ")


def test_a_categorical_time_column_is_said_to_be_one(tmp_path: Path) -> None:
    """Its error (and inspect's problem) said "type String", the type it is read as."""
    log = tmp_path / "categories.parquet"
    values = np.arange(3, dtype=float)
    time = pl.Series(["0.0", "1.0", "2.0"]).cast(pl.Categorical)
    pl.DataFrame({"t": time, "u": values, "y": values}).write_parquet(log)
    with pytest.raises(LogError, match=r"column 't' has type Categorical, expected seconds"):
        load_signals(log, SPEC)
    (problem,) = inspect_log(log)["problems"]
    assert problem.startswith("column 't' has type Categorical, expected seconds")
