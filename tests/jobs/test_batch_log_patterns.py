"""A log path that names no file but holds ``*``, ``?`` or ``[``: a pattern no shell expanded.

``hybridlog batch 'logs/*.csv'`` (quoted) failed as one log named ``*.csv`` with "No such
file or directory" only; it still fails as that log, and its error now says why.
"""

from __future__ import annotations

from pathlib import Path

from hybridlog.io.writers import write_table
from hybridlog.jobs.batch import run_batch
from tests.support.logfiles import tank_run

HINT = "a pattern the shell did not expand (quoted, or it matched nothing)?"


def test_a_pattern_no_shell_expanded_fails_as_its_log_with_a_hint(tmp_path: Path) -> None:
    logs = tmp_path / "logs"
    write_table(logs / "s1.csv", tank_run(steps=20, seed=1).columns)
    # a file whose name holds brackets is a log like any other
    bracketed = write_table(logs / "run[1].csv", tank_run(steps=20, seed=2).columns)
    given = [logs / "*.csv", logs / "s?.parquet", bracketed, logs / "gone.csv"]
    outcome = run_batch(given, "three_tank_hstf", out_dir=tmp_path / "out", estimator="imm")
    by_log = {Path(o.log).name: o for o in outcome.logs}
    for pattern in ("*.csv", "s?.parquet"):
        assert by_log[pattern].status == "failed"
        error = by_log[pattern].error or ""
        assert "No such file or directory" in error and HINT in error
        assert error.endswith("give it unquoted, or give the folder of logs")
    assert by_log["run[1].csv"].status == "done"
    missing = by_log["gone.csv"]
    assert missing.status == "failed" and HINT not in (missing.error or "")
    assert HINT in (tmp_path / "out" / "summary.md").read_text()
