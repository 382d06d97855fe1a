"""Read options a batch gives every log: applied where they apply, checked once up front.

``analyze --time header`` refuses a CSV or Parquet file, whose time column is the only time
it has.  A batch over a folder of mixed formats failed every table with that message
("use --time log"), which its bags could not be given in the same run; and a batch of
tables only failed each of them, after removing the reports an earlier run had made of
them, instead of refusing the option as ``--recover`` over no MCAP file is.  A ``--map``
of a symbol the model lacks failed every log alike too.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from hybridlog.errors import OptionError
from hybridlog.io import ReadOptions
from hybridlog.io.writers import write_table
from hybridlog.jobs.batch import run_batch
from tests.support.logfiles import tank_run
from tests.support.paths import SAMPLE_LOGS

TANK = "three_tank_hstf"
HEADER = ReadOptions(time="header")


def test_the_tables_of_a_mixed_batch_are_read_by_their_time_column(tmp_path: Path) -> None:
    logs = tmp_path / "logs"
    logs.mkdir()
    write_table(logs / "run.csv", tank_run(steps=30, seed=1).columns)
    bag = shutil.copy(SAMPLE_LOGS / "three_tank_hstf.mcap", logs / "bag.mcap")

    outcome = run_batch([logs], TANK, out_dir=tmp_path / "out", estimator="imm", read=HEADER)

    status = {Path(o.log).name: (o.status, o.error) for o in outcome.logs}
    assert status["run.csv"] == ("done", None)
    assert status["bag.mcap"][0] == "failed"  # its topics have no header.stamp: its own error
    assert "has no header.stamp" in str(status["bag.mcap"][1]), status
    assert (
        "--time header: applied to the bag or MCAP file of the batch; the other log (1 csv) "
        "is a table, read by its time column"
    ) in outcome.notes
    assert Path(bag).is_file()


def test_a_batch_of_tables_only_refuses_it_and_keeps_the_earlier_reports(tmp_path: Path) -> None:
    logs = [write_table(tmp_path / f"s{k}.csv", tank_run(steps=30, seed=k).columns) for k in (1, 2)]
    out = tmp_path / "out"
    run_batch(logs, TANK, out_dir=out, estimator="imm")

    with pytest.raises(OptionError, match=r"^--time header: no log of the batch is a bag or an"):
        run_batch(logs, TANK, out_dir=out, estimator="imm", read=HEADER)

    assert (out / "s1.csv" / "report.json").is_file() and (out / "s2.csv" / "report.json").is_file()


def test_a_map_of_a_symbol_the_model_lacks_is_refused_before_any_log(tmp_path: Path) -> None:
    # it depends on the model alone: each log failed with it, losing its earlier report
    logs = [write_table(tmp_path / f"s{k}.csv", tank_run(steps=30, seed=k).columns) for k in (1, 2)]
    out = tmp_path / "out"
    run_batch(logs, TANK, out_dir=out, estimator="imm")

    with pytest.raises(OptionError, match=r"^--map 'y9=y1': unknown symbol 'y9'; valid symbols"):
        run_batch(logs, TANK, out_dir=out, estimator="imm", read=ReadOptions(maps=("y9=y1",)))

    assert (out / "s1.csv" / "report.json").is_file() and (out / "s2.csv" / "report.json").is_file()
