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
import signal
import sys
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, NoReturn, TextIO

if TYPE_CHECKING:
    from _typeshed import ReadableBuffer

__all__ = [
    "BLAS_THREADS",
    "local_batch_jobs",
    "lost_output",
    "main",
    "open_standard_descriptors",
    "single_threaded_blas",
    "tolerate_closed_output",
]

STANDARD_DESCRIPTORS = (0, 1, 2)
"""stdin, stdout and stderr."""

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


def _writable_folder(path: str) -> bool:
    """Whether ``path`` is, or could be made as, a folder this process can write."""
    while not os.path.lexists(path):
        parent = os.path.dirname(path)
        if parent == path:
            return False
        path = parent
    return os.path.isdir(path) and os.access(path, os.W_OK | os.X_OK)


def writable_matplotlib_folder() -> None:
    """Give matplotlib a folder it can write, in the console script, unless the user chose one.

    matplotlib keeps its settings and its font list in ``$MPLCONFIGDIR``, else
    ``$XDG_CONFIG_HOME/matplotlib`` and ``$XDG_CACHE_HOME/matplotlib`` (``~/.config``,
    ``~/.cache``).  Where those cannot be written (a read-only home in CI, a container's user
    without one, the README's advice to point ``HYBRIDLOG_CACHE_DIR`` elsewhere) it wrote a
    two-line warning on stderr in every command that draws, under ``-q`` too, and built the
    font list again each time.  There ``MPLCONFIGDIR`` is set to ``matplotlib`` in hybridlog's
    own cache folder (:func:`hybridlog.jit.cache_dir`), before any worker is started; where
    that cannot be written either, matplotlib is left to say so.  Only the console script
    sets it, never the library.  Nothing is created here: matplotlib makes the folder it uses.
    """
    if os.environ.get("MPLCONFIGDIR"):
        return
    home = os.path.expanduser("~")
    defaults = (
        os.environ.get("XDG_CONFIG_HOME") or os.path.join(home, ".config"),
        os.environ.get("XDG_CACHE_HOME") or os.path.join(home, ".cache"),
    )
    if all(_writable_folder(os.path.join(base, "matplotlib")) for base in defaults):
        return
    from hybridlog.errors import HybridlogError
    from hybridlog.jit import cache_dir

    try:
        folder = os.fspath(cache_dir() / "matplotlib")
    except HybridlogError:  # no home and no cache folder: matplotlib says what it does
        return
    if _writable_folder(folder):
        os.environ["MPLCONFIGDIR"] = folder


def open_standard_descriptors() -> None:
    """Open ``/dev/null`` on each of descriptors 0, 1 and 2 that is closed (``2>&-``, ``<&-``).

    A command started with one of them closed (a shell's ``>&-``, a daemon, a CI step) had
    the next file it opened take that number: ``analyze ... 2>&-`` had its log, its model or
    a report file on descriptor 2, where everything that writes to the process's standard
    error (a library's C code, a polars panic, the workers it forks) writes; and with
    ``sys.stderr`` left ``None`` the progress bars' check failed (exit 2, nothing said).
    Opened first thing, before any other file or process: what is written there is dropped.
    In order, so each ``open`` takes the lowest closed number, the one checked.
    """
    for descriptor in STANDARD_DESCRIPTORS:
        try:
            os.fstat(descriptor)
        except OSError:
            os.open(os.devnull, os.O_RDWR)


class _ReaderMayLeave(io.FileIO):
    """A standard stream's file descriptor whose reader may close it: the rest is dropped.

    ``hybridlog inspect LOG | head -1`` closes the pipe after one line; the next write then
    fails with ``EPIPE`` (Python ignores ``SIGPIPE``).  click turned that into exit code 1
    with nothing said, which hybridlog uses for a missed CI gate: ``hybridlog models | head
    -1`` and ``--help | head -1`` "failed", and ``analyze ... | head -1`` ended before its
    gates were checked.  Here the descriptor is pointed at ``/dev/null`` at the first such
    write, and the command carries on to its own exit code: its output files, gates and
    messages on the other stream are what they would have been.

    Any other failure is treated so too, so that writing the error cannot fail again; on
    stdout (``> file`` on a full disk, ``> /dev/full``) it is kept for :func:`lost_output`:
    the output was lost, not refused by a reader.  It was an "unexpected OSError" said to be
    a bug, and a traceback where the error message could not be written either.
    """

    def write(self, data: ReadableBuffer, /) -> int:
        try:
            return super().write(data)
        except OSError as err:
            if self.fileno() == 1 and not isinstance(err, BrokenPipeError):
                _LOST.append(err.strerror or str(err))
            self._to_null()
            return memoryview(data).nbytes

    def _to_null(self) -> None:
        null = os.open(os.devnull, os.O_WRONLY)
        try:
            os.dup2(null, self.fileno())
        finally:
            os.close(null)


