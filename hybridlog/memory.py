"""Memory a run needs against what this machine can still give it: refused up front.

``simulate`` and the analyses (``analyze``, ``compare``, each log of ``batch``) estimate
the memory of their large arrays before allocating them and refuse, with one line naming
what and how much, a run that cannot fit: on Linux an allocation larger than the free
memory mostly succeeds and the kernel kills the process later, minutes into the run and
without a word.

The workers of a local ``batch --jobs N`` run side by side: each log is checked against the
memory the others have reserved too (:class:`MemoryLedger`, :func:`reserved`), or N logs that
each fit alone were all let through together.
"""

from __future__ import annotations

import contextlib
import fcntl
import mmap
import os
import tempfile
import threading
import time
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

from hybridlog.cgroups import memory_room
from hybridlog.errors import HybridlogError

__all__ = ["MemoryLedger", "available_memory", "check_fits", "reserved", "size_text"]


def available_memory() -> int | None:
    """Bytes of memory this process can still get: ``MemAvailable``, capped by its cgroups.

    The cap is what the limits of its control groups leave it
    (:func:`hybridlog.cgroups.memory_room`).

    ``None`` when the system says nothing (then no check is made).
    """
    available: int | None = None
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                available = int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    if available is None:
        try:
            available = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (OSError, ValueError, AttributeError):
            return None
    room = memory_room()
    return available if room is None else min(available, room)


def size_text(size: float) -> str:
    """``"5.1 GB"``, ``"840.0 MB"``: a size in bytes for people (powers of ten)."""
    return f"{size / 1e9:,.1f} GB" if size >= 1e8 else f"{size / 1e6:,.1f} MB"


def check_fits(
    parts: Sequence[tuple[str, int]],
    *,
    what: str,
    remedy: str,
    error: type[HybridlogError],
    available: int | None = None,
) -> None:
    """Raise ``error`` when the ``parts`` (what, bytes) need more than the memory available.

    ``available`` defaults to :func:`available_memory`; when the system says nothing, no check
    is made.  The message: ``<what> would need about <total> of memory (<the three largest
    parts, when there are several>) and <available> is available; <remedy>``.
    """
    if available is None:
        available = available_memory()
    needed = sum(size for _, size in parts)
    if available is None or needed <= available:
        return
    largest = sorted(parts, key=lambda part: -part[1])[:3]
    shares = ", ".join(f"{name} {size_text(size)}" for name, size in largest if size > 0)
    raise error(
        f"{what} would need about {size_text(needed)} of memory"
        f"{f' ({shares})' if len(parts) > 1 else ''} and {size_text(available)} is available; "
        f"{remedy}"
    )


WAIT_POLL_S = 0.05
"""How often a worker waiting for the memory others hold looks again."""


