"""Run a batch's tasks on a Dask distributed cluster (``hybridlog batch --scheduler``).

The client (the ``hybridlog batch`` process) submits one task per log to the scheduler at
the given address; Dask workers run :func:`hybridlog.jobs.batch_task.analyze_log`, which writes the
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

The workers are checked before anything is written (:func:`check_workers`): a scheduler
without workers is waited for :data:`WORKER_WAIT_S` at most, then refused with one line
(a batch waited forever for workers that never came), and so is one whose workers are all
paused (:func:`_paused_workers`: Dask runs no task on a worker past its memory limit's
pause fraction, where hybridlog's imports alone leave a small one); a worker with another hybridlog
version, or one whose working folder is not the client's when the batch names a relative
path, is refused by name (its reports would record another version, or its relative paths
name other files, or none).  Once the batch folder is made, every worker must see it
(:func:`check_out`, by a file of this run's in it: a folder of the same path on a worker's own
disk, where its reports would go while the summaries point to folders missing here, is
refused by name).  A worker that joins later is checked by each task it runs
(:func:`_run_task`: the log fails, naming why).  When every worker leaves mid-batch, the
client waits :data:`WORKER_WAIT_S` for one to come back, then stops the batch with one line
(the logs done keep their folders: the next run skips them, and redoes those that failed).

Needs the optional extra ``hybridlog[dask]`` (``dask[distributed]``).
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import os
import sys
import threading
import time
import uuid
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar, cast

from hybridlog.errors import HybridlogError, OptionError, OutputError, excerpt
from hybridlog.memory import available_memory, check_fits, size_text

__all__ = [
    "CONNECT_TIMEOUT_S",
    "STOP_WAIT_S",
    "WORKER_WAIT_S",
    "WorkerMemory",
    "check_out",
    "check_workers",
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

WORKER_WAIT_S = 60.0
"""How long the batch waits for a worker when the scheduler has none (seconds): before its
first log, and when every worker left mid-batch; then it stops with an error (exit 2)."""

POLL_S = 0.5
"""How often the client, waiting for results, looks whether the scheduler still has workers."""

_CANCELLED = {
    "scheduler-connection-lost": "the connection to the scheduler was lost",
    "unknown": "by a client of the scheduler",
}
"""Dask's reasons for cancelling a future, in words."""

_STOP = threading.local()
"""In a task's thread on a worker: ``event``, the batch's stop event (:func:`_run_task`)."""


def connect(address: str) -> Any:
    """A Dask client of the scheduler at ``address`` (close it when done).

    Raises
    ------
    OptionError
        When Dask is not installed, ``address`` is not an address (no port, an unknown
        scheme, a blank at either end), the scheduler cannot be reached within
        :data:`CONNECT_TIMEOUT_S`, or what answers there does not speak Dask
        (:func:`_handshake`).
    """
    try:
        from distributed import Client
    except ImportError as err:
        raise OptionError(
            "--scheduler: Dask is not installed; install the extra: pip install 'hybridlog[dask]'"
        ) from err
    quoted = excerpt(address)
    if address != address.strip():
        raise OptionError(
            f"--scheduler {quoted}: the address has a blank at its start or end; write it "
            "without, e.g. tcp://host:8786"
        )
    # bare where it reads as written; quoted where a colon would run into the message's
    shown = quoted if address.endswith(":") or not address else quoted[1:-1]
    try:
        _check_port(address)
        _handshake(address)
        return cast(Any, Client)(address, timeout=CONNECT_TIMEOUT_S)
    except Exception as err:  # refused, timed out, a bad address, or not a Dask scheduler
        reason = excerpt(" ".join(str(err).split()) or type(err).__name__, 120)[1:-1]
        if isinstance(err, ValueError):  # distributed's parsing: no port, an unknown scheme
            raise OptionError(
                f"--scheduler {shown}: not a scheduler address ({reason}); "
                "expected e.g. tcp://host:8786"
            ) from err
        if isinstance(err, OSError) and not isinstance(err, TimeoutError):
            raise OptionError(
                f"--scheduler {shown}: cannot reach the Dask scheduler within "
                f"{CONNECT_TIMEOUT_S:g} s ({reason})"
            ) from err
        # something listens there, but does not speak Dask (a dashboard's or other HTTP port)
        why = "no Dask handshake" if isinstance(err, TimeoutError) else "its reply is not Dask's"
        raise OptionError(
            f"--scheduler {shown}: what answers there is not a Dask scheduler ({why}); "
            "give the scheduler's address, e.g. tcp://host:8786, not its dashboard's"
        ) from err