_LOST: list[str] = []
"""Why writing to stdout failed, other than its reader leaving (:class:`_ReaderMayLeave`)."""


def lost_output() -> str | None:
    """Why the console script's stdout could not be written (a full disk), or ``None``.

    ``sys.stdout`` is flushed first, so what it still held is tried too.
    """
    with contextlib.suppress(OSError, ValueError, AttributeError):
        sys.stdout.flush()
    return _LOST[0] if _LOST else None


def _tolerant(stream: TextIO | None, descriptor: int) -> TextIO:
    """``stream`` written through :class:`_ReaderMayLeave`, with its encoding and buffering.

    ``None`` (the descriptor was closed when Python started, ``>&-``, and is
    ``/dev/null`` now: :func:`open_standard_descriptors`) becomes a stream on it.
    """
    if stream is None:
        raw = _ReaderMayLeave(descriptor, "w", closefd=False)
        return io.TextIOWrapper(io.BufferedWriter(raw), errors="backslashreplace")
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
    ``sys.__stdout__`` and ``sys.__stderr__``, their descriptors open), also where the
    process started with one closed (:func:`open_standard_descriptors`, called first).
    """
    open_standard_descriptors()
    sys.stdout = _tolerant(sys.stdout, 1)
    sys.stderr = _tolerant(sys.stderr, 2)


def local_batch_jobs(args: Sequence[str]) -> int:
    """The ``--jobs`` of a ``batch`` command line run by local workers; 1 for any other line.

    ``--jobs auto`` is the cores this process may use, as the CLI reads it.
    """
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
    if jobs.strip().lower() == "auto":
        from hybridlog.environment import usable_cores

        return usable_cores()
    return int(jobs) if jobs.isascii() and jobs.isdigit() else 1


_DROPPED: list[KeyboardInterrupt] = []
"""A Ctrl-C that Python dropped before the CLI handles signals (:func:`_dropped_interrupt`)."""

_SEND_AGAIN_S = 0.05
"""How long after a dropped Ctrl-C ``SIGINT`` is sent again (as the CLI's own hook waits)."""


def _dropped_interrupt(
    previous: Callable[[sys.UnraisableHookArgs], object],
) -> Callable[[sys.UnraisableHookArgs], None]:
    """A ``sys.unraisablehook`` that keeps a Ctrl-C Python dropped, and sends it again.

    Python's ``KeyboardInterrupt`` raised inside a callback it calls from C (the import
    system's module-lock ``weakref`` callback, while the CLI is imported) is dropped with
    "Exception ignored in" and a traceback: ``compare`` Ctrl-C'd 65 ms after it started went
    on to write its reports and exit 0.  Kept for :func:`main` to end on, and ``SIGINT`` is
    sent again from a thread, for one dropped after that check and before the CLI's own
    handling (:mod:`hybridlog.cli_process`, whose hook passes any other to this one).
    """

    def hook(unraisable: sys.UnraisableHookArgs) -> None:
        if not isinstance(unraisable.exc_value, KeyboardInterrupt):
            previous(unraisable)
            return
        _DROPPED.append(unraisable.exc_value)
        import threading  # here: a dropped Ctrl-C only
        import time

        def send_again() -> None:
            time.sleep(_SEND_AGAIN_S)
            if not _ABORTED:  # ended on it already: sent now, it would land in the exit
                os.kill(os.getpid(), signal.SIGINT)

        threading.Thread(target=send_again, daemon=True).start()

    return hook


_ABORTED: list[bool] = []
"""Set once :func:`main` ends on a Ctrl-C (a dropped one is then not sent again)."""


def _aborted() -> NoReturn:
    _ABORTED.append(True)
    sys.stderr.write("hybridlog: aborted\n")
    sys.exit(130)


def main() -> None:
    """The console script ``hybridlog`` and ``python -m hybridlog``: :func:`hybridlog.cli.main`."""
    sys.unraisablehook = _dropped_interrupt(sys.unraisablehook)
    open_standard_descriptors()
    single_threaded_blas()
    writable_matplotlib_folder()
    try:
        if local_batch_jobs(sys.argv[1:]) > 1:
            from hybridlog.environment import check_environment, check_umask
            from hybridlog.errors import HybridlogError
            from hybridlog.jobs.workers import start_forkserver

            # a head start only: where it fails, the command tries again and says why (a
            # malformed NUMBA_* setting would break the forkserver's warm-up with a traceback)
            with contextlib.suppress(HybridlogError):
                check_environment()
                check_umask()
                start_forkserver()
        from hybridlog.cli import main as run_cli
    except KeyboardInterrupt:  # Ctrl-C before the CLI handles it: no traceback of imports
        _aborted()
    if _DROPPED:
        _aborted()
    run_cli()
