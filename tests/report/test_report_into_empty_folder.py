"""An empty folder given as ``--out`` is filled, not replaced: it keeps what the user set."""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path

import pytest

from hybridlog.errors import OutputError
from hybridlog.outputs import MARKER, atomic_output_dir, is_ours, recorded_files, temporary_name
from hybridlog.report import write_report
from tests.jobs.test_outputs_safety import _dead_pid
from tests.report.test_report_files import DT, make_run


def test_an_empty_folder_keeps_its_permissions_and_identity(tmp_path: Path) -> None:
    """The report folder was built next to it and renamed over it: a private (700) folder
    became 755, readable by every user, a group's folder lost its set-group-ID bit, and a
    mount point (a container's ``-v $PWD/out:/out``) could not be written at all
    ('cannot move outputs into /out: Device or resource busy')."""
    out = tmp_path / "private"
    out.mkdir()
    out.chmod(0o2700)
    before = out.stat()
    result, signals = make_run(n=20)
    write_report(out, result, signals, log="l", model_name="m", dt=DT)
    after = out.stat()
    assert (after.st_ino, stat.S_IMODE(after.st_mode)) == (before.st_ino, 0o2700)
    assert sorted(p.name for p in out.iterdir()) == [
        MARKER, "estimates.csv", "plots", "report.json", "report.md", "timeline.csv"
    ]  # fmt: skip
    assert is_ours(out)
    assert recorded_files(out) is not None and "report.json" in recorded_files(out)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["private"]  # no temporary left


def test_a_failed_move_into_an_empty_folder_leaves_it_empty(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = tmp_path / "out"
    out.mkdir()
    rename = os.rename
    moved: list[str] = []

    def second_fails(source: Path, target: Path) -> None:
        if Path(target).parent == out and moved:
            raise OSError(errno.EIO, "Input/output error")
        moved.append(Path(target).name)
        rename(source, target)

    monkeypatch.setattr(os, "rename", second_fails)
    with (
        pytest.raises(OutputError, match=rf"^cannot move outputs into {out}: Input/output"),
        atomic_output_dir(out) as staged,
    ):
        (staged / "report.json").write_text("{}")
        (staged / "report.md").write_text("# r\n")
    assert moved[0] == MARKER  # first: a folder cut short is still known as ours
    assert list(out.iterdir()) == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_what_a_killed_run_left_in_an_empty_folder_is_not_the_users(tmp_path: Path) -> None:
    """A run killed (``kill -9``, the OOM killer) while it wrote into the empty folder left
    its temporary there; the next run took the folder for the user's, not empty."""
    out = tmp_path / "out"
    out.mkdir()
    ours = temporary_name(out / out.name).name  # the name a run gives it, here a dead one's
    left = ours.replace(f"-{os.getpid()}-", f"-{_dead_pid()}-")
    (out / left).mkdir()
    (out / left / MARKER).write_text("{}")
    (out / left / "report.json").write_text("{")
    result, signals = make_run(n=20)
    write_report(out, result, signals, log="l", model_name="m", dt=DT)
    assert left not in os.listdir(out) and (out / "report.json").is_file()
