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
import os
import sys
from collections.abc import Sequence

__all__ = ["BLAS_THREADS", "local_batch_jobs", "main", "single_threaded_blas"]

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

    run_cli()
