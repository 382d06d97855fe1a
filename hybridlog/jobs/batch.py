"""Batch reprocessing: one estimator over many logs, each into its own report folder.

A failing log never stops the others: any exception while analysing a log, and a worker
process that dies, is recorded as that log's one-line error in the summary.  A log whose
folder already holds a report of the same model and estimator is skipped (its report is reused
in the summary) unless ``force`` is given.  ``jobs > 1`` analyses logs in parallel worker
processes (:mod:`hybridlog.jobs.workers`), which exit when the batch process dies.  Logs are
processed and summarised in natural order (``s1, s2, s10``).
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from hybridlog.errors import HybridlogError, OptionError, OutputError, ReportError
from hybridlog.io import ReadOptions
from hybridlog.jobs.analysis import (
    analyze,
    gates_for,
    input_paths,
    parse_sets,
    prepare_estimators,
)
from hybridlog.jobs.workers import run_tasks
from hybridlog.outputs import (
    MARKER,
    PathLike,
    atomic_files,
    check_apart,
    check_dir_target,
    is_ours,
    remove_stale_temporaries,
    write_marker,
)
from hybridlog.report import Report, evaluate_gates, read_report
from hybridlog.report.summary import markdown_table, write_summary_csv
from hybridlog.report.tables import check_table_format

_COLUMNS = ("log", "status", "samples", "vaf", "mse", "mode_accuracy", "error")
_ERROR_LIMIT = 300


@dataclass(frozen=True)
class LogOutcome:
    """How one log of a batch ended: ``done``, ``skipped`` (already done) or ``failed``."""

    log: str
    folder: str
    status: str
    report: Report | None
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


def natural_key(text: str) -> tuple[tuple[int, int | str], ...]:
    """Sort key that orders digit runs by value: ``s1, s2, s10`` rather than ``s1, s10, s2``."""
    return tuple(
        (0, int(part)) if part.isdigit() else (1, part) for part in re.split(r"(\d+)", text) if part
    )


def folder_names(logs: Sequence[Path]) -> list[str]:
    """A distinct report folder name per log: its stem, made unique with its parent's name.

    Names never start with a dot, so a report folder is never hidden nor taken for
    hybridlog's marker or temporary files.
    """
    stems = [log.stem for log in logs]
    names: list[str] = []
    for log, stem in zip(logs, stems, strict=True):
        name = stem if stems.count(stem) == 1 else f"{log.parent.name or 'log'}_{stem}"
        name = "_" + name[1:] if name.startswith(".") else name or "_"
        while name in names:
            name += "_"
        names.append(name)
    return names


def _one_line(text: str) -> str:
    line = " ".join(text.split())
    return line if len(line) <= _ERROR_LIMIT else line[: _ERROR_LIMIT - 1] + "…"


def _analyze_checked(
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
    path = Path(folder)
    if path.exists() or path.is_symlink():
        # A folder hybridlog did not write is never replaced, with or without --force.
        check_dir_target(path, force=True)
        report_file = path / "report.json"
        if not force and report_file.is_file():
            try:
                report: Report | None = read_report(report_file)
            except ReportError:
                report = None  # an unreadable or malformed earlier report is redone
            if report is not None:
                made_with = (report.model, report.estimator)
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
    return LogOutcome(log, folder, "done", outcome.report, None)


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
    """Analyse one log of the batch; every failure becomes the log's one-line error."""
    try:
        return _analyze_checked(
            log, folder, model_ref, model_name, estimator, sets, read, table_format, force
        )
    except HybridlogError as err:
        return LogOutcome(log, folder, "failed", None, _one_line(str(err)))
    except Exception as err:  # a reader or estimator bug must not stop the other logs
        return LogOutcome(log, folder, "failed", None, _one_line(f"{type(err).__name__}: {err}"))


# --- the batch ---------------------------------------------------------------------------------


def _prepare_root(root: Path) -> None:
    """Create the batch folder, or check that an existing one is hybridlog's."""
    if root.exists() or root.is_symlink():
        check_dir_target(root, force=True)  # a file, a link, or a folder of someone else's
        if any(root.iterdir()) and not is_ours(root):
            raise OutputError(
                f"output directory {root} holds files hybridlog did not write (no {MARKER} "
                "file); choose another --out or empty the folder yourself"
            )
    try:
        root.mkdir(parents=True, exist_ok=True)
        if not (root / MARKER).is_file():
            write_marker(root)
    except OSError as err:
        raise OutputError(f"cannot create output directory {root}: {err.strerror}") from err
    remove_stale_temporaries(root)


def run_batch(
    logs: Sequence[PathLike],
    model_ref: str | Path,
    *,
    out_dir: PathLike,
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

    Everything shared by the logs (model, options, gates, the output folder) is checked
    before the first log is read: the output folder must not be, contain or sit inside any
    log, the model file, a centres file or a ``--msg-dir``.  ``progress`` is called with each
    log's outcome as it finishes.
    """
    if jobs < 1:
        raise OptionError("--jobs: must be at least 1")
    paths = sorted((Path(log) for log in logs), key=lambda p: natural_key(str(p)))
    # the model, the estimator and every --set value are checked before any work
    model, overrides = parse_sets(sets, model_ref)
    (prepared,) = prepare_estimators(model, [estimator], overrides)
    gates = gates_for(model, fail_under, fail_over)
    chosen = prepared.name
    check_table_format(table_format)
    read = read or ReadOptions()
    root = Path(os.path.abspath(out_dir))
    summary_md, summary_csv = root / "summary.md", root / "summary.csv"
    check_apart(
        [("--out", out_dir), ("--out", summary_md), ("--out", summary_csv)],
        input_paths(paths, model_ref, [prepared], read),
    )
    _prepare_root(root)
    folders = [str(root / name) for name in folder_names(paths)]
    arguments = [
        (
            str(log),
            folder,
            str(model_ref),
            model.name,
            chosen,
            tuple(sets),
            read,
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
        outcomes = run_tasks(
            _analyze_one,
            arguments,
            jobs=jobs,
            died=lambda i, reason: LogOutcome(
                str(paths[i]), folders[i], "failed", None, f"worker process died ({reason})"
            ),
            done=progress,
        )
    rows = [
        [
            o.log,
            o.status,
            None if o.report is None else o.report.samples,
            None if o.report is None else o.report.vaf,
            None if o.report is None else o.report.mse,
            None if o.report is None else o.report.modes.accuracy,
            o.error,
        ]
        for o in outcomes
    ]
    table = markdown_table(_COLUMNS, rows)
    failed = [f"- {o.log}: {o.error}" for o in outcomes if o.status == "failed"]
    text = f"# Batch: {model.name}\n\n{table}\n"
    if failed:
        text += f"\n## Failed logs ({len(failed)} of {len(outcomes)})\n\n" + "\n".join(failed)
        text += "\n"
    with atomic_files([summary_md, summary_csv], force=True) as (markdown, csv):
        markdown.write_text(text, encoding="utf-8")
        write_summary_csv(csv, _COLUMNS, rows)
    failures = [
        f"{o.log}: {failure}"
        for o in outcomes
        if o.report is not None
        for failure in evaluate_gates(o.report, gates)
    ]
    return BatchOutcome(logs=outcomes, table=table, gate_failures=failures)
