"""An output path that runs through a file (``run.csv/../out``) is refused, not followed.

The folder part of an output path was resolved as :func:`os.path.realpath` does, which
takes ``run.csv/..`` for the folder holding ``run.csv``; the system refuses such a path (a
file is no folder to go up from).  So ``analyze run.csv --out run.csv/../out`` wrote into
``./out`` and printed ``report: run.csv/../out/report.md``, a path nobody could open; batch,
compare, cluster and simulate did the same.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hybridlog.errors import OutputError
from hybridlog.jobs.batch import run_batch
from hybridlog.outputs import check_dir_target, check_file_target
from hybridlog.outputs.file_targets import check_followable


@pytest.fixture
def log(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "run.csv"
    path.write_text("t,y1\n0,1\n", encoding="utf-8")
    return path


@pytest.mark.parametrize("given", ["run.csv/../out", "run.csv/x/../../out", "link/../out"])
def test_a_folder_through_a_file_is_refused(log: Path, given: str) -> None:
    (log.parent / "link").symlink_to(log)
    with pytest.raises(OutputError, match=r"cannot be created: (run\.csv|link) is not a folder"):
        check_dir_target(given, force=False)
    with pytest.raises(OutputError, match=r"is not a folder"):
        check_file_target(f"{given}.json", force=False)
    assert sorted(p.name for p in log.parent.iterdir()) == ["link", "run.csv"]


def test_paths_the_system_follows_are_left_alone(log: Path) -> None:
    (log.parent / "d").mkdir()
    (log.parent / "dlink").symlink_to(log.parent / "d")
    for given in ["out", "d/../out", "dlink/../out", "missing/x", str(log.parent / "out")]:
        check_followable(given)
    assert check_dir_target("dlink/../out", force=False) == log.parent / "out"


def test_batch_refuses_it_before_writing(log: Path) -> None:
    with pytest.raises(OutputError, match=r"^run\.csv/\.\./out: cannot be created: run\.csv is"):
        run_batch([log], "three_tank_hstf", out_dir="run.csv/../out", estimator="imm")
    assert sorted(p.name for p in log.parent.iterdir()) == ["run.csv"]


@pytest.mark.parametrize("given", ["missing/../out", "missing/x/../../out", "missing/.."])
def test_a_path_going_up_out_of_a_missing_folder_is_refused(log: Path, given: str) -> None:
    # written to ./out while the command printed missing/../out/report.md (no such path)
    with pytest.raises(OutputError, match=r"cannot be created: missing does not exist, so '\.\.'"):
        check_dir_target(given, force=False)
    with pytest.raises(OutputError, match=r"missing does not exist"):
        check_file_target(f"{given}/j.xml", force=False)
    assert sorted(p.name for p in log.parent.iterdir()) == ["run.csv"]
