"""``--junit`` may not name, lie in or hold a log's report folder of the batch.

Before, ``--junit out/s1.csv/report.json`` was found wrong only once every log had been
analysed (exit 2, no summaries written), and ``--junit out/s1.csv/junit.xml`` put the JUnit
file into a report folder that the batch replaces whole.  Now both are refused before any
log is read, naming the log.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hybridlog.errors import OutputError
from hybridlog.io.writers import write_table
from hybridlog.jobs.batch import run_batch
from tests.support.logfiles import tank_run


@pytest.mark.parametrize(
    ("junit", "relation"),
    [
        ("s1.csv/report.json", "lies in"),
        ("sub/s2.csv/junit.xml", "lies in"),
        ("s1.csv", "is"),
        ("sub", "holds"),
    ],
)
def test_junit_in_a_report_folder_is_refused_before_any_log_is_read(
    tmp_path: Path, junit: str, relation: str
) -> None:
    logs = tmp_path / "logs"
    (logs / "sub").mkdir(parents=True)
    paths = [
        write_table(logs / name, tank_run(steps=20, seed=k).columns)
        for k, name in enumerate(["s1.csv", "sub/s2.csv"], start=1)
    ]
    out = tmp_path / "out"
    with pytest.raises(OutputError, match=f"--junit .* {relation} the report folder"):
        run_batch(paths, "three_tank_hstf", out_dir=out, estimator="imm", junit=out / junit)
    assert not out.exists()


def test_junit_beside_the_summaries_is_fine(tmp_path: Path) -> None:
    log = write_table(tmp_path / "s1.csv", tank_run(steps=20, seed=1).columns)
    out = tmp_path / "out"
    run_batch([log], "three_tank_hstf", out_dir=out, estimator="imm", junit=out / "junit.xml")
    assert (out / "junit.xml").is_file()
