"""Write every output of ``hybridlog analyze`` into one directory, atomically."""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Mapping, Sequence
from contextlib import ExitStack
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any

from hybridlog.background import Background, Task, beside
from hybridlog.estimators.result import EstimationResult
from hybridlog.outputs import atomic_output_dir
from hybridlog.report.build import ReportBuilder
from hybridlog.report.document import Report
from hybridlog.report.gates import GATES_KEY, Gate, gate_records
from hybridlog.report.markdown import render_markdown
from hybridlog.report.plot_figures import prepare_plotting
from hybridlog.report.plot_reducer import PlotReducer
from hybridlog.report.plots import draw_into, figure_shapes
from hybridlog.report.table_format import TableFormat, check_table_format
from hybridlog.report.tables import TableWriter, estimates_table, states_with_truth, timeline_table
from hybridlog.signals import AlignedSignals

if TYPE_CHECKING:
    from hybridlog.model.hybrid_model import HybridModel

__all__ = ["write_report"]


class _RunTables:
    """The timeline and estimates tables of one run, appended a chunk at a time.

    The writers open with the first chunk, whose tables give the schemas; every chunk's
    tables have the same columns, the ``<x>_true`` ones decided on the whole run's truth
    (:func:`~hybridlog.report.tables.states_with_truth`).  Each writer encodes in a thread
    of its own (:class:`~hybridlog.report.tables.TableWriter`).  Used as a context manager:
    leaving it with an exception abandons both writers (their threads ended, the files left
    to the atomic output folder to discard).
    """

    def __init__(self, folder: Path, table_format: TableFormat, signals: AlignedSignals) -> None:
        self._folder = folder
        self._format = table_format
        self._signals = signals
        self._truth = states_with_truth(signals)
        self._writers: list[TableWriter] = []
        self._stack = ExitStack()

    def __enter__(self) -> _RunTables:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self._stack.__exit__(exc_type, exc, traceback)

    def add(self, chunk: EstimationResult, start: int) -> None:
        """Append a chunk of the run's result, which covers rows from ``start`` on."""
        rows = self._signals.rows(start, start + chunk.n_samples)
        tables = (
            timeline_table(chunk, rows),
            estimates_table(chunk, rows, truth_states=self._truth),
        )
        if not self._writers:
            self._writers = [
                self._stack.enter_context(
                    TableWriter(self._folder / name, self._format, table.schema)
                )
                for name, table in zip(("timeline", "estimates"), tables, strict=True)
            ]
        for writer, table in zip(self._writers, tables, strict=True):
            writer.add(table)

    def close(self) -> None:
        """Finish both files (the writers' threads write what they still hold)."""
        for writer in self._writers:
            writer.close()
        self._stack.pop_all()


