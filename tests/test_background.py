"""hybridlog.background: a function in a thread or a worker process, its value or error back."""

from __future__ import annotations

import os
import signal
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from hybridlog import background
from hybridlog.background import Background, Task, Worker, beside, forked
from hybridlog.errors import ReportError


def test_the_value_comes_back_from_another_thread() -> None:
    ran_in: list[threading.Thread] = []

    def work() -> int:
        ran_in.append(threading.current_thread())
        return 42

    task = Background(work, "test")
    assert task.result() == 42
    assert ran_in and ran_in[0] is not threading.current_thread()


def test_the_error_is_raised_in_the_caller_and_wait_only_waits() -> None:
    def fail() -> None:
        raise ValueError("bad log")

    task = Background(fail, "test")
    task.wait()  # the clean-up path: no error from here
    with pytest.raises(ValueError, match="bad log"):
        task.result()


def _pid_and_sum(values: list[int]) -> tuple[int, int]:
    return os.getpid(), sum(values)


def _fail(message: str) -> None:
    raise ReportError(message)


class UnpicklableError(Exception):
    def __reduce__(self) -> object:
        raise TypeError("no")


def _fail_unpicklably() -> None:
    raise UnpicklableError("odd")


def _die() -> None:
    os.kill(os.getpid(), signal.SIGKILL)


@pytest.fixture
def worker() -> Iterator[Worker]:
    started = Worker("test")
    yield started
    started.close()


def test_a_worker_runs_functions_in_its_own_process_and_sends_the_values_back(
    worker: Worker,
) -> None:
    big = list(range(100_000))  # sent pickled: the worker was forked before it existed
    first = worker.submit(_pid_and_sum, big)
    second = worker.submit(_pid_and_sum, [1, 2])
    assert second.result()[1] == 3  # outcomes may be asked for in any order
    pid, total = first.result()
    assert pid != os.getpid() and total == sum(big)
    assert first.result() == (pid, total)  # kept: asking again reads nothing more


def test_a_workers_error_is_raised_in_the_caller_and_wait_only_waits(worker: Worker) -> None:
    task = worker.submit(_fail, "plots: bad axis")
    task.wait()
    with pytest.raises(ReportError, match="bad axis"):
        task.result()
    assert worker.submit(_pid_and_sum, [4]).result()[1] == 4  # it goes on serving


def test_an_error_that_cannot_be_pickled_still_arrives_as_one_line(worker: Worker) -> None:
    with pytest.raises(RuntimeError, match="UnpicklableError: odd"):
        worker.submit(_fail_unpicklably).result()


def test_a_killed_worker_is_an_error_naming_the_signal_for_every_task_owed(
    worker: Worker,
) -> None:
    dying = worker.submit(_die)
    after = worker.submit(_pid_and_sum, [1])
    with pytest.raises(ChildProcessError, match="test: the process was killed by signal SIGKILL"):
        dying.result()
    with pytest.raises(ChildProcessError, match="SIGKILL"):
        after.result()
    with pytest.raises(ChildProcessError, match="SIGKILL"):  # sent once it is gone: the same
        worker.submit(_pid_and_sum, [2]).result()


def test_a_closed_worker_ends_and_takes_no_more(worker: Worker) -> None:
    worker.close()
    worker.close()  # idempotent
    with pytest.raises(RuntimeError, match="closed"):
        worker.submit(_pid_and_sum, [1])


def test_beside_uses_the_worker_where_one_was_started(
    monkeypatch: pytest.MonkeyPatch, worker: Worker
) -> None:
    task = beside(_pid_and_sum, [1], name="test")
    assert isinstance(task, Background)  # a library caller: a thread
    assert task.result() == (os.getpid(), 1)
    monkeypatch.setitem(background._WORKERS, background.PLOTS, worker)
    task = beside(_pid_and_sum, [2], name="test")
    assert isinstance(task, Task) and task.result()[0] != os.getpid()
    assert isinstance(beside(_pid_and_sum, [3], name="t", role="other"), Background)


