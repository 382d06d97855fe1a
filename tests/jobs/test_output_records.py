"""The records beside single output files (``.<name>.hybridlog``) under attack.

A record is what lets ``--force`` replace a file hybridlog wrote (SPEC §9); whatever lies
under a record's name, and whatever happens to the file between its move and its record,
must neither hang a run nor make a user's file look like hybridlog's.
"""

from __future__ import annotations

import os
import threading
from pathlib import Path

import pytest

from hybridlog.io.writers import write_table
from hybridlog.outputs import check_file_target, publishing, record_path, wrote_file

COLUMNS = {"t": [0.0, 1.0, 2.0], "y": [1.0, 2.0, 3.0]}


def _finishes(call: object, seconds: float = 10.0) -> bool:
    """Whether ``call()`` returns within ``seconds`` (a daemon thread: a hang is abandoned)."""
    done = threading.Event()

    def run() -> None:
        call()  # type: ignore[operator]
        done.set()

    threading.Thread(target=run, daemon=True).start()
    return done.wait(seconds)


@pytest.mark.parametrize("kind", ["fifo", "device", "link", "huge", "folder"])
def test_what_lies_under_a_records_name_is_no_record_and_never_hangs(
    tmp_path: Path, kind: str
) -> None:
    log = write_table(tmp_path / "run.csv", COLUMNS)
    record = record_path(log)
    genuine = record.read_bytes()
    record.unlink()
    if kind == "fifo":
        os.mkfifo(record)  # opening it to read would wait for a writer for ever
    elif kind == "device":
        record.symlink_to("/dev/zero")  # reading it would never end
    elif kind == "link":
        (tmp_path / "elsewhere").write_bytes(genuine)
        record.symlink_to(tmp_path / "elsewhere")
    elif kind == "huge":
        with record.open("wb") as handle:  # sparse: 1 GiB of nothing, read whole before
            handle.truncate(1 << 30)
    else:
        record.mkdir()
    before = os.lstat(record)
    assert _finishes(lambda: wrote_file(log))
    assert not wrote_file(log)
    log.unlink()  # a fresh write records its file: it must neither hang nor take the name
    assert _finishes(lambda: write_table(log, COLUMNS))
    assert not wrote_file(log)
    after = os.lstat(record)
    assert (after.st_ino, after.st_mode, after.st_size) == (
        before.st_ino,
        before.st_mode,
        before.st_size,
    )


def test_a_file_put_in_place_between_the_move_and_the_record_is_not_recorded(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    log = tmp_path / "run.csv"
    move = publishing._move_file

    def move_then_overtaken(staged: Path, target: Path, *, force: bool) -> None:
        move(staged, target, force=force)
        mine = tmp_path / "mine.csv"
        mine.write_text("the user's own file, written at this very moment\n")
        os.replace(mine, target)

    monkeypatch.setattr(publishing, "_move_file", move_then_overtaken)
    write_table(log, COLUMNS)
    monkeypatch.undo()
    assert not wrote_file(log)  # so --force will not replace the user's file
    assert not record_path(log).exists()


def test_an_output_goes_where_the_system_resolves_its_path(tmp_path: Path) -> None:
    """``link/../run.csv`` is ``<link's target's parent>/run.csv`` to ``open`` and to the
    check that outputs are not inputs; the file must be written there, not lexically next to
    ``link``."""
    (tmp_path / "a" / "b").mkdir(parents=True)
    (tmp_path / "link").symlink_to(tmp_path / "a" / "b")
    named = tmp_path / "link" / ".." / "run.csv"
    assert check_file_target(named, force=False) == tmp_path / "a" / "run.csv"
    write_table(named, COLUMNS)
    assert (tmp_path / "a" / "run.csv").is_file() and wrote_file(tmp_path / "a" / "run.csv")
    assert not (tmp_path / "run.csv").exists() and not record_path(tmp_path / "run.csv").exists()


def test_a_batchs_junit_file_edited_since_is_the_users(tmp_path: Path) -> None:
    from hybridlog.errors import OutputError
    from hybridlog.jobs.batch import run_batch
    from tests.support.logfiles import tank_run

    log = write_table(tmp_path / "logs" / "run.csv", tank_run(steps=40).columns)
    junit = tmp_path / "ci" / "junit.xml"
    for _ in range(2):  # a CI job re-runs into its own JUnit file, with or without --force
        run_batch([log], "three_tank_hstf", out_dir=tmp_path / "out", estimator="imm", junit=junit)
    assert wrote_file(junit)
    with junit.open("a") as handle:
        handle.write("<!-- flaky on Tuesdays: ask Ana -->\n")
    edited = junit.read_bytes()
    for force in (False, True):
        with pytest.raises(OutputError, match="edited since"):
            run_batch(
                [log],
                "three_tank_hstf",
                out_dir=tmp_path / "out",
                estimator="imm",
                junit=junit,
                force=force,
            )
    assert junit.read_bytes() == edited


def test_a_remounted_file_system_keeps_hybridlogs_files_its_own(tmp_path: Path) -> None:
    """A remount (NFS, FUSE, a btrfs subvolume) gives the file system a new device number;
    the file and its record beside it are unchanged, so the file is still hybridlog's."""
    import json

    log = write_table(tmp_path / "run.csv", COLUMNS)
    record = json.loads(record_path(log).read_text())
    record_path(log).write_text(json.dumps({**record, "device": record["device"] + 1}))
    assert wrote_file(log)
    write_table(log, COLUMNS, force=True)
    record = json.loads(record_path(log).read_text())
    record_path(log).write_text(json.dumps({**record, "inode": record["inode"] + 1}))
    assert wrote_file(log)  # a copy that kept its content and time (cp -a) is still ours
    record_path(log).write_text(json.dumps({**record, "sha256": "0" * 64}))
    assert not wrote_file(log)  # another content is not


def test_a_written_file_that_cannot_be_removed_is_one_line_naming_it(tmp_path: Path) -> None:
    """batch's summaries and JUnit file of a previous run are removed with their records
    (one ``remove_written``); where the system refuses, the file and the consequence are said."""
    from hybridlog.errors import OutputError
    from hybridlog.outputs.records import record_path, remove_written

    gone = tmp_path / "summary.md"
    remove_written(gone, "the previous run's file", "would stay")  # nothing there: no error
    stuck = tmp_path / "summary.csv"
    stuck.mkdir()  # a folder where the file was: unlink refuses it
    (stuck / "x").write_text("x")
    record_path(stuck).write_text("{}")
    with pytest.raises(OutputError) as refused:
        remove_written(stuck, "the previous run's file", "would be left beside this run's")
    assert str(refused.value).startswith(
        f"{stuck}: cannot remove the previous run's file, which would be left beside this run's: "
    )
    assert "\n" not in str(refused.value)
