"""A resumed batch reuses a log's report only while its folder is as hybridlog wrote it.

Before, a folder whose provenance matched was skipped whatever became of its files: a deleted
timeline.csv stayed missing under "skipped (unchanged)", and a report.json whose VAF was
raised by hand put that VAF into summary.csv and passed the gate on it.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

from hybridlog.io.writers import write_table
from hybridlog.jobs.batch import run_batch
from tests.support.logfiles import tank_run

TANK = "three_tank_hstf"


def _logs(folder: Path) -> list[Path]:
    folder.mkdir()
    return [
        write_table(folder / f"s{k}.csv", tank_run(steps=30, seed=k).columns) for k in (1, 2, 3)
    ]


def _statuses(logs: list[Path], out: Path, **options: object) -> dict[str, str]:
    outcome = run_batch(logs, TANK, out_dir=out, estimator="imm", **options)
    return {Path(o.log).name: o.status for o in outcome.logs}


def test_a_report_folder_missing_a_file_is_redone(tmp_path: Path) -> None:
    logs = _logs(tmp_path / "logs")
    out = tmp_path / "out"
    assert set(_statuses(logs, out, plots="all").values()) == {"done"}
    (out / "s1.csv" / "timeline.csv").unlink()
    next((out / "s3.csv" / "plots").glob("*.png")).unlink()
    assert _statuses(logs, out, plots="all") == {
        "s1.csv": "done",
        "s2.csv": "skipped",
        "s3.csv": "done",
    }
    assert (out / "s1.csv" / "timeline.csv").is_file()


def test_an_edited_report_is_never_reused_for_the_summary_or_the_gates(tmp_path: Path) -> None:
    logs = _logs(tmp_path / "logs")
    out = tmp_path / "out"
    first = run_batch(logs, TANK, out_dir=out, estimator="imm", fail_under=["vaf=99"])
    assert len(first.gate_failures) == 3
    report = out / "s2.csv" / "report.json"
    data = json.loads(report.read_text(encoding="utf-8"))
    data["vaf"] = 99.5
    report.write_text(json.dumps(data), encoding="utf-8")

    again = run_batch(logs, TANK, out_dir=out, estimator="imm", fail_under=["vaf=99"])

    s2 = next(o for o in again.logs if Path(o.log).name == "s2.csv")
    assert s2.status == "failed"
    assert s2.error is not None and "changed since hybridlog wrote them" in s2.error
    with (out / "summary.csv").open(encoding="utf-8", newline="") as file:
        rows = {Path(row["log"]).name: row for row in csv.DictReader(file)}
    assert rows["s2.csv"]["status"] == "failed"
    assert rows["s2.csv"]["vaf"] == ""
    assert json.loads(report.read_text(encoding="utf-8"))["vaf"] == 99.5  # the user's, kept


def test_a_folder_whose_marker_is_gone_is_still_reused(tmp_path: Path) -> None:
    """Hidden files left out (a CI artifact): nothing to check against, reused as before."""
    logs = _logs(tmp_path / "logs")
    out = tmp_path / "out"
    assert set(_statuses(logs, out).values()) == {"done"}
    (out / "s1.csv" / ".hybridlog").unlink()
    assert _statuses(logs, out)["s1.csv"] == "skipped"


def test_a_folder_without_its_marker_that_lost_a_table_is_not_skipped(tmp_path: Path) -> None:
    # "skipped" with its timeline gone: the files every report has are still asked for
    logs = _logs(tmp_path / "logs")
    out = tmp_path / "out"
    assert set(_statuses(logs, out, table_format="parquet").values()) == {"done"}
    for name in ("s1.csv", "s2.csv"):
        (out / name / ".hybridlog").unlink()
    (out / "s2.csv" / "timeline.parquet").unlink()
    outcome = run_batch(logs, TANK, out_dir=out, estimator="imm", table_format="parquet")
    s1, s2, s3 = outcome.logs
    assert (s1.status, s3.status) == ("skipped", "skipped")
    # nothing to tell its files from the user's: failed, naming the folder, nothing replaced
    assert s2.status == "failed" and s2.error is not None
    assert "does not list what hybridlog wrote there" in s2.error
    assert (out / "s2.csv" / "report.json").is_file()
