"""CSV and Parquet logs: reading, checks and their messages, mapping, inspect."""

from __future__ import annotations

import json
import tempfile
from datetime import datetime, timedelta
from pathlib import Path
from typing import Any
from unittest import mock

import numpy as np
import polars as pl
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hybridlog.errors import LogError, OptionError
from hybridlog.io import (
    ReadOptions,
    SignalSpec,
    csv_lines,
    format_inspection,
    inspect_log,
    load_signals,
    write_table,
)
from hybridlog.io.tables import TableSource
from hybridlog.io.writers import Column

MODEL: dict[str, Any] = {
    "states": ("x1", "x2"),
    "inputs": ("u",),
    "outputs": ("y",),
    "mode_ids": ("1", "valve_open"),
    "dt": 0.1,
}


SPEC_FIELDS = {"states", "inputs", "outputs", "mode_ids", "dt", "signals", "truth"}


def load(path: Path, notes: dict[str, Any] | None = None, **options: Any) -> Any:
    """``load_signals`` with the spec keys of ``options`` over ``MODEL``, the rest read options."""
    spec = {**MODEL, **{k: v for k, v in options.items() if k in SPEC_FIELDS}}
    read = {k: tuple(v) if k == "maps" else v for k, v in options.items() if k not in SPEC_FIELDS}
    return load_signals(path, SignalSpec(**spec), ReadOptions(**read), notes=notes)


def csv_file(tmp_path: Path, text: str, name: str = "log.csv") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


GOOD = "t,u,y,mode\n0.0,1,10,1\n0.1,2,20,1\n0.2,3,30,valve_open\n0.3,4,40,valve_open\n"


def test_reads_a_plain_csv(tmp_path: Path) -> None:
    signals = load(csv_file(tmp_path, GOOD))
    np.testing.assert_array_equal(signals.time, [0.0, 0.1, 0.2, 0.3])
    np.testing.assert_array_equal(signals.inputs[:, 0], [1, 2, 3, 4])
    np.testing.assert_array_equal(signals.outputs[:, 0], [10, 20, 30, 40])
    assert signals.truth_modes is not None
    np.testing.assert_array_equal(signals.truth_modes, [0, 0, 1, 1])
    assert signals.truth_states is None
    assert signals.source.endswith("log.csv")


def test_non_numeric_cell_names_line_and_column(tmp_path: Path) -> None:
    path = csv_file(tmp_path, "t,u,y\n0.0,1,10\n0.1,2,20\n0.2,3,oops\n")
    with pytest.raises(LogError) as info:
        load(path)
    message = str(info.value)
    assert "log.csv" in message
    assert "line 4" in message
    assert "'y'" in message
    assert "'oops'" in message
    assert "\n" not in message


def test_non_numeric_cell_in_an_unmapped_column_is_ignored(tmp_path: Path) -> None:
    path = csv_file(tmp_path, "t,u,y,note\n0.0,1,10,start\n0.1,2,20,\n")
    assert load(path).n_samples == 2


def test_blanks_around_numbers_are_accepted(tmp_path: Path) -> None:
    signals = load(csv_file(tmp_path, "t,u,y\n0.0, 1 ,10\n0.1,2,  20.5\n"))
    np.testing.assert_array_equal(signals.outputs[:, 0], [10, 20.5])
    np.testing.assert_array_equal(signals.inputs[:, 0], [1, 2])


@pytest.mark.parametrize(
    ("text", "line", "how"),
    [
        ("t,u,y\n0.0,1,1\n0.2,1,1\n0.1,1,1\n", "line 4", "goes backwards"),
        ("t,u,y\n0.0,1,1\n0.1,1,1\n0.1,1,1\n", "line 4", "repeats"),
    ],
)
def test_time_must_increase(tmp_path: Path, text: str, line: str, how: str) -> None:
    with pytest.raises(LogError, match=how) as info:
        load(csv_file(tmp_path, text))
    assert line in str(info.value)
    assert "'t'" in str(info.value)


@pytest.mark.parametrize("cell", ["nan", "NaN", "inf", "-inf"])
def test_non_finite_mapped_value_names_time_and_column(tmp_path: Path, cell: str) -> None:
    path = csv_file(tmp_path, f"t,u,y\n0.0,1,1\n0.1,1,1\n0.2,1,{cell}\n")
    with pytest.raises(LogError) as info:
        load(path)
    message = str(info.value)
    assert "t=0.2 s" in message
    assert "column 'y'" in message
    assert "line 4" in message
    assert "output 'y'" in message


def test_non_finite_unmapped_value_is_ignored(tmp_path: Path) -> None:
    assert load(csv_file(tmp_path, "t,u,y,z\n0.0,1,1,nan\n0.1,1,1,inf\n")).n_samples == 2


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
@pytest.mark.parametrize(
    ("column", "value", "symbol"),
    [
        ("x1", -1e271, "truth.x1"),  # what a corrupted Parquet decoded to (issue 7)
        ("u", 1e300, "input 'u'"),
        ("y", -np.finfo(float).max, "output 'y'"),
        ("y", 2.0**480, "output 'y'"),  # the bound itself is out of range
    ],
)
def test_out_of_range_value_names_column_and_time(
    tmp_path: Path, suffix: str, column: str, value: float, symbol: str
) -> None:
    n = 6
    columns: dict[str, Column] = {
        "t": np.arange(n) * 0.1,
        "u": np.ones(n),
        "y": np.arange(n, dtype=float),
        "x1": np.full(n, 2.0),
    }
    columns[column] = np.where(np.arange(n) == 3, value, columns[column])  # type: ignore[call-overload]
    path = write_table(tmp_path / f"log{suffix}", columns)
    with pytest.raises(LogError) as info:
        load(path)
    message = str(info.value)
    assert message.startswith(f"{path}, {'line 5' if suffix == '.csv' else 'row 4'}, column")
    assert f"column {column!r}" in message and symbol in message
    assert "t=0.3 s is out of range" in message and "--drop-nonfinite" in message
    notes: dict[str, Any] = {}
    signals = load(path, drop_nonfinite=True, notes=notes)
    assert notes["out_of_range_dropped"] == {column: 1}
    assert "nonfinite_dropped" not in notes
    if column == "x1":
        assert signals.truth_states is not None
        # the short gap is bridged, and its point, which has no truth, is not scored
        np.testing.assert_array_equal(signals.truth_states[:, 0], [2, 2, 2, np.nan, 2, 2])
    else:
        assert signals.n_samples == n


