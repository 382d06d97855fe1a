"""A log of a hidden name inside a folder of logs is said, not passed over in silence.

Names starting with '.' are not searched (a tool's folders, temporaries).  Before, a log so
named (``.r500.csv``: a recorder's file never renamed, a name hidden by mistake) was left
out without a word: 499 of 500 logs analysed, the summaries and gates passing without it,
while a link to a folder not searched got a note.  Now a note names them (a count and the
first few); the folder holding only such logs says so in its error.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hybridlog.errors import OptionError
from hybridlog.io.writers import write_table
from hybridlog.jobs.batch_logs import batch_logs
from hybridlog.outputs import temporary_name
from tests.support.logfiles import tank_run


def _log(path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    return write_table(path, tank_run(steps=5, seed=1).columns)


def test_hidden_logs_are_named_in_a_note(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    logs = Path("logs")
    for name in ("r1.csv", ".r2.csv", "deep/.r3.CSV", "deep/.r4.csv", "deep/.r5.csv"):
        _log(logs / name)
    (logs / ".bag").mkdir()  # a ROS 2 bag folder of a hidden name: a log
    (logs / ".bag" / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")

    found = batch_logs([logs])

    assert [Path(p).name for p in found.paths] == ["r1.csv"]
    (note,) = found.notes
    assert note == (
        "5 logs whose names start with '.' were skipped ('logs/.bag', 'logs/.r2.csv', "
        "'logs/deep/.r3.CSV' and 2 more; hidden names are not searched for logs, nor "
        "folders starting with '.'): rename them, or give them as LOGS, to analyse them"
    )


def test_what_is_no_hidden_log_is_not_named(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A tool's hidden folder, macOS's ``._`` companions, hybridlog's temporaries, a hidden
    link to a log of the batch and a hidden log given as LOGS are not logs left out."""
    monkeypatch.chdir(tmp_path)
    logs = Path("logs")
    _log(logs / "r1.csv")
    _log(logs / ".git" / "kept.csv")  # a folder starting with '.' is not searched
    (logs / "._r1.csv").write_bytes(b"\x00\x05\x16\x07")  # macOS's metadata of r1.csv
    # a log being written (hybridlog's writers refuse to write to such a name themselves)
    temporary_name(logs / "r9.csv", keep_suffix=True).write_bytes((logs / "r1.csv").read_bytes())
    (logs / ".latest.csv").symlink_to("r1.csv")
    _log(logs / ".given.csv")

    found = batch_logs([logs, logs / ".given.csv"])

    assert sorted(Path(p).name for p in found.paths) == [".given.csv", "r1.csv"]
    assert found.notes == ()
    # an AppleDouble file without its log beside it is a hidden log like any other
    (logs / "r1.csv").rename(logs / "r0.csv")
    assert "('logs/._r1.csv', 'logs/.given.csv'; hidden" in batch_logs([logs]).notes[0]


def test_a_folder_of_hidden_logs_only_names_them_in_its_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    _log(Path("logs/.r1.csv"))
    Path("logs/notes.txt").write_text("field notes\n")

    with pytest.raises(OptionError) as refused:
        batch_logs(["logs"])

    assert str(refused.value).endswith(
        "names starting with '.' and hybridlog's output folders are skipped: it holds "
        "'logs/.r1.csv'; give it as LOGS)"
    )


def test_a_broken_hidden_link_is_not_named_in_the_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Emacs's lock of a file being edited: .#r1.csv, a link to user@host.pid, no log
    monkeypatch.chdir(tmp_path)
    Path("logs").mkdir()
    (Path("logs") / ".#r1.csv").symlink_to("user@host.4242")

    with pytest.raises(OptionError) as refused:
        batch_logs(["logs"])

    assert str(refused.value).endswith(
        "names starting with '.' and hybridlog's output folders are skipped)"
    )


def test_a_hidden_log_a_log_links_to_is_not_named(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # a recorder's latest.csv -> .current.csv: the hidden log is analysed, as latest.csv
    monkeypatch.chdir(tmp_path)
    logs = Path("logs")
    _log(logs / ".current.csv")
    (logs / "latest.csv").symlink_to(".current.csv")

    found = batch_logs([logs])

    assert found.paths == ["logs/latest.csv"] and found.notes == ()
