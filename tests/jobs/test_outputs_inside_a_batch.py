"""``analyze`` and ``compare`` do not write into a batch folder, whose summaries name its reports.

``analyze run.csv --out nightly/s1.csv --force`` replaced the batch's report of ``s1.csv``
with one of another log (or other settings): summary.md/.csv and the JUnit file then gave
numbers that no report in the folder held.  A comparison's reports were kept so already
(``_check_not_part``); a batch folder, whose marker lists no files, was not.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from hybridlog.errors import OutputError
from hybridlog.io.writers import write_table
from hybridlog.jobs.analysis import analyze
from hybridlog.jobs.batch import run_batch
from hybridlog.jobs.compare import compare
from hybridlog.outputs.folder_targets import check_outside_batch
from tests.support.logfiles import tank_run


@pytest.fixture(scope="module")
def batch(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("batch")
    log = write_table(root / "logs" / "s1.csv", tank_run(steps=30, seed=1).columns)
    run_batch([log], "three_tank_hstf", out_dir=root / "out", estimator="imm")
    return root


def test_analyze_into_a_batch_report_is_refused_and_it_stays(batch: Path) -> None:
    report = batch / "out" / "s1.csv" / "report.json"
    before = report.read_bytes()
    other = write_table(batch / "other.csv", tank_run(steps=20, seed=2).columns)
    with pytest.raises(OutputError, match=r"is inside the batch folder .*out, whose summaries"):
        analyze(other, "three_tank_hstf", out_dir=batch / "out" / "s1.csv", force=True)
    with pytest.raises(OutputError, match=r"is inside the batch folder"):
        compare(other, "three_tank_hstf", ["imm", "hstf"], out_dir=report.parent, force=True)
    assert report.read_bytes() == before


def test_a_new_folder_inside_a_batch_folder_replaces_nothing(batch: Path) -> None:
    """``batch --out .`` then ``analyze`` there: its default folder is new, and written."""
    check_outside_batch(batch / "out" / "s1_imm")


def test_folders_beside_or_without_summaries_are_not_a_batch(batch: Path, tmp_path: Path) -> None:
    check_outside_batch(batch / "elsewhere")
    copy = tmp_path / "copy"
    shutil.copytree(batch / "out", copy, ignore=shutil.ignore_patterns("*summary*"))
    check_outside_batch(copy / "s1.csv")  # no summaries: nothing names its reports


def test_a_folder_the_summaries_do_not_name_is_written_again(batch: Path) -> None:
    """``analyze`` in a working folder that is also a batch's output, run again with --force:
    its own folder, which no summary names, was refused as 'inside the batch folder, whose
    summaries name its reports' once it existed (the first run had written it)."""
    mine = batch / "out" / "s1_hstf"
    mine.mkdir()
    try:
        check_outside_batch(mine)
        (mine / "d").mkdir()
        check_outside_batch(mine / "d")
    finally:
        shutil.rmtree(mine)


def test_a_folder_holding_a_named_report_or_beside_an_unread_summary_is_refused(
    batch: Path, tmp_path: Path
) -> None:
    copy = tmp_path / "copy"
    shutil.copytree(batch / "out", copy)
    summary = copy / "summary.csv"
    summary.write_text(summary.read_text(encoding="utf-8").replace(",s1.csv", ",d2/s1.csv"))
    (copy / "d2").mkdir()
    with pytest.raises(OutputError, match=r"is inside the batch folder"):
        check_outside_batch(copy / "d2")  # holds d2/s1.csv's report
    check_outside_batch(copy / "s1.csv")  # no longer named
    summary.write_text("not, a summary\n")  # no folder column: every folder taken for one
    with pytest.raises(OutputError, match=r"is inside the batch folder"):
        check_outside_batch(copy / "s1.csv")