def test_nonfinite_and_out_of_range_are_counted_apart(tmp_path: Path) -> None:
    path = csv_file(tmp_path, "t,u,y\n0.0,1,1\n0.1,1,nan\n0.2,1,1e200\n0.3,1,2\n0.4,1,3\n")
    notes: dict[str, Any] = {}
    signals = load(path, drop_nonfinite=True, notes=notes)
    assert notes["nonfinite_dropped"] == {"y": 1}
    assert notes["out_of_range_dropped"] == {"y": 1}
    assert np.all(np.abs(signals.outputs) < 10)


def test_non_finite_time_is_an_error(tmp_path: Path) -> None:
    with pytest.raises(LogError, match=r"line 3, column 't'.*not a finite"):
        load(csv_file(tmp_path, "t,u,y\n0.0,1,1\nnan,1,1\n"))


@pytest.mark.parametrize(
    ("text", "pattern"),
    [
        ("", "empty file"),
        ("\n0,1,2\n", r"line 1: no header"),
        ("0.0,1,2\n0.1,1,2\n", r"line 1: no header.*looks like data"),
        ("t,u,y\n", "no data rows"),
        ("t,u,y,y\n0,1,2,3\n", r"duplicate column name 'y'"),
        ("t,u,,y\n0,1,2,3\n", r"column 3 of the header has no name"),
        ("x,u,y\n0,1,2\n", r"no time column.*'t' or 'time'"),
    ],
)
def test_malformed_tables(tmp_path: Path, text: str, pattern: str) -> None:
    with pytest.raises(LogError, match=pattern):
        load(csv_file(tmp_path, text))


def test_time_column_may_be_called_time(tmp_path: Path) -> None:
    signals = load(csv_file(tmp_path, "time,u,y\n5.0,1,2\n5.1,1,3\n"))
    np.testing.assert_array_equal(signals.time, [5.0, 5.1])


def test_empty_time_cell_names_its_line(tmp_path: Path) -> None:
    with pytest.raises(LogError, match=r"line 3, column 't': empty time cell"):
        load(csv_file(tmp_path, "t,u,y\n0.0,1,1\n,1,1\n0.2,1,1\n"))


def test_blank_lines_are_skipped_but_counted(tmp_path: Path) -> None:
    text = "t,u,y\n0.0,1,1\n\n0.1,2,2\n0.2,3,x\n\n\n"
    path = csv_file(tmp_path, text)
    with pytest.raises(LogError, match="line 5"):
        load(path)
    path.write_text(text.replace(",x", ",3"))
    np.testing.assert_array_equal(load(path).outputs[:, 0], [1, 2, 3])


@pytest.mark.parametrize(
    ("text", "shown"),
    [
        ("t,u,y\n0.0,1,1\n0.1,1,1\n0.2,1", "2 of 3 fields"),
        # cut inside the last number: every field is there, and 69.78 would read as 6
        ("t,u,y\n0.0,1,1\n0.1,1,1\n0.2,1,6", "all its fields"),
    ],
)
def test_a_last_line_without_line_ending_is_an_error(tmp_path: Path, text: str, shown: str) -> None:
    path = csv_file(tmp_path, text)
    with pytest.raises(LogError, match=rf"line 4: the last line \({shown}\) has no line ending"):
        load(path)
    if shown == "all its fields":  # the same line, ended, is read
        for ending in ("\n", "\r\n"):
            path.write_text(text + ending)
            np.testing.assert_array_equal(load(path).time, [0.0, 0.1, 0.2])


def test_line_with_too_many_fields_is_an_error(tmp_path: Path) -> None:
    with pytest.raises(LogError, match=r"line 3: 4 fields, but the header names 3 columns"):
        load(csv_file(tmp_path, "t,u,y\n0.0,1,1\n0.1,1,1,7\n"))


@pytest.mark.parametrize(
    ("text", "line", "fields"),
    [
        ("t,u,y\n0.0,1,1\n0.1,1\n0.2,1,1\n", 3, "2 fields"),  # too few: was silently missing
        ("t,u,y\n0.0,1,1\n0.1\n0.2,1,1\n", 3, "1 field,"),
        ("t,u,y\n0.0,1,1\n\n0.1,1,1\n0.2,1\n", 5, "2 fields"),  # blank lines still count
        ('t,u,y\n0.0,"1",1\n0.1,"1,5"\n0.2,1,1\n', 3, "2 fields"),  # quoted: csv module
        ("t,u,y\r\n0.0,1,1\r\n0.1,1,1,7\r\n", 3, "4 fields"),
        # A short line and a long one whose commas cancel out in the file's count: polars
        # refused the long one as "not a readable CSV file (found more fields than defined
        # in 'Schema')", naming no line
        ("t,u,y\n0.0,1,1\n0.1,1\n0.2,1,1,1\n", 3, "2 fields"),
        ("t,u,y\n0.0,1,1\n0.1\n0.2,1,1,1,1\n0.3,1,1\n", 3, "1 field,"),
        ("t,u,y\n0.0,1,1\n0.1,1,1,1\n0.2,1\n", 3, "4 fields"),
    ],
)
def test_line_with_a_wrong_number_of_fields_is_an_error(
    tmp_path: Path, text: str, line: int, fields: str
) -> None:
    path = csv_file(tmp_path, text)
    with pytest.raises(LogError, match=rf"line {line}: {fields}.*header names 3 columns"):
        load(path)
    with pytest.raises(LogError, match=rf"line {line}: {fields}"):
        inspect_log(path)


