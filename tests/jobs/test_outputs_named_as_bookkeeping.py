"""No output is named as hybridlog names its own bookkeeping: markers, records, temporaries.

``batch --out o --junit o/.hybridlog`` wrote the JUnit XML over the batch folder's marker
once the batch had made it, exit 0; ``--junit o/.summary.md.hybridlog`` wrote it over
summary.md's record, and every later run into ``o`` was refused (summary.md read as edited
by hand); a name of a temporary is removed by a later run as a dead run's leftover.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hybridlog.errors import OutputError
from hybridlog.jobs.batch import run_batch
from hybridlog.outputs import MARKER, check_dir_target, check_file_target, is_temporary
from hybridlog.report.junit import check_junit_target
from tests.conftest import Main
from tests.jobs.test_batch_resume import write_logs

TANK = "three_tank_hstf"

_NAMES = {
    MARKER: "marker",
    f".summary.md{MARKER}": "record of a file it wrote ('summary.md')",
    ".summary.csv.hybridlog-tmp-0a7c-4242-0123abcd": "temporary file",  # temporary_name's
}


def test_the_names_are_hybridlogs() -> None:
    assert is_temporary(".summary.csv.hybridlog-tmp-0a7c-4242-0123abcd")


@pytest.mark.parametrize(("name", "kind"), _NAMES.items())
def test_an_output_named_as_bookkeeping_is_refused(tmp_path: Path, name: str, kind: str) -> None:
    for check in (
        lambda path: check_file_target(path, force=True),
        lambda path: check_dir_target(path, force=True),
        check_junit_target,
    ):
        with pytest.raises(OutputError, match="named as hybridlog's own") as err:
            check(tmp_path / "o" / name)
        assert kind in str(err.value)
    with pytest.raises(OutputError, match="named as hybridlog's own"):
        check_dir_target(f"{tmp_path / name}/", force=True)  # a folder, as given
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("name", _NAMES)
def test_a_junit_file_named_as_the_batch_folders_bookkeeping_is_refused(
    tmp_path: Path, name: str
) -> None:
    logs = write_logs(tmp_path / "logs", ["s1.csv"], steps=20)
    out = tmp_path / "out"
    with pytest.raises(OutputError, match=r"^--junit .*named as hybridlog's own"):
        run_batch(logs, TANK, out_dir=out, estimator="imm", junit=out / name)
    assert not out.exists()  # refused before anything is written


def test_cli_refuses_a_junit_file_over_the_batch_folders_marker(
    tmp_path: Path, hybridlog_main: Main
) -> None:
    logs = write_logs(tmp_path / "logs", ["s1.csv"], steps=20)
    out = tmp_path / "out"
    args = ["batch", *map(str, logs), "--model", TANK, "--estimator", "imm", "--out", str(out)]
    code, err = hybridlog_main([*args, "--junit", str(out / MARKER)])
    assert code == 2
    assert err.count("\n") == 1 and "--junit" in err and "named as hybridlog's own marker" in err
    assert not out.exists()
