"""hybridlog.background: a function in a thread, its value or its error in the caller's."""

from __future__ import annotations

import threading

import pytest

from hybridlog.background import Background


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
