"""The JUnit file of a batch folder's previous run is withdrawn by a run that does not write it.

Before, ``batch ... --junit j.xml`` and then ``batch ...`` (without ``--junit``, or with
another file) left ``j.xml`` as it was: the previous run's cases and passed gates, which a
CI step publishing ``j.xml`` presented as the current run's, beside summaries of another.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from types import SimpleNamespace

import pytest

from hybridlog.errors import OutputError
from hybridlog.jobs.batch import run_batch
from hybridlog.outputs import MARKER
from tests.jobs.test_batch_resume import write_logs

TANK = "three_tank_hstf"


def _batch(logs: list[Path], out: Path, junit: Path | None) -> list[str]:
    return run_batch(logs, TANK, out_dir=out, estimator="imm", junit=junit).notes


def test_a_run_without_junit_removes_the_previous_runs_file(tmp_path: Path) -> None:
    logs = write_logs(tmp_path / "logs", ["s1.csv"], steps=20)
    # a long path: the note names the file removed whole (a cut one named no file; CI's
    # pytest-xdist folders made the path long enough to cut)
    out, junit = tmp_path / "out", tmp_path / ("ci" * 60) / "junit.xml"
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


def test_the_same_file_of_another_batch_folder_stays(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Two batch folders of the same logs write byte-identical JUnit files to one path.

    Before, batch folder a's run without --junit removed the file batch folder b wrote
    since (the same SHA-256): b's current results, gone.  The logs' wall times, in the
    file, are held alike here, as they may come out alike to the millisecond.
    """
    from hybridlog.jobs import batch_task

    monkeypatch.setattr(batch_task, "time", SimpleNamespace(perf_counter=lambda: 1.0))
    logs = write_logs(tmp_path / "logs", ["s1.csv"], steps=20)
    junit = tmp_path / "junit.xml"
    _batch(logs, tmp_path / "a", junit)
    written_by_a = junit.read_bytes()
    _batch(logs, tmp_path / "b", junit)
    assert junit.read_bytes() == written_by_a  # the same content, another file

    assert _batch(logs, tmp_path / "a", None) == []
    assert junit.is_file()


def test_a_marker_edited_to_a_path_outside_removes_nothing(tmp_path: Path) -> None:
    """A relative path in the marker leading out of the batch folder names nothing of its."""
    logs = write_logs(tmp_path / "logs", ["s1.csv"], steps=20)
    out, junit = tmp_path / "out", tmp_path / "out" / "junit.xml"
    _batch(logs, out, junit)
    outside = tmp_path / "junit.xml"
    junit.rename(outside)
    (out / ".junit.xml.hybridlog").rename(tmp_path / ".junit.xml.hybridlog")
    marker = json.loads((out / MARKER).read_text(encoding="utf-8"))
    marker["junit"]["path"] = "../junit.xml"
    (out / MARKER).write_text(json.dumps(marker), encoding="utf-8")

    assert _batch(logs, out, None) == []
    assert outside.is_file()


def test_a_junit_path_that_is_a_link_is_refused_before_anything_is_removed(
    tmp_path: Path,
) -> None:
    """A link to the batch's own JUnit file read as that file: the file was withdrawn as the
    previous run's, the link left pointing at nothing and the batch refused at its end, exit
    2, with no summary and no JUnit file left."""
    logs = write_logs(tmp_path / "logs", ["s1.csv"], steps=20)
    out, junit = tmp_path / "out", tmp_path / "junit.xml"
    _batch(logs, out, junit)
    written = junit.read_bytes()
    links = {"to the batch's file": junit, "to nothing": tmp_path / "gone.xml"}
    for why, target in links.items():
        link = tmp_path / f"link {why}.xml"
        link.symlink_to(target)
        with pytest.raises(OutputError, match=r"^--junit .*: is a symbolic link \(to "):
            _batch(logs, out, link)
        assert junit.read_bytes() == written, why
        assert (out / "summary.md").is_file(), why
        assert not target.exists() or target == junit
