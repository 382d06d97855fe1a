"""Report folders of logs not in the batch are named, not passed off as this run's.

A log renamed since an earlier run into the same ``--out`` kept its old report folder (as it
should: a run over part of the logs must not lose the others'), but nothing said so:
summary.md listed the logs of this run only, and the old folder's report.md read as one of
them to whoever opened the batch folder or its CI artifact.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import hybridlog.jobs.batch_outcomes as batch_outcomes
from hybridlog.errors import excerpt
from hybridlog.jobs.batch import run_batch
from hybridlog.jobs.batch_others import other_folders
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
    assert [o.name for o in other_folders(Path("out"), [Path(o.folder) for o in again.logs])] == [
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


def test_a_log_is_never_written_into_the_report_of_a_log_renamed_since(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``runs/b.csv`` became a folder of logs: their reports would go inside ``out/b.csv``."""
    monkeypatch.chdir(tmp_path)
    write_logs(Path("runs"), ["a.csv", "b.csv"], steps=10)
    run_batch(["runs"], TANK, out_dir="out")
    old = sorted(p.name for p in Path("out/b.csv").iterdir())
    Path("runs/b.csv").unlink()
    write_logs(Path("runs/b.csv"), ["c.csv"], steps=10, first_seed=3)
    write_logs(Path("runs/b.csv/deep"), ["d.csv"], steps=10, first_seed=4)

    again = run_batch(["runs"], TANK, out_dir="out")

    outcomes = {o.log: o for o in again.logs}
    assert outcomes["runs/a.csv"].status == "skipped"
    for log in ("runs/b.csv/c.csv", "runs/b.csv/deep/d.csv"):
        assert outcomes[log].status == "failed"
        error = outcomes[log].error
        assert error is not None and error.startswith("report folder '")
        assert error.endswith(
            "/out/b.csv', the report an earlier run wrote for another log (since renamed or "
            "moved, or left out); move that folder out of --out, or choose another --out"
        )
    assert sorted(p.name for p in Path("out/b.csv").iterdir()) == old  # nothing put in it
    assert again.notes[-1].startswith("--out holds a report folder of logs not in this batch")


def test_a_file_where_a_logs_folder_would_be_made_fails_that_log_alone(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Before, the whole batch was refused: "cannot create output directory out: File exists"."""
    monkeypatch.chdir(tmp_path)
    write_logs(Path("runs"), ["a.csv"], steps=10)
    run_batch(["runs"], TANK, out_dir="out")
    write_logs(Path("runs/deep"), ["c.csv"], steps=10, first_seed=3)
    Path("out/deep").write_text("mine\n")

    outcome = run_batch(["runs"], TANK, out_dir="out")

    assert {o.log: o.status for o in outcome.logs} == {
        "runs/a.csv": "skipped",
        "runs/deep/c.csv": "failed",
    }
    assert outcome.logs[1].error == (
        f"{tmp_path}/out/deep/c.csv: cannot be created: {tmp_path}/out/deep is not a folder"
    )
    assert Path("out/deep").read_text() == "mine\n"


def test_a_logs_folder_holding_the_report_of_a_log_moved_since_names_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``runs/deep/`` became a bag: its folder ``out/deep`` holds ``deep/c.csv``'s report.

    It was refused as holding "files hybridlog did not write".
    """
    monkeypatch.chdir(tmp_path)
    write_logs(Path("runs"), ["a.csv"], steps=10)
    write_logs(Path("runs/deep"), ["c.csv"], steps=10, first_seed=3)
    run_batch(["runs"], TANK, out_dir="out")
    Path("runs/deep/c.csv").rename("runs/c.csv")
    Path("runs/deep/metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
    monkeypatch.setattr(batch_outcomes, "_ERROR_LIMIT", 1000)  # pytest's folders: not cut

    again = run_batch(["runs"], TANK, out_dir="out")

    bag = next(o for o in again.logs if o.log == "runs/deep")
    assert bag.status == "failed"
    assert bag.error == (
        f"report folder {excerpt(f'{tmp_path}/out/deep')} holds "
        f"{excerpt(f'{tmp_path}/out/deep/c.csv')}, the report an earlier run wrote for "
        "another log (since renamed or moved, or left out); move that folder out of --out, "
        "or choose another --out"
    )
    assert Path("out/deep/c.csv/report.json").is_file()