@settings(max_examples=200, deadline=None)
@given(
    data=st.binary(max_size=300).map(lambda b: bytes(b',\n"a1'[x % 5] for x in b)),
    block=st.integers(1, 64),
)
def test_separators_are_counted_across_blocks(data: bytes, block: int) -> None:
    """The record-width check counts a block at a time: the counts of the whole file."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "log.csv"
        path.write_bytes(data)
        with mock.patch.object(csv_lines, "COUNTED_AT_ONCE", block):
            counted = csv_lines._count_separators(path)
    last = data[-1] if data else -1
    assert counted == (data.count(b","), data.count(b"\n"), b'"' in data, last)


def test_a_short_line_beyond_the_first_block_is_found(tmp_path: Path) -> None:
    rows = [f"{0.01 * k:.2f},1,1" for k in range(60_000)]
    rows[50_000] = "500.00,1"
    path = csv_file(tmp_path, "t,u,y\n" + "\n".join(rows) + "\n")
    assert path.stat().st_size > 2 * csv_lines.COUNTED_AT_ONCE
    with pytest.raises(LogError, match=r"line 50002: 2 fields, but the header names 3 columns"):
        load(path)


def test_zeroed_or_binary_file_gives_a_short_error(tmp_path: Path) -> None:
    path = tmp_path / "log.csv"
    path.write_bytes(b"\x00" * 16384 + b"\n" + b"\x00" * 16384 + b"\n")
    with pytest.raises(LogError) as info:
        load(path)
    message = str(info.value)
    assert "line 1" in message and "not printable" in message and "\\x00" in message
    assert len(message) < 200 + len(str(path))
    garbage = "9" * 5000 + "x"
    path.write_text(f"t,u,y\n0.0,1,1\n0.1,{garbage},1\n0.2,1,1\n")
    with pytest.raises(LogError, match=r"line 3, column 'u': '9+…9+x' is not a number") as info:
        load(path)
    assert len(str(info.value)) < 200 + len(str(path))


def test_unsupported_format_and_missing_file(tmp_path: Path) -> None:
    other = tmp_path / "log.txt"
    other.write_text(GOOD)
    with pytest.raises(LogError, match=r"log.txt: unsupported log format.*\.csv, \.parquet"):
        load(other)
    with pytest.raises(LogError, match=r"nope.csv: no such file"):
        load(tmp_path / "nope.csv")
    with pytest.raises(LogError, match="a directory"):
        load(tmp_path)


# ---------------------------------------------------------------- multi-rate and truth


def test_empty_cells_are_missing_samples(tmp_path: Path) -> None:
    # u at 10 Hz, y at 5 Hz in one table: y's empty cells are not samples.
    text = "t,u,y\n0.0,1,10\n0.1,2,\n0.2,3,30\n0.3,4,\n0.4,5,50\n"
    signals = load(csv_file(tmp_path, text), dt=0.2)
    np.testing.assert_array_equal(signals.time, [0.0, 0.2, 0.4])
    np.testing.assert_array_equal(signals.inputs[:, 0], [1, 3, 5])
    np.testing.assert_array_equal(signals.outputs[:, 0], [10, 30, 50])


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_sort_combines_rows_of_one_time_per_column(tmp_path: Path, suffix: str) -> None:
    """A long-format table (a row per signal) read with ``--sort``: one sample per column."""
    frame = pl.DataFrame(
        {
            "t": [0.0, 0.0, 0.2, 0.1, 0.1, 0.2, 0.2],
            "u": [1.0, None, 3.0, 2.0, None, None, 33.0],
            "y": [None, 10.0, None, None, 20.0, 30.0, None],
            "mode": ["1", None, None, None, "valve_open", "1", None],
        }
    )
    path = tmp_path / f"long{suffix}"
    frame.write_csv(path) if suffix == ".csv" else frame.write_parquet(path)
    with pytest.raises(LogError, match=r"time repeats .* \(--sort puts rows in time order"):
        TableSource(path).read(["u", "y"], ["mode"])
    with TableSource(path, ReadOptions(sort=True)) as source:
        reading = source.read(["u", "y"], ["mode"])
    u, y, mode = reading.numeric["u"], reading.numeric["y"], reading.labels["mode"]
    np.testing.assert_array_equal(u.time_ns, [0, 100_000_000, 200_000_000])
    np.testing.assert_array_equal(u.values, [1.0, 2.0, 33.0])  # the last of 3 and 33 at 0.2
    np.testing.assert_array_equal(y.time_ns, [0, 100_000_000, 200_000_000])
    np.testing.assert_array_equal(y.values, [10.0, 20.0, 30.0])
    assert [mode.categories[c] for c in mode.codes] == ["1", "valve_open", "1"]
    assert reading.notes["rows_combined"] == 4
    assert reading.notes["duplicates_dropped"] == 1  # the row of u = 3 gave nothing
    assert "values_superseded" not in reading.notes
    # 33 was on the last row (row 7: line 8 of the CSV) of the table
    assert reading.locate("u", 2) == ("line 8" if suffix == ".csv" else "row 7") + ", column 'u'"
    signals = load(path, sort=True, dt=0.1)
    np.testing.assert_array_equal(signals.inputs[:, 0], [1.0, 2.0, 33.0])
    np.testing.assert_array_equal(signals.outputs[:, 0], [10.0, 20.0, 30.0])
    # a row that gives y but whose u a later row replaces: u's value is counted as replaced
    partial = csv_file(tmp_path, "t,u,y\n0,1,2\n0,3,\n0.1,4,5\n", "partial.csv")
    with TableSource(partial, ReadOptions(sort=True)) as source:
        reading = source.read(["u", "y"])
    np.testing.assert_array_equal(reading.numeric["u"].values, [3.0, 4.0])
    np.testing.assert_array_equal(reading.numeric["y"].values, [2.0, 5.0])
    assert reading.notes == {"rows_combined": 1, "values_superseded": {"u": 1}}


def test_unknown_truth_mode_names_value_line_and_time(tmp_path: Path) -> None:
    path = csv_file(tmp_path, "t,u,y,mode\n0.0,1,1,1\n0.1,1,1,valve_shut\n")
    with pytest.raises(LogError) as info:
        load(path)
    message = str(info.value)
    assert "'valve_shut'" in message
    assert "line 3" in message
    assert "t=0.1 s" in message


def test_mode_ids_are_compared_as_stripped_text(tmp_path: Path) -> None:
    signals = load(csv_file(tmp_path, "t,u,y,mode\n0.0,1,1, 1 \n0.1,1,1,valve_open\n"))
    assert signals.truth_modes is not None
    np.testing.assert_array_equal(signals.truth_modes, [0, 1])
    with pytest.raises(LogError, match=r"'01' at t=0 s is not a mode"):
        load(csv_file(tmp_path, "t,u,y,mode\n0.0,1,1,01\n", name="zero.csv"))


def test_mode_ids_are_compared_in_one_unicode_form(tmp_path: Path) -> None:
    # a log writing é as e + a combining accent was refused as no mode of a model whose id
    # is the precomposed é, the error listing an id that looked the same
    composed, decomposed = "\u00e9", "e\u0301"
    text = f"t,u,y,mode\n0.0,1,1,{decomposed}\n0.1,1,1,1\n0.2,1,1,{composed}\n"
    signals = load(csv_file(tmp_path, text), mode_ids=("1", composed))
    np.testing.assert_array_equal(signals.truth_modes, [1, 0, 1])
    signals = load(csv_file(tmp_path, text, name="other.csv"), mode_ids=("1", decomposed))
    np.testing.assert_array_equal(signals.truth_modes, [1, 0, 1])


@pytest.mark.parametrize(
    ("cells", "modes"),
    [
        (["1.0", "", " 1.0 ", "1"], [0, 0, 0]),  # pandas' integers with a gap (none there)
        (["1e0", "1"], [0, 0]),
    ],
)
def test_whole_numbers_written_as_floats_are_mode_ids(
    tmp_path: Path, cells: list[str], modes: list[int]
) -> None:
    """A CSV mode column of numbers reads as a float column of Parquet or a message field."""
    rows = "".join(f"{0.1 * k:.1f},1,1,{cell}\n" for k, cell in enumerate(cells))
    signals = load(csv_file(tmp_path, "t,u,y,mode\n" + rows), dt=0.1)
    assert signals.truth_modes is not None
    kept = [code for code in signals.truth_modes.tolist() if code >= 0]
    assert kept == modes


@pytest.mark.parametrize(
    ("cells", "label", "line"),
    [
        (["1.0", "valve_open"], "1.0", 2),  # a column of text: as written
        (["1.0", "1.5"], "1.5", 3),
        (["1.0", "nan"], "nan", 3),
        (["1", "1.0", "01"], "01", 4),  # written as an integer: as written
    ],
    ids=["beside text", "beside a fraction", "beside nan", "beside a leading zero"],
)
def test_the_cell_that_names_no_mode_is_named(
    tmp_path: Path, cells: list[str], label: str, line: int
) -> None:
    """A whole number written as a float is a mode id beside cells that are not ids.

    ``1.0`` beside ``1.5`` was read as written, for the column held a number that is not
    whole, and refused as the first bad cell: the error named a valid mode, not the ``1.5``.
    """
    rows = "".join(f"{0.1 * k:.1f},1,1,{cell}\n" for k, cell in enumerate(cells))
    with pytest.raises(LogError, match=rf"line {line}, column 'mode': truth.mode '{label}' at"):
        load(csv_file(tmp_path, "t,u,y,mode\n" + rows), dt=0.1)


def test_a_parquet_boolean_mode_is_0_or_1(tmp_path: Path) -> None:
    """As a ROS ``bool`` or a JSON boolean is; it read ``'true'``, no mode of modes 0 and 1."""
    path = tmp_path / "log.parquet"
    frame = {"t": [0.0, 0.1, 0.2], "u": [1.0] * 3, "y": [1.0] * 3, "mode": [False, True, None]}
    pl.DataFrame(frame).write_parquet(path)
    signals = load(path, dt=0.1, mode_ids=("0", "1"))
    assert signals.truth_modes is not None
    np.testing.assert_array_equal(signals.truth_modes[:2], [0, 1])


def test_a_parquet_text_column_is_no_number(tmp_path: Path) -> None:
    """A Parquet ``String`` mode ``"1.0"`` is text, as a ROS or JSON string is: no mode ``1``."""
    path = tmp_path / "log.parquet"
    frame = {"t": [0.0, 0.1], "u": [1.0, 1.0], "y": [1.0, 1.0], "mode": ["1", "1.0"]}
    pl.DataFrame(frame).write_parquet(path)
    with pytest.raises(LogError, match=r"row 2, column 'mode': truth.mode '1.0' at t=0.1 s"):
        load(path, dt=0.1)


@pytest.mark.parametrize(
    "cells",
    [
        pl.Series("mode", [" b", "a", None, "b ", "", "a", "  ", "c", "b"], dtype=pl.String),
        pl.Series("mode", ["b", "a", None, "b", "c"], dtype=pl.Categorical),
        pl.Series("mode", [2.0, 1.0, None, 2.0, 3.0]),
        pl.Series("mode", [2.5, 1.0, None, 2.5]),
        pl.Series("mode", [None, "", " "], dtype=pl.String),
    ],
    ids=["text", "categorical", "whole floats", "fractional floats", "all empty"],
)
def test_label_columns_read_as_codes_of_their_stripped_labels(
    tmp_path: Path, cells: pl.Series
) -> None:
    """Labels are worked out on distinct values; each row gets the code of its own cell."""
    path = tmp_path / "log.parquet"
    t = np.arange(cells.len()) * 0.1
    pl.DataFrame([pl.Series("t", t), cells]).write_parquet(path)
    with TableSource(path) as source:
        series = source.read([], ["mode"]).labels["mode"]
    # the label of each cell, one at a time: stripped text, empty = none, 2.0 -> "2" (beside
    # 2.5 too, as a message log reads a number)
    floats = cells.dtype.is_float()
    expected = [
        None
        if c is None or not str(c).strip()
        else str(int(c) if floats and c == int(c) else c).strip()
        for c in cells.to_list()
    ]
    kept = [i for i, label in enumerate(expected) if label is not None]
    assert series.categories == tuple(dict.fromkeys(expected[i] for i in kept))
    assert [series.categories[c] for c in series.codes] == [expected[i] for i in kept]
    assert series.codes.dtype == np.int64
    np.testing.assert_array_equal(series.time_ns, np.rint(t[kept] * 1e9).astype(np.int64))


@pytest.mark.parametrize("sort", [False, True])
def test_parquet_columns_read_one_by_one_follow_the_kept_rows(tmp_path: Path, sort: bool) -> None:
    """Numeric Parquet columns are decoded after the rows are known; each lands on its row."""
    t = [0.0, 0.1, 0.3, 0.2, 0.4, 0.4, 0.5] if sort else [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6]
    n = len(t)
    frame = pl.DataFrame(
        {
            "t": t,
            "u": pl.Series(range(10, 10 + n), dtype=pl.Int32),  # cast to Float64
            "y": [float(k) if k != 2 else None for k in range(n)],  # an empty cell
            "mode": ["1", "valve_open"] * (n // 2) + ["1"],
        }
    )
    path = tmp_path / "log.parquet"
    frame.write_parquet(path, row_group_size=2)  # several row groups
    with TableSource(path, ReadOptions(sort=sort)) as source:
        reading = source.read(["u", "y"], ["mode"])
    # the reference: the rows in time order, the last of equal times kept (every column
    # has a value at both rows of t = 0.4: y's empty cell is at row 2)
    order = sorted(range(n), key=lambda k: t[k])
    kept = [k for i, k in enumerate(order) if i + 1 == n or t[order[i + 1]] != t[k]]
    u, y = reading.numeric["u"], reading.numeric["y"]
    assert u.values.dtype == np.float64
    np.testing.assert_array_equal(u.values, [10.0 + k for k in kept])
    np.testing.assert_array_equal(u.time_ns, [round(t[k] * 1e9) for k in kept])
    np.testing.assert_array_equal(y.values, [float(k) for k in kept if k != 2])
    np.testing.assert_array_equal(y.time_ns, [round(t[k] * 1e9) for k in kept if k != 2])
    mode = reading.labels["mode"]
    labels = frame["mode"].to_list()
    assert [mode.categories[c] for c in mode.codes] == [labels[k] for k in kept]
    assert reading.locate("y", 2) == f"row {[k for k in kept if k != 2][2] + 1}, column 'y'"


def test_truth_states_by_column_name(tmp_path: Path) -> None:
    signals = load(csv_file(tmp_path, "t,u,y,x2\n0.0,1,1,7\n0.1,1,1,8\n"))
    assert signals.truth_states is not None
    assert signals.state_names == ("x1", "x2")
    assert np.isnan(signals.truth_states[:, 0]).all()
    np.testing.assert_array_equal(signals.truth_states[:, 1], [7, 8])


# ---------------------------------------------------------------- mapping


def test_missing_output_lists_closest_columns(tmp_path: Path) -> None:
    path = csv_file(tmp_path, "t,u,y_meas,yy,pressure\n0,1,2,3,4\n")
    with pytest.raises(LogError) as info:
        load(path, outputs=("y_mes",))
    message = str(info.value)
    assert "output 'y_mes'" in message
    assert "closest: 'y_meas'" in message
    assert "pressure" not in message


def test_map_overrides_the_default_column(tmp_path: Path) -> None:
    path = csv_file(tmp_path, "t,u,y,level\n0.0,1,10,100\n0.1,2,20,200\n")
    signals = load(path, maps=["y=level"])
    np.testing.assert_array_equal(signals.outputs[:, 0], [100, 200])
    assert signals.output_names == ("y",)


def test_map_to_a_missing_column_lists_closest(tmp_path: Path) -> None:
    path = csv_file(tmp_path, "t,u,y,level\n0.0,1,10,100\n")
    with pytest.raises(LogError, match=r"--map y=levle\): no column 'levle'; closest: 'level'"):
        load(path, maps=["y=levle"])


@pytest.mark.parametrize("time_column", ["t", "time"])
def test_mapping_the_time_column_says_it_is_the_time(tmp_path: Path, time_column: str) -> None:
    """--map u=t: 'no column 't' ... available: u, y', as if the file had no such column."""
    path = csv_file(tmp_path, f"{time_column},u,y\n0.0,1,10\n0.1,2,20\n")
    with pytest.raises(LogError) as info:
        load(path, maps=[f"u={time_column}"])
    assert f"from --map u={time_column}): '{time_column}' is the table's time column" in str(
        info.value
    )
    assert "not a signal; other columns: 'u', 'y'" in str(info.value)
    # a model input named like the time column: its default column is the time
    with pytest.raises(
        LogError,
        match=rf"input '{time_column}' \(column '{time_column}', the default; use --map "
        rf"{time_column}=\.\.\. for another\): '{time_column}' is the table's time column",
    ):
        load(path, inputs=(time_column,))
    # 't' is the time even after 'time' in the header: "the first of 't', 'time' in the
    # header" read as if the header's order chose
    both = csv_file(tmp_path, "time,t,u,y\n5.0,0.0,1,10\n5.1,0.1,2,20\n")
    with pytest.raises(LogError) as info:
        load(both, maps=["u=t"])
    assert "'t' is the table's time column ('t' or, without it, 'time', in seconds)" in str(
        info.value
    )


def test_map_unknown_symbol_is_an_option_error(tmp_path: Path) -> None:
    path = csv_file(tmp_path, GOOD)
    with pytest.raises(OptionError, match=r"unknown symbol 'z'.*u, y, truth.mode, truth.x1"):
        load(path, maps=["z=y"])
    with pytest.raises(OptionError, match="SYMBOL=PATH"):
        load(path, maps=["y"])


def test_map_truth_mode_and_state(tmp_path: Path) -> None:
    path = csv_file(tmp_path, "t,u,y,phase,h1\n0.0,1,1,valve_open,5\n0.1,1,1,1,6\n")
    signals = load(path, maps=["truth.mode=phase", "truth.x1=h1"])
    assert signals.truth_modes is not None and signals.truth_states is not None
    np.testing.assert_array_equal(signals.truth_modes, [1, 0])
    np.testing.assert_array_equal(signals.truth_states[:, 0], [5, 6])


def test_model_signal_paths_apply_only_when_present(tmp_path: Path) -> None:
    path = csv_file(tmp_path, "t,u,y,level\n0.0,1,10,100\n")
    used = load(path, signals={"y": "level"})
    np.testing.assert_array_equal(used.outputs[:, 0], [100])
    ignored = load(path, signals={"y": "/sensor/level.data"})
    np.testing.assert_array_equal(ignored.outputs[:, 0], [10])


# ---------------------------------------------------------------- Parquet


def test_parquet_round_trip(tmp_path: Path) -> None:
    rng = np.random.default_rng(1)
    n = 50
    columns: dict[str, Column] = {
        "t": np.arange(n) * 0.1,
        "u": rng.normal(size=n),
        "y": rng.normal(size=n) * 1e-300,
        "x1": rng.normal(size=n),
        "mode": ["1" if k < 20 else "valve_open" for k in range(n)],
    }
    signals = {}
    for suffix in (".csv", ".parquet"):
        path = write_table(tmp_path / f"log{suffix}", columns)
        signals[suffix] = load(path)
        np.testing.assert_array_equal(signals[suffix].inputs[:, 0], columns["u"])
        np.testing.assert_array_equal(signals[suffix].outputs[:, 0], columns["y"])
        assert signals[suffix].truth_states is not None
        np.testing.assert_array_equal(signals[suffix].truth_states[:, 0], columns["x1"])
        assert signals[suffix].truth_modes is not None
        assert signals[suffix].truth_modes.tolist() == [0] * 20 + [1] * 30
    np.testing.assert_array_equal(signals[".csv"].time, signals[".parquet"].time)


def test_parquet_non_numeric_signal_column(tmp_path: Path) -> None:
    path = tmp_path / "log.parquet"
    pl.DataFrame({"t": [0.0, 0.1], "u": [1.0, 2.0], "y": ["a", "b"]}).write_parquet(path)
    with pytest.raises(
        LogError,
        match=r"log.parquet: output 'y' \(column 'y', the default; .*\): column 'y' has type Str",
    ):
        load(path)


def test_parquet_typed_columns(tmp_path: Path) -> None:
    path = tmp_path / "log.parquet"
    start = datetime(2024, 5, 1, 12, 0, 0)
    pl.DataFrame(
        {
            "time": [start + timedelta(milliseconds=100 * k) for k in range(3)],
            "u": pl.Series([1, 2, 3], dtype=pl.Int32),
            "y": pl.Series([1.5, 2.5, 3.5], dtype=pl.Float32),
            "mode": pl.Series([1, 1, 1], dtype=pl.Int64),
        }
    ).write_parquet(path)
    signals = load(path)
    assert signals.truth_modes is not None
    np.testing.assert_array_equal(signals.truth_modes, [0, 0, 0])
    np.testing.assert_array_equal(signals.inputs[:, 0], [1, 2, 3])
    # Float seconds at Unix-epoch magnitude resolve ~0.2 µs.
    assert signals.time[0] == (start - datetime(1970, 1, 1)).total_seconds()
    np.testing.assert_allclose(np.diff(signals.time), 0.1, atol=1e-6)


def test_parquet_row_numbers_in_messages(tmp_path: Path) -> None:
    path = tmp_path / "log.parquet"
    pl.DataFrame({"t": [0.0, 0.1, 0.05], "u": [1.0] * 3, "y": [1.0] * 3}).write_parquet(path)
    with pytest.raises(LogError, match=r"row 3, column 't': time goes backwards"):
        load(path)


def test_corrupt_parquet(tmp_path: Path) -> None:
    path = tmp_path / "log.parquet"
    path.write_bytes(b"PAR1 this is not parquet")
    with pytest.raises(LogError, match="not a readable Parquet file"):
        load(path)


# ---------------------------------------------------------------- inspect


def test_inspect_reports_columns_rate_and_gaps(tmp_path: Path) -> None:
    times = [0.0, 0.1, 0.2, 0.3, 0.8, 0.9, 1.0]
    lines = ["t,u,y,note"] + [f"{t},{k},{2 * k},n{k}" for k, t in enumerate(times)]
    path = csv_file(tmp_path, "\n".join(lines) + "\n")
    info = inspect_log(path)
    json.dumps(info, allow_nan=False)
    assert info["format"] == "csv"
    assert info["rows"] == 7
    assert info["problems"] == []
    assert info["time"] == {"column": "t", "start": 0.0, "end": 1.0, "duration": 1.0}
    # 7 samples in 1 s: 6 Hz on average, though the median step is 0.1 s
    assert info["sample_time"] == pytest.approx(0.1)
    assert info["rate_hz"] == pytest.approx(6.0)
    assert (info["min_step"], info["max_step"], info["regular"]) == (0.1, 0.5, False)
    assert info["gap_count"] == 1
    assert info["gaps"][0]["start"] == pytest.approx(0.3)
    assert info["gaps"][0]["end"] == pytest.approx(0.8)
    by_name = {c["name"]: c for c in info["columns"]}
    assert by_name["y"] == {
        "name": "y",
        "dtype": "float64",
        "count": 7,
        "nonfinite": 0,
        "min": 0.0,
        "max": 12.0,
        "rate_hz": pytest.approx(6.0),
        "sample_time": pytest.approx(0.1),
        "min_step": pytest.approx(0.1),
        "max_step": pytest.approx(0.5),
        "regular": False,
        "repeated": 0,
        "gap_count": 1,
        "gaps": [{"start": 0.3, "end": 0.8, "duration": pytest.approx(0.5)}],
    }
    assert by_name["note"]["dtype"] == "string"
    assert by_name["note"]["min"] is None
    text = format_inspection(info)
    assert "(1 s), 6 Hz on average" in text
    assert "timing irregular: median step 0.1 s (10 Hz), steps 0.1 s to 0.5 s" in text
    assert "0.3 s to 0.8 s" in text
    assert "note" in text and "string" in text


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_inspect_finds_a_gap_in_one_column(tmp_path: Path, suffix: str) -> None:
    """Empty cells of ``y`` for 3 s in a 10 Hz table: y's gap, though time has none."""
    t = np.arange(100) * 0.1
    y = np.where((t > 3.0) & (t < 6.05), np.nan, t)
    frame = pl.DataFrame({"t": t, "u": t, "y": y}).with_columns(pl.col("y").fill_nan(None))
    path = tmp_path / f"hole{suffix}"
    frame.write_csv(path) if suffix == ".csv" else frame.write_parquet(path)
    info = inspect_log(path)
    assert info["gap_count"] == 0
    by_name = {c["name"]: c for c in info["columns"]}
    assert by_name["u"]["gap_count"] == 0
    assert by_name["y"]["count"] == 70
    assert by_name["y"]["gap_count"] == 1
    assert by_name["y"]["gaps"] == [
        {"start": pytest.approx(3.0), "end": pytest.approx(6.1), "duration": pytest.approx(3.1)}
    ]
    assert by_name["y"]["sample_time"] == pytest.approx(0.1)
    text = format_inspection(info)
    assert "time gaps: none" in text
    assert "  y: 3 s to 6.1 s (3.1 s)" in text
    assert "  u:" not in text
    with pytest.raises(LogError, match="gap"):
        load(path, dt=0.1)


