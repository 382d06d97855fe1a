"""Batch reprocessing: one estimator over many logs, each into its own report folder.

A failing log never stops the others: its error is recorded in the summary.  A log whose
folder already holds a ``report.json`` is skipped (its report is reused in the summary)
unless ``force`` is given.  ``jobs > 1`` analyses logs in parallel worker processes.
"""

from __future__ import annotations

import json
import multiprocessing
import os
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hybridlog.analysis import (
    ReadOptions,
    analyze,
    gates_for,
    markdown_table,
    parse_sets,
    prepare_estimators,
    write_summary_csv,
)
from hybridlog.errors import HybridlogError, OptionError
from hybridlog.report import evaluate_gates

_COLUMNS = ("log", "status", "samples", "vaf", "mse", "mode_accuracy", "error")


@dataclass(frozen=True)
class LogOutcome:
    """How one log of a batch ended: ``done``, ``skipped`` (already done) or ``failed``."""

    log: str
    folder: str
    status: str
    report: dict[str, Any] | None
    error: str | None


@dataclass(frozen=True)
class BatchOutcome:
    """The whole batch: per-log outcomes, the summary table and the missed CI gates."""

    logs: list[LogOutcome]
    table: str
    gate_failures: list[str]

    @property
    def failed(self) -> int:
        """Number of logs that could not be analysed."""
        return sum(1 for log in self.logs if log.status == "failed")


def folder_names(logs: Sequence[Path]) -> list[str]:
    """A distinct report folder name per log: its stem, made unique with its parent's name."""
    stems = [log.stem for log in logs]
    names = []
    for log, stem in zip(logs, stems, strict=True):
        name = stem if stems.count(stem) == 1 else f"{log.parent.name or 'log'}_{stem}"
        while name in names:
            name += "_"
        names.append(name)
    return names


def _analyze_one(
    log: str,
    folder: str,
    model_ref: str,
    model_name: str,
    estimator: str,
    sets: tuple[str, ...],
    read: ReadOptions,
    table_format: str,
    force: bool,
) -> LogOutcome:
    report_file = Path(folder) / "report.json"
    if not force and report_file.is_file():
        try:
            report = json.loads(report_file.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            report = None  # an unreadable earlier report is redone
        if isinstance(report, dict):
            made_with = (report.get("model"), report.get("estimator"))
            if made_with == (model_name, estimator):
                return LogOutcome(log, folder, "skipped", report, None)
            return LogOutcome(
                log,
                folder,
                "failed",
                None,
                f"{folder} holds a report of {made_with[1]} with model {made_with[0]}; "
                "use --force to replace it, or another --out",
            )
    try:
        outcome = analyze(
            log,
            model_ref,
            out_dir=folder,
            estimator=estimator,
            sets=sets,
            read=read,
            table_format=table_format,
            force=True,
        )
    except HybridlogError as err:
        return LogOutcome(log, folder, "failed", None, str(err))
    return LogOutcome(log, folder, "done", outcome.report, None)


def run_batch(
    logs: Sequence[str | Path],
    model_ref: str | Path,
    *,
    out_dir: str | os.PathLike[str],
    estimator: str | None = None,
    jobs: int = 1,
    sets: Sequence[str] = (),
    read: ReadOptions | None = None,
    fail_under: Sequence[str] = (),
    fail_over: Sequence[str] = (),
    table_format: str = "csv",
    force: bool = False,
    progress: Callable[[LogOutcome], None] | None = None,
) -> BatchOutcome:
    """Analyse every log into ``<out>/<log name>/`` and write ``summary.md``/``summary.csv``.

    ``progress`` is called with each log's outcome as it finishes (in the order of ``logs``).
    """
    if jobs < 1:
        raise OptionError("--jobs: must be at least 1")
    paths = [Path(log) for log in logs]
    # the model, the estimator and every --set value are checked before any work
    model, overrides = parse_sets(sets, model_ref)
    (prepared,) = prepare_estimators(model, [estimator], overrides)
    gates = gates_for(model, fail_under, fail_over)
    root = Path(out_dir)
    root.mkdir(parents=True, exist_ok=True)
    folders = [str(root / name) for name in folder_names(paths)]
    chosen = prepared.name
    arguments = [
        (
            str(log),
            folder,
            str(model_ref),
            model.name,
            chosen,
            tuple(sets),
            read or ReadOptions(),
            table_format,
            force,
        )
        for log, folder in zip(paths, folders, strict=True)
    ]
    outcomes: list[LogOutcome] = []
    if jobs == 1 or len(arguments) == 1:
        for args in arguments:
            outcomes.append(_analyze_one(*args))
            if progress is not None:
                progress(outcomes[-1])
    else:
        context = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(max_workers=jobs, mp_context=context) as pool:
            for outcome in pool.map(_analyze_one, *zip(*arguments, strict=True)):
                outcomes.append(outcome)
                if progress is not None:
                    progress(outcome)
    rows = [
        [
            o.log,
            o.status,
            None if o.report is None else o.report["samples"],
            None if o.report is None else o.report["vaf"],
            None if o.report is None else o.report["mse"],
            None if o.report is None else o.report["modes"]["accuracy"],
            o.error,
        ]
        for o in outcomes
    ]
    table = markdown_table(_COLUMNS, rows)
    (root / "summary.md").write_text(f"# Batch: {model.name}\n\n{table}\n", encoding="utf-8")
    write_summary_csv(root / "summary.csv", _COLUMNS, rows)
    failures = [
        f"{o.log}: {failure}"
        for o in outcomes
        if o.report is not None
        for failure in evaluate_gates(o.report, gates)
    ]
    return BatchOutcome(logs=outcomes, table=table, gate_failures=failures)
