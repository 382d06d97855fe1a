"""Run a batch's tasks on a Dask distributed cluster (``hybridlog batch --scheduler``).

The client (the ``hybridlog batch`` process) submits one task per log to the scheduler at
the given address; Dask workers run :func:`hybridlog.jobs.batch.analyze_log`, which writes the
log's report folder into the shared output folder atomically (through
:mod:`hybridlog.outputs`), and send back its outcome; the client assembles the summary.  So
the workers must see the logs, the model file and the output folder at the same paths as the
client (a shared file system), and have the same hybridlog installed.  A worker keeps the
loaded model and compiled code between the logs it analyses, like a local worker process.

Needs the optional extra ``hybridlog[dask]`` (``dask[distributed]``).
"""

from __future__ import annotations

import uuid
from collections.abc import Callable, Sequence
from typing import Any, TypeVar, cast

from hybridlog.errors import OptionError, excerpt

__all__ = ["CONNECT_TIMEOUT_S", "connect", "run_on_dask"]

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
