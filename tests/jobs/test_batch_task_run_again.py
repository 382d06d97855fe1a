"""A log's task run twice in one batch (Dask recomputes a result lost with its worker)."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

import hybridlog.jobs.batch as batch
from hybridlog.io.writers import write_table
from hybridlog.jobs.batch import run_batch
from hybridlog.jobs.batch_job import BatchJob
from hybridlog.jobs.batch_outcomes import LogOutcome
from tests.support.logfiles import tank_run


def test_a_task_run_again_in_the_same_batch_is_done_and_a_later_run_skips_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """On Dask, a worker that died before the client collected a finished log's result
    made the scheduler run that log's task again elsewhere: it found the report its first
    run had just written and the log read ``skipped`` in summary.csv (``1 analysed, 1
    skipped (unchanged)``), where ``--jobs 1`` said ``done`` of the same logs."""
    logs = [
        write_table(tmp_path / "logs" / f"s{k}.csv", tank_run(steps=30, seed=k).columns)
        for k in (1, 2)
    ]
    analyze = batch.analyze_log

    def twice(job: BatchJob, log: str, folder: str) -> LogOutcome:
        analyze(job, log, folder)  # the result Dask lost with its worker
        return analyze(job, log, folder)

    monkeypatch.setattr(batch, "analyze_log", twice)
    out = tmp_path / "out"
    first = run_batch(logs, "three_tank_hstf", out_dir=out, estimator="imm")
    assert [o.status for o in first.logs] == ["done", "done"]
    with (out / "summary.csv").open(encoding="utf-8", newline="") as file:
        assert [row["status"] for row in csv.DictReader(file)] == ["done", "done"]
    monkeypatch.setattr(batch, "analyze_log", analyze)
    again = run_batch(logs, "three_tank_hstf", out_dir=out, estimator="imm")
    assert [o.status for o in again.logs] == ["skipped", "skipped"]  # another run: resumed
