"""CSV cells read as written: a time past float64 named as written, a time that is not
finite refused with --drop-nonfinite too (saying so), boolean columns read as Parquet's."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import polars as pl
import pytest

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, format_inspection, inspect_log, load_signals

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1",), dt=0.1)
N = 20


def _csv(tmp_path: Path, time: str, u: str = "1.0") -> Path:
    lines = ["t,u,y", *(f"{k / 10},{u if k == 4 else 1.0},{k}" for k in range(N))]
    lines[5] = f"{time},{u},4"
    log = tmp_path / "log.csv"
    log.write_text("\n".join(lines) + "\n")
    return log


@pytest.mark.parametrize("drop", [False, True])
def test_a_time_past_float64_is_named_as_written(tmp_path: Path, drop: bool) -> None:
    log = _csv(tmp_path, "1e400")
    with pytest.raises(LogError) as error:
        load_signals(log, SPEC, ReadOptions(drop_nonfinite=drop))
    assert str(error.value) == (
        f"{log}, line 6, column 't': time '1e400' is beyond the range of a float64 (about 1.8e308)"
    )


@pytest.mark.parametrize("time", ["nan", "-Inf"])
def test_a_time_not_finite_is_refused_with_drop_nonfinite_saying_so(
    tmp_path: Path, time: str
) -> None:
    log = _csv(tmp_path, time)
    with pytest.raises(LogError) as error:
        load_signals(log, SPEC, ReadOptions(drop_nonfinite=True))
    assert str(error.value) == (
        f"{log}, line 6, column 't': time '{time}' is not a finite number of seconds "
        "(--drop-nonfinite drops values, never a row without a finite time)"
    )


@pytest.mark.parametrize("spelled", [("true", "false"), ("True", "False")])
def test_a_csv_boolean_column_reads_as_the_parquet_one(
    tmp_path: Path, spelled: tuple[str, str]
) -> None:
    on = np.arange(N) % 3 == 0
    frame = pl.DataFrame({"t": np.arange(N) / 10, "u": on, "y": np.arange(N, dtype=float)})
    frame.write_parquet(tmp_path / "log.parquet")
    text = ["t,u,y", *(f"{k / 10},{spelled[0] if on[k] else spelled[1]},{k}" for k in range(N))]
    (tmp_path / "log.csv").write_text("\n".join(text) + "\n")
    from_csv = load_signals(tmp_path / "log.csv", SPEC)
    from_parquet = load_signals(tmp_path / "log.parquet", SPEC)
    np.testing.assert_array_equal(from_csv.inputs, from_parquet.inputs)
    np.testing.assert_array_equal(from_csv.inputs[:, 0], on.astype(float))


def test_a_boolean_among_numbers_is_refused_with_the_rule(tmp_path: Path) -> None:
    log = _csv(tmp_path, "0.4", u="true")
    with pytest.raises(LogError) as error:
        load_signals(log, SPEC)
    assert str(error.value) == (
        f"{log}, line 6, column 'u': 'true' is not a number (true and false read as 1 and 0 "
        "only in a column of nothing else)"
    )


def test_a_boolean_time_column_is_no_time(tmp_path: Path) -> None:
    log = tmp_path / "log.csv"
    log.write_text("t,u,y\n" + "".join(f"true,1,{k}\n" for k in range(N)))
    with pytest.raises(LogError, match=r"'true' is not a number$"):
        load_signals(log, SPEC)


def test_inspect_describes_a_csv_boolean_column_as_the_parquet_one(tmp_path: Path) -> None:
    on = np.arange(N) % 3 == 0
    frame = pl.DataFrame({"t": np.arange(N) / 10, "u": on, "y": np.arange(N, dtype=float)})
    frame.write_parquet(tmp_path / "log.parquet")
    frame.write_csv(tmp_path / "log.csv")
    described = [
        next(c for c in inspect_log(tmp_path / f"log.{kind}")["columns"] if c["name"] == "u")
        for kind in ("csv", "parquet")
    ]
    assert described[0] == described[1]
    assert (described[0]["dtype"], described[0]["min"], described[0]["max"]) == ("boolean", 0, 1)


def test_inspect_says_a_non_finite_time_is_not_dropped(tmp_path: Path) -> None:
    # it listed the time column's NaN under "refused unless --drop-nonfinite", which
    # analyze --drop-nonfinite then refused
    t = np.arange(N) / 10
    t[4] = np.nan
    frame = pl.DataFrame({"t": t, "u": np.ones(N), "y": np.full(N, np.nan)})
    frame.write_parquet(tmp_path / "log.parquet")
    text = format_inspection(inspect_log(tmp_path / "log.parquet")).splitlines()
    assert "  t: 1 of 20 (the time: refused even with --drop-nonfinite)" in text
    assert "  y: 20 of 20" in text
