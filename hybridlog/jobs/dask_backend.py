"""Run a batch's tasks on a Dask distributed cluster (``hybridlog batch --scheduler``).

The client (the ``hybridlog batch`` process) submits one task per log to the scheduler at
the given address; Dask workers run :func:`hybridlog.jobs.batch.analyze_log`, which writes the
log's report folder into the shared output folder atomically (through
:mod:`hybridlog.outputs`), and send back its outcome; the client assembles the summary.  So
the workers must see the logs, the model file and the output folder at the same paths as the
client (a shared file system), and have the same hybridlog installed.  A worker keeps the
loaded model and compiled code between the logs it analyses, like a local worker process.

A Dask worker's ``memory_limit`` binds its logs: its nanny kills the worker past a fraction
of it (``distributed.worker.memory.terminate``, 0.95 by default), and every task that ran or
waited on it, other logs too, is retried elsewhere and killed again, until Dask gives up
("KilledWorker").  So a log analysed on a Dask worker is checked against that limit, less the
worker's process memory and what its other threads' logs hold (:func:`worker_reserved`), as
a local worker's log is against the machine's memory: one that cannot fit is refused with
one line naming the limit; one that fits alone but not beside the others waits for them.

Interrupted (Ctrl-C, the console script's ``SIGTERM``/``SIGHUP``, an error while the results
arrive), the client sets the batch's stop event on the scheduler before it lets go of the
tasks: a task that has not started returns at once, and a running one stops at its next
check (:func:`stopped`: before its log is read, between the estimator's chunks), its
temporary report folder removed, so that the cluster writes no report into ``--out`` after
the batch has ended.  The client waits :data:`STOP_WAIT_S` for the running tasks to stop;
Dask cannot interrupt one inside a compiled loop or an estimator computed whole, which
stops at its next check (or publishes its finished folder) on its own.

Needs the optional extra ``hybridlog[dask]`` (``dask[distributed]``).
"""

from __future__ import annotations

import contextlib
import sys
import threading
import time
import uuid
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any, TypeVar, cast

from hybridlog.errors import HybridlogError, OptionError, excerpt
from hybridlog.memory import available_memory, check_fits, size_text

__all__ = [
    "CONNECT_TIMEOUT_S",
    "STOP_WAIT_S",
    "WorkerMemory",
    "connect",
    "run_on_dask",
    "stopped",
    "worker_memory",
    "worker_reserved",
]

R = TypeVar("R")

CONNECT_TIMEOUT_S = 5.0
"""How long the client tries to reach the scheduler before giving up (seconds)."""

STOP_WAIT_S = 3.0
"""How long an interrupted batch waits for its running tasks to stop (seconds)."""

_STOP = threading.local()
"""In a task's thread on a worker: ``event``, the batch's stop event (:func:`_run_task`)."""


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

    batch = uuid.uuid4().hex
    stop = f"hybridlog-batch-{batch}-stop"
    futures: list[Any] = []
    try:
        for k, task in enumerate(tasks):
            futures.append(
                client.submit(
                    _run_task, function, stop, *task, pure=False, key=f"hybridlog-batch-{batch}-{k}"
                )
            )
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
    except BaseException:
        _request_stop(client, stop, futures)
        raise
    finally:
        client.close()


def _request_stop(client: Any, stop: str, futures: Sequence[Any]) -> None:
    """Stop the batch's tasks: set its stop event, wait for the running ones, cancel the rest."""
    from distributed import Event, wait

    with contextlib.suppress(Exception):  # a cluster gone: nothing of it runs on
        cast(Any, Event)(stop, client=client).set()
        with contextlib.suppress(TimeoutError):
            cast(Any, wait)(list(futures), timeout=STOP_WAIT_S)
        client.cancel(list(futures), force=True)


def _run_task(function: Callable[..., R], stop: str, *task: Any) -> R:
    """On a worker: ``function(*task)`` with the batch's stop event known to :func:`stopped`."""
    from distributed import Event

    _STOP.event = cast(Any, Event)(stop)
    try:
        return function(*task)
    finally:
        _STOP.event = None


