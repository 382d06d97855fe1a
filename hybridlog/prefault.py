"""Fault in the pages of a compiled loop's large output arrays on the other core meanwhile.

A compiled filter or smoother writes its outputs row by row into arrays allocated just before
it (``np.empty``/``np.zeros``: no page is touched until the loop writes it).  Each first write
to a page is a page fault, and on the virtual machines hybridlog is measured on one that lands
on memory the guest has never used costs about 2-3 ms per MiB (measured: 0.49-0.59 s to fill
a fresh 206 MiB array, 0.026 s for one on memory the process had freed before).  A 10^6-sample
IMM filter writes about 100 MB of outputs, its smoother's forward pass another 206 MiB of
per-mode records (:class:`~hybridlog.estimators.common.ModeStore`): the loop spends as much
time in faults as in arithmetic.

:func:`populated_beside` asks the kernel, from a thread, to fault those pages in with
``madvise(MADV_POPULATE_WRITE)`` (Linux 5.14) while the loop runs: the thread spends its
time in the kernel without the GIL, on the core the loop does not use, a slice of every
array at a time in the order the loop writes them.  The call only maps pages, as a write
would, and never changes their content, so it may run over rows the loop has written or is
writing; nothing it does changes a result.  Where the call is not available (another
system, an older kernel) nothing is done.

References
----------
madvise(2), ``MADV_POPULATE_WRITE``.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import mmap
import sys
import threading
from collections.abc import Callable, Iterable, Iterator

import numpy as np

__all__ = ["MIN_BYTES", "arrays_in", "populated_beside"]

MADV_POPULATE_WRITE = 23
"""Linux's ``MADV_POPULATE_WRITE`` (``<asm-generic/mman-common.h>``)."""

MIN_BYTES = 1 << 22
"""Arrays below 4 MiB are left to the loop (their faults cost less than starting a thread)."""

SLICES = 64
"""Each array is populated in this many slices, all arrays' first slices first."""

_usable = sys.platform.startswith("linux")
"""Cleared when the kernel refuses the call (``EINVAL``: older than 5.14)."""


def _madvise() -> Callable[[int, int, int], int] | None:
    try:
        libc = ctypes.CDLL(None, use_errno=True)
    except OSError:  # pragma: no cover - every Linux has a C library loaded
        return None
    function = libc.madvise
    function.argtypes = [ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int]
    function.restype = ctypes.c_int
    madvise: Callable[[int, int, int], int] = function
    return madvise


def _pages(array: np.ndarray) -> tuple[int, int]:
    """The whole pages inside ``array``'s memory: ``(first address, length)``."""
    start = array.ctypes.data
    first = -(-start // mmap.PAGESIZE) * mmap.PAGESIZE
    last = (start + array.nbytes) // mmap.PAGESIZE * mmap.PAGESIZE
    return first, max(last - first, 0)


def _populate(ranges: list[tuple[int, int]]) -> None:
    """Populate every range slice by slice (ctypes releases the GIL during each call)."""
    global _usable
    madvise = _madvise()
    if madvise is None:
        _usable = False
        return
    # whole pages per slice, so that every call starts on a page boundary
    sizes = [-(-length // SLICES // mmap.PAGESIZE) * mmap.PAGESIZE for _, length in ranges]
    for index in range(SLICES):
        for (first, length), size in zip(ranges, sizes, strict=True):
            lo = first + index * size
            hi = min(lo + size, first + length)
            if hi > lo and not _advised(madvise, lo, hi - lo):
                if ctypes.get_errno() == errno.EINVAL:  # this kernel has no such advice
                    _usable = False
                return  # ENOMEM or EFAULT should not happen; the loop faults on its own


RETRIES = 8
"""Calls of one slice interrupted (``EINTR``: a signal, such as a worker process's
``SIGCHLD``) or refused for now (``EAGAIN``) before its pages are left to the loop."""


def _advised(madvise: Callable[[int, int, int], int], start: int, length: int) -> bool:
    """``madvise(start, length, MADV_POPULATE_WRITE)``, again where a signal interrupted it.

    Without the retry one interrupted call ended the population: every slice after it was
    left to the loop's faults, without a word.
    """
    for _ in range(RETRIES):
        if madvise(start, length, MADV_POPULATE_WRITE) == 0:
            return True
        if ctypes.get_errno() not in (errno.EINTR, errno.EAGAIN):
            return False
    return False


def arrays_in(value: object) -> list[np.ndarray]:
    """The arrays in ``value``: itself, or those in a tuple (named tuples included), nested."""
    if isinstance(value, np.ndarray):
        return [value]
    if isinstance(value, tuple):
        return [array for item in value for array in arrays_in(item)]
    return []


@contextlib.contextmanager
def populated_beside(arrays: Iterable[np.ndarray]) -> Iterator[None]:
    """Fault in the pages of the large C-contiguous ``arrays`` from a thread while the body runs.

    The thread is joined before the context exits, so the arrays outlive it.
    """
    ranges = [_pages(a) for a in arrays if a.nbytes >= MIN_BYTES and a.flags.c_contiguous]
    ranges = [r for r in ranges if r[1] > 0]
    if not (_usable and ranges):
        yield
        return
    thread = threading.Thread(
        target=_populate, args=(ranges,), name="hybridlog-populate", daemon=True
    )
    thread.start()
    try:
        yield
    finally:
        thread.join()
