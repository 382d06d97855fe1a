"""Memory a run needs against what this machine can still give it: refused up front.

``simulate`` and the analyses (``analyze``, ``compare``, each log of ``batch``) estimate
the memory of their large arrays before allocating them and refuse, with one line naming
what and how much, a run that cannot fit: on Linux an allocation larger than the free
memory mostly succeeds and the kernel kills the process later, minutes into the run and
without a word.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from hybridlog.errors import HybridlogError

__all__ = ["available_memory", "check_fits", "size_text"]


def available_memory() -> int | None:
    """Bytes of memory this process can still get: ``MemAvailable``, capped by a cgroup limit.

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
    try:
        limit = Path("/sys/fs/cgroup/memory.max").read_text().strip()
        used = Path("/sys/fs/cgroup/memory.current").read_text().strip()
        if limit != "max":
            available = min(available, max(int(limit) - int(used), 0))
    except (OSError, ValueError):
        pass
    return available


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