def test_inspect_lists_the_time_gaps_once_not_once_per_column(tmp_path: Path) -> None:
    """A 2 s hole in the time of a table of 20 full columns: each column's gaps are the
    time's, and inspect listed that one gap 21 times; a column with a hole of its own still
    lists its gaps (the time's among them)."""
    t = np.arange(100) * 0.1 + np.where(np.arange(100) >= 50, 2.0, 0.0)
    full = {f"c{i}": t for i in range(20)}
    y = np.where((t > 3.0) & (t < 3.45), np.nan, t)
    frame = pl.DataFrame({"t": t, **full, "y": y}).with_columns(pl.col("y").fill_nan(None))
    path = tmp_path / "hole.csv"
    frame.write_csv(path)
    info = inspect_log(path)
    by_name = {c["name"]: c for c in info["columns"]}
    assert info["gap_count"] == by_name["c7"]["gap_count"] == 1  # the JSON keeps every column's
    lines = format_inspection(info).split("\n")
    assert lines.count("  4.9 s to 7 s (2.1 s)") == 1
    assert not [line for line in lines if line.startswith("  c")]
    assert "  y: 3 s to 3.5 s (0.5 s)" in lines and "  y: 4.9 s to 7 s (2.1 s)" in lines


def test_inspect_describes_a_long_format_table(tmp_path: Path) -> None:
    """A row per signal (times repeat): inspect gave up on time ('time repeats') and showed
    no rate or gap of any column; repeats are counted, as for a topic, and each column timed."""
    rows = [f"{k / 10},{k},\n{k / 10},,{2 * k}\n" for k in range(10)]
    info = inspect_log(csv_file(tmp_path, "t,u,y\n" + "".join(rows)))
    assert info["problems"] == []
    assert info["repeated"] == 10
    by_name = {c["name"]: c for c in info["columns"]}
    for name in ("u", "y"):
        assert by_name[name]["count"] == 10
        assert by_name[name]["rate_hz"] == pytest.approx(10.0)
        assert by_name[name]["regular"] is True
    text = format_inspection(info)
    assert "repeated times: 10 rows at the time of the one before (analyze refuses them" in text
    backwards = inspect_log(csv_file(tmp_path, "t,u\n0.0,1\n0.1,1\n0.05,1\n", "b.csv"))
    assert backwards["time"] is None
    assert "line 4, column 't': time goes backwards" in backwards["problems"][0]


