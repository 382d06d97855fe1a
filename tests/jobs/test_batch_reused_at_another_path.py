"""A report reused for a log now at another path is said to name the earlier path.

A log is skipped by its content, wherever it lies (a batch folder restored elsewhere must
resume, not redo every log), so after ``logs`` was renamed ``logs_b`` its report was reused
as it should be; but that report's title and report.json's ``log`` still named
``logs/r1.csv`` while summary.md/.csv named ``logs_b/r1.csv``, and nothing said why.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from hybridlog.jobs.batch import run_batch
from tests.jobs.test_batch_resume import write_logs

TANK = "three_tank_hstf"


def test_a_report_made_from_the_log_at_another_path_is_named(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    write_logs(Path("logs"), ["r1.csv", "r2.csv"], steps=10)
    run_batch(["logs"], TANK, out_dir="out", estimator="imm")
    Path("logs").rename("logs_b")

    again = run_batch(["logs_b"], TANK, out_dir="out", estimator="imm")

    assert [o.status for o in again.logs] == ["skipped", "skipped"]  # not redone
    assert json.loads(Path("out/r1.csv/report.json").read_text())["log"] == "logs/r1.csv"
    assert again.notes == [
        "2 logs were skipped, their content the one an earlier run analysed at another path "
        "('logs_b/r1.csv' read as 'logs/r1.csv', 'logs_b/r2.csv' read as 'logs/r2.csv'): "
        "their reused report.md and report.json name that path; remove a report folder to "
        "redo its log under its path now (summary.md lists them)"
    ]
    summary = Path("out/summary.md").read_text()
    assert summary.endswith(
        "\n## Reports made from the log at another path (2)\n\n"
        "Unchanged since an earlier run analysed them at another path, so their reports were "
        "reused: report.md and report.json name that path.\n\n"
        "- logs_b/r1.csv: read as logs/r1.csv\n"
        "- logs_b/r2.csv: read as logs/r2.csv\n"
    )
    # the same path spelled otherwise is the same path
    Path("logs_b").rename("logs")
    same = run_batch(["./logs/r1.csv", "logs/r2.csv"], TANK, out_dir="out", estimator="imm")
    assert [o.status for o in same.logs] == ["skipped", "skipped"] and same.notes == []


def test_a_log_given_by_its_absolute_path_is_not_at_another_path(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # logs/r1.csv then, /tmp/.../logs/r1.csv now: the same file, and the report names it
    monkeypatch.chdir(tmp_path)
    write_logs(Path("logs"), ["r1.csv"], steps=10)
    run_batch(["logs"], TANK, out_dir="out", estimator="imm")

    again = run_batch([str(tmp_path / "logs")], TANK, out_dir="out", estimator="imm")

    assert [o.status for o in again.logs] == ["skipped"] and again.notes == []
    assert "another path" not in Path("out/summary.md").read_text()
