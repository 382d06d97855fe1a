"""The memory of an estimator's run over ``n`` samples: its result and its own arrays.

A light module (no numpy): the jobs check a run against the memory available
(:func:`hybridlog.memory.check_fits`) after reading the log and before the estimator
allocates anything.  An entry of the registry names, in its options module, a function
``(model, options, n) -> [(what, bytes), ...]`` for the arrays beyond the result
(:attr:`~hybridlog.estimators.registry.Estimator.memory`); the sizes count the arrays the
code allocates, 8 bytes a float or an index.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from hybridlog.model.hybrid_model import HybridModel

__all__ = ["MODE_BYTES", "REPORT_FACTOR", "Parts", "result_bytes"]

Parts = list[tuple[str, int]]
"""What is allocated and how many bytes, largest first where it matters to the reader."""

REPORT_FACTOR = 1.5
"""The run's peak over its result: the report's temporaries (metrics a column at a time,
tables and plot reductions a block at a time, matplotlib when the plots are drawn in a
thread) and what the allocators keep after freeing.  Measured on the three-tank model at
10^6 samples (peak RSS less the RSS when the check is made, after reading): ``imm`` grew
by 113-146 MiB over a result of 99 MiB.  With the estimators' own arrays counted as
allocated, the estimates were 1.1-2.0 times the growth measured: ``smooth = true`` 431
against 346 MiB, ``viterbi`` 202 against 185, ``kbest`` 385 against 193, ``kbest`` with
``smooth`` 668 against 469 (not every page of the k-best search's arrays is touched).  So
a run refused needs at least about half of what the message says."""


MODE_BYTES = 8
"""Bytes a sample of the estimated mode sequence (an int64 index), which the report of a
streamed run keeps whole for its mode metrics."""


def result_bytes(model: HybridModel, n: int) -> int:
    """An :class:`~hybridlog.estimators.result.EstimationResult` of ``n`` samples.

    Per sample the mode index, the mode probabilities, the state means and variances and the
    output prediction.
    """
    return MODE_BYTES * n + 8 * n * (model.n_modes + 2 * model.n_states + model.n_outputs)
