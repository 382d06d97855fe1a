"""An existing folder given as ``--out`` is filled in place, not replaced: it keeps what the
user set.  Empty, or a report of ours refreshed with ``--force``; the old report stays until
the new one is complete, and stays whole if the refresh fails or is interrupted."""

from __future__ import annotations

import errno
import os
import shutil
import stat
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

from hybridlog.errors import OutputError
from hybridlog.io.bag_writers import write_log
from hybridlog.outputs import MARKER, atomic_output_dir, is_ours, recorded_files, temporary_name
from hybridlog.report import write_report
from tests.jobs.test_outputs_safety import _dead_pid
from tests.report.test_report_files import DT, make_run
from tests.support.logfiles import tank_run


def _write(out: Path, version: str, *, force: bool = False) -> None:
    """A small folder of outputs, its files telling which ``version`` wrote them."""
    with atomic_output_dir(out, force=force) as staged:
        (staged / "report.json").write_text(f'{{"v": "{version}"}}')
        (staged / "report.md").write_text(f"# {version}\n")
        (staged / "plots").mkdir()
        (staged / "plots" / "modes.png").write_text(version)


def _content(folder: Path) -> dict[str, bytes]:
    return {
        p.relative_to(folder).as_posix(): p.read_bytes()
        for p in sorted(folder.rglob("*"))
        if p.is_file() and p.name != MARKER
    }


@pytest.mark.parametrize("earlier", [False, True], ids=["empty", "forced"])
def test_the_folder_keeps_its_permissions_and_identity(tmp_path: Path, earlier: bool) -> None:
    """The report folder was built next to it and renamed over it: a private (700) folder
    became 755, readable by every user, a group's folder lost its set-group-ID bit, and a
    mount point (a container's ``-v $PWD/out:/out``) could not be written at all
    ('cannot move outputs into /out: Device or resource busy').  The empty folder was mended
    first; a ``--force`` run into the folder of an earlier one still replaced it."""
    out = tmp_path / "private"
    result, signals = make_run(n=20)
    if earlier:
        write_report(out, result, signals, log="l", model_name="m", dt=DT)
    else:
        out.mkdir()
    out.chmod(0o2700)
    before = out.stat()
    write_report(out, result, signals, log="l2", model_name="m", dt=DT, force=True)
    after = out.stat()
    assert (after.st_ino, stat.S_IMODE(after.st_mode)) == (before.st_ino, 0o2700)
    assert sorted(p.name for p in out.iterdir()) == [
        MARKER, "estimates.csv", "plots", "report.json", "report.md", "timeline.csv"
    ]  # fmt: skip
    assert '"log": "l2"' in (out / "report.json").read_text()
    assert is_ours(out)
    assert recorded_files(out) is not None and "report.json" in recorded_files(out)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["private"]  # no temporary left


def test_a_bag_refreshed_with_force_keeps_its_folder(tmp_path: Path) -> None:
    """``simulate --out bag --format ros2-…`` renamed its new bag over the old one too."""
    bag = tmp_path / "bag"
    columns = tank_run(steps=20).columns
    write_log(bag, columns, format="ros2-sqlite3")
    bag.chmod(0o700)
    before = bag.stat()
    write_log(bag, columns, format="ros2-mcap", force=True)
    after = bag.stat()
    assert (after.st_ino, stat.S_IMODE(after.st_mode)) == (before.st_ino, 0o700)
    # rosbag2 names the storage file after the folder: staged inside it, still its name
    assert sorted(p.name for p in bag.iterdir()) == ["bag.mcap", "metadata.yaml"]
    assert "bag.mcap" in (bag / "metadata.yaml").read_text()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bag"]


def _failing_at(
    call: int, error: BaseException, *names: str, done: bool = False
) -> Callable[[pytest.MonkeyPatch], list[int]]:
    """Patch the ``os`` functions ``names`` so that their ``call``-th call, together, raises
    ``error``: instead of its step, or once it is ``done`` (Ctrl-C right after a rename)."""

    def patch(monkeypatch: pytest.MonkeyPatch) -> list[int]:
        calls = [0]
        for name in names:
            real = getattr(os, name)

            def counted(*args: object, _real: Callable[..., None] = real) -> None:
                calls[0] += 1
                if calls[0] == call:
                    if done:
                        _real(*args)
                    raise error
                _real(*args)

            monkeypatch.setattr(os, name, counted)
        return calls

    return patch


