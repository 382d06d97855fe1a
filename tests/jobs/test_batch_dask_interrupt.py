"""An interrupted Dask batch leaves the cluster writing nothing more into ``--out``.

Ctrl-C in ``hybridlog batch --scheduler`` ended the client, but the tasks already running
on the workers went on and published their report folders into ``--out`` after the batch
had exited 130 (after a CI job was cancelled and its folder cleaned, say).  The client now
sets the batch's stop event before it lets go of the tasks: a running task stops before its
next chunk, its temporary folder removed (``s3.csv`` here); one that had not begun its log
never starts it (``s2.csv``).
"""

from __future__ import annotations

import threading
from pathlib import Path

import pytest

from hybridlog.io.writers import write_table
from hybridlog.jobs import batch, batch_task, dask_backend
from hybridlog.jobs.batch import run_batch
from hybridlog.jobs.batch_job import BatchJob
from hybridlog.jobs.batch_outcomes import LogOutcome
from tests.support.logfiles import tank_run

distributed = pytest.importorskip("distributed")

RELEASE = threading.Event()
"""Lets the held logs' tasks go on (the workers are threads of this process)."""
HELD_S = 240.0
"""How long a held task waits for the release at most: only a guard against a hang.  At 30 s
the held tasks went on by themselves under a loaded machine (the first log, whose outcome
interrupts the batch, took longer than that) and published reports the test then found."""
ENDED = threading.Semaphore(0)
"""Released by each held task as it returns."""
ANALYZE = batch.analyze_log


READ = batch_task.read_log


def held_analysis(job: BatchJob, log: str, folder: str) -> LogOutcome:
    """The batch's task; ``s2.csv`` held before it starts, ``s3.csv`` while its log is read."""
    if Path(log).name == "s1.csv":
        return ANALYZE(job, log, folder)
    if Path(log).name == "s2.csv":
        RELEASE.wait(timeout=HELD_S)
    try:
        return ANALYZE(job, log, folder)
    finally:
        ENDED.release()


def held_reading(log: str, *args: object) -> object:
    """The log read; ``s3.csv``'s held until the test releases it (then it is streamed)."""
    if Path(log).name == "s3.csv":
        RELEASE.wait(timeout=HELD_S)
    return READ(log, *args)  # type: ignore[arg-type]


def test_an_interrupted_dask_batch_publishes_no_report_after_it_ended(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    logs = [
        write_table(tmp_path / "logs" / f"s{k}.csv", tank_run(steps=40, seed=k).columns)
        for k in (1, 2, 3)
    ]
    RELEASE.clear()
    monkeypatch.setattr(batch, "analyze_log", held_analysis)
    monkeypatch.setattr(batch_task, "read_log", held_reading)
    request_stop = getattr(dask_backend, "_request_stop", None)

    def stop_then_release(*args: object) -> None:
        if request_stop is not None:
            request_stop(*args)
        RELEASE.set()  # the held tasks go on only once the batch was stopped

    monkeypatch.setattr(dask_backend, "_request_stop", stop_then_release, raising=False)

    def interrupt(outcome: LogOutcome) -> None:
        assert Path(outcome.log).name == "s1.csv"
        raise KeyboardInterrupt  # Ctrl-C as the first log's outcome arrives

    out = tmp_path / "out"
    with distributed.LocalCluster(
        n_workers=1,
        threads_per_worker=3,  # all three logs start at once
        processes=False,
        protocol="tcp",
        host="127.0.0.1",
        dashboard_address=":0",  # any free port: 8787 may be taken (by a scheduler)
    ) as cluster:
        with pytest.raises(KeyboardInterrupt):
            run_batch(
                logs,
                "three_tank_hstf",
                out_dir=out,
                estimator="imm",
                scheduler=cluster.scheduler_address,
                progress=interrupt,
            )
        RELEASE.set()
        for _ in (2, 3):  # the held tasks have returned: whatever they wrote is there
            assert ENDED.acquire(timeout=HELD_S)
    assert (out / "s1.csv" / "report.json").is_file()
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == ["s1.csv"]
    assert not [p for p in out.iterdir() if ".hybridlog-tmp" in p.name]
    assert not (out / "summary.md").exists()  # an interrupted batch writes no summary
