"""One log of a batch as its summaries show it (:class:`BatchRow`), and the summaries' columns.

:data:`BATCH_METRICS` are the metrics of every log; :func:`gated_columns` adds a column per
gated metric not shown already and :func:`state_columns` one per state some report has an
RMSE of (batch's summaries and compare's table alike); :func:`gate_cell` is one run's gates
in a table.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from hybridlog.report.gates import metric as report_metric
from hybridlog.report.summary_offline import fallback_cells, offline_label

if TYPE_CHECKING:
    from hybridlog.report.document import Report
    from hybridlog.report.report_parts import SmoothingMetrics

__all__ = ["BATCH_METRICS", "BatchRow", "gate_cell", "gated_columns", "state_columns"]


@dataclass(frozen=True)
class BatchRow:
    r"""One log of a batch, as its summaries show it.

    Attributes
    ----------
    log:
        The log's path as given, as :func:`~hybridlog.errors.as_name` writes it (a byte
        that is not UTF-8 ``\xNN``, a backslash ``\\``).
    folder:
        Its report folder, relative to the batch folder (written the same way).
    status:
        ``done``, ``skipped`` (an earlier report of the same run reused) or ``failed``.
    report:
        The report (``None`` when the log could not be analysed).
    error:
        The one-line error of a failed log.
    gates:
        ``(gate, failure)`` per CI gate, e.g. ``("--fail-under vaf=90", "vaf = 87.2 is under
        the bound 90")``; ``failure`` is ``None`` for a gate met.  Empty for a failed log.
    made_from:
        For a log skipped whose reused report an earlier run made from its content read at
        another path (the logs' folder renamed since), the path that report names.
    seconds:
        The log's wall time in this run (JUnit's ``time``): reading, estimating and writing.
    """

    log: str
    folder: str
    status: str
    report: Report | None
    error: str | None
    gates: tuple[tuple[str, str | None], ...] = ()
    made_from: str | None = None
    seconds: float = 0.0

    @property
    def missed(self) -> list[str]:
        """The failure messages of the gates this log missed."""
        return [failure for _, failure in self.gates if failure is not None]

    @property
    def passed(self) -> bool:
        """Analysed, and every gate met."""
        return self.status != "failed" and not self.missed

    def metrics(self) -> list[object]:
        """The key metrics shown for every log: samples, VAF, MSE, mode accuracy."""
        r = self.report
        if r is None:
            return [None, None, None, None]
        return [r.samples, r.vaf, r.mse, r.modes.accuracy]

    def values(self, metrics: Sequence[str]) -> list[object]:
        """The report's value of each of ``metrics`` (gate names: ``fit``, ``state_rmse.x1``).

        ``None`` where the report holds ``null``, and for a failed log.
        """
        r = self.report
        return [None if r is None else report_metric(r, name) for name in metrics]

    def offline_pairs(self, metrics: Sequence[str]) -> list[tuple[str, float | None, float | None]]:
        """``(metric, offline, filter's own)`` for each of ``metrics`` (:func:`offline_metrics`).

        Read from the report's ``smoothing`` block (``smoothed``, ``filtered``); ``None``
        where a side is unknown (no true mode or state, a failed log, a report of the filter
        alone).
        """
        smoothing = None if self.report is None else self.report.smoothing
        if smoothing is None:
            return [(metric, None, None) for metric in metrics]
        return [
            (
                metric,
                _side_value(smoothing.smoothed, metric),
                _side_value(smoothing.filtered, metric),
            )
            for metric in metrics
        ]

    def samples_apart(self, metric: str) -> tuple[int, int] | None:
        """The two sample counts of a ``state_rmse.<x>`` metric over other samples, else ``None``.

        ``(filter's samples, offline samples)``, :meth:`Smoothing.samples_apart`.
        """
        smoothing = None if self.report is None else self.report.smoothing
        base, _, state = metric.partition(".")
        if smoothing is None or base != "state_rmse":
            return None
        return smoothing.samples_apart(state)

    def offline_cells(self, metrics: Sequence[str]) -> list[object]:
        """The cells of :func:`offline_columns` (empty for a failed log)."""
        smoothing = None if self.report is None else self.report.smoothing
        cells: list[object] = []
        for metric, offline, own in self.offline_pairs(metrics):
            cells += [own] if metric == "mode_accuracy" else [offline, own]
        fallbacks = None if smoothing is None else smoothing.fallbacks
        return [
            *cells,
            None if smoothing is None else offline_label(smoothing),
            *fallback_cells(fallbacks),
        ]


BATCH_METRICS = ("samples", "vaf", "mse", "mode_accuracy")
"""The metrics of each log in the batch summaries (report keys)."""


def gated_columns(gated: Sequence[str], shown: Sequence[str]) -> tuple[str, ...]:
    """The gated metrics a batch summary adds as columns: those it does not show already.

    Once each, in the gates' order: a batch gated on ``fit`` or ``state_rmse.x1`` shows each
    log's value, not only, for a log that missed the gate, the message that says so.
    """
    return tuple(dict.fromkeys(name for name in gated if name not in shown))


def state_columns(reports: Iterable[Report | None]) -> tuple[str, ...]:
    """``state_rmse.<x>`` for each state some report has an RMSE of (a true state in the log).

    compare's table and batch's summary.csv showed no state's RMSE unless gated (or, in a
    batch, smoothed), though for an observer the states are what it estimates; a state no
    report could be scored on gets no column.
    """
    states = dict.fromkeys(
        x
        for report in reports
        if report is not None
        for x, state in report.states.items()
        if state.rmse is not None
    )
    return tuple(f"state_rmse.{x}" for x in states)


def _side_value(side: SmoothingMetrics, metric: str) -> float | None:
    """One side's value of a metric of :func:`offline_metrics` (``None`` when unknown)."""
    base, _, qualifier = metric.partition(".")
    if base == "state_rmse":
        state = side.states.get(qualifier)
        return None if state is None else state.rmse
    if qualifier:
        component = side.components.get(qualifier)
        return None if component is None else component.mode_accuracy
    return side.mode_accuracy


def gate_cell(n_gates: int, missed: Sequence[str]) -> str:
    """The gates of one run in a summary table: ``pass (2)``, ``FAIL: vaf = 87.2 is ...``.

    Empty when no gate was given.
    """
    if not n_gates:
        return ""
    if not missed:
        return f"pass ({n_gates})"
    return "FAIL: " + "; ".join(missed)
