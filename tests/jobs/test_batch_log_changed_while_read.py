"""A log that changes while the batch reads it is not analysed; its report would lie.

Before, the batch hashed a log's bytes and then read it: a log still being written (a
recorder appending to it, a sync replacing it) was analysed as it was when read, and its
report recorded the content hashed before, which it was not made from; the log came out
"done" with numbers of a cut-off read.  Now what ``stat`` says of it (size, modification
time) is taken before the hash and compared after the read: a change fails the log with its
name, and no report folder is left.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from hybridlog.io.writers import write_table
from hybridlog.jobs import batch_task
from hybridlog.jobs.batch import run_batch
from tests.support.logfiles import tank_run

TANK = "three_tank_hstf"


def _logs(folder: Path) -> list[Path]:
    folder.mkdir()
    return [write_table(folder / f"s{k}.csv", tank_run(steps=30, seed=k).columns) for k in (1, 2)]


def test_a_log_changed_between_hash_and_read_fails_with_its_name(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    logs = _logs(tmp_path / "logs")
    out = tmp_path / "out"
    read_log = batch_task.read_log

    def read_after_a_write(log: str, *args: Any, **kwargs: Any) -> Any:
        if Path(log).name == "s1.csv":  # written on after the batch hashed it
            write_table(Path(log), tank_run(steps=40, seed=9).columns, force=True)
        return read_log(log, *args, **kwargs)

    monkeypatch.setattr(batch_task, "read_log", read_after_a_write)
    outcome = run_batch(logs, TANK, out_dir=out, estimator="imm")

    by_name = {Path(o.log).name: o for o in outcome.logs}
    assert by_name["s2.csv"].status == "done"
    s1 = by_name["s1.csv"]
    assert s1.status == "failed"
    assert s1.error is not None and "s1.csv" in s1.error and "changed while" in s1.error
    assert not (out / "s1.csv").exists()

    monkeypatch.setattr(batch_task, "read_log", read_log)  # the log finished: analysed as it is now
    again = run_batch(logs, TANK, out_dir=out, estimator="imm")
    assert {Path(o.log).name: o.status for o in again.logs} == {
        "s1.csv": "done",
        "s2.csv": "skipped",
    }
