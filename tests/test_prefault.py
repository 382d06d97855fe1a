"""``hybridlog.prefault``: pages faulted in beside a loop, never a value changed."""

from __future__ import annotations

import ctypes
import errno
import subprocess
import sys
import threading

import numpy as np
import pytest

from hybridlog import prefault
from hybridlog.estimators.common import ModeStore
from hybridlog.prefault import MIN_BYTES, arrays_in, populated_beside
from tests.support.paths import ROOT

linux_only = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="madvise advice")


def _resident_mib() -> float:
    with open("/proc/self/statm") as statm:
        return int(statm.read().split()[1]) * 4096 / 2**20


def test_arrays_in_finds_the_arrays_of_nested_named_tuples() -> None:
    store = ModeStore(np.zeros((2, 3, 9)), np.zeros((0, 3)))
    found = arrays_in((np.ones(2), (store, 3.0, "text"), None))
    assert [a.shape for a in found] == [(2,), (2, 3, 9), (0, 3)]
    assert found[1] is store.states


_RESIDENT = """
import numpy as np
from hybridlog import prefault
from tests.test_prefault import _resident_mib
array = np.empty(64 * 2**20 // 8)  # 64 MiB, no page touched yet
before = _resident_mib()
with prefault.populated_beside([array]):
    pass
print(prefault._usable, _resident_mib() - before)
"""


@linux_only
def test_the_pages_of_a_large_array_become_resident() -> None:
    """In a process of its own: a test worker's earlier tests (its heap, its signals) once
    left the 64 MiB already resident or the population interrupted, and the test failed on
    a machine that populates as it should."""
    done = subprocess.run(
        [sys.executable, "-c", _RESIDENT], capture_output=True, text=True, check=True, cwd=ROOT
    )
    usable, grown = done.stdout.split()
    assert usable == "True", "this kernel has MADV_POPULATE_WRITE (Linux 5.14)"
    assert float(grown) > 60


@linux_only
def test_a_call_a_signal_interrupts_is_made_again(monkeypatch: pytest.MonkeyPatch) -> None:
    """madvise(2) returns EINTR when a signal arrives (a worker process's SIGCHLD): the
    population went on to no other slice, and the pages were left to the loop's faults."""
    real = prefault._madvise()
    assert real is not None
    calls: list[tuple[int, int]] = []

    def interrupted_once(start: int, length: int, advice: int) -> int:
        calls.append((start, length))
        if len(calls) == 1:
            ctypes.set_errno(errno.EINTR)
            return -1
        return int(real(start, length, advice))

    monkeypatch.setattr(prefault, "_madvise", lambda: interrupted_once)
    array = np.empty(8 * 2**20 // 8)
    with populated_beside([array]):
        pass
    first, length = prefault._pages(array)
    assert calls[0] == calls[1]  # the interrupted slice again
    assert sum(size for _, size in calls[1:]) == length
    assert calls[-1][0] + calls[-1][1] == first + length


@linux_only
def test_small_arrays_start_no_thread() -> None:
    started = threading.active_count()
    with populated_beside([np.empty(MIN_BYTES // 8 - 1)]):
        assert threading.active_count() == started


def test_what_the_body_writes_is_kept_whatever_the_thread_does() -> None:
    """The body writes rows while the thread populates the same pages: every value stays."""
    n = 6 * 2**20 // 8
    first, second = np.empty(n), np.empty((n // 4, 4))
    with populated_beside([first, second]):
        for lo in range(0, n, 4096):
            first[lo : lo + 4096] = np.arange(lo, min(lo + 4096, n))
        second[:] = 7.0
    assert np.array_equal(first, np.arange(n, dtype=np.float64))
    assert (second == 7.0).all()
