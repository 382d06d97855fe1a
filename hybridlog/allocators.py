"""Make the C allocators hand memory back to the system when it is freed, not keep it.

A one-log command (``analyze``, ``compare``) frees large blocks all along: polars' buffers
while the log is decoded and the tables are written (polars allocates with its own
jemalloc), numpy's temporaries of metrics and plots (glibc's ``malloc``).  By default both
allocators keep freed memory for later: jemalloc returns freed pages over the next 0.5 to
1 s (polars sets ``dirty_decay_ms:500,muzzy_decay_ms:1000`` when imported, and appends what
the variable already holds), and glibc serves blocks below a threshold that grows up to
32 MiB (its "dynamic mmap threshold") from heaps it trims only from the top.  Kept, those pages
still count in the process's resident set, and the peak adds them to what is live.

:func:`return_freed_memory` sets both to return freed memory: jemalloc through its
configuration variable (read when polars' allocator starts, so only before polars is
imported): pages that decay are purged (``MADV_DONTNEED``) rather than lazily freed
(``MADV_FREE``, "muzzy", which leaves them resident until the system needs memory); glibc
through ``mallopt`` (``M_MMAP_THRESHOLD`` fixed at :data:`MMAP_THRESHOLD`: larger blocks
are mapped on their own and unmapped when freed).  On a 10^6-row ``analyze`` (median
peak of four runs each, interleaved) the jemalloc setting took about 15 MiB off the peak
and glibc's threshold 10 to 20, in the same time; ``dirty_decay_ms:0`` (purge at every
free) took as much off but cost 0.2 s of wall time.  It changes no result; it is
process-wide, so only the console script calls it (``hybridlog.cli``), never the library.

References
----------
jemalloc(3), ``opt.dirty_decay_ms`` and ``opt.muzzy_decay_ms``; mallopt(3),
``M_MMAP_THRESHOLD``.
"""

from __future__ import annotations

import ctypes
import os
import sys

__all__ = ["JEMALLOC_CONF", "JEMALLOC_CONF_VARIABLE", "MMAP_THRESHOLD", "return_freed_memory"]

JEMALLOC_CONF_VARIABLE = "_RJEM_MALLOC_CONF"
"""The variable polars' jemalloc reads its options from (tikv-jemallocator's prefix)."""

JEMALLOC_CONF = "muzzy_decay_ms:0"
"""Pages polars freed are purged when they decay, not left resident as "muzzy" pages (appended
to polars' own settings, whose ``dirty_decay_ms:500`` stays)."""

MMAP_THRESHOLD = 1 << 20
"""Bytes from which glibc maps a block on its own (and unmaps it when freed): 1 MiB.

Fixing it also stops glibc from raising it after each large free.  A 10^6-sample column
is 8 MB; the blocks below 1 MiB are Python objects and small arrays, kept as before."""

_M_MMAP_THRESHOLD = -3
"""``M_MMAP_THRESHOLD`` of glibc's ``<malloc.h>``."""


def return_freed_memory() -> bool:
    """Set polars' jemalloc and glibc's ``malloc`` to return freed memory (module docstring).

    A jemalloc configuration the user set is kept, and the variable has no effect once
    polars is imported (its allocator has read it).  ``mallopt`` is called where the C
    library has it (glibc).

    Returns
    -------
    bool
        Whether glibc's threshold was set (``False`` on a C library without ``mallopt``).
    """
    if "polars" not in sys.modules:
        os.environ.setdefault(JEMALLOC_CONF_VARIABLE, JEMALLOC_CONF)
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (AttributeError, OSError):
        return False
    mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    mallopt.restype = ctypes.c_int
    return bool(mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD))