def test_inspect_lists_time_problems_instead_of_failing(tmp_path: Path) -> None:
    path = csv_file(tmp_path, "t,y\n0.0,1\n0.2,nan\n0.1,3\n")
    info = inspect_log(path)
    assert info["time"] is None
    assert len(info["problems"]) == 1
    assert "line 4" in info["problems"][0]
    json.dumps(info, allow_nan=False)
    assert "problems:" in format_inspection(info)


def test_inspect_parquet(tmp_path: Path) -> None:
    path = write_table(tmp_path / "log.parquet", {"t": np.arange(4) * 0.5, "y": np.ones(4)})
    info = inspect_log(path)
    assert info["format"] == "parquet"
    assert info["rate_hz"] == pytest.approx(2.0)
    assert [c["dtype"] for c in info["columns"]] == ["float64", "float64"]


def test_fields_exclude_time(tmp_path: Path) -> None:
    with TableSource(csv_file(tmp_path, GOOD)) as source:
        assert source.fields() == ("u", "y", "mode")
        assert source.time_column == "t"


@pytest.mark.parametrize("text", ["t,u,y\r0.0,1,1\r0.1,1,1\r", "t,u,y\r0.0,1,1\r0.1,1,1"])
def test_carriage_returns_alone_as_line_endings_are_named(tmp_path: Path, text: str) -> None:
    """Classic Mac OS line endings: one line to the csv module, an odd table to polars."""
    path = csv_file(tmp_path, text)
    with pytest.raises(LogError, match=r"line 1: ends in a carriage return alone"):
        load(path)
    with pytest.raises(LogError, match=r"carriage return alone"):
        inspect_log(path)