def _count(n: int) -> Iterator[tuple[int, int]]:
    for k in range(n):
        yield os.getpid(), k


def _count_then_fail(n: int) -> Iterator[int]:
    yield from range(n)
    raise ReportError("chunk 3: bad")


def test_a_stream_sends_its_items_as_they_come_and_its_error_after_them(
    worker: Worker,
) -> None:
    before = worker.submit(_pid_and_sum, [5])
    items = list(worker.stream(_count, 4))
    assert [k for _, k in items] == [0, 1, 2, 3] and items[0][0] != os.getpid()
    assert before.result()[1] == 5  # an earlier outcome read meanwhile is kept for it
    received = []
    with pytest.raises(ReportError, match="chunk 3: bad"):
        for item in worker.stream(_count_then_fail, 3):
            received.append(item)
    assert received == [0, 1, 2]
    assert worker.submit(_pid_and_sum, [6]).result()[1] == 6  # still serving


def test_a_stream_left_before_its_end_stops_the_worker(worker: Worker) -> None:
    items = worker.stream(_count, 10**9)
    next(items)
    items.close()
    assert not worker.alive
    with pytest.raises(RuntimeError, match="closed"):
        worker.submit(_pid_and_sum, [1])


def test_arrays_cross_out_of_band_and_functions_may_be_named(worker: Worker) -> None:
    values = np.arange(300_000, dtype=np.float64)
    (pid, total) = worker.submit(_pid_and_sum, values).result()
    assert total == values.sum()
    assert worker.submit("os:getpid").result() == pid  # imported in the worker


def test_a_later_worker_does_not_keep_an_earlier_one_alive() -> None:
    """A worker forked after another closes its copy of the other's pipe: closing the
    first worker ends it even while the second lives."""
    first = Worker("first")
    second = Worker("second")
    try:
        pid = first.submit("os:getpid").result()
        first.close()  # waits for the child: it would hang if the second held its pipe
        with pytest.raises(ProcessLookupError):
            os.kill(pid, 0)
        assert second.submit(_pid_and_sum, [1]).result()[1] == 1
    finally:
        second.close()


def _big_items(n: int) -> Iterator[np.ndarray]:
    for _ in range(n):
        yield np.zeros(1 << 20)  # 8 MB: more than the pipe holds


def test_closing_a_worker_in_the_middle_of_a_stream_ends_it() -> None:
    """The command leaves while the child blocks on writing an item (an error, Ctrl-C): the
    closed pipe ends the child, and close does not wait for the stream to finish."""
    import time

    worker = Worker("test")
    items = worker.stream(_big_items, 10**6)
    next(items)
    start = time.monotonic()
    worker.close()
    assert time.monotonic() - start < 5 and not worker.alive


def _pids_of_a_forked_call() -> tuple[int, int]:
    """(this process, the process a forked call ran in)."""
    return os.getpid(), forked(os.getpid)()


def _forked_failure() -> None:
    forked(lambda: _fail("states.png: bad axis"))()


def _forked_exit() -> None:
    forked(lambda: os._exit(3))()


def test_forked_outside_a_worker_runs_at_once_and_its_waiter_gives_the_outcome() -> None:
    ran_in: list[int] = []

    def work() -> int:
        ran_in.append(os.getpid())
        return 7

    wait = forked(work)
    assert ran_in == [os.getpid()]  # run already, in this process
    assert wait() == 7
    failing = forked(lambda: _fail("late"))  # no error yet: the waiter raises it
    with pytest.raises(ReportError, match="late"):
        failing()


def test_forked_in_a_worker_runs_in_a_child_of_the_worker(worker: Worker) -> None:
    worker_pid, child_pid = worker.submit(_pids_of_a_forked_call).result()
    assert len({os.getpid(), worker_pid, child_pid}) == 3


