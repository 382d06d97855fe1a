"""An output folder removed while hybridlog writes in it: one line naming the output.

``rm -rf out`` while a batch still wrote its reports took the temporary folders the workers
were writing: a log's error was Python's ``FileNotFoundError`` naming a temporary
``.run.csv.hybridlog-tmp-...`` folder, not the report it was to be.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from hybridlog.errors import OutputError
from hybridlog.outputs import atomic_output_dir


@pytest.mark.parametrize("exists", [False, True], ids=["new", "replaced"])
def test_a_report_folder_removed_while_written_is_named(tmp_path: Path, exists: bool) -> None:
    out = tmp_path / "out"
    target = out / "run.csv"
    if exists:
        with atomic_output_dir(target) as tmp:
            (tmp / "report.json").write_text("{}", encoding="utf-8")

    with (
        pytest.raises(OutputError, match=r"run\.csv: cannot be written: the folder it was being "),
        atomic_output_dir(target, force=True) as tmp,
    ):
        shutil.rmtree(out)  # the batch folder removed by another program
        (tmp / "report.json").write_text("{}", encoding="utf-8")
    assert not out.exists()


def test_an_error_of_a_folder_still_there_is_left_as_it_is(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError), atomic_output_dir(tmp_path / "run.csv") as tmp:
        (tmp / "missing" / "report.json").write_text("{}", encoding="utf-8")