@pytest.mark.parametrize(
    ("text", "words"),
    [
        # an unclosed quote swallows the rest: it was reported at the end of the file
        (
            't,u,y\n0.0,1,1\n0.1,"1,1\n0.2,1,1\n0.3,1,1\n',
            "line 3: a quoted field runs on to line 5",
        ),
        # a field over two lines shifted every later line number by one
        ('t,u,y\n0.0,1,"1\n"\n0.1,1,x\n', "line 2: a quoted field runs on to line 3"),
    ],
)
def test_a_quoted_field_over_several_lines_names_where_it_starts(
    tmp_path: Path, text: str, words: str
) -> None:
    with pytest.raises(LogError, match=rf"log\.csv, {words}; .* \(an unclosed quote\?\)"):
        load(csv_file(tmp_path, text))


@pytest.mark.parametrize(
    "header",
    ["t, u, y, mode", "t ,u ,y ,mode", " t , u , y , mode ", "t,  u,y,mode"],
)
def test_header_names_are_read_without_the_spaces_around_them(tmp_path: Path, header: str) -> None:
    # Loggers that write "t, u, y" gave the columns " u" and " y", which no user means.
    body = "0.0, 1, 10, 1\n0.1, 2, 20, 1\n0.2, 3, 30, valve_open\n0.3, 4, oops, 1\n"
    path = csv_file(tmp_path, f"{header}\n{body}")
    notes: dict[str, Any] = {}
    with pytest.raises(LogError, match=r"line 5, column 'y': 'oops' is not a number"):
        load(path)
    path.write_text(f"{header}\n{body.replace('oops', '40')}")
    signals = load(path, notes)
    np.testing.assert_array_equal(signals.inputs[:, 0], [1, 2, 3, 4])
    np.testing.assert_array_equal(signals.outputs[:, 0], [10, 20, 30, 40])
    np.testing.assert_array_equal(signals.truth_modes, [0, 0, 1, 0])
    written = header.split(",")
    assert notes["csv_names_stripped"] == [n.strip() for n in written if n != n.strip()]
    assert [c["name"] for c in inspect_log(path)["columns"]] == ["t", "u", "y", "mode"]
    assert load(path, sort=True).n_samples == 4
    assert load(path, signals={"u": "u"}).n_samples == 4

    from hybridlog.report.reading_notes import report_reading_notes

    assert any("CSV header names read without the spaces" in n for n in report_reading_notes(notes))


