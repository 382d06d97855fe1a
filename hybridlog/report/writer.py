"""Write every output of ``hybridlog analyze`` into one directory, atomically."""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from hybridlog.background import Background, Forked, beside
from hybridlog.estimators.result import EstimationResult
from hybridlog.outputs import atomic_output_dir
from hybridlog.report.build import build_report
from hybridlog.report.document import Report
from hybridlog.report.markdown import render_markdown
from hybridlog.report.tables import (
    check_table_format,
    estimates_table,
    timeline_table,
    write_table,
)
from hybridlog.signals import AlignedSignals

if TYPE_CHECKING:
    from hybridlog.model.hybrid_model import HybridModel

__all__ = ["import_plotting", "write_plots", "write_report"]


def import_plotting(model: HybridModel | None = None) -> None:
    """Import what :func:`write_plots` draws with (matplotlib's figure and Agg canvas).

    About 0.3 s of Python that ``analyze`` spends in a thread while the estimator's compiled
    loop runs without the GIL, rather than before its first figure; with ``model``, the
    empty figures of its plots are made there too
    (:func:`hybridlog.report.plots.prepare_figures`).
    """
    import matplotlib.backends.backend_agg
    import matplotlib.figure  # noqa: F401

    from hybridlog.report import plots

    if model is not None:
        plots.prepare_figures(
            plots.figure_shapes(model.n_outputs, model.n_states, bool(model.components))
        )


def write_plots(plot_dir: Path, result: EstimationResult, signals: AlignedSignals) -> list[Path]:
    """:func:`hybridlog.report.plots.write_plots`, importing matplotlib only when called."""
    from hybridlog.report.plots import write_plots as draw

    return draw(plot_dir, result, signals)


def write_report(
    out_dir: str | os.PathLike[str],
    result: EstimationResult,
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
) -> Report:
    """Compute the metrics of a run and write its output directory (SPEC §8).

    Writes ``report.json``, ``report.md``, ``timeline.<fmt>``, ``estimates.<fmt>`` and
    ``plots/{outputs,modes,states}.png`` into a temporary directory and renames it to
    ``out_dir`` only when all of them are complete (see
    :func:`hybridlog.outputs.atomic_output_dir`).

    Parameters
    ----------
    out_dir:
        The output directory.
    result:
        What the estimator returned.
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
        explain, :func:`~hybridlog.report.build.build_report`).

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

    """
    fmt = check_table_format(table_format)
    with atomic_output_dir(out_dir, force=force) as tmp:
        plot_dir = Path(tmp / "plots")
        # The plots are drawn beside the metrics and tables (see :mod:`hybridlog.background`:
        # in a forked child where the process allows it, else in a thread: matplotlib holds
        # the GIL, numpy's reductions and polars' writers mostly do not).  Plots that depend
        # on the report start after it.
        drawing = _draw(plot_dir, result, signals) if plots is True else None
        try:
            report = build_report(
                result,
                signals,
                log=log,
                model_name=model_name,
                dt=dt,
                reading=reading,
                extra=extra,
                model=model,
            )
            (tmp / "report.json").write_text(report.to_json(), encoding="utf-8")
            (tmp / "report.md").write_text(render_markdown(report), encoding="utf-8")
            write_table(timeline_table(result, signals), tmp / "timeline", fmt)
            write_table(estimates_table(result, signals), tmp / "estimates", fmt)
            if callable(plots) and plots(report):
                drawing = _draw(plot_dir, result, signals)
            if drawing is not None:
                drawing.result()
        finally:
            if drawing is not None:  # never leave the folder while the drawing writes into it
                drawing.wait()
    return report


def _draw(
    plot_dir: Path, result: EstimationResult, signals: AlignedSignals
) -> Background[list[Path]] | Forked[list[Path]]:
    """:func:`write_plots` into a new ``plot_dir``, beside the caller.

    :func:`hybridlog.background.beside`: in a forked child in a one-command process, else
    in a thread.
    """

    def draw() -> list[Path]:
        plot_dir.mkdir()
        return write_plots(plot_dir, result, signals)

    return beside(draw, "hybridlog-plots")