def _check_port(address: str) -> None:
    """Refuse a port no socket can have (0, above 65535) as distributed's parsing refuses others.

    distributed parses ``tcp://host:99999`` and then retries the connection, whose
    ``OverflowError`` it hides, until its timeout: "cannot reach ... Timed out".

    Raises
    ------
    ValueError
        When ``address`` names a host and port and the port is not 1 to 65535.
    """
    from distributed.comm.addressing import parse_address, parse_host_port

    scheme, location = parse_address(address)
    if scheme == "inproc":  # an in-process address has no port
        return
    port = parse_host_port(location)[1]
    if not 1 <= port <= 65535:
        raise ValueError(f"port {port} is not 1 to 65535")


def _handshake(address: str) -> None:
    """Connect to ``address`` and read its Dask handshake, within 2 x :data:`CONNECT_TIMEOUT_S`.

    Dask's client waits for the handshake without a timeout: a server that accepts the
    connection but never answers in Dask's protocol (an HTTP server waiting for its request
    to end, such as the scheduler's own dashboard) kept the batch waiting forever.

    Raises
    ------
    ValueError
        When ``address`` is not an address (distributed's parsing).
    OSError
        When nothing accepts the connection within :data:`CONNECT_TIMEOUT_S` (not a
        :class:`TimeoutError`: distributed words its own timeouts).
    TimeoutError
        When the connection was accepted but no handshake came.
    Exception
        Whatever reading a reply that is not Dask's raised (a ``MemoryError`` for an HTTP
        reply's bytes read as a frame's length).
    """
    import asyncio

    from distributed.comm.core import connect as open_comm
    from distributed.security import Security

    arguments = cast(Any, Security)().get_connection_args("client")

    async def shake() -> None:
        opening = cast(Any, open_comm)(address, timeout=CONNECT_TIMEOUT_S, **arguments)
        comm = await asyncio.wait_for(opening, 2 * CONNECT_TIMEOUT_S)
        await comm.close()

    failure: list[BaseException] = []

    def run() -> None:
        try:
            asyncio.run(shake())
        except BaseException as err:  # raised in the caller's thread
            failure.append(err)

    # a loop of its own, in a thread of its own: the caller may run one (a notebook); a
    # daemon thread, so that Ctrl-C ends the batch at once, not after the handshake's wait
    thread = threading.Thread(target=run, name="hybridlog-dask-handshake", daemon=True)
    thread.start()
    thread.join()
    if failure:
        raise failure[0]


@dataclass(frozen=True)
class Workers:
    """What every worker of the batch must share with the client (:func:`check_workers`)."""

    address: str
    """The scheduler's address, as given."""
    version: str
    """The client's hybridlog version."""
    cwd: str | None
    """The client's working folder when the batch names a relative path, else None."""
    relative: str
    """A relative path the batch names (for the message), or ``""``."""
    out: str = ""
    """The batch folder (``--out``), once :func:`check_out` found every worker sees it."""
    probe: str = ""
    """A file of this run's in :attr:`out` that a worker seeing the folder sees, or ``""``."""


