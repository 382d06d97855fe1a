"""polars' errors and panics on a log's file, as a :class:`~hybridlog.errors.LogError`.

:func:`panics_refused` turns a panic (a damaged Parquet page) into one, holding what polars
wrote on the process's standard error meanwhile; :func:`first_line` is the part of a
library's error a message quotes.
"""

from __future__ import annotations

import contextlib
import os
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from hybridlog.errors import LogError, excerpt
from hybridlog.polars_import import pl


@contextlib.contextmanager
def panics_refused(path: Path, kind: str) -> Iterator[None]:
    """Refuse a file on which polars panics (a damaged Parquet page), as a :class:`LogError`.

    A panic is a ``BaseException`` (``pyo3_runtime.PanicException``), which escaped as a
    traceback, after Rust's own message and, with ``RUST_BACKTRACE`` set, its stack printed
    to the process's standard error: that is held while polars reads, and written out unless
    polars panicked.  ``sys.stderr`` is ``None`` in a process started with descriptor 2
    closed: a worker of ``batch --jobs 2 2>&-`` (multiprocessing's forkserver), where every
    log failed on "'NoneType' object has no attribute 'flush'".
    """
    if sys.stderr is not None:
        sys.stderr.flush()
    saved = os.dup(2)
    panicked = False
    try:
        with _held_file() as held:
            os.dup2(held.fileno(), 2)
            try:
                yield
            except pl.exceptions.PanicException as err:
                panicked = True
                raise LogError(
                    f"{path}: not a readable {kind} file (damaged? polars failed on it: "
                    f"{first_line(err)})"
                ) from None
            finally:
                os.dup2(saved, 2)
                if not panicked:
                    held.seek(0)
                    written = held.read()
                    if written:
                        os.write(2, written)
    finally:
        os.close(saved)


def _held_file() -> Any:
    """A file in memory (no disk, no ``TMPDIR``), or a temporary file where there is none."""
    if hasattr(os, "memfd_create"):
        return os.fdopen(os.memfd_create("hybridlog-polars-stderr"), "w+b")
    return tempfile.TemporaryFile()  # pragma: no cover - not Linux


def first_line(err: BaseException) -> str:
    """The first line of a library's error, cut short: it may quote the file's bytes."""
    text = str(err).strip()
    return excerpt(text.splitlines()[0], 120)[1:-1] if text else type(err).__name__
