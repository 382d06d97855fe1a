"""What ``analyze`` and ``compare`` send their estimators' worker to run, apart from the job.

A function sent to a worker (:mod:`hybridlog.background`) goes pickled by its module and
name, and the worker imports that module to run it.  Sent from the job's own module (they are
sent by :mod:`hybridlog.jobs.estimation`), they made the worker import the whole job, with the
readers' and the report's modules it never runs: its warm-up request took 0.12 s of a core,
against 0.08 s from here, while the command reads its log on the other one.  This module
imports only what an estimator's warm-up and its chunks need
(``tests/jobs/test_estimator_calls.py``).
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING, Any

from hybridlog.cluster.progress import WorkReporter, current_wait, reporting

if TYPE_CHECKING:
    from hybridlog.estimators import Prepared
    from hybridlog.estimators.result import EstimationResult
    from hybridlog.model.hybrid_model import HybridModel

__all__ = ["reported", "warm_up_told"]


def warm_up_told(
    estimator: Prepared,
    model: HybridModel,
    wait: Callable[[str, str], contextlib.AbstractContextManager[None]] | None = None,
) -> None:
    """``estimator.warm_up(model)`` inside ``wait``'s context, which names what it compiles.

    :attr:`WorkReporter.wait <hybridlog.cluster.progress.WorkReporter.wait>`; by default
    the installed reporter's (:func:`~hybridlog.cluster.progress.current_wait`), if any:
    a batch's worker warms up so before its first log (:mod:`hybridlog.jobs.batch_task`).
    """
    with (current_wait() if wait is None else wait)(
        f"{estimator.name}: compiling machine code for model {model.name!r}",
        "its first run with these options; later runs load it from the cache",
    ):
        estimator.warm_up(model)


def reported(
    reporter: WorkReporter,
    stream: Callable[..., Iterator[EstimationResult]],
    *args: Any,
) -> Iterator[EstimationResult]:
    """``stream(*args)`` with ``reporter`` installed (:mod:`hybridlog.cluster.progress`).

    Run in the estimators' worker, whose stderr is the command's.
    """
    with reporting(reporter):
        yield from stream(*args)
