"""Batch workers forked from a warm forkserver: warm, single-threaded forks, robust.

Each worker starts with numba's CPU target set up and the filters imported (the forkserver
imported :mod:`hybridlog.jobs.worker_warmup`), from a forkserver that has no thread but its
main one when it forks and never imported polars; a worker that dies fails only its task
and a fresh one takes the rest; workers see the caller's current environment and folder;
a worker with nothing left to do ends while the others finish; nothing outlives a killed
caller.
"""

from __future__ import annotations

import contextlib
import gc
import os
import signal
import subprocess
import sys
import textwrap
import time
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import pytest

from hybridlog.jobs.workers import POLARS_THREADS, STOP_GRACE_S, WARMUP, WorkerPool
from tests.support.processes import alive, descendants, kill_and_expect_the_family_gone


def _facts(_: int) -> dict[str, Any]:
    """What a worker had when its task started (this module imports no polars or numba)."""
    facts: dict[str, Any] = {
        "pid": os.getpid(),
        "forkserver": os.getppid(),
        "warmup": WARMUP in sys.modules,
        "polars": "polars" in sys.modules,
        "numba": "numba" in sys.modules,
        "task": "hybridlog.jobs.batch_task" in sys.modules,  # a batch's, analysing a log
        "planning": "hybridlog.jobs.batch_plan" in sys.modules,  # the batch process's only
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
        assert facts["warmup"] and facts["numba"] and facts["cpu_target"] and facts["task"]
        assert not facts["polars"] and not facts["planning"]
        # OpenBLAS's pools (numpy's and scipy's) stop before each fork and are not restarted
        assert facts["forkserver_threads"] == 1


def _pid(_: int) -> int:
    return os.getpid()


def test_as_many_tasks_as_workers_run_in_different_workers() -> None:
    # the first worker was given QUEUED tasks before the next got any: a batch of two logs
    # with --jobs 2 ran both in one worker, one after the other
    for jobs in (2, 3):
        with WorkerPool(jobs) as pool:
            pids = pool.run(_pid, [(k,) for k in range(jobs)], died=_died)
        assert len(set(pids)) == jobs, pids


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


def _ctrl_c_after_polars(folder: str) -> tuple[bool, int]:
    """Ctrl-C reaching a worker that imported polars (which installs a SIGINT handler of its
    own, aborting running queries), then a polars query."""
    import polars as pl

    os.kill(os.getpid(), signal.SIGINT)
    pl.DataFrame({"a": [1, 2]}).lazy().sink_csv(Path(folder, "a.csv"))
    return signal.SIGINT in signal.sigpending(), len(Path(folder, "a.csv").read_text())


def test_ctrl_c_never_reaches_a_worker_not_even_through_polars(tmp_path: Path) -> None:
    """The pool's process decides what Ctrl-C stops: it stays pending in its workers."""
    with WorkerPool(1) as pool:
        (result,) = pool.run(_ctrl_c_after_polars, [(str(tmp_path),)], died=_died)
    assert result == (True, len("a\n1\n2\n"))


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


STAGING_CALLER = """
import sys
from hybridlog.jobs.workers import WorkerPool
from tests.jobs.test_workers import _died, _stage_and_sleep

with WorkerPool(2) as pool:
    pool.run(_stage_and_sleep, [(sys.argv[1],)] * 4, died=_died)  # two queued per worker
"""


def _stage_and_sleep(folder: str) -> None:
    """A task that removes what it wrote when it unwinds (as a report's temporary folder)."""
    staged = Path(folder, str(os.getpid()))
    staged.touch()
    try:
        time.sleep(120)
    finally:
        staged.unlink()


def test_workers_of_a_killed_caller_unwind_their_tasks(tmp_path: Path) -> None:
    """``kill -9`` of the caller runs no clean-up there; its workers still run their tasks'."""
    root = Path(__file__).resolve().parents[2]
    caller = subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(STAGING_CALLER), str(tmp_path)], cwd=root
    )
    try:
        deadline = time.monotonic() + 120
        while len(list(tmp_path.iterdir())) < 2 and time.monotonic() < deadline:
            time.sleep(0.05)
        assert len(list(tmp_path.iterdir())) == 2, "the workers never started"
        kill_and_expect_the_family_gone(caller, descendants(caller.pid))
        assert list(tmp_path.iterdir()) == []
    finally:
        if caller.poll() is None:
            caller.kill()
            caller.wait()


