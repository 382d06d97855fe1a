"""``--jobs N`` beyond the logs or the memory: capped, with a note, not N processes started.

``--jobs 500`` forked a worker per log up to 500 (each 70-150 MB before its first log): the
kernel's out-of-memory killer or swapping, not a batch.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

import hybridlog.jobs.batch as batch
import hybridlog.jobs.workers as workers
from hybridlog.io.writers import write_table
from hybridlog.jobs.batch import WORKER_BASELINE_BYTES, pool_size, run_batch
from tests.support.logfiles import tank_run


def test_jobs_are_capped_by_the_memory_the_workers_need(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(batch, "available_memory", lambda: 3 * WORKER_BASELINE_BYTES + 1)
    size, notes = pool_size(500, 1000)
    assert size == 3
    assert notes == [
        "--jobs 500: 3 worker processes, as many as the memory available (0.5 GB) holds "
        "at about 150 MB each before their logs"
    ]
    assert pool_size(2, 1000) == (2, [])  # what fits is left alone
    monkeypatch.setattr(batch, "available_memory", lambda: 1)
    assert pool_size(4, 10)[0] == 1  # never fewer than one
    monkeypatch.setattr(batch, "available_memory", lambda: None)  # the system says nothing
    assert pool_size(500, 1000) == (500, [])


def test_a_batch_starts_no_more_workers_than_logs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    logs = [
        write_table(tmp_path / "logs" / f"s{k}.csv", tank_run(steps=20, seed=k).columns)
        for k in (1, 2)
    ]
    sizes: list[int] = []
    original = workers.WorkerPool.__init__

    def recorded(self: workers.WorkerPool, jobs: int, **kwargs: Any) -> None:
        sizes.append(jobs)
        original(self, jobs, **kwargs)

    monkeypatch.setattr(workers.WorkerPool, "__init__", recorded)
    outcome = run_batch(
        logs, "three_tank_hstf", out_dir=tmp_path / "out", estimator="imm", jobs=500
    )
    assert sizes == [2]
    assert [o.status for o in outcome.logs] == ["done", "done"]
    assert outcome.notes == ["--jobs 500: 2 logs, so 2 at once"]