@pytest.mark.parametrize("header", ['t,"u""x",y,mode', '"t","u""x","y",mode'])
def test_a_quote_written_twice_in_a_header_name_is_one_quote(tmp_path: Path, header: str) -> None:
    # RFC 4180's "u""x" names the column u"x; polars kept both quotes in the name, found no
    # column u"x, and the log was refused: "not a readable CSV file (unable to find column)"
    path = csv_file(tmp_path, f"{header}\n{GOOD.split(chr(10), 1)[1]}")
    assert [c["name"] for c in inspect_log(path)["columns"]] == ["t", 'u"x', "y", "mode"]
    signals = load(path, maps=['u=u"x'])
    np.testing.assert_array_equal(signals.inputs[:, 0], [1, 2, 3, 4])
    np.testing.assert_array_equal(signals.truth_modes, [0, 0, 1, 1])
    path.write_text(path.read_text().replace("0.3,4,40", "0.3,4,oops"))
    with pytest.raises(LogError, match=r"line 5, column 'y': 'oops' is not a number"):
        load(path, maps=['u=u"x'])


@pytest.mark.parametrize("header", ['t,u"x,y,mode', 't,u,y,mode"'])
def test_a_quote_inside_an_unquoted_header_name_is_refused(tmp_path: Path, header: str) -> None:
    # polars opened a quote at u"x that ran to the end of the file: the log read as 0 rows
    # (inspect) or "no data rows" (analyze), with no word of the quote
    path = csv_file(tmp_path, f"{header}\n{GOOD.split(chr(10), 1)[1]}")
    refused = r"line 1: a quote inside a column name that is not quoted \('t,u"
    with pytest.raises(LogError, match=refused):
        inspect_log(path)
    with pytest.raises(LogError, match=refused):
        load(path)