def _stubborn(folder: str, index: int) -> int:
    """Task 0 ignores SIGTERM (as a compiled loop that never returns to Python would)."""
    if index == 0:
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        Path(folder, str(os.getpid())).touch()
        time.sleep(120)
    deadline = time.monotonic() + 120
    while not any(Path(folder).iterdir()) and time.monotonic() < deadline:
        time.sleep(0.01)
    return index


class _InterruptedError(Exception):
    pass


def test_leaving_the_pool_on_an_error_kills_a_stuck_worker_then_cleans_up(tmp_path: Path) -> None:
    """A worker that does not end on SIGTERM is killed after the grace period; ``clean_up``
    runs once every worker has ended (it removes what they left)."""
    ended: list[tuple[bool, bool]] = []

    def clean_up(workers: Sequence[int]) -> None:
        stuck = {int(p.name) for p in tmp_path.iterdir()}
        ended.append((stuck <= set(workers), not any(alive(pid) for pid in workers)))

    def done(result: int) -> None:
        raise _InterruptedError  # the caller fails while task 0 runs (a Ctrl-C)

    started = time.monotonic()
    with pytest.raises(_InterruptedError), WorkerPool(2, clean_up=clean_up) as pool:
        # task 0 (and 1, queued behind it) to one worker, 2 and 3 to the other
        pool.run(_stubborn, [(str(tmp_path), k) for k in range(4)], died=_died, done=done)
    assert ended == [(True, True)]
    assert STOP_GRACE_S <= time.monotonic() - started < 60


INTERRUPTED_CALLER = """
import os, signal, sys, threading, time
from pathlib import Path
from hybridlog.jobs.workers import WorkerPool
from tests.jobs.test_workers import _died, _stage_and_translate

folder = Path(sys.argv[1])

def interrupt() -> None:  # Ctrl-C to this process once both workers are in their tasks
    while len(list(folder.iterdir())) < 2:
        time.sleep(0.01)
    os.kill(os.getpid(), signal.SIGINT)

threading.Thread(target=interrupt, daemon=True).start()
try:
    with WorkerPool(2) as pool:
        pool.run(_stage_and_translate, [(str(folder),)] * 4, died=_died)
except KeyboardInterrupt:
    print("interrupted")
"""


def _stage_and_translate(folder: str) -> None:
    """A task whose library turns the stop into another exception, talking as it does."""
    staged = Path(folder, str(os.getpid()))
    staged.touch()
    try:
        time.sleep(120)
    except BaseException:  # as polars does with what a signal handler raises in its check
        print("thread 'async-executor-0' panicked", file=sys.stderr, flush=True)
        raise KeyboardInterrupt from None
    finally:
        staged.unlink()


def test_a_stopped_worker_ends_silently_whatever_its_task_raises(tmp_path: Path) -> None:
    """Ctrl-C of the caller: each worker unwinds its task and ends without a word, even when
    the task ends with another exception than the stop's and prints while unwinding."""
    root = Path(__file__).resolve().parents[2]
    done = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(INTERRUPTED_CALLER), str(tmp_path)],
        cwd=root,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert (done.stdout, done.stderr) == ("interrupted\n", "")
    assert list(tmp_path.iterdir()) == []


def test_a_temporary_folder_too_long_for_the_workers_socket_is_one_line(tmp_path: Path) -> None:
    # the forkserver's socket goes in TMPDIR: a long path was a traceback and exit code 1
    from tests.support.paths import ROOT, SAMPLE_LOGS

    long = tmp_path / ("t" * 120)
    long.mkdir()
    logs = [str(SAMPLE_LOGS / name) for name in ("three_tank_hstf.csv", "ice_clutch.csv")]
    done = subprocess.run(
        [sys.executable, "-m", "hybridlog", "batch", *logs, "--model", "three_tank_hstf",
         "--out", str(tmp_path / "out"), "--jobs", "2"],
        cwd=ROOT, capture_output=True, text=True, timeout=120,
        env={**os.environ, "TMPDIR": str(long)},
    )  # fmt: skip
    assert done.returncode == 2, done.stderr
    assert (
        done.stderr.startswith(
            "hybridlog: error: --jobs: cannot start the worker processes: AF_UNIX path too long"
        )
        and done.stderr.count("\n") == 1
    ), done.stderr
    assert "set TMPDIR to a shorter writable folder, or use --jobs 1" in done.stderr
    assert not (tmp_path / "out").exists()