def write_report(
    out_dir: str | os.PathLike[str],
    result: EstimationResult | Iterable[EstimationResult],
    signals: AlignedSignals,
    *,
    log: str,
    model_name: str,
    dt: float,
    table_format: str = "csv",
    force: bool = False,
    reading: Mapping[str, Any] | None = None,
    extra: Mapping[str, Any] | None = None,
    plots: bool | Callable[[Report], bool] = True,
    model: HybridModel | None = None,
    gates: Sequence[Gate] = (),
) -> Report:
    """Compute the metrics of a run and write its output directory (SPEC §8).

    Writes ``report.json``, ``report.md``, ``timeline.<fmt>``, ``estimates.<fmt>`` and
    ``plots/{outputs,modes,states}.png`` into a temporary directory and renames it to
    ``out_dir`` only when all of them are complete (see
    :func:`hybridlog.outputs.atomic_output_dir`).

    The result may come whole or in consecutive chunks of rows
    (:meth:`hybridlog.estimators.Prepared.stream`, whose arrays a later chunk overwrites):
    each chunk is taken by the metrics (:class:`~hybridlog.report.build.ReportBuilder`),
    appended to both tables and reduced for the plots
    (:class:`~hybridlog.report.plot_reducer.PlotReducer`) before the next is asked for, so a
    streamed run never holds its whole result.  When the plots are to be drawn, matplotlib
    is imported and the empty figures are made meanwhile
    (:func:`~hybridlog.report.plot_figures.prepare_plotting`), and the figures are drawn from the
    reduced data beside ``report.json``, ``report.md`` and the tables' last batches: both
    :func:`hybridlog.background.beside`, in the process's worker (the console script's
    ``analyze`` and ``compare``: the analysing process never imports matplotlib) or in a
    thread.

    Parameters
    ----------
    out_dir:
        The output directory.
    result:
        What the estimator returned, or its chunks in order.
    signals:
        The aligned signals it ran on.
    log:
        Path or name of the log, recorded in the report.
    model_name:
        Name of the model, recorded in the report.
    dt:
        The model's sample time in seconds.
    table_format:
        ``"csv"`` or ``"parquet"`` for the timeline and estimates tables.
    force:
        Replace a non-empty existing ``out_dir``.
    reading:
        What reading the log did, recorded as the report's ``reading``.
    extra:
        Additional top-level report keys (they replace computed keys of the same name).
    plots:
        Whether to draw ``plots/`` (matplotlib is imported only then), or a test of the
        report that decides it (``hybridlog batch --plots failed``: logs that miss a gate).
    model:
        The model the result was estimated with (for the outputs a smoothed run's estimates
        explain, :func:`~hybridlog.report.build.build_report`, and the figures made ahead).
    gates:
        CI gates checked against the report and recorded in it (``analyze``'s; key
        ``gates``, :func:`~hybridlog.report.gates.gate_records`).

    Returns
    -------
    Report
        The report; ``report.json`` holds its :meth:`~Report.to_json`.

    Raises
    ------
    OptionError
        For an unknown ``table_format``.
    OutputError
        When ``out_dir`` exists and is not empty (without ``force``) or cannot be written.
    LogError
        When the run is too short to report (before any chunk is asked for).

    """
    fmt = check_table_format(table_format)
    chunks = (result,) if isinstance(result, EstimationResult) else result
    builder = ReportBuilder(signals, log=log, dt=dt, model=model)
    preparing: Background[None] | Task[None] | None = None
    if plots is True:
        shapes = [] if model is None else _shapes(model)
        preparing = beside(prepare_plotting, shapes, name="hybridlog-import-plotting")
    try:
        with atomic_output_dir(out_dir, force=force) as tmp:
            report = _write_into(
                tmp, chunks, signals, builder, fmt, plots, reading, extra, model_name, gates
            )
    finally:
        if preparing is not None:
            preparing.wait()
    if preparing is not None:
        preparing.result()
    return report


def _shapes(model: HybridModel) -> list[tuple[int, float]]:
    """The figures of a model's plots, made ahead (:func:`~.plots.figure_shapes`)."""
    return figure_shapes(model.n_outputs, model.n_states, bool(model.components), model.n_modes)


def _start_drawing(folder: Path, reducer: PlotReducer) -> Background[list[Path]] | Task[list[Path]]:
    """Draw the plots of every row ``reducer`` took into ``folder / "plots"``, beside the caller."""
    return beside(draw_into, folder / "plots", reducer.finish(), name="hybridlog-plots")


def _write_into(
    folder: Path,
    chunks: Iterable[EstimationResult],
    signals: AlignedSignals,
    builder: ReportBuilder,
    fmt: TableFormat,
    plots: bool | Callable[[Report], bool],
    reading: Mapping[str, Any] | None,
    extra: Mapping[str, Any] | None,
    model_name: str,
    gates: Sequence[Gate],
) -> Report:
    """Everything :func:`write_report` writes, into the temporary ``folder``."""
    reducer: PlotReducer | None = None
    drawing: Background[list[Path]] | Task[list[Path]] | None = None
    try:
        with _RunTables(folder, fmt, signals) as tables:
            for chunk in chunks:
                start = builder.rows
                builder.add(chunk)
                tables.add(chunk, start)
                if plots is not False:
                    if reducer is None:
                        reducer = PlotReducer(
                            signals, chunk.mode_ids, chunk.state_names, chunk.output_names
                        )
                    reducer.add(chunk, start)
            if reducer is not None and plots is True:
                # the longest step left: started before the report's last metrics
                drawing = _start_drawing(folder, reducer)
            report = builder.report(model_name=model_name, reading=reading, extra=extra)
            if gates:
                report = report.with_extra({GATES_KEY: gate_records(report, gates)})
            if reducer is not None and callable(plots) and plots(report):
                drawing = _start_drawing(folder, reducer)
            (folder / "report.json").write_text(report.to_json(), encoding="utf-8")
            (folder / "report.md").write_text(render_markdown(report), encoding="utf-8")
            tables.close()
        if drawing is not None:
            drawing.result()
    finally:
        if drawing is not None:  # never leave the folder while the drawing writes into it
            drawing.wait()
    return report
