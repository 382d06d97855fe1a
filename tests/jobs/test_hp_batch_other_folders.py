"""Report folders of logs not in the batch are named, not passed off as this run's.

A log renamed since an earlier run into the same ``--out`` kept its old report folder (as it
should: a run over part of the logs must not lose the others'), but nothing said so:
summary.md listed the logs of this run only, and the old folder's report.md read as one of
them to whoever opened the batch folder or its CI artifact.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hybridlog.jobs.batch import other_report_folders, run_batch
from tests.jobs.test_batch_resume import write_logs

TANK = "three_tank_hstf"


def test_a_renamed_logs_old_folder_is_kept_and_named(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    write_logs(Path("runs"), ["a.csv", "b.csv"], steps=10)
    write_logs(Path("runs/deep"), ["c.csv"], steps=10, first_seed=3)
    first = run_batch(["runs"], TANK, out_dir="out")
    assert first.notes == []
    assert "Other report folders" not in Path("out/summary.md").read_text()
    Path("runs/b.csv").rename("runs/b2.csv")
    Path("runs/deep/c.csv").rename("runs/c.csv")
    Path("runs/a.csv").write_text("t,u\n0,1\n")  # fails now: its folder is its own
    again = run_batch(["runs"], TANK, out_dir="out")
    assert {Path(o.log).name: o.status for o in again.logs} == {
        "a.csv": "failed",
        "b2.csv": "done",
        "c.csv": "done",
    }
    assert other_report_folders(Path("out"), [Path(o.folder) for o in again.logs]) == [
        "b.csv",
        "deep/c.csv",
    ]
    assert again.notes == [
        "--out holds 2 report folders of logs not in this batch ('b.csv', 'deep/c.csv'; "
        "renamed, moved or left out since an earlier run): kept, and not in its summaries"
    ]
    assert Path("out/b.csv/report.json").is_file()  # kept
    summary = Path("out/summary.md").read_text()
    assert "\n## Other report folders (2)\n" in summary
    assert summary.rstrip().splitlines()[-2:] == ["- b.csv", "- deep/c.csv"]
