"""polars as every hybridlog module imports it: with ``SIGINT`` left to Python.

Importing polars (2.1) replaces the process's ``SIGINT`` action with its own (the
``signal-hook`` crate's, with ``SA_RESTART``), chained to Python's, and does so even where
``SIGINT`` is ignored (``nohup``, a script's background job).  A Ctrl-C then also sets
polars' own flag, and polars' next streaming query (a log read, a table written) aborts with
``KeyboardInterrupt`` or panics in its threads with a Rust backtrace on stderr:

* an ignored ``SIGINT`` interrupts hybridlog all the same, with that backtrace;
* a Ctrl-C raises ``KeyboardInterrupt`` twice, the second inside the ``except`` or
  ``finally`` block that was removing a half-written output folder
  (pola-rs/polars#23988).

So polars is imported here and nowhere else, and the first import re-installs Python's own
action for ``SIGINT``, whatever :func:`signal.getsignal` says it is: the default handler,
``SIG_IGN`` or a caller's handler (:func:`take_back_sigint`).  A Ctrl-C then raises one
``KeyboardInterrupt``, once the polars call running returns (a chunk read or written), and an
ignored one stays ignored.  Only the main thread may set an action: where polars is first
imported in another (a log read in a thread while numba sets up,
:func:`hybridlog.jobs.estimation.read_for_estimation`), the main thread calls
:func:`take_back_sigint` once that thread is done.  ``tests/test_polars_import.py``.
"""

from __future__ import annotations

import os
import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import BinaryIO, Literal

ANY_TIME_ZONE = "POLARS_IGNORE_TIMEZONE_PARSE_ERROR"
"""Set before polars is imported: it then takes a Parquet timestamp's zone as written.

Arrow writes a fixed offset as the zone (``+05:30``: pandas' ``FixedOffset``, a
``datetime.timezone``), which polars 2.1 does not know and so panicked on, whatever column
was read: a valid log was refused as "damaged".  A zoned timestamp is stored in UTC whatever
its zone, and hybridlog reads it so (``io/time_column.py``, ``time_column._temporal_ns``), so the
zone never matters.  Set once here, before polars starts a thread: changing the environment
while other threads may read it is undefined behaviour in C."""
os.environ[ANY_TIME_ZONE] = "1"

import polars as pl  # noqa: E402  (after the setting it reads)
from polars.io.plugins import register_io_source  # noqa: E402

__all__ = ["SET_ON_IMPORT", "pl", "polars_file", "register_io_source", "take_back_sigint"]

SET_ON_IMPORT = (ANY_TIME_ZONE, "_RJEM_MALLOC_CONF")
"""The environment variables the first import sets, for the rest of the process: ours, and
the options of polars' jemalloc, which polars' own ``__init__`` writes (its defaults, then what
the variable held) before its allocator starts.  They stay: its allocator has read the variable,
and changing the environment while other threads may read it is undefined behaviour in C.  A
library call's first import of polars is the one change it leaves in the environment
(README's "From Python"; ``tests/jobs/test_library_calls.py``)."""


def take_back_sigint() -> None:
    """Re-install Python's own ``SIGINT`` action over polars' (module docstring).

    Does nothing outside the main thread or where Python did not install the action
    (:func:`signal.getsignal` gives ``None``).
    """
    if threading.current_thread() is not threading.main_thread():
        return
    action = signal.getsignal(signal.SIGINT)
    if action is not None:
        signal.signal(signal.SIGINT, action)


take_back_sigint()


@contextmanager
def polars_file(path: Path, mode: Literal["rb", "wb"]) -> Iterator[Path | BinaryIO]:
    r"""``path`` as polars' readers and writers take it: the path, or the file opened here.

    polars takes a name as the UTF-8 of its text, so it is given only a path whose text's
    UTF-8 is the name the system has: others are opened by Python, which takes any name the
    system does.  Those are a name in another encoding (a log's, a batch's report folder
    named after it: its text holds escaped bytes, lone surrogates) and, where Python reads
    names as ASCII (``LC_ALL=C`` without UTF-8 mode: a cron job, a minimal container), every
    name that is not ASCII (``é.csv`` is the text ``\udcc3\udca9.csv`` there: polars
    failed with 'Object does not have a .write() method').  Readers given the path must also
    be told ``glob=False``: polars otherwise expands ``*``, ``?`` and ``[...]`` in it
    (``run[1].csv`` matched nothing, ``run?.csv`` another log).
    """
    try:
        as_polars_reads_it = str(path).encode("utf-8")
    except UnicodeEncodeError:
        as_polars_reads_it = None
    if as_polars_reads_it != os.fsencode(path):
        with path.open(mode) as handle:
            yield handle
        return
    yield path