def check_workers(
    client: Any, address: str, inputs: Sequence[tuple[str, str]], model: tuple[str, str]
) -> Workers:
    """Wait for the scheduler's first worker, check them all; what each task checks again.

    ``inputs`` are what the batch reads, ``(what it is, path)`` each (the logs, the model
    file, a centres file, a ``--msg-dir``): every worker must see each this process sees,
    and run in this process's folder when one is relative.  ``model`` is the model's
    reference and its SHA-256 here (:func:`~hybridlog.jobs.provenance.model_hash`): a
    worker must read the same (a built-in model of other sources, a file of the same path
    on another disk).

    Raises
    ------
    OptionError
        When no worker joined within :data:`WORKER_WAIT_S`, or a worker cannot import
        hybridlog, has another version, another working folder while paths are relative,
        does not see an input, or reads another model.
    """
    from hybridlog import __version__

    relative = [path for _, path in inputs if not os.path.isabs(path)]
    shown = excerpt(address)[1:-1]
    expected = Workers(
        address, __version__, os.getcwd() if relative else None, relative[0] if relative else ""
    )
    try:
        client.wait_for_workers(1, timeout=WORKER_WAIT_S)
    except TimeoutError as err:  # it counts running workers: a paused one is not "none"
        paused = _paused_workers(client)
        if paused is not None:
            raise OptionError(_all_paused(shown, paused, "before the first log")) from err
        raise OptionError(_no_workers(shown, "none joined")) from err
    try:
        facts = cast(dict[str, tuple[str, str]], client.run(_worker_facts))
    except Exception as err:  # a worker without hybridlog cannot unpickle the function
        reason = excerpt(" ".join(f"{type(err).__name__}: {err}".split()), 120)[1:-1]
        raise OptionError(
            f"--scheduler {shown}: a Dask worker cannot run hybridlog ({reason}); install "
            f"hybridlog {__version__} on every worker"
        ) from err
    for worker, fact in sorted(facts.items()):
        problem = _mismatch(expected, *fact)
        if problem is not None:
            raise OptionError(f"--scheduler {shown}: the Dask worker {worker} {problem}")
    # what this process does not see either fails alone, as in a local batch (a missing log)
    seen = [(what, path) for what, path in inputs if os.path.exists(path)]
    unseen = cast(dict[str, int], client.run(_first_unseen, [path for _, path in seen]))
    for worker, k in sorted(unseen.items()):
        if k >= 0:
            what, path = seen[k]
            raise OptionError(
                f"--scheduler {shown}: the Dask worker {worker} does not see the {what} "
                f"{excerpt(path)}; the workers must see the logs, the model file and --out "
                "at the same paths as this process (a shared file system)"
            )
    ref, digest = model
    digests = cast(dict[str, str], client.run(_model_digest, ref))
    for worker, theirs in sorted(digests.items()):
        if theirs != digest:
            raise OptionError(
                f"--scheduler {shown}: the Dask worker {worker} reads another model "
                f"{excerpt(ref)} (SHA-256 {theirs[:12] or 'unreadable'} there, {digest[:12]} "
                "here: other hybridlog sources, or another file at that path); the workers "
                "must have this process's installation and files"
            )
    # a worker Dask paused (its process past its memory limit's pause fraction, as the
    # checks' imports may leave it) takes no task: the batch waited for it for good
    since = time.monotonic()
    while (paused := _paused_workers(client)) is not None:
        if time.monotonic() - since >= WORKER_WAIT_S:
            raise OptionError(_all_paused(shown, paused, "before the first log"))
        time.sleep(POLL_S)
    return expected


