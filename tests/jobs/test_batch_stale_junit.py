"""The JUnit file of a batch folder's previous run is withdrawn by a run that does not write it.

Before, ``batch ... --junit j.xml`` and then ``batch ...`` (without ``--junit``, or with
another file) left ``j.xml`` as it was: the previous run's cases and passed gates, which a
CI step publishing ``j.xml`` presented as the current run's, beside summaries of another.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from hybridlog.jobs.batch import run_batch
from tests.jobs.test_batch_resume import write_logs

TANK = "three_tank_hstf"


def _batch(logs: list[Path], out: Path, junit: Path | None) -> list[str]:
    return run_batch(logs, TANK, out_dir=out, estimator="imm", junit=junit).notes


def test_a_run_without_junit_removes_the_previous_runs_file(tmp_path: Path) -> None:
    logs = write_logs(tmp_path / "logs", ["s1.csv"], steps=20)
    out, junit = tmp_path / "out", tmp_path / "ci" / "junit.xml"
    junit.parent.mkdir()
    _batch(logs, out, junit)
    assert junit.is_file()

    notes = _batch(logs, out, None)

    assert not junit.exists() and not (junit.parent / ".junit.xml.hybridlog").exists()
    assert notes == [
        f"removed '{junit}', the JUnit file of the previous run into --out (its results "
        "would read as this run's); this run writes none"
    ]
    assert _batch(logs, out, None) == []  # said once


def test_another_junit_file_replaces_it_and_the_users_own_stays(tmp_path: Path) -> None:
    logs = write_logs(tmp_path / "logs", ["s1.csv"], steps=20)
    out, first, second = tmp_path / "out", tmp_path / "a.xml", tmp_path / "b.xml"
    _batch(logs, out, first)
    assert "this run writes --junit" in _batch(logs, out, second)[0]
    assert not first.exists() and second.is_file()
    with second.open("a", encoding="utf-8") as file:
        file.write("<!-- the user's -->\n")  # edited: the user's now, never removed
    assert _batch(logs, out, None) == []
    assert second.read_text(encoding="utf-8").endswith("<!-- the user's -->\n")


def test_a_copy_of_the_batch_folder_removes_only_its_own_file(tmp_path: Path) -> None:
    """A JUnit file inside the batch folder is the copy's own; one outside is the original's."""
    logs = write_logs(tmp_path / "logs", ["s1.csv"], steps=20)
    for junit in (tmp_path / "out" / "junit.xml", tmp_path / "junit.xml"):
        out = tmp_path / "out"
        _batch(logs, out, junit)
        copy = tmp_path / "copy"
        shutil.copytree(out, copy, symlinks=True)
        notes = _batch(logs, copy, None)
        inside = junit.parent == out
        assert (copy / "junit.xml").exists() is False
        assert junit.is_file()  # the original's, in either case
        assert bool(notes) is inside
        shutil.rmtree(copy)
        shutil.rmtree(out)
        junit.unlink(missing_ok=True)
