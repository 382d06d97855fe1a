"""``batch --out`` naming a link to a batch folder, or a file, is refused as such.

The summaries were checked before the folder itself: a link to a finished batch folder got
"summary.md: exists and hybridlog did not write it (or it changed since)" (the summaries
were compared against the link's path, not the folder's), a file "summary.md: cannot be
created".  Now the folder is checked first and the error says what is wrong with it.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hybridlog.errors import OutputError
from hybridlog.io.writers import write_table
from hybridlog.jobs.batch import run_batch
from tests.support.logfiles import tank_run


def test_a_link_to_a_batch_folder_is_refused_as_a_link(tmp_path: Path) -> None:
    log = write_table(tmp_path / "s1.csv", tank_run(steps=20, seed=1).columns)
    out = tmp_path / "out"
    run_batch([log], "three_tank_hstf", out_dir=out, estimator="imm")
    link = tmp_path / "link"
    link.symlink_to(out)
    with pytest.raises(OutputError, match=r"is a symbolic link .*does not write through"):
        run_batch([log], "three_tank_hstf", out_dir=link, estimator="imm")


def test_a_file_is_refused_as_not_a_folder(tmp_path: Path) -> None:
    log = write_table(tmp_path / "s1.csv", tank_run(steps=20, seed=1).columns)
    (tmp_path / "out").write_text("mine\n")
    with pytest.raises(OutputError, match="exists and is not a directory"):
        run_batch([log], "three_tank_hstf", out_dir=tmp_path / "out", estimator="imm")
    assert (tmp_path / "out").read_text() == "mine\n"