@contextlib.contextmanager
def check_out(client: Any, workers: Workers, out: Path) -> Iterator[Workers]:
    """Check every worker sees the batch folder ``out``; what each task checks, for the batch.

    Called once the folder is made (its marker written).  A file of this run's, hidden,
    named like a temporary (:func:`~hybridlog.outputs.temporary_name`: removed by a later
    run if this process dies), is made in it for the ``with`` block: a worker must see that
    very file, so a folder of the same path on its own disk (an earlier run's there, marker
    and all) does not pass for the client's.

    Raises
    ------
    OptionError
        When a worker does not see the file, naming the worker and the folder (the file
        removed: the caller removes what it made of the folder).
    OutputError
        When the file cannot be written into the folder (a batch folder made read-only).
    """
    from hybridlog.outputs import temporary_name

    probe = temporary_name(out / "shared")
    try:
        probe.write_bytes(b"")
    except OSError as err:
        raise OutputError(f"cannot write into output directory {out}: {err.strerror}") from err
    try:
        seen = cast(dict[str, bool], client.run(_sees, str(probe)))
        for worker, sees in sorted(seen.items()):
            if not sees:
                shown = excerpt(workers.address)[1:-1]
                raise OptionError(
                    f"--scheduler {shown}: {_unseen_out(worker, str(out))}; its reports would "
                    "go to its own disk, and the summaries here name folders missing here"
                )
        yield dataclasses.replace(workers, out=str(out), probe=str(probe))
    finally:
        with contextlib.suppress(OSError):
            probe.unlink()


def _sees(path: str) -> bool:
    """On a worker: whether it sees ``path``."""
    return os.path.exists(path)


def _unseen_out(worker: str, out: str) -> str:
    """Why a worker cannot run the batch's logs: it does not see --out (short: a log's error)."""
    return (
        f"the Dask worker {worker} does not see --out {excerpt(out)} (not on a shared file system?)"
    )


def _model_digest(ref: str) -> str:
    """On a worker: :func:`~hybridlog.jobs.provenance.model_hash` of ``ref``, or ``""``."""
    from hybridlog.jobs.provenance import model_hash

    try:
        return model_hash(ref)
    except HybridlogError:
        return ""


def _first_unseen(paths: Sequence[str]) -> int:
    """On a worker: the index of the first of ``paths`` it does not see, or -1."""
    return next((k for k, path in enumerate(paths) if not os.path.exists(path)), -1)


def _no_workers(shown: str, why: str) -> str:
    return (
        f"--scheduler {shown}: the scheduler has no workers ({why} within "
        f"{WORKER_WAIT_S:g} s); start some: dask worker {shown}"
    )


def _paused_workers(client: Any) -> list[str] | None:
    """The scheduler's workers when every one is paused (Dask runs no task there), or None.

    Each as ``"ADDRESS (USED of its LIMIT memory limit)"``; ``None`` when a worker runs, or
    there is none.
    """
    workers = client.scheduler_info(n_workers=-1).get("workers", {})
    if not workers or any(info.get("status") != "paused" for info in workers.values()):
        return None
    return [
        # in MB: size_text's "0.3 GB of its 0.3 GB" said nothing of a 350 MB worker
        f"{address} ({(info.get('metrics', {}).get('memory') or 0) / 1e6:,.0f} MB of its "
        f"{(info.get('memory_limit') or 0) / 1e6:,.0f} MB memory limit)"
        for address, info in sorted(workers.items())
    ]


def _all_paused(shown: str, paused: Sequence[str], when: str) -> str:
    listed = ", ".join(paused[:3]) + (f" and {len(paused) - 3} more" if len(paused) > 3 else "")
    return (
        f"--scheduler {shown}: every Dask worker is paused, so none runs a log ({when}; none "
        f"resumed within {WORKER_WAIT_S:g} s): {listed}; Dask pauses a worker whose process "
        "holds 80 % of its memory limit (its default): start the workers with more memory"
    )


def _worker_facts() -> tuple[str, str]:
    """On a worker: its hybridlog version and working folder."""
    from hybridlog import __version__

    return __version__, os.getcwd()


def _mismatch(expected: Workers, version: str, cwd: str) -> str | None:
    """Why a worker of ``version`` working in ``cwd`` cannot run the batch's logs, or None."""
    if version != expected.version:
        return (
            f"has hybridlog {excerpt(version, 40)[1:-1]}, this process {expected.version}: its "
            "reports would record another version; install the same on every worker"
        )
    if expected.cwd is not None and os.path.realpath(cwd) != os.path.realpath(expected.cwd):
        return (
            f"runs in {excerpt(cwd)}, not in {excerpt(expected.cwd)}, so the relative path "
            f"{excerpt(expected.relative)} names another file there, or none; give absolute "
            "paths, or start the workers in this folder"
        )
    return None