@pytest.mark.parametrize("header", ["t,u,y, y", "t,u , u,y", "t, t,u,y"])
def test_header_names_that_differ_only_in_spaces_are_refused(tmp_path: Path, header: str) -> None:
    path = csv_file(tmp_path, f"{header}\n0,1,2,3\n")
    with pytest.raises(LogError, match=r"line 1: the header's columns '.*' and '.*' differ only"):
        load(path)


@pytest.mark.parametrize("suffix", ["csv", "parquet"])
def test_a_time_column_beside_t_is_said_to_be_passed_over(tmp_path: Path, suffix: str) -> None:
    # both 't' and 'time' (halved): 't' was the time without a word about the other one
    frame = pl.read_csv(csv_file(tmp_path, GOOD)).with_columns(time=pl.col("t") * 0.5)
    path = tmp_path / f"both.{suffix}"
    frame.write_csv(path) if suffix == "csv" else frame.write_parquet(path)
    notes: dict[str, Any] = {}
    np.testing.assert_array_equal(load(path, notes).time, [0.0, 0.1, 0.2, 0.3])
    assert notes["time_columns_passed_over"] == ["t", "time"]
    mapped = load(path, maps=["u=time"])  # still a column like any other
    np.testing.assert_array_equal(mapped.inputs[:, 0], [0.0, 0.05, 0.1, 0.15])

    from hybridlog.report.reading_notes import report_reading_notes

    assert "NOTE: the time is column 't'; 'time' beside it is read as a signal" in "\n".join(
        report_reading_notes(notes)
    )
    alone: dict[str, Any] = {}
    load(csv_file(tmp_path, GOOD), alone)
    assert "time_columns_passed_over" not in alone
