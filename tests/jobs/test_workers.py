"""Batch workers forked from a warm forkserver: warm, single-threaded forks, robust.

Each worker starts with numba's CPU target set up and the filters imported (the forkserver
imported :mod:`hybridlog.jobs.worker_warmup`), from a forkserver that has no thread but its
main one when it forks and never imported polars; a worker that dies fails only its task
and a fresh one takes the rest; workers see the caller's current environment and folder;
nothing outlives a killed caller.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path
from typing import Any

import pytest

from hybridlog.jobs.workers import POLARS_THREADS, WARMUP, WorkerPool
from tests.support.processes import descendants, kill_and_expect_the_family_gone


def _facts(_: int) -> dict[str, Any]:
    """What a worker had when its task started (this module imports no polars or numba)."""
    facts: dict[str, Any] = {
        "pid": os.getpid(),
        "forkserver": os.getppid(),
        "warmup": WARMUP in sys.modules,
        "polars": "polars" in sys.modules,
        "numba": "numba" in sys.modules,
        "forkserver_threads": len(os.listdir(f"/proc/{os.getppid()}/task")),
        "variable": os.environ.get("HYBRIDLOG_TEST_VARIABLE"),
        "cwd": os.getcwd(),
    }
    if facts["numba"]:
        from numba.core import registry

        # numba's CPU target keeps its contexts once set up (jit.set_up did it)
        facts["cpu_target"] = "_toplevel_target_context" in vars(registry.cpu_target)
    return facts


def _facts_or_die(index: int) -> dict[str, Any]:
    if index == 1:
        os.kill(os.getpid(), signal.SIGKILL)
    return _facts(index)


def _died(index: int, reason: str) -> dict[str, Any]:
    return {"died": reason}


def test_workers_start_warm_from_a_single_threaded_forkserver_without_polars() -> None:
    with WorkerPool(2) as pool:
        results = pool.run(_facts, [(k,) for k in range(4)], died=_died)
    assert len({r["pid"] for r in results}) == 2
    assert len({r["forkserver"] for r in results}) == 1
    for facts in results:
        assert facts["warmup"] and facts["numba"] and facts["cpu_target"]
        assert not facts["polars"]
        # OpenBLAS's pools (numpy's and scipy's) stop before each fork and are not restarted
        assert facts["forkserver_threads"] == 1


def test_a_worker_killed_mid_task_is_replaced_by_a_warm_one() -> None:
    with WorkerPool(1) as pool:
        results = pool.run(_facts_or_die, [(k,) for k in range(4)], died=_died)
    assert results[1] == {"died": "killed by signal SIGKILL"}
    first, rest = results[0], results[2:]
    # the task queued behind the killed one ran in the new worker, as did the others
    assert {r["pid"] for r in rest} != {first["pid"]}
    assert len({r["pid"] for r in rest}) == 1
    assert {r["forkserver"] for r in rest} == {first["forkserver"]}
    assert all(r["numba"] and r["cpu_target"] for r in rest)


def test_workers_see_the_callers_current_environment_and_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    with WorkerPool(1) as pool:  # the forkserver may run already, started elsewhere
        (before,) = pool.run(_facts, [(0,)], died=_died)
    monkeypatch.setenv("HYBRIDLOG_TEST_VARIABLE", "changed")
    monkeypatch.chdir(tmp_path)
    with WorkerPool(1) as pool:
        (after,) = pool.run(_facts, [(0,)], died=_died)
    assert after["forkserver"] == before["forkserver"]
    assert (before["variable"], after["variable"]) == (None, "changed")
    assert after["cwd"] == str(tmp_path)


def _polars_threads(_: int) -> tuple[str | None, int]:
    import polars as pl

    return os.environ.get(POLARS_THREADS), pl.thread_pool_size()


def test_each_workers_polars_gets_its_share_of_the_cores(monkeypatch: pytest.MonkeyPatch) -> None:
    """Two workers on N cores: N // 2 polars threads each, not N each; the caller's wins."""
    monkeypatch.delenv(POLARS_THREADS, raising=False)
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    share = max(1, (cores or 1) // 2)
    with WorkerPool(2) as pool:
        results = pool.run(_polars_threads, [(k,) for k in range(4)], died=_died)
    assert set(results) == {(str(share), share)}
    monkeypatch.setenv(POLARS_THREADS, "3")
    with WorkerPool(2) as pool:
        (result,) = pool.run(_polars_threads, [(0,)], died=_died)
    assert result == ("3", 3)


KILLED_CALLER = """
import sys
from hybridlog.jobs.workers import WorkerPool
from tests.jobs.test_workers import _died, _sleep

with WorkerPool(2) as pool:
    pool.run(_sleep, [(sys.argv[1],)] * 4, died=_died)  # two queued per worker
"""


def _sleep(folder: str) -> None:
    Path(folder, str(os.getpid())).touch()
    time.sleep(120)


def test_workers_forkserver_and_tracker_die_with_a_killed_caller(tmp_path: Path) -> None:
    root = Path(__file__).resolve().parents[2]
    caller = subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(KILLED_CALLER), str(tmp_path)], cwd=root
    )
    try:
        deadline = time.monotonic() + 120
        while len(list(tmp_path.iterdir())) < 2 and time.monotonic() < deadline:
            time.sleep(0.05)
        workers = {int(p.name) for p in tmp_path.iterdir()}
        assert len(workers) == 2, "the workers never started"
        family = descendants(caller.pid)
        assert workers <= set(family)
        kill_and_expect_the_family_gone(caller, family)
    finally:
        if caller.poll() is None:
            caller.kill()
            caller.wait()
