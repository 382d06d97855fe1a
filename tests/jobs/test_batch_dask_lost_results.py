"""A Dask worker that dies takes the results it holds with it: those logs are not failed.

Dask's own client and scheduler are replaced by a few lines that play what they did when a
worker died between a task's end and the client's collecting it (a real crash is a race).
"""

from __future__ import annotations

from typing import Any

import pytest

from hybridlog.jobs import dask_backend

distributed = pytest.importorskip("distributed")


class _Future:
    """A future whose status reads each of ``statuses`` in turn, one per wait."""

    def __init__(self, key: str, statuses: list[str], value: str) -> None:
        self.key, self.statuses, self.value, self.waits = key, statuses, value, 0

    @property
    def status(self) -> str:
        return self.statuses[min(self.waits, len(self.statuses)) - 1]

    def result(self) -> str:
        assert self.status == "finished"
        return self.value

    def exception(self) -> BaseException | None:
        return None

    def release(self) -> None:
        """Dask's: the client lets go of the result."""


class _Client:
    """Submits each task as a future reading the next of ``statuses``."""

    def __init__(self, statuses: list[list[str]]) -> None:
        self.statuses = iter(statuses)
        self.submitted = 0

    def submit(self, *args: Any, key: str, **kwargs: Any) -> _Future:
        self.submitted += 1
        return _Future(key, next(self.statuses), f"analysed {self.submitted - 1}")

    def close(self) -> None:
        """Dask's: the client disconnects."""


def _wait(futures: set[_Future], **kwargs: Any) -> tuple[set[_Future], set[_Future]]:
    """Every future returned as done (its status read after: it may have been lost since)."""
    for future in futures:
        future.waits += 1
    return set(futures), set()


def test_a_result_lost_after_its_task_ended_is_waited_for_not_failed(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A log whose finished result was lost with its worker before the client took it
    failed with 'on the Dask cluster: NoneType: None', its report written and Dask about to
    compute it again."""
    monkeypatch.setattr(distributed, "wait", _wait)
    client = _Client([["finished"], ["lost", "finished"]])
    workers = dask_backend.Workers("tcp://127.0.0.1:1", "0", None, "")
    results = dask_backend.run_on_dask(
        lambda: None,
        [(), ()],
        client,
        workers,
        died=lambda k, why: f"died {k}: {why}",
        failed=lambda k, why: f"failed {k}: {why}",
    )
    assert results == ["analysed 0", "analysed 1"]


def test_a_log_whose_workers_all_died_says_so_in_a_line_that_keeps_its_point() -> None:
    """Dask's KilledWorker text (400 characters: the task's key, a web page) was cut in the
    middle to fit the log's error, through 'but all those workers died'."""
    from distributed.scheduler import KilledWorker

    class Worker:
        address = "tcp://10.0.0.7:39133"

    why = dask_backend._task_error(KilledWorker("hybridlog-batch-0a1b-4", Worker(), 3))
    assert why == (
        "each of the 4 workers that ran it died, the last tcp://10.0.0.7:39133; Dask gave up "
        "on it (KilledWorker): see that worker's log"
    )
