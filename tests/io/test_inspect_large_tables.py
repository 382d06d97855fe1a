"""``inspect`` reads a CSV log a block of lines at a time, not whole as text.

Read whole, every cell a polars string, a 1.3 GB CSV of 10^7 rows peaked at 4.1 GB and a
2.2 GB one of 300 columns at 6.2 GB; a block at a time, 0.57 GB and 0.27 GB, with the same
description (:mod:`hybridlog.io.csv_tally`).  The peak is measured here as the process's
high-water mark of resident memory, reset before ``inspect`` (Linux).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hybridlog.io import csv_tally
from hybridlog.io.inspect import inspect_log
from hybridlog.polars_import import pl

CLEAR_REFS = Path("/proc/self/clear_refs")


def peak_rss() -> int:
    """The process's high-water mark of resident memory, in bytes."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) * 1024
    raise AssertionError("no VmHWM")


@pytest.mark.skipif(not CLEAR_REFS.exists(), reason="needs Linux's /proc/self/clear_refs")
def test_inspect_of_a_csv_log_holds_a_block_of_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    rows = 250_000
    rng = np.random.default_rng(0)
    columns = {"t": np.arange(rows) * 0.01}
    columns.update({f"y{i}": rng.normal(size=rows) for i in range(8)})
    log = tmp_path / "large.csv"
    pl.DataFrame(columns).write_csv(log)
    size = log.stat().st_size  # 42 MB
    monkeypatch.setattr(csv_tally, "CSV_BYTES_AT_ONCE", 1 << 20)
    small = tmp_path / "small.csv"
    small.write_text("t,y\n0,1\n1,2\n")
    inspect_log(small)  # imports and polars' threads before the measurement
    CLEAR_REFS.write_text("5")  # the high-water mark starts again from what is resident
    before = peak_rss()
    info = inspect_log(log)
    grown = peak_rss() - before
    assert info["rows"] == rows
    assert info["columns"][1]["count"] == rows
    # whole, as text: 3.8 times the file's size; a block at a time, two thirds of it (the
    # times and each column's in turn, polars' threads)
    assert grown < size, (grown, size)


def test_blocks_of_a_few_lines_describe_the_log_as_one_block(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    log = tmp_path / "odd.csv"
    log.write_text(
        "t, u,y,flag,name\n"
        "0,1,,true,a\n"
        "\n"
        "1,inf,2,False,\n"
        "  ,,,,\n"
        "2,9007199254740993,,,b\n"
        "3,nan,4,TRUE,c\n"
        "7,1e400,5,false,d\n"
    )
    whole = inspect_log(log)
    monkeypatch.setattr(csv_tally, "CSV_BYTES_AT_ONCE", 5)
    assert inspect_log(log) == whole
    assert whole["rows"] == 5  # the blank lines are no rows
    u, y, flag, name = whole["columns"][1:]
    assert (u["dtype"], u["count"], u["nonfinite"], u["min"], u["max"]) == (
        "float64",
        5,
        3,
        1.0,
        9007199254740992.0,
    )
    assert (y["count"], y["gap_count"], flag["dtype"], name["dtype"]) == (3, 0, "boolean", "string")
    assert whole["problems"] == [
        "line 6, column 'u': 9007199254740993 is an integer beyond 2^53, which a float64 "
        "cannot hold (it would read as 9007199254740992)"
    ]
