"""hybridlog.background: a function in a thread or a forked child, its value or error back."""

from __future__ import annotations

import os
import signal
import threading

import pytest

from hybridlog import background
from hybridlog.background import Background, Forked, beside
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


def test_a_forked_child_sees_the_callers_memory_and_sends_the_value_back() -> None:
    big = list(range(100_000))  # not copied: the child reads it as it was at the fork

    def work() -> tuple[int, int]:
        return os.getpid(), sum(big)

    pid, total = Forked(work, "test").result()
    assert pid != os.getpid() and total == sum(big)


def test_a_forked_childs_error_is_raised_in_the_caller_and_wait_only_waits() -> None:
    def fail() -> None:
        raise ReportError("plots: bad axis")

    task = Forked(fail, "test")
    task.wait()
    with pytest.raises(ReportError, match="bad axis"):
        task.result()


def test_an_error_that_cannot_be_pickled_still_arrives_as_one_line() -> None:
    class UnpicklableError(Exception):
        def __reduce__(self) -> object:
            raise TypeError("no")

    def fail() -> None:
        raise UnpicklableError("odd")

    with pytest.raises(RuntimeError, match="UnpicklableError: odd"):
        Forked(fail, "test").result()


def test_a_killed_child_is_an_error_naming_the_signal() -> None:
    def die() -> None:
        os.kill(os.getpid(), signal.SIGKILL)

    with pytest.raises(ChildProcessError, match="test: the process was killed by signal SIGKILL"):
        Forked(die, "test").result()


def test_beside_forks_only_where_the_process_allowed_it(monkeypatch: pytest.MonkeyPatch) -> None:
    assert isinstance(beside(lambda: 1, "test"), Background)  # a library caller: a thread
    monkeypatch.setitem(background._POLICY, "fork", True)
    task = beside(os.getpid, "test")
    assert isinstance(task, Forked) and task.result() != os.getpid()
