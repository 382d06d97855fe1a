"""A log on a Dask worker is checked against the worker's ``memory_limit``, not the machine's.

A batch on ``dask worker --memory-limit 400MB`` with a smoothed 600,000-sample log (0.4 GB)
passed the check against the machine's free memory; the nanny killed the worker past 95 % of
its limit, Dask retried the log on 4 workers, killing each, and the small log queued on the
same worker failed with it: two rows "worker process died (... KilledWorker ...)".  The log
that cannot fit is now refused with one line naming the limit, and the others run.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from pathlib import Path

import pytest

from hybridlog.errors import LogError
from hybridlog.io.writers import write_table
from hybridlog.jobs import dask_backend
from hybridlog.jobs.batch import run_batch
from hybridlog.jobs.dask_backend import WorkerMemory, worker_reserved
from tests.support.logfiles import tank_run

MB = 1_000_000


def _hold(
    need: int,
    memory: WorkerMemory,
    read_memory: Callable[[], WorkerMemory | None] = dask_backend.worker_memory,
) -> contextlib.AbstractContextManager[float]:
    return worker_reserved(
        [("the estimates", need)],
        memory,
        what="run.csv: 10 samples through imm",
        remedy="analyse a shorter log",
        error=LogError,
        read_memory=read_memory,
    )


def test_a_log_over_the_workers_limit_is_refused_naming_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(dask_backend, "available_memory", lambda: 64_000 * MB)
    memory = WorkerMemory(limit=90 * MB, fraction=0.95, used=50 * MB)
    with pytest.raises(LogError) as refused, _hold(40 * MB, memory):
        pass  # 35.5 MB left before the nanny stops it
    assert str(refused.value) == (
        "run.csv: 10 samples through imm would need about 40.0 MB of memory and 35.5 MB is "
        "available; analyse a shorter log, or Dask workers with more memory (this one: "
        "memory_limit 90.0 MB, stopped past 95%, 50.0 MB in use)"
    )
    with _hold(35 * MB, memory) as waited:
        assert waited == 0.0  # not a log that waited (the batch notes those)
        assert list(dask_backend._HELD.values()) == [35 * MB]
    assert not dask_backend._HELD


def test_a_log_that_fits_alone_waits_for_the_workers_other_logs(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(dask_backend, "available_memory", lambda: None)
    memory = WorkerMemory(limit=400 * MB, fraction=1.0, used=200 * MB)
    with contextlib.ExitStack() as first:
        first.enter_context(_hold(150 * MB, memory))

        def others_done() -> WorkerMemory:
            first.close()  # the other thread's log ends while this one waits
            return memory

        with _hold(150 * MB, memory, read_memory=others_done) as waited:
            assert waited > 0.0
            assert list(dask_backend._HELD.values()) == [150 * MB]
    assert not dask_backend._HELD


def test_a_dask_batch_checks_each_log_against_the_workers_limit(tmp_path: Path) -> None:
    distributed = pytest.importorskip("distributed")
    import dask

    log = write_table(tmp_path / "logs" / "s1.csv", tank_run(steps=20, seed=1).columns)
    # a limit the worker (threads of this process) is over already; never paused or killed
    never = {f"distributed.worker.memory.{k}": False for k in ("target", "spill", "pause")}
    with (
        dask.config.set({**never, "distributed.worker.memory.terminate": False}),
        distributed.LocalCluster(
            n_workers=1,
            threads_per_worker=1,
            processes=False,
            protocol="tcp",
            host="127.0.0.1",
            dashboard_address=":0",  # any free port: 8787 may be taken (by a scheduler)
            memory_limit="10MB",
        ) as cluster,
    ):
        outcome = run_batch(
            [log],
            "three_tank_hstf",
            out_dir=tmp_path / "out",
            estimator="imm",
            scheduler=cluster.scheduler_address,
        )
    (row,) = outcome.logs
    assert row.status == "failed"
    assert "is available; analyse a shorter log" in (row.error or "")
    assert "(this one: memory_limit 10.0 MB, " in (row.error or "")
    assert "stopped past" not in (row.error or "")  # terminate is off: never stopped
    assert not (tmp_path / "out" / "s1.csv").exists()
