"""A log whose report folder's path is too long for the system fails alone.

A report folder is its log's path below ``--out``: a deep tree of logs under a long
``--out`` gave a path the system refuses (``ENAMETOOLONG``), and the batch's own checks
(``Path.is_symlink``, ``Path.exists``) raised on it, ending the whole batch as "unexpected
OSError" before any log was analysed.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hybridlog.errors import OutputError
from hybridlog.io.writers import write_table
from hybridlog.jobs.batch import run_batch
from hybridlog.outputs import check_dir_target
from tests.support.logfiles import tank_run

TANK = "three_tank_hstf"


def _deep(root: Path, parts: int) -> Path:
    return root.joinpath(*(f"{k:02d}" + "d" * 198 for k in range(parts)))


@pytest.mark.parametrize("force", [False, True])
def test_a_report_folder_too_long_for_the_system_fails_its_log_alone(
    tmp_path: Path, force: bool
) -> None:
    logs = tmp_path / "logs"
    deep = _deep(logs, 16)
    deep.mkdir(parents=True)
    far = write_table(deep / "far.csv", tank_run(steps=30, seed=1).columns)
    near = write_table(logs / "near.csv", tank_run(steps=30, seed=2).columns)
    out = _deep(tmp_path / "out", 4)
    assert len(str(far)) < 4000 < len(str(out / far.relative_to(logs)))

    for _ in range(2):  # and again, resumed
        outcome = run_batch([far, near], TANK, out_dir=out, estimator="imm", force=force)
        statuses = {Path(o.log).name: o.status for o in outcome.logs}
        assert statuses["far.csv"] == "failed"
        assert statuses["near.csv"] in ("done", "skipped")
        (error,) = (o.error for o in outcome.logs if o.status == "failed")
        assert error is not None and "the path is too long" in error
        assert "at most 4095 here" in error
        assert (out / "near.csv" / "report.json").is_file()


def test_an_output_folder_too_long_is_refused_naming_the_limit(tmp_path: Path) -> None:
    with pytest.raises(OutputError, match=r"the path is too long \(\d+ bytes with its temporary"):
        check_dir_target(_deep(tmp_path, 21), force=False)
