"""A log path that names no file but holds ``*``, ``?`` or ``[``: a pattern no shell expanded.

``hybridlog batch 'logs/*.csv'`` (quoted) failed as one log named ``*.csv`` with "No such
file or directory" only; it still fails as that log, and its error now says why.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hybridlog.errors import OptionError
from hybridlog.io.writers import write_table
from hybridlog.jobs.batch import run_batch
from hybridlog.jobs.batch_logs import batch_logs
from hybridlog.jobs.batch_names import folder_names
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
        assert f"{pattern}: no such file; " in error and HINT in error  # as analyze says it
        assert error.endswith("give it unquoted, or give the folder of logs")
    assert by_log["run[1].csv"].status == "done"
    missing = by_log["gone.csv"]
    assert missing.status == "failed" and HINT not in (missing.error or "")
    assert HINT in (tmp_path / "out" / "summary.md").read_text()


def test_a_log_found_twice_names_the_arguments_that_hold_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``batch nest nest/sub`` said "log 'nest/sub/b.csv' is given twice", a name never typed."""
    monkeypatch.chdir(tmp_path)  # short relative paths, quoted whole
    (tmp_path / "nest" / "sub").mkdir(parents=True)
    for name in ("a.csv", "sub/b.csv"):
        (tmp_path / "nest" / name).write_bytes(b"")

    def refusal(*given: str) -> str:
        with pytest.raises(OptionError) as raised:
            folder_names(*batch_logs(given)[:2])
        return str(raised.value)

    assert refusal("nest", "nest/sub") == (
        "log 'nest/sub/b.csv' is given twice (in the folders of logs 'nest' and 'nest/sub'); "
        "give it once"
    )
    assert refusal("nest/sub/b.csv", "nest") == (
        "log 'nest/sub/b.csv' is given twice (as itself, and in the folder of logs 'nest'); "
        "give it once"
    )
    assert refusal("nest", "nest").endswith(
        "is given twice (the folder of logs 'nest' is given twice); give it once"
    )
    assert refusal("nest/a.csv", "nest/a.csv") == "log 'nest/a.csv' is given twice"