def stopped() -> Callable[[], bool] | None:
    """In a task of a Dask batch, whether the batch was stopped, as a function; else None.

    Taken in the task's thread; the function may be called from any thread (the estimators'
    chunks are made in one of their own).
    """
    event = getattr(_STOP, "event", None)
    if event is None:
        return None
    return lambda: bool(event.is_set())


@dataclass(frozen=True)
class WorkerMemory:
    """What binds the memory of the logs a Dask worker analyses (bytes)."""

    limit: int
    """The worker's ``memory_limit``."""
    fraction: float
    """Of ``limit``, where its nanny kills the worker (1 when it never does)."""
    used: int
    """The worker process's memory now (its logs' allocations included)."""


def worker_memory() -> WorkerMemory | None:
    """The memory of the Dask worker this thread runs a task of, or None.

    None outside a Dask worker (Dask not even imported), and for a worker without a
    ``memory_limit``.
    """
    distributed = sys.modules.get("distributed")
    if distributed is None:
        return None
    try:
        worker = distributed.get_worker()
    except ValueError:  # not in a task of a worker
        return None
    manager = getattr(worker, "memory_manager", None)
    limit = getattr(manager, "memory_limit", None)
    if not limit:
        return None
    import dask

    terminate = dask.config.get("distributed.worker.memory.terminate", default=False)
    fraction = float(terminate) if terminate is not False and 0 < float(terminate) < 1 else 1.0
    return WorkerMemory(int(limit), fraction, int(worker.monitor.get_process_memory()))


_HELD: dict[int, int] = {}
"""The bytes each running task of this worker process holds (by a token of its own)."""
_HELD_LOCK = threading.Lock()

WAIT_POLL_S = 0.05
"""How often a log waiting for the memory its worker's other logs hold looks again."""


def _try_hold(token: int, need: int, memory: WorkerMemory) -> tuple[bool, int, int]:
    """Hold ``need`` for ``token`` if it fits now: ``(held, budget, what the others hold)``."""
    budget = int(memory.limit * memory.fraction) - memory.used
    machine = available_memory()
    if machine is not None:
        budget = min(budget, machine)
    with _HELD_LOCK:
        # what the others hold is counted twice while they allocate: never too little
        others = sum(_HELD.values())
        if need + others <= budget:
            _HELD[token] = need
            return True, budget, others
        return False, budget, others


@contextlib.contextmanager
def worker_reserved(
    parts: Sequence[tuple[str, int]],
    memory: WorkerMemory,
    *,
    what: str,
    remedy: str,
    error: type[HybridlogError],
    read_memory: Callable[[], WorkerMemory | None] = worker_memory,
) -> Iterator[float]:
    """Hold the ``parts``' memory on this Dask worker for the ``with`` block; the seconds waited.

    ``memory`` is the worker's (:func:`worker_memory`); while the log waits for its worker's
    other logs, ``read_memory`` reads it again.  Raises ``error``
    (:func:`~hybridlog.memory.check_fits`'s message, with the worker's limit) when the parts
    cannot fit with nothing else held.
    """
    need = sum(size for _, size in parts)
    token = object()
    started = time.monotonic()
    waited = 0.0  # exactly, when the log never waited: the batch notes the logs that did
    while True:
        fits, budget, others = _try_hold(id(token), need, memory)
        if fits:
            break
        if not others:  # alone, it cannot fit
            stop = "" if memory.fraction == 1 else f", stopped past {memory.fraction:.0%}"
            check_fits(
                parts,
                what=what,
                remedy=(
                    f"{remedy}, or Dask workers with more memory (this one: memory_limit "
                    f"{size_text(memory.limit)}{stop}, {size_text(memory.used)} in use)"
                ),
                error=error,
                available=max(budget, 0),
            )
        time.sleep(WAIT_POLL_S)
        waited = time.monotonic() - started
        memory = read_memory() or memory
    try:
        yield waited
    finally:
        with _HELD_LOCK:
            _HELD.pop(id(token), None)
