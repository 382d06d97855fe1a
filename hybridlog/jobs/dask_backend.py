"""Run a batch's tasks on a Dask distributed cluster (``hybridlog batch --scheduler``).

The client (the ``hybridlog batch`` process) submits one task per log to the scheduler at
the given address; Dask workers run :func:`hybridlog.jobs.batch.analyze_log`, which writes the
log's report folder into the shared output folder atomically (through
:mod:`hybridlog.outputs`), and send back its outcome; the client assembles the summary.  So
the workers must see the logs, the model file and the output folder at the same paths as the
client (a shared file system), and have the same hybridlog installed.  A worker keeps the
loaded model and compiled code between the logs it analyses, like a local worker process.

**Memory.**  Each log's memory is checked on the Dask worker that runs it, against what that
worker may still take before its nanny restarts it (its ``memory_limit`` times Dask's
``distributed.worker.memory.terminate`` fraction, less what the process holds), and beside
the logs its other threads run at the same time, as a local ``--jobs N`` pool checks its
workers together (:func:`worker_memory`): a log that would fit alone waits for them, one
that cannot fit even alone fails with one line naming the limit.  Workers do not pool their
memory with one another: each has its own limit, as Dask itself manages it (several workers
on one machine with limits adding up to more than it has are the cluster's configuration).

Needs the optional extra ``hybridlog[dask]`` (``dask[distributed]``).
"""

from __future__ import annotations

import contextlib
import logging
import sys
import uuid
from collections.abc import Callable, Sequence
from typing import Any, TypeVar, cast

from hybridlog.errors import OptionError, excerpt

__all__ = ["CONNECT_TIMEOUT_S", "connect", "run_on_dask", "worker_memory"]

R = TypeVar("R")

CONNECT_TIMEOUT_S = 5.0
"""How long the client tries to reach the scheduler before giving up (seconds)."""


def connect(address: str) -> Any:
    """A Dask client of the scheduler at ``address`` (close it when done).

    Raises
    ------
    OptionError
        When Dask is not installed, ``address`` is not an address (no port, an unknown
        scheme), or the scheduler cannot be reached within :data:`CONNECT_TIMEOUT_S`.
    """
    try:
        from distributed import Client
    except ImportError as err:
        raise OptionError(
            "--scheduler: Dask is not installed; install the extra: pip install 'hybridlog[dask]'"
        ) from err
    try:
        return cast(Any, Client)(address, timeout=CONNECT_TIMEOUT_S)
    except Exception as err:  # refused, timed out, a bad address, or not a Dask scheduler
        reason = excerpt(" ".join(str(err).split()) or type(err).__name__, 120)[1:-1]
        shown = excerpt(address)[1:-1]
        if isinstance(err, ValueError):  # distributed's parsing: no port, an unknown scheme
            raise OptionError(
                f"--scheduler {shown}: not a scheduler address ({reason}); "
                "expected e.g. tcp://host:8786"
            ) from err
        raise OptionError(
            f"--scheduler {shown}: cannot reach the Dask scheduler within "
            f"{CONNECT_TIMEOUT_S:g} s ({reason})"
        ) from err


def run_on_dask(
    function: Callable[..., R],
    tasks: Sequence[tuple[Any, ...]],
    client: Any,
    *,
    died: Callable[[int, str], R],
    done: Callable[[R], None] | None = None,
) -> list[R]:
    """Run ``function(*task)`` for every task on the cluster of ``client`` (:func:`connect`).

    Parameters
    ----------
    function:
        A module-level function that returns its result and does not raise (catch per task
        what may fail); workers import it by reference.
    tasks:
        Argument tuples (pickled by Dask).
    client:
        A client from :func:`connect`; it is closed when all tasks are done.
    died:
        The result of task ``i`` when Dask could not run it (its worker died, Dask gave up),
        from ``(i, reason)``.
    done:
        Called with each result as it arrives (in completion order).

    Returns
    -------
    list
        One result per task, in the order of ``tasks``.
    """
    from distributed import as_completed

    # What goes wrong reaches the user as the tasks' outcomes ("on the Dask cluster: ...");
    # the client's own log, a scheduler lost when the same Ctrl-C ended it, was tracebacks
    # on the batch's stderr, at times before the interrupt reached this thread.
    dask_logs = logging.getLogger("distributed")
    level = dask_logs.level
    dask_logs.setLevel(logging.CRITICAL + 1)
    try:
        batch = uuid.uuid4().hex
        futures = [
            client.submit(function, *task, pure=False, key=f"hybridlog-batch-{batch}-{k}")
            for k, task in enumerate(tasks)
        ]
        index = {future.key: k for k, future in enumerate(futures)}
        results: dict[int, R] = {}
        for future in cast(Any, as_completed)(futures):
            k = index[future.key]
            if future.status == "finished":
                results[k] = future.result()
            else:
                error = future.exception()
                reason = " ".join(f"{type(error).__name__}: {error}".split())
                results[k] = died(k, f"on the Dask cluster: {excerpt(reason, 200)[1:-1]}")
            if done is not None:
                done(results[k])
        return [results[k] for k in range(len(tasks))]
    finally:
        client.close()
        dask_logs.setLevel(level)


def worker_memory() -> contextlib.AbstractContextManager[None]:
    """On a Dask worker, a ``with`` block in which a log reserves memory against its limit.

    Elsewhere (a local worker process, the batch process), or on a worker without a memory
    limit (each log then checked against the machine's memory alone), it does nothing.  See
    the module docstring; :func:`hybridlog.memory.shared_between_threads`.
    """
    if "distributed" not in sys.modules:  # never imported here: no Dask worker
        return contextlib.nullcontext()
    from distributed import get_worker

    try:
        worker = get_worker()
    except ValueError:  # not in a Dask worker's task
        return contextlib.nullcontext()
    memory_limit = worker.memory_manager.memory_limit
    if not memory_limit:
        return contextlib.nullcontext()
    import dask.config

    fraction = dask.config.get("distributed.worker.memory.terminate", default=False) or 1.0
    usable = int(memory_limit * float(fraction))
    from hybridlog.memory import shared_between_threads, size_text

    return shared_between_threads(
        int(worker.state.nthreads),
        _room_below(usable),
        limited_by=f" to this Dask worker (memory limit {size_text(memory_limit)})",
    )


_ROOM: dict[int, Callable[[], int | None]] = {}


def _room_below(usable: int) -> Callable[[], int | None]:
    """What this process may still take below ``usable`` bytes (one function per ``usable``)."""
    if usable not in _ROOM:
        import psutil  # type: ignore[import-untyped]  # a dependency of distributed

        process = psutil.Process()

        def room() -> int | None:
            return max(usable - int(process.memory_info().rss), 0)

        _ROOM.clear()
        _ROOM[usable] = room
    return _ROOM[usable]
