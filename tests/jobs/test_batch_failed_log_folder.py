"""A log that fails in a batch keeps no report of an earlier run in the batch folder.

Before, a log whose earlier run succeeded (another content of the log, other ``--set``
values, a model since edited) and that failed in this run kept its old folder: the batch
folder, and the CI artifact made of it, held a report.md with numbers beside a summary that
said the log failed.  Now that folder is removed, unless removing it would lose something
(a file edited since hybridlog wrote it, a folder of another estimator's).
"""

from __future__ import annotations

import csv
from pathlib import Path

from hybridlog.io.writers import write_table
from hybridlog.jobs.batch import run_batch
from tests.jobs.test_batch_resume_intact import _logs, _statuses
from tests.support.logfiles import tank_run


def test_a_log_that_fails_now_loses_its_earlier_report(tmp_path: Path) -> None:
    logs = _logs(tmp_path / "logs")
    out = tmp_path / "out"
    assert set(_statuses(logs, out).values()) == {"done"}
    logs[1].write_text("t,unrelated\n0,1\n", encoding="utf-8")  # now it cannot be analysed

    assert _statuses(logs, out) == {"s1.csv": "skipped", "s2.csv": "failed", "s3.csv": "skipped"}

    assert not (out / "s2.csv").exists()
    assert sorted(p.name for p in out.iterdir() if p.name.startswith(".s2")) == []
    assert (out / "s1.csv" / "report.json").is_file() and (out / "s3.csv" / "report.json").is_file()
    with (out / "summary.csv").open(encoding="utf-8", newline="") as handle:
        rows = {row["log"]: row for row in csv.DictReader(handle)}
    assert rows[str(logs[1])]["status"] == "failed" and rows[str(logs[1])]["folder"] == ""


def test_an_earlier_report_holding_an_edit_is_kept(tmp_path: Path) -> None:
    logs = _logs(tmp_path / "logs")
    out = tmp_path / "out"
    _statuses(logs, out)
    notes = out / "s2.csv" / "report.md"
    notes.write_text(notes.read_text(encoding="utf-8") + "\nmy notes\n", encoding="utf-8")
    logs[1].write_text("t,unrelated\n0,1\n", encoding="utf-8")

    assert _statuses(logs, out)["s2.csv"] == "failed"

    assert notes.read_text(encoding="utf-8").endswith("my notes\n")


def test_a_failed_log_leaves_no_empty_folder_above_its_report(tmp_path: Path) -> None:
    # logs/d2/deep/bad.csv failed: out/d2/deep/ was made for its report and stayed, empty
    logs = tmp_path / "logs"
    good = write_table(logs / "d1" / "good.csv", tank_run(steps=30, seed=1).columns)
    (logs / "d2" / "deep").mkdir(parents=True)
    bad = logs / "d2" / "deep" / "bad.csv"
    bad.write_text("t,unrelated\n0,1\n", encoding="utf-8")
    (logs / "d3").mkdir()
    other = write_table(logs / "d3" / "ok.csv", tank_run(steps=30, seed=2).columns)
    (logs / "d3" / "bad.csv").write_text("t,unrelated\n0,1\n", encoding="utf-8")
    out = tmp_path / "out"

    outcome = run_batch([logs], "three_tank_hstf", out_dir=out, estimator="imm")

    statuses = {Path(o.log).relative_to(logs).as_posix(): o.status for o in outcome.logs}
    assert statuses == {
        "d1/good.csv": "done",
        "d2/deep/bad.csv": "failed",
        "d3/bad.csv": "failed",
        "d3/ok.csv": "done",
    }
    assert not (out / "d2").exists()
    assert (out / "d1" / "good.csv" / "report.json").is_file()
    assert (out / "d3" / "ok.csv" / "report.json").is_file()  # a folder holding a report stays
    assert not (out / "d3" / "bad.csv").exists()
    assert good.is_file() and other.is_file()
