"""``batch --scheduler``: each log's memory checked against its Dask worker's memory limit.

Each log was checked as if it ran alone on the machine: a log bigger than its worker's
``memory_limit`` was let through, and Dask's nanny then restarted the worker ("worker process
died"); two threads of one worker each let a log through that fitted only alone.
"""

from __future__ import annotations

import threading
import time
from pathlib import Path

import pytest

import hybridlog.memory as memory
from hybridlog.errors import LogError
from hybridlog.io.writers import write_table
from hybridlog.jobs.batch import run_batch
from hybridlog.memory import reserved, shared_between_threads
from tests.support.logfiles import tank_run

distributed = pytest.importorskip("distributed")
dask_config = pytest.importorskip("dask.config")


def test_a_log_beyond_its_dask_workers_limit_fails_naming_it(tmp_path: Path) -> None:
    logs = [
        write_table(tmp_path / "logs" / f"s{k}.csv", tank_run(steps=40, seed=k).columns)
        for k in (1, 2)
    ]
    # this process holds more than 100 MB already: no log fits below the worker's limit
    # (Dask's own pausing and spilling are off, or the worker would take no task at all)
    no_dask_memory_rules = {
        f"distributed.worker.memory.{rule}": False
        for rule in ("target", "spill", "pause", "terminate")
    }
    with (
        dask_config.set(no_dask_memory_rules),
        distributed.LocalCluster(
            n_workers=1,
            threads_per_worker=2,
            processes=False,
            protocol="tcp",
            host="127.0.0.1",
            dashboard_address=None,
            memory_limit="100MB",
        ) as cluster,
    ):
        outcome = run_batch(
            logs,
            "three_tank_hstf",
            out_dir=tmp_path / "out",
            estimator="imm",
            scheduler=cluster.scheduler_address,
        )
    assert [o.status for o in outcome.logs] == ["failed", "failed"]
    for log in outcome.logs:
        assert "of memory" in (log.error or "")
        assert "to this Dask worker (memory limit 0.1 GB)" in (log.error or "")
    # the same logs on their own, with no Dask worker's limit: analysed
    alone = run_batch(logs, "three_tank_hstf", out_dir=tmp_path / "alone", estimator="imm")
    assert [o.status for o in alone.logs] == ["done", "done"]


def test_threads_sharing_a_limit_run_side_by_side_only_what_fits(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(memory, "available_memory", lambda: 10**12)  # the machine: plenty
    monkeypatch.setattr(memory, "WAIT_POLL_S", 0.005)
    limit = 100  # what the worker may still take

    def room() -> int:
        return limit

    order: list[str] = []
    first_in = threading.Event()

    def run(name: str, hold_s: float) -> None:
        with (
            shared_between_threads(2, room, limited_by=" to this worker"),
            reserved([("arrays", 60)], what=name, remedy="", error=LogError) as waited,
        ):
            order.append(f"{name} in after {waited:.2f}")
            first_in.set()
            time.sleep(hold_s)
            order.append(f"{name} out")

    a = threading.Thread(target=run, args=("a", 0.2))
    a.start()
    first_in.wait()
    b = threading.Thread(target=run, args=("b", 0.0))
    b.start()
    a.join()
    b.join()
    assert order[:2] == ["a in after 0.00", "a out"]  # b waited: 60 + 60 > 100
    assert order[2].startswith("b in after") and order[2] != "b in after 0.00"
    # one that cannot fit even alone is refused, naming the limit
    with (
        pytest.raises(LogError, match=r"and 100 B|available to this worker"),
        shared_between_threads(2, room, limited_by=" to this worker"),
        reserved([("arrays", 200)], what="c", remedy="shorter", error=LogError),
    ):
        pass
    # outside the block, a thread checks against the machine alone
    with reserved([("arrays", 200)], what="d", remedy="", error=LogError) as waited:
        assert waited == 0.0