class MemoryLedger:
    """The memory the concurrent workers of one pool have reserved, shared between processes.

    One slot per worker: the bytes its running log needs (0 between logs), and the budget:
    the memory available when a worker last reserved while no other held any.  A log's
    ``need`` is let through when ``need`` plus what the others hold fits in the budget (and
    ``need`` in what is available now, for the machine's other load); when it would fit
    alone but not beside them, the worker waits until they release enough (the batch runs
    fewer logs at once instead of all of them being killed by the kernel); when it cannot
    fit even alone, it is refused as :func:`check_fits` refuses it.  What a log holds is
    counted twice while it allocates (in its slot and in the memory no longer available):
    never too little.

    Made by the pool's process and sent to each worker when it starts, with its slot
    (:meth:`install`); a dead worker's slot is cleared by the pool (:meth:`release`) before
    another takes it.  The slots live in an anonymous shared file, mapped by every process
    and locked with a POSIX record lock (and a thread lock within a process): not
    multiprocessing's semaphores, which its resource tracker records, and which a signal to
    the whole process group (a CI runner's ``SIGTERM``) left it printing a traceback.
    """

    def __init__(self, slots: int, fd: int | None = None) -> None:
        self.slots = slots
        self._fd = _anonymous_file((slots + 1) * 8) if fd is None else fd
        self._map = mmap.mmap(self._fd, (slots + 1) * 8)
        self._words = memoryview(self._map).cast("q")  # the slots, then the budget
        self._thread_lock = threading.Lock()

    def __reduce__(self) -> tuple[Any, ...]:
        """Sent to a worker as it starts: the file's descriptor goes with it."""
        from multiprocessing import reduction

        return _ledger_of, (reduction.DupFd(self._fd), self.slots)

    @contextlib.contextmanager
    def _locked(self) -> Iterator[None]:
        with self._thread_lock:
            fcntl.lockf(self._fd, fcntl.LOCK_EX)
            try:
                yield
            finally:
                fcntl.lockf(self._fd, fcntl.LOCK_UN)

    def close(self) -> None:
        """Let the shared file go (the pool's process, once its workers have ended)."""
        self._words.release()
        self._map.close()
        os.close(self._fd)

    def install(self, slot: int) -> None:
        """Make this process's :func:`reserved` reserve in ``slot`` of this ledger."""
        _INSTALLED[:] = [(self, slot)]

    def release(self, slot: int) -> None:
        """Clear ``slot``: its worker is done with its log, or dead."""
        with self._locked():
            self._words[slot] = 0

    def held(self) -> list[int]:
        """The bytes reserved in each slot."""
        with self._locked():
            return list(self._words[: self.slots])

    def _try(self, slot: int, need: int) -> tuple[bool, int | None]:
        """Reserve ``need`` in ``slot`` if it fits now: ``(reserved, memory it could have)``.

        The memory is ``None`` when the system says nothing (then it is let through); a
        ``need`` larger than it, with nothing else reserved, cannot fit at all.
        """
        with self._locked():
            held = self._words
            others = sum(held[: self.slots]) - held[slot]
            available = available_memory()
            if available is None:
                return True, None
            if others == 0:
                held[self.slots] = available
            budget = held[self.slots]
            if need + others <= budget and need <= available:
                held[slot] = need
                return True, max(budget, available)
            return False, max(budget, available)

    @contextlib.contextmanager
    def reserve(
        self,
        slot: int,
        parts: Sequence[tuple[str, int]],
        *,
        what: str,
        remedy: str,
        error: type[HybridlogError],
    ) -> Iterator[float]:
        """Hold the ``parts``' memory in ``slot`` for the ``with`` block; yields the seconds waited.

        Raises ``error`` (:func:`check_fits`'s message) when the parts cannot fit even with
        nothing else reserved.
        """
        need = sum(size for _, size in parts)
        started = time.monotonic()
        waited = 0.0
        while True:
            fits, alone = self._try(slot, need)
            if fits:
                break
            if alone is not None and need > alone:
                check_fits(parts, what=what, remedy=remedy, error=error, available=alone)
            time.sleep(WAIT_POLL_S)
            waited = time.monotonic() - started
        try:
            yield waited
        finally:
            self.release(slot)


def _anonymous_file(size: int) -> int:
    """A descriptor of a zeroed file of ``size`` bytes with no name (memory, not a disk)."""
    if hasattr(os, "memfd_create"):
        fd = os.memfd_create("hybridlog-memory-ledger")
    else:  # pragma: no cover - not Linux
        with tempfile.TemporaryFile() as file:
            fd = os.dup(file.fileno())
    os.ftruncate(fd, size)
    return fd


def _ledger_of(duplicate: Any, slots: int) -> MemoryLedger:
    """The ledger in a worker: the file's descriptor its pool's process sent."""
    return MemoryLedger(slots, fd=duplicate.detach())


_INSTALLED: list[tuple[MemoryLedger, int]] = []
"""This process's ledger and slot, in a worker of a pool (:meth:`MemoryLedger.install`)."""


@contextlib.contextmanager
def reserved(
    parts: Sequence[tuple[str, int]],
    *,
    what: str,
    remedy: str,
    error: type[HybridlogError],
) -> Iterator[float]:
    """:func:`check_fits` for the ``with`` block, counting the pool's other workers.

    In a worker of a pool (a ledger installed), the parts are reserved in its ledger
    (:meth:`MemoryLedger.reserve`: waiting while the others hold what they would need);
    elsewhere they are checked against the memory available.  Yields the seconds waited.
    """
    if not _INSTALLED:
        check_fits(parts, what=what, remedy=remedy, error=error)
        yield 0.0
        return
    ledger, slot = _INSTALLED[0]
    with ledger.reserve(slot, parts, what=what, remedy=remedy, error=error) as waited:
        yield waited
