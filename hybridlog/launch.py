"""The ``hybridlog`` command's first module: what starts before the CLI is imported.

Importing :mod:`hybridlog.cli` (click, every option, the estimators' registry) takes about
0.12 s of one core while the other is idle.  A local ``batch --jobs N`` (N > 1) forks its
workers from a forkserver that must first warm up for 0.6-0.7 s of its own core (numpy,
numba's set-up: :mod:`hybridlog.jobs.worker_warmup`); started here, it warms up while the
CLI is imported, not after.

The command line is glanced at, not parsed: the forkserver is started when the first word
that is not an option is ``batch`` and ``--jobs N`` or ``--jobs=N`` says N > 1, with no
``--scheduler``, all before any ``--``.  The CLI then parses and checks everything as it
always does, and starts the forkserver itself when this glance did not
(:func:`hybridlog.jobs.workers.start_forkserver` is idempotent).  A wrong guess costs only
the other core's time: a forkserver nobody uses is stopped when the process ends.
"""

from __future__ import annotations

import contextlib
import io
import os
import sys
from collections.abc import Sequence
from typing import TYPE_CHECKING, TextIO

if TYPE_CHECKING:
    from _typeshed import ReadableBuffer

__all__ = [
    "BLAS_THREADS",
    "local_batch_jobs",
    "main",
    "single_threaded_blas",
    "tolerate_closed_output",
]

BLAS_THREADS = "OPENBLAS_NUM_THREADS"
"""Read by NumPy's OpenBLAS when it loads (:func:`single_threaded_blas`)."""


def single_threaded_blas() -> None:
    """Give NumPy's OpenBLAS one thread in the console script, unless the user set it.

    hybridlog's BLAS calls are on matrices of a model's size (a covariance's eigenvalues when
    a model is loaded, matplotlib's 3×3 transforms); a pool thread does none of their work
    but spins after each call: 1.6 % of a 10^6-row ``analyze``'s CPU samples and 2.7 % of a
    200-log ``batch --jobs 2``'s were in OpenBLAS's ``blas_thread_server`` (``perf``), on a
    core the plots or the other worker needed.  Set first thing, before any process is
    started: the variable is read once, when OpenBLAS loads, and the batch workers'
    forkserver (started here) and every worker inherit it.  Only the console script sets
    it, never the library.
    """
    os.environ.setdefault(BLAS_THREADS, "1")


class _ReaderMayLeave(io.FileIO):
    """A standard stream's file descriptor whose reader may close it: the rest is dropped.

    ``hybridlog inspect LOG | head -1`` closes the pipe after one line; the next write then
    fails with ``EPIPE`` (Python ignores ``SIGPIPE``).  click turned that into exit code 1
    with nothing said, which hybridlog uses for a missed CI gate: ``hybridlog models | head
    -1`` and ``--help | head -1`` "failed", and ``analyze ... | head -1`` ended before its
    gates were checked.  Here the descriptor is pointed at ``/dev/null`` at the first such
    write, and the command carries on to its own exit code: its output files, gates and
    messages on the other stream are what they would have been.
    """

    def write(self, data: ReadableBuffer, /) -> int:
        try:
            return super().write(data)
        except BrokenPipeError:
            null = os.open(os.devnull, os.O_WRONLY)
            try:
                os.dup2(null, self.fileno())
            finally:
                os.close(null)
            return memoryview(data).nbytes


def _tolerant(stream: TextIO | None) -> TextIO | None:
    """``stream`` written through :class:`_ReaderMayLeave`, with its encoding and buffering."""
    if stream is None:  # the descriptor was closed when Python started (``>&-``)
        return None
    try:
        descriptor = stream.fileno()
    except (AttributeError, OSError, ValueError):  # not a file (a test's capture)
        return stream
    stream.flush()
    raw = _ReaderMayLeave(descriptor, "w", closefd=False)
    return io.TextIOWrapper(
        io.BufferedWriter(raw),
        encoding=stream.encoding,
        errors=stream.errors,
        line_buffering=bool(stream.line_buffering),
        write_through=getattr(stream, "write_through", False),
    )


def tolerate_closed_output() -> None:
    """Let the console script's stdout and stderr be closed by their readers (``| head -1``).

    Only the console script, never the library: ``sys.stdout`` and ``sys.stderr`` become
    text streams over :class:`_ReaderMayLeave` (the original objects stay in
    ``sys.__stdout__`` and ``sys.__stderr__``, their descriptors open).
    """
    sys.stdout = _tolerant(sys.stdout)
    sys.stderr = _tolerant(sys.stderr)


def local_batch_jobs(args: Sequence[str]) -> int:
    """The ``--jobs`` of a ``batch`` command line run by local workers; 1 for any other line."""
    words = list(args[: list(args).index("--")] if "--" in args else args)
    command = next((word for word in words if not word.startswith("-")), None)
    if command != "batch" or any(w.split("=", 1)[0] == "--scheduler" for w in words):
        return 1
    jobs = "1"
    for k, word in enumerate(words):
        if word == "--jobs" and k + 1 < len(words):
            jobs = words[k + 1]
        elif word.startswith("--jobs="):
            jobs = word.removeprefix("--jobs=")
    return int(jobs) if jobs.isascii() and jobs.isdigit() else 1


def main() -> None:
    """The console script ``hybridlog`` and ``python -m hybridlog``: :func:`hybridlog.cli.main`."""
    single_threaded_blas()
    try:
        if local_batch_jobs(sys.argv[1:]) > 1:
            from hybridlog.environment import check_environment
            from hybridlog.errors import HybridlogError
            from hybridlog.jobs.workers import start_forkserver

            # a head start only: where it fails, the command tries again and says why (a
            # malformed NUMBA_* setting would break the forkserver's warm-up with a traceback)
            with contextlib.suppress(HybridlogError):
                check_environment()
                start_forkserver()
        from hybridlog.cli import main as run_cli
    except KeyboardInterrupt:  # Ctrl-C before the CLI handles it: no traceback of imports
        sys.stderr.write("hybridlog: aborted\n")
        sys.exit(130)
    run_cli()
