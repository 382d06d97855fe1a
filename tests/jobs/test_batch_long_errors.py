"""A log's error longer than a summary cell keeps its end: what is wrong.

Errors were cut at 300 characters from the start; an error starts with the log's path (and
often the report folder's), so for a log with a long name what was left read
``.../aaaa…aaa.csv: the name 'aaaa…aaa.csv' is to…``.  Now the middle is cut.
"""

from __future__ import annotations

from pathlib import Path

from hybridlog.io.writers import write_table
from hybridlog.jobs.batch import run_batch
from tests.support.logfiles import tank_run


def test_a_long_error_keeps_its_reason(tmp_path: Path) -> None:
    logs = tmp_path / "logs"
    logs.mkdir()
    # too long a name for hybridlog to write, a log recorded by something else
    write_table(logs / "long.csv", tank_run(steps=20, seed=1).columns).rename(
        logs / ("a" * 251 + ".csv")
    )
    write_table(logs / "ok.csv", tank_run(steps=20, seed=2).columns)
    outcome = run_batch([logs], "three_tank_hstf", out_dir=tmp_path / "out", estimator="imm")
    failed = outcome.logs[0]
    assert failed.status == "failed"
    assert failed.error is not None
    assert len(failed.error) <= 300
    assert failed.error.endswith("bytes here)")
    assert "is too long" in failed.error
    assert outcome.logs[1].status == "done"


def test_a_long_reason_behind_a_long_path_is_kept_whole() -> None:
    from hybridlog.jobs.batch_outcomes import error_line

    reason = "the reason, " + "x" * 170 + " (the end)"
    line = error_line("/logs/" + "p" * 400 + ".csv: " + reason)
    assert len(line) <= 300 and line.startswith("/logs/ppp") and "…" in line
    assert line.endswith(reason)  # the end kept 99 characters: half of this reason