def run_on_dask(
    function: Callable[..., R],
    tasks: Sequence[tuple[Any, ...]],
    client: Any,
    workers: Workers,
    *,
    died: Callable[[int, str], R],
    failed: Callable[[int, str], R] | None = None,
    done: Callable[[R], None] | None = None,
    kept: Callable[[R], bool] | None = None,
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
    workers:
        What each worker must share with the client (:func:`check_workers`): a task on a
        worker that does not is the log's failure, naming why.
    died:
        The result of task ``i`` when Dask could not run it (its worker died, Dask gave up),
        from ``(i, reason)``.
    failed:
        The result of task ``i`` that raised on a worker that lives on (a worker unfit for
        the batch, :func:`_run_task`; a task the scheduler could not unpickle), from
        ``(i, reason)``; ``died``'s when None.
    done:
        Called with each result as it arrives (in completion order).
    kept:
        Whether a result's log is done for good (the next run skips it), not failed (it
        redoes it): counted apart when the batch ends mid-way; every result when None.

    Returns
    -------
    list
        One result per task, in the order of ``tasks``.

    Raises
    ------
    OptionError
        When the scheduler had no worker for :data:`WORKER_WAIT_S` (every one left), or
        the batch's tasks were lost with the connection to it (or cancelled by someone).
    """
    from distributed import wait
    from distributed.client import FuturesCancelledError

    batch = uuid.uuid4().hex
    stop = f"hybridlog-batch-{batch}-stop"
    pending: set[Any] = set()
    # the client logs its lost connection with tracebacks: the batch says it in one line
    quiet = logging.getLogger("distributed.client")
    level = quiet.level
    quiet.setLevel(logging.CRITICAL)
    try:
        index: dict[str, int] = {}
        for k, task in enumerate(tasks):
            future = client.submit(
                _run_task,
                function,
                stop,
                # plain values: the scheduler unpickles the task too, maybe another version
                dataclasses.astuple(workers),
                *task,
                pure=False,
                key=f"hybridlog-batch-{batch}-{k}",
            )
            index[future.key] = k
            pending.add(future)
        results: dict[int, R] = {}
        alone_since: float | None = None  # since when the scheduler has had no worker
        while pending:
            try:
                finished, pending = cast(Any, wait)(
                    pending, timeout=POLL_S, return_when="FIRST_COMPLETED"
                )
            except FuturesCancelledError as err:  # the scheduler lost, or someone cancelled
                reasons = {_CANCELLED.get(group.reason, group.reason) for group in err.error_groups}
                why = ", ".join(sorted(reasons))
                why = f"its tasks were cancelled: {why}"
                raise _ended(workers, why, _how_far(results, len(tasks), kept)) from None
            except TimeoutError:
                try:
                    paused = _paused_workers(client)
                    running = paused is None and bool(client.nthreads())
                except Exception as err:  # the scheduler gone (refused, closed, timed out)
                    why = excerpt(" ".join(f"{type(err).__name__}: {err}".split()), 80)[1:-1]
                    why = f"the scheduler is gone: {why}"
                    raise _ended(workers, why, _how_far(results, len(tasks), kept)) from None
                if running:
                    alone_since = None
                    continue
                now = time.monotonic()
                alone_since = now if alone_since is None else alone_since
                if now - alone_since >= WORKER_WAIT_S and paused:
                    how_far = _how_far(results, len(tasks), kept)
                    raise OptionError(
                        _all_paused(excerpt(workers.address)[1:-1], paused, f"mid-batch, {how_far}")
                    ) from None
                if now - alone_since >= WORKER_WAIT_S:
                    raise OptionError(
                        _no_workers(
                            excerpt(workers.address)[1:-1],
                            "every worker left mid-batch, "
                            f"{_how_far(results, len(tasks), kept)}; none came back",
                        )
                    ) from None
                continue
            alone_since = None
            for future in sorted(finished, key=lambda f: index[f.key]):
                k = index[future.key]
                if future.status == "finished":
                    results[k] = future.result()
                elif future.status != "error":
                    # lost since it finished, with the worker that held its result: Dask
                    # runs it again (its error was 'NoneType: None', a log that did not fail)
                    pending.add(future)
                    continue
                else:
                    error = future.exception()
                    reason = f"on the Dask cluster: {_task_error(error)}"
                    lost = type(error).__name__ == "KilledWorker" or failed is None
                    results[k] = died(k, reason) if lost else cast(Any, failed)(k, reason)
                # let go of it: held, its result would be computed again (its log analysed
                # again) when the worker keeping it leaves
                future.release()
                if done is not None:
                    done(results[k])
        return [results[k] for k in range(len(tasks))]
    except BaseException:
        _request_stop(client, stop, list(pending))
        raise
    finally:
        client.close()
        quiet.setLevel(level)


def _task_error(error: BaseException) -> str:
    """Why Dask could not run a log's task, in one short line.

    Dask's ``KilledWorker`` is said by what it holds (how many workers died running the task,
    the last one's address): its own words, 400 characters naming the task's key and a web
    page, were cut in the middle to fit the log's error, through ``all those workers died``.
    """
    if type(error).__name__ == "KilledWorker" and len(error.args) == 3:
        _, last, allowed = error.args
        address = excerpt(getattr(last, "address", last), 60)[1:-1]
        return (
            f"each of the {allowed + 1} workers that ran it died, the last {address}; "
            "Dask gave up on it (KilledWorker): see that worker's log"
        )
    return excerpt(" ".join(f"{type(error).__name__}: {error}".split()), 200)[1:-1]


def _ended(workers: Workers, why: str, how_far: str) -> OptionError:
    """The error of a batch the cluster stopped running (:func:`_how_far` it got)."""
    return OptionError(
        f"--scheduler {excerpt(workers.address)[1:-1]}: the batch ended mid-way ({why}); {how_far}"
    )


def _how_far(results: Mapping[int, R], total: int, kept: Callable[[R], bool] | None) -> str:
    """How many of ``total`` logs a batch ended mid-way did, and how many failed.

    The logs done keep their folders and the next run skips them; the failed ones it redoes
    ("3 of 10 logs done", counting the failed ones too, told the user those were skipped).
    """
    done = sum(1 for result in results.values() if kept is None or kept(result))
    failed = len(results) - done
    text = f"{done:,} of {total:,} logs done, which the next run skips"
    if failed:
        text += f"; {failed:,} failed, which it redoes"
    return text


def _request_stop(client: Any, stop: str, futures: Sequence[Any]) -> None:
    """Stop the batch's tasks: set its stop event, wait for the running ones, cancel the rest."""
    from distributed import Event, wait

    with contextlib.suppress(Exception):  # a cluster gone: nothing of it runs on
        cast(Any, Event)(stop, client=client).set()
        with contextlib.suppress(TimeoutError):
            cast(Any, wait)(list(futures), timeout=STOP_WAIT_S)
        client.cancel(list(futures), force=True)


def _run_task(
    function: Callable[..., R],
    stop: str,
    workers: tuple[str, str, str | None, str, str, str],
    *task: Any,
) -> R:
    """On a worker: ``function(*task)`` with the batch's stop event known to :func:`stopped`.

    Raises
    ------
    OptionError
        When this worker does not share what the batch needs with the client (a worker that
        joined after :func:`check_workers` or :func:`check_out`): the log fails, naming why.
    """
    from distributed import Event, get_worker

    expected = Workers(*workers)
    problem = _mismatch(expected, *_worker_facts())
    if problem is not None:
        raise OptionError(f"the Dask worker {get_worker().address} {problem}")
    if expected.probe and not _sees(expected.probe):
        raise OptionError(_unseen_out(get_worker().address, expected.out))
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