@pytest.mark.parametrize(
    ("error", "done"),
    [
        (OSError(errno.EIO, "Input/output error"), False),
        (KeyboardInterrupt(), False),
        (KeyboardInterrupt(), True),
    ],
    ids=["io-error", "ctrl-c", "ctrl-c-after-the-step"],
)
@pytest.mark.parametrize("earlier", [False, True], ids=["empty", "forced"])
def test_a_refresh_cut_short_at_any_step_leaves_the_folder_as_it_was(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    error: BaseException,
    done: bool,
    earlier: bool,
) -> None:
    """Each rename, link and replace of the refresh fails in turn (an I/O error, Ctrl-C
    before or right after the step): the steps done are undone, the earlier report (or the
    empty folder) is what remains."""
    out = tmp_path / "out"
    if earlier:
        _write(out, "old")
    else:
        out.mkdir()
    before, names = _content(out), sorted(os.listdir(out))
    marker = (out / MARKER).read_bytes() if earlier else None
    expected = OutputError if isinstance(error, OSError) else KeyboardInterrupt
    call = 1
    while True:
        with monkeypatch.context() as patched:
            calls = _failing_at(call, error, "rename", "replace", "link", done=done)(patched)
            try:
                _write(out, "new", force=True)
            except expected:
                pass
            else:
                break
        assert _content(out) == before, call
        assert ((out / MARKER).read_bytes() if earlier else None) == marker
        assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
        assert sorted(os.listdir(out)) == names, call  # no temporary left, no marker added
        call += 1
    assert calls[0] == (10 if earlier else 5)  # each step was cut short once: 3 entries moved
    # aside, the old marker kept (link, replace), the new one put in (same), 3 entries moved in
    assert _content(out)["report.md"] == b"# new\n"


def test_without_hard_links_the_marker_is_copied(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = tmp_path / "out"
    _write(out, "old")

    def no_links(*_: object) -> None:
        raise OSError(errno.EPERM, "Operation not permitted")

    monkeypatch.setattr(os, "link", no_links)
    _write(out, "new", force=True)
    assert _content(out)["report.md"] == b"# new\n" and is_ours(out)
    assert sorted(p.name for p in out.iterdir()) == [MARKER, "plots", "report.json", "report.md"]


_KILLED_AT = """
import os, sys
from pathlib import Path
from hybridlog.outputs import atomic_output_dir

calls, at = [0], int(sys.argv[2])
for name in ("rename", "replace", "link"):
    def counted(*args, _real=getattr(os, name)):
        calls[0] += 1
        if calls[0] == at:
            os._exit(9)  # as a kill -9: no clean-up of any kind
        _real(*args)
    setattr(os, name, counted)
with atomic_output_dir(sys.argv[1], force=True) as staged:
    (staged / "report.json").write_text('{"v": "new"}')
    (staged / "report.md").write_text("# new\\n")
    (staged / "plots").mkdir()
    (staged / "plots" / "modes.png").write_text("new")
"""


@pytest.mark.parametrize("earlier", [False, True], ids=["empty", "forced"])
def test_a_run_killed_at_any_step_leaves_a_folder_the_next_run_refreshes(
    tmp_path: Path, earlier: bool
) -> None:
    """A run killed (``kill -9``) while it moved the entries left the folder hybridlog's, and
    the next run with ``--force`` removes what it left (a killed fill of an empty folder left
    its temporary without a marker, which the next run took for the user's files)."""
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    call = 1
    while True:
        shutil.rmtree(out, ignore_errors=True)
        if earlier:
            _write(out, "old")
        else:
            out.mkdir()
        run = [sys.executable, "-c", _KILLED_AT, str(out), str(call)]
        if subprocess.run(run, env=env, check=False).returncode == 0:
            break
        # hybridlog's, or (killed before its marker was in) holding only temporaries
        left = [p.name for p in out.iterdir() if "hybridlog-" not in p.name]
        assert is_ours(out) if earlier or left else not left, call
        _write(out, "next", force=True)
        assert _content(out) == {
            "report.json": b'{"v": "next"}',
            "report.md": b"# next\n",
            "plots/modes.png": b"next",
        }, call
        assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
        call += 1
    assert call == (11 if earlier else 6)  # killed at each step in turn, then run through


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
