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
    monkeypatch.setattr(batch, "usable_cores", lambda: 1_000)
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


def test_jobs_auto_is_named_auto_in_notes_and_errors(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``--jobs auto`` was the core count by the time the batch saw it: a 2-core machine
    refused "--jobs 2: has no effect with --scheduler" (a 1-core one took it), and one log
    gave the note "--jobs 2: 1 log, so 1 at once" for a number the user never wrote."""
    import hybridlog.errors as errors

    monkeypatch.setattr(batch, "usable_cores", lambda: 1)
    with pytest.raises(errors.OptionError, match=r"^--jobs auto: has no effect with --scheduler"):
        run_batch([], "three_tank_hstf", out_dir=tmp_path / "o", jobs="auto", scheduler="tcp://x:1")
    monkeypatch.setattr(batch, "usable_cores", lambda: 4)
    monkeypatch.setattr(batch, "available_memory", lambda: 3 * WORKER_BASELINE_BYTES + 1)
    assert pool_size(2, 1, auto=True) == (1, [])  # fewer logs than cores: said by no note
    assert pool_size(4, 10, auto=True)[1] == [
        "--jobs auto (4 cores): 3 worker processes, as many as the memory available (0.5 GB) "
        "holds at about 150 MB each before their logs"
    ]


def test_jobs_keep_the_notes_on_the_logs_found(tmp_path: Path) -> None:
    """With ``--jobs 2`` the notes on the logs found (a hidden log skipped) were replaced by
    the workers' cap, so the hidden log's note was said with ``--jobs 1`` only."""
    folder = tmp_path / "logs"
    for name in ("s1.csv", ".s2.csv"):
        write_table(folder / name, tank_run(steps=20, seed=1).columns)
    outcome = run_batch(
        [folder], "three_tank_hstf", out_dir=tmp_path / "out", estimator="imm", jobs=2
    )
    assert [o.status for o in outcome.logs] == ["done"]
    assert len(outcome.notes) == 2
    assert "'.' was skipped" in outcome.notes[0]
    assert outcome.notes[1] == "--jobs 2: 1 log, so 1 at once"


def test_more_workers_than_cores_are_said_to_slow_the_batch(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """``--jobs 64`` on 2 cores took 35 s where ``--jobs 2`` took 5 s, without a word."""
    monkeypatch.setattr(batch, "usable_cores", lambda: 2)
    monkeypatch.setattr(batch, "available_memory", lambda: None)
    assert pool_size(2, 100) == (2, [])
    assert pool_size(64, 3) == (3, ["--jobs 64: 3 logs, so 3 at once", _slower("64", 3)])
    assert pool_size(64, 100) == (64, [_slower("64", 64)])
    monkeypatch.setattr(batch, "usable_cores", lambda: 1)
    assert pool_size(2, 100) == (2, [_slower("2", 2, cores="1 core")])


def _slower(asked: str, size: int, cores: str = "2 cores") -> str:
    return (
        f"--jobs {asked}: {size} worker processes on {cores}: each sets up its own compiler "
        "and imports (about 150 MB) and the logs share the cores, so more workers than cores "
        "make a batch slower, not faster (--jobs auto: one per core)"
    )
