"""A link to a folder inside a folder of logs is said, not passed over in silence.

Links to folders are not followed (a loop would never end).  Before, the logs that only
such a link led to were left out of the batch without a word: a nightly run over a folder
of links to the recorders' disks summarised and gated none of their logs, exit 0.  Now a
note names the links not searched; a link into a folder searched anyway (whose logs the
batch has under their own names, or a loop) is not named.
"""

from __future__ import annotations

from pathlib import Path

from hybridlog.io.writers import write_table
from hybridlog.jobs.batch_logs import batch_logs
from tests.support.logfiles import tank_run


def _log(path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    return write_table(path, tank_run(steps=5, seed=1).columns)


def test_a_link_to_a_folder_elsewhere_is_named_in_a_note(tmp_path: Path) -> None:
    _log(tmp_path / "disk" / "far.csv")
    _log(tmp_path / "logs" / "near.csv")
    (tmp_path / "logs" / "disk").symlink_to(tmp_path / "disk")

    found = batch_logs([tmp_path / "logs"])

    assert [Path(p).name for p in found.paths] == ["near.csv"]
    (note,) = found.notes
    assert "a link to a folder was not searched" in note and "logs/disk'" in note
    # given as well, its logs are in the batch and the link is not named
    both = batch_logs([tmp_path / "logs", tmp_path / "disk"])
    assert sorted(Path(p).name for p in both.paths) == ["far.csv", "near.csv"]
    assert both.notes == ()


def test_a_loop_or_a_link_within_the_folder_is_not_named(tmp_path: Path) -> None:
    _log(tmp_path / "logs" / "a" / "run.csv")
    (tmp_path / "logs" / "b").mkdir()
    (tmp_path / "logs" / "b" / "up").symlink_to("..")
    (tmp_path / "logs" / "b" / "to_a").symlink_to("../a")

    found = batch_logs([tmp_path / "logs"])

    assert [Path(p).name for p in found.paths] == ["run.csv"] and found.notes == ()
