"""One log file under two names (a symbolic or hard link) is one log of a batch.

``batch runs`` over a folder holding ``a.csv`` and ``latest.csv -> a.csv`` analysed the file
twice: two rows in the summaries, counted twice in the gates and the summary plot.  Only
paths equal as text were refused as "given twice".
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from hybridlog.errors import OptionError
from hybridlog.jobs.batch import run_batch
from hybridlog.jobs.batch_logs import batch_logs
from tests.jobs.test_batch_resume import write_logs

TANK = "three_tank_hstf"


def test_a_log_found_again_under_a_link_is_analysed_once_with_a_note(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)  # short relative names, shown whole
    runs = Path("runs")
    write_logs(runs, ["a.csv", "b.csv"], steps=20)
    (runs / "latest.csv").symlink_to("b.csv")
    os.link(runs / "a.csv", runs / "a_copy.csv")
    (runs / "sub").mkdir()
    (runs / "sub" / "zz.csv").symlink_to(tmp_path / runs / "a.csv")
    found = batch_logs([runs])
    assert [Path(p).name for p in found.paths] == ["a.csv", "b.csv"]
    (note,) = found.notes
    assert "3 logs were found again under another name" in note
    assert f"'{runs / 'a_copy.csv'}' as '{runs / 'a.csv'}'" in note
    assert f"'{runs / 'latest.csv'}' as '{runs / 'b.csv'}'" in note
    outcome = run_batch([runs], TANK, out_dir="out", fail_under=["vaf=0"])
    assert [Path(o.log).name for o in outcome.logs] == ["a.csv", "b.csv"]
    assert outcome.notes == [note]
    summary = (tmp_path / "out" / "summary.csv").read_text()
    assert "latest" not in summary and "a_copy" not in summary
    assert not (tmp_path / "out" / "latest.csv").exists()


def test_a_log_given_under_a_second_name_is_refused_naming_both(tmp_path: Path) -> None:
    runs = tmp_path / "runs"
    write_logs(runs, ["a.csv"], steps=20)
    (tmp_path / "link.csv").symlink_to(runs / "a.csv")
    os.link(runs / "a.csv", tmp_path / "hard.csv")
    with pytest.raises(OptionError, match=r"'.*link.csv' is the same file as .*symbolic link"):
        batch_logs([tmp_path / "link.csv", runs / "a.csv"])
    with pytest.raises(OptionError, match=r"'.*hard.csv' is the same file as .*a hard link"):
        batch_logs([runs, tmp_path / "hard.csv"])  # given, beside a folder that holds it
    (tmp_path / "runs_link").symlink_to(runs, target_is_directory=True)
    with pytest.raises(OptionError, match=r"folder of logs '.*runs_link' is the folder of logs"):
        batch_logs([runs, tmp_path / "runs_link"])
    # a path equal as text keeps its own message, naming the folders given
    with pytest.raises(OptionError, match="given twice"):
        run_batch([runs, runs / "a.csv"], TANK, out_dir=tmp_path / "out")