def _told_wait(folder: str, index: int, fail: bool) -> int:
    """A task whose work is told as a wait (as a model's first compiling is), begun by the
    pool's every task before any ends (each waits for the others' marks), failing if asked."""
    from hybridlog.cluster.progress import current_reporter

    reporter = current_reporter()
    assert reporter is not None
    here = Path(folder)
    try:
        with reporter.wait("imm: compiling", "first run"):
            (here / str(index)).touch()
            deadline = time.monotonic() + 30
            while len(list(here.iterdir())) < 2 and time.monotonic() < deadline:
                time.sleep(0.01)
            # both begins are written now, on two pipes the pool reads in no set order: give
            # it time to read the other's before this end (under load it once read them apart)
            time.sleep(0.5)
            if fail:
                raise ValueError("no machine code")
    except ValueError:
        return -1
    return index


class _Told:
    """The pool's side of the waits: what it was told, in order."""

    def __init__(self) -> None:
        self.events: list[str] = []

    @contextlib.contextmanager
    def wait(self, what: str, why: str) -> Iterator[None]:
        self.events.append(f"begin {what} ({why})")
        try:
            yield
        except BaseException:
            self.events.append("failed")
            raise
        self.events.append("ended")


@pytest.mark.parametrize(("fails", "last"), [((False, False), "ended"), ((True, True), "failed")])
def test_the_workers_waits_are_held_once_in_the_pools_process(
    tmp_path: Path, fails: tuple[bool, bool], last: str
) -> None:
    # batch's workers compiled a model's machine code for 10-20 s under a bar at 0/N: their
    # waits are the pool's to say, once for the workers doing the same work side by side;
    # a work that failed in every worker is said to have failed (no "done")
    told = _Told()
    tasks = [(str(tmp_path), index, fail) for index, fail in enumerate(fails)]
    with WorkerPool(2) as pool:
        results = pool.run(_told_wait, tasks, died=_died, wait=told.wait)
    assert results == [-1 if fail else index for index, fail in enumerate(fails)]
    assert told.events == ["begin imm: compiling (first run)", last]


def _told_wait_or_die(folder: str) -> int:
    from hybridlog.cluster.progress import current_reporter

    reporter = current_reporter()
    assert reporter is not None
    with reporter.wait("imm: compiling", "first run"):
        os.kill(os.getpid(), signal.SIGKILL)
    return 0


def test_a_wait_of_a_worker_that_dies_ends_as_failed(tmp_path: Path) -> None:
    told = _Told()
    with WorkerPool(1) as pool:
        results = pool.run(_told_wait_or_die, [(str(tmp_path),)], died=_died, wait=told.wait)
    assert results == [{"died": "killed by signal SIGKILL"}]
    assert told.events == ["begin imm: compiling (first run)", "failed"]


def _collector(_: int) -> dict[str, Any]:
    return {
        "pid": os.getpid(),
        "enabled": gc.isenabled(),
        "frozen": gc.get_freeze_count(),
        "full_passes": gc.get_stats()[2]["collections"],
    }


def test_the_warm_up_and_a_workers_first_task_run_without_the_collector() -> None:
    # the forkserver's warm-up, on the path of every batch before its first log, spent
    # 0.07 s of its 0.6 s in the collector's passes over objects that all live on
    with WorkerPool(1) as pool:
        first, second = pool.run(_collector, [(0,), (1,)], died=_died)
    assert first["pid"] == second["pid"]
    assert first["frozen"] > 10_000  # the warm-up's objects, walked by no worker's collector
    assert first["full_passes"] == 0  # none in the forkserver (inherited by the fork) either
    assert not first["enabled"]  # its imports (polars, the report's writer), one log
    assert second["enabled"]  # the logs after it collected as usual


def _first_or_alone(index: int) -> tuple[int, bool]:
    """Task 0 ends at once; task 1 waits (5 s at most) until no other worker is left."""
    if index == 0:
        return os.getpid(), True
    deadline = time.monotonic() + 5.0
    while time.monotonic() < deadline:
        if not set(descendants(os.getppid())) - {os.getpid()}:
            return os.getpid(), True
        time.sleep(0.01)
    return os.getpid(), False


def test_a_worker_with_nothing_left_ends_while_the_others_finish() -> None:
    # it ended only when the pool was left, after the last log: at the batch's end
    with WorkerPool(2) as pool:
        results = pool.run(_first_or_alone, [(0,), (1,)], died=_died)
        assert [alone for _, alone in results] == [True, True]
        # tasks given afterwards go to new workers, not to the ones let go
        again = pool.run(_pid, [(0,), (1,)], died=_died)
    assert all(isinstance(pid, int) for pid in again)
    assert not set(again) & {pid for pid, _ in results}
