"""Line 1 of a CSV log is read to a bounded length, and the csv module's error is a LogError.

A file named ``.csv`` with no line end in its first megabytes (a binary file, an image of
zeros) was read whole as its header line, taking 2.3 times its size in memory, and ended in
the :mod:`csv` module's "field larger than field limit": ``analyze`` said "unexpected Error",
and a batch's log failed as "Error: field larger than field limit (131072)".
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hybridlog.errors import LogError
from hybridlog.io.csv_header import header_names
from hybridlog.io.writers import write_table
from hybridlog.jobs.batch import run_batch
from tests.support.logfiles import tank_run


def test_a_file_without_a_line_end_is_refused_after_its_first_megabyte(tmp_path: Path) -> None:
    log = tmp_path / "zeros.csv"
    with log.open("wb") as handle:
        handle.truncate(3 << 20)  # sparse: zeros
    with pytest.raises(LogError, match=r"zeros\.csv, line 1: no line end in its first 1,048,576"):
        header_names(log)


def test_a_column_name_past_the_csv_modules_limit_is_named_as_line_1(tmp_path: Path) -> None:
    log = tmp_path / "wide.csv"
    log.write_text("t," + "u" * 200_000 + "\n0,1\n", encoding="utf-8")
    with pytest.raises(LogError, match=r"wide\.csv, line 1: cannot be read as a CSV header"):
        header_names(log)


def test_in_a_batch_it_fails_that_log_alone_saying_why(tmp_path: Path) -> None:
    logs = tmp_path / "logs"
    logs.mkdir()
    write_table(logs / "ok.csv", tank_run(steps=30, seed=1).columns)
    with (logs / "zeros.csv").open("wb") as handle:
        handle.truncate(3 << 20)

    outcome = run_batch([logs], "three_tank_hstf", out_dir=tmp_path / "out", estimator="imm")

    status = {Path(o.log).name: (o.status, o.error or "") for o in outcome.logs}
    assert status["ok.csv"][0] == "done"
    assert status["zeros.csv"][0] == "failed"
    assert "line 1: no line end in its first" in status["zeros.csv"][1]