def test_a_forked_childs_error_or_silent_end_is_raised_by_its_waiter(worker: Worker) -> None:
    with pytest.raises(ReportError, match=r"states\.png: bad axis"):
        worker.submit(_forked_failure).result()
    with pytest.raises(ChildProcessError, match="exit code 3 and no result"):
        worker.submit(_forked_exit).result()
    assert worker.submit(_pid_and_sum, [2]).result()[1] == 2  # the worker goes on serving


def _process_state(pid: int) -> str | None:
    """The state letter of process ``pid`` (``Z``: ended, not collected), None once gone."""
    try:
        return (Path("/proc") / str(pid) / "stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return None


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc")
def test_a_released_worker_ends_by_itself_and_close_collects_it(worker: Worker) -> None:
    pid, _ = worker.submit(_pid_and_sum, [1]).result()
    worker.release()
    assert not worker.alive
    with pytest.raises(RuntimeError, match="closed"):
        worker.submit(_pid_and_sum, [1])
    deadline = time.monotonic() + 10
    while _process_state(pid) != "Z" and time.monotonic() < deadline:
        time.sleep(0.01)
    assert _process_state(pid) == "Z"  # ended on its own, not waited for yet
    worker.close()
    assert _process_state(pid) is None


def test_a_worker_closed_with_work_still_owed_is_stopped_at_once(worker: Worker) -> None:
    """A command that fails while its workers still warm up does not wait for them."""
    pid, _ = worker.submit(_pid_and_sum, [1]).result()
    worker.submit(time.sleep, 30)  # a warm-up nobody will ask the outcome of
    start = time.monotonic()
    worker.close()
    assert time.monotonic() - start < 5  # not the 30 s of the work, nor the 10 s of patience
    assert not worker.alive
    if Path("/proc/self/stat").exists():
        assert _process_state(pid) is None


def _slow_child_of_a_worker(marker: str) -> int:
    """Fork a child that writes its pid to ``marker``, then works for 1 s; wait for it."""

    def work() -> int:
        Path(marker).write_text(str(os.getpid()))
        time.sleep(1.0)
        return os.getpid()

    return forked(work)()


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc")
def test_a_forked_child_ends_soon_after_its_worker_is_killed(
    worker: Worker, tmp_path: Path
) -> None:
    marker = tmp_path / "child.pid"
    task = worker.submit(_slow_child_of_a_worker, str(marker))
    deadline = time.monotonic() + 10
    while not (marker.exists() and marker.read_text()) and time.monotonic() < deadline:
        time.sleep(0.01)
    child = int(marker.read_text())
    worker.stop()  # the command interrupted while the child works
    with pytest.raises(ChildProcessError):
        task.result()
    deadline = time.monotonic() + 10
    while _process_state(child) not in (None, "Z") and time.monotonic() < deadline:
        time.sleep(0.05)
    assert _process_state(child) in (None, "Z")  # it finished its work, found no reader, ended


class _Ended(SystemExit):
    """What the console script's handler raises on ``SIGTERM`` (``hybridlog.cli_process``)."""


def _raise_ended(signum: int, frame: object) -> None:
    raise _Ended(128 + signum)


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGHUP])
def test_a_worker_dies_of_sigterm_and_sighup_whatever_its_parents_handler(
    signum: signal.Signals,
) -> None:
    """A command's SIGTERM (or SIGHUP) to its process group reaches its workers too: each
    dies of it, silently, instead of raising the handler the command installed before the
    fork (an exception that ended the task, or, in a library's callback, was printed with
    a traceback while the worker went on)."""
    previous = signal.signal(signum, _raise_ended)
    try:
        started = Worker("test")
    finally:
        signal.signal(signum, previous)
    try:
        task = started.submit(_signal_self, int(signum))
        with pytest.raises(ChildProcessError, match=f"killed by signal {signum.name}"):
            task.result()
    finally:
        started.close()


def _signal_self(signum: int) -> str:
    try:
        os.kill(os.getpid(), signum)
        time.sleep(5)
    except BaseException as err:  # what the command's handler, inherited, would raise
        return f"went on after {type(err).__name__}"
    return "went on"
