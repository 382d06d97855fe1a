"""summary.csv and comparison.csv, written with :mod:`csv`, read back by polars as written.

The batch process writes summary.csv without polars (:func:`write_summary_csv`); what a
user's polars (or any CSV reader) reads must be the values given: text with commas,
quotes and line breaks (a carriage return too), integers, floats of every size and the
non-finite ones, booleans, and missing cells.
"""

from __future__ import annotations

import csv
import math
import tempfile
from pathlib import Path

import polars as pl
from hypothesis import given, settings
from hypothesis import strategies as st

from hybridlog.report.summary_tables import write_summary_csv

TEXT = st.text(alphabet=st.sampled_from("abcXYZ019 ,;\"'\n\r\té…"), min_size=1, max_size=12).filter(
    lambda s: s.strip() == s and s.strip()
)  # an empty cell is a missing value
KINDS = {
    "text": (TEXT, pl.String),
    "int": (st.integers(-(2**62), 2**62), pl.Int64),
    "float": (st.floats(allow_nan=True, allow_infinity=True), pl.Float64),
    "bool": (st.booleans(), pl.Boolean),
}


@st.composite
def tables(draw: st.DrawFn) -> tuple[list[str], list[str], list[list[object]]]:
    # two columns at least: a row of one missing cell would be an empty line
    kinds = draw(st.lists(st.sampled_from(sorted(KINDS)), min_size=2, max_size=5))
    header = [f"c{k}_{kind}" for k, kind in enumerate(kinds)]
    count = draw(st.integers(1, 8))
    rows = [[draw(st.none() | KINDS[kind][0]) for kind in kinds] for _ in range(count)]
    return header, kinds, rows


def _same(read: object, given: object) -> bool:
    if isinstance(given, float) and math.isnan(given):
        return isinstance(read, float) and math.isnan(read)
    return read == given


@settings(max_examples=200, deadline=None)
@given(tables())
def test_polars_reads_back_what_was_written(
    table: tuple[list[str], list[str], list[list[object]]],
) -> None:
    header, kinds, rows = table
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "summary.csv"
        write_summary_csv(path, header, rows)
        schema = {name: KINDS[kind][1] for name, kind in zip(header, kinds, strict=True)}
        frame = pl.read_csv(path, schema=schema)
    assert frame.columns == header
    assert frame.height == len(rows)
    for k, name in enumerate(header):
        column = frame[name].to_list()
        for row, read in zip(rows, column, strict=True):
            assert _same(read, row[k]), (name, read, row[k])


def test_cells_as_written(tmp_path: Path) -> None:
    path = tmp_path / "summary.csv"
    rows: list[list[object]] = [["a,b", 300, 1e-05, None, True, float("nan"), -math.inf]]
    write_summary_csv(path, ["log", "samples", "mse", "vaf", "ok", "x", "y"], rows)
    assert path.read_text(encoding="utf-8") == (
        'log,samples,mse,vaf,ok,x,y\n"a,b",300,1e-05,,true,NaN,-inf\n'
    )


def test_a_carriage_return_is_quoted(tmp_path: Path) -> None:
    # csv.writer quotes only the characters of its own line end: with "\n" a log named
    # "a\rb.csv" was written bare, and every reader split its row in two
    path = tmp_path / "summary.csv"
    write_summary_csv(path, ["log", "folder"], [["/logs/a\rb.csv", "a\rb.csv"], ["c.csv", "c.csv"]])
    text = path.read_bytes().decode("utf-8")
    assert text == 'log,folder\n"/logs/a\rb.csv","a\rb.csv"\nc.csv,c.csv\n'
    with path.open(encoding="utf-8", newline="") as file:
        assert list(csv.reader(file)) == [
            ["log", "folder"],
            ["/logs/a\rb.csv", "a\rb.csv"],
            ["c.csv", "c.csv"],
        ]
    assert pl.read_csv(path)["log"].to_list() == ["/logs/a\rb.csv", "c.csv"]
