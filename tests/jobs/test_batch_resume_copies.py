"""A batch folder copied or restored whole is still hybridlog's; an edit in it is still not.

Before, every file was recognised by its inode, size and modification time: a copy of the
folder (``cp -a``, ``rsync -a``, ``shutil.copytree``, a tar archive or a CI cache restored)
has new inodes, and a GNU tar archive keeps whole seconds only, so resuming a cached batch
exited 2 with "summary.md changed since a batch wrote it", every time.  Now a file with
another inode is hybridlog's when it kept its size, the modification time a copy keeps and,
where one was recorded (every small file, every report document), its content's SHA-256.
"""

from __future__ import annotations

import io
import json
import os
import shutil
import subprocess
import tarfile
from collections.abc import Callable
from pathlib import Path

import pytest

from hybridlog.errors import OutputError
from hybridlog.io.writers import write_table
from hybridlog.jobs.batch import run_batch
from hybridlog.outputs import MARKER, atomic_output_dir, edited_files, records, wrote_file
from tests.support.logfiles import tank_run

TANK = "three_tank_hstf"


@pytest.fixture(scope="module")
def finished(tmp_path_factory: pytest.TempPathFactory) -> tuple[list[Path], Path]:
    """Two logs and the batch folder a first run wrote for them."""
    root = tmp_path_factory.mktemp("finished")
    (root / "logs").mkdir()
    logs = [
        write_table(root / "logs" / f"s{k}.csv", tank_run(steps=30, seed=k).columns) for k in (1, 2)
    ]
    run_batch(logs, TANK, out_dir=root / "out", estimator="imm")
    return logs, root / "out"


def _cp_a(source: Path, target: Path) -> None:
    subprocess.run(["cp", "-a", str(source), str(target)], check=True)


def _copytree(source: Path, target: Path) -> None:
    shutil.copytree(source, target, copy_function=shutil.copy2)


def _tar(form: int) -> Callable[[Path, Path], None]:
    def round_trip(source: Path, target: Path) -> None:
        archive = io.BytesIO()
        with tarfile.open(fileobj=archive, mode="w", format=form) as tar:
            tar.add(source, arcname=target.name)
        archive.seek(0)
        with tarfile.open(fileobj=archive) as tar:
            tar.extractall(target.parent, filter="tar")

    return round_trip


COPIES = {
    "cp -a": _cp_a,
    "copytree copy2": _copytree,
    "tar GNU (whole seconds)": _tar(tarfile.GNU_FORMAT),
    "tar PAX (float seconds)": _tar(tarfile.PAX_FORMAT),
}


@pytest.mark.parametrize("how", list(COPIES))
def test_a_copied_or_restored_batch_folder_resumes(
    finished: tuple[list[Path], Path], tmp_path: Path, how: str
) -> None:
    logs, out = finished
    copy = tmp_path / "restored"
    COPIES[how](out, copy)
    assert os.stat(copy / "summary.md").st_ino != os.stat(out / "summary.md").st_ino
    outcome = run_batch(logs, TANK, out_dir=copy, estimator="imm")
    assert {o.status for o in outcome.logs} == {"skipped"}
    assert wrote_file(copy / "summary.md")  # and the next run takes it as its own


def test_a_same_size_edit_with_its_time_put_back_in_a_restored_folder_is_the_users(
    finished: tuple[list[Path], Path], tmp_path: Path
) -> None:
    logs, out = finished
    copy = tmp_path / "restored"
    COPIES["tar GNU (whole seconds)"](out, copy)
    for name in ("summary.md", "s1.csv/report.md"):
        path = copy / name
        status = path.stat()
        text = path.read_bytes()
        path.write_bytes(text.replace(b"imm", b"IMM", 1))  # same size
        os.utime(path, ns=(status.st_atime_ns, status.st_mtime_ns))  # touch -d
        assert path.stat().st_size == status.st_size
    with pytest.raises(OutputError, match=r"summary\.md changed since a batch wrote it"):
        run_batch(logs, TANK, out_dir=copy, estimator="imm", force=True)
    kept = (copy / "summary.md").read_bytes()
    (copy / "summary.md").rename(tmp_path / "my_summary.md")
    outcome = run_batch(logs, TANK, out_dir=copy, estimator="imm")
    s1 = next(o for o in outcome.logs if Path(o.log).name == "s1.csv")
    assert s1.status == "failed"
    assert s1.error is not None and "changed since hybridlog wrote them" in s1.error
    assert b"IMM" in (copy / "s1.csv" / "report.md").read_bytes()  # the edit is kept
    assert (tmp_path / "my_summary.md").read_bytes() == kept


def test_a_report_edited_in_place_with_its_time_put_back_is_never_reused(
    finished: tuple[list[Path], Path], tmp_path: Path
) -> None:
    """Same inode, same size, same nanosecond: only the content tells (its SHA-256)."""
    logs, out = finished
    copy = tmp_path / "copy"
    _cp_a(out, copy)
    report = copy / "s2.csv" / "report.json"
    status = report.stat()
    data = json.loads(report.read_text(encoding="utf-8"))
    shown = json.dumps(data["vaf"])
    forged = json.dumps(99.0).ljust(len(shown))[: len(shown)]
    with report.open("r+b") as handle:  # in place: the inode stays
        original = handle.read()
        text = original.replace(shown.encode(), forged.encode(), 1)
        assert text != original and len(text) == status.st_size
        handle.seek(0)
        handle.write(text)
    os.utime(report, ns=(status.st_atime_ns, status.st_mtime_ns))
    assert report.stat().st_ino == status.st_ino
    outcome = run_batch(logs, TANK, out_dir=copy, estimator="imm")
    s2 = next(o for o in outcome.logs if Path(o.log).name == "s2.csv")
    assert s2.status == "failed" and s2.report is None  # its forged VAF reaches no summary


def test_large_tables_are_recognised_by_size_and_time_without_a_digest(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A table over the digest limit is not hashed when written (its cost), yet a copy of it
    is still recognised, and an edit that changes its time or size still is not."""
    monkeypatch.setattr(records, "_DIGESTED_LIMIT", 64)
    with atomic_output_dir(tmp_path / "report") as folder:
        (folder / "table.csv").write_text("t,y\n" + "0.5,1.25\n" * 40)
        (folder / "report.md").write_text("# A report\n" + "text\n" * 40)
        (folder / "small.csv").write_text("t\n0\n")
    marker = json.loads((tmp_path / "report" / MARKER).read_text())
    assert {name: len(entry) for name, entry in marker["identities"].items()} == {
        "table.csv": 3,  # inode, size, time
        "report.md": 4,  # and SHA-256: a report document, whatever its size
        "small.csv": 4,
    }
    for how in ("copytree copy2", "tar GNU (whole seconds)"):
        copy = tmp_path / how.replace(" ", "_")
        COPIES[how](tmp_path / "report", copy)
        assert edited_files(copy) == []
        table = copy / "table.csv"
        table.write_text(table.read_text().replace("1.25", "1.75"))  # same size, new time
        assert edited_files(copy) == ["table.csv"]
