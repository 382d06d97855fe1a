"""The jobs the commands run: one log through one estimator into one report, and its kin.

This layer joins the others (``io`` → ``model`` → ``estimators`` → ``report``) and is what
the CLI calls; it prints nothing and raises :class:`~hybridlog.errors.HybridlogError`.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

import polars as pl

from hybridlog.errors import OptionError, excerpt
from hybridlog.estimators import Prepared, prepare, resolve_estimator
from hybridlog.estimators.options import closest
from hybridlog.io import ReadSettings, load_signals
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.model.loader import load_model
from hybridlog.outputs import PathLike, atomic_output_dir, check_apart, check_dir_target
from hybridlog.report import Report, evaluate_gates, parse_gates, validate_gates, write_report
from hybridlog.report.gates import Gate, metric
from hybridlog.report.tables import check_table_format
from hybridlog.signals import AlignedSignals


@dataclass(frozen=True)
class ReadOptions:
    """How to read and align a log (``--map``, ``--resample``, ``--max-gap``, ...).

    ``time``, ``sort``, ``recover`` and ``msg_dirs`` go to the reader
    (:class:`~hybridlog.io.source.ReadSettings`); ``split_gaps`` and ``drop_nonfinite`` to
    :func:`~hybridlog.io.load_signals`.
    """

    maps: tuple[str, ...] = ()
    resample: str = "nearest"
    max_gap: float | None = None
    split_gaps: bool = False
    time: str = "log"
    sort: bool = False
    drop_nonfinite: bool = False
    recover: bool = False
    msg_dirs: tuple[str, ...] = ()


@dataclass(frozen=True)
class Overrides:
    """``--set NAME=VALUE`` values, split into model parameters and estimator options.

    Both are read-only mappings: the value is built once by :func:`parse_sets`.
    """

    parameters: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}))
    options: Mapping[str, str] = field(default_factory=lambda: MappingProxyType({}))


def parse_sets(values: Sequence[str], model_ref: str | Path) -> tuple[HybridModel, Overrides]:
    """Load the model and split ``--set`` values into parameters and estimator options.

    Names of model parameters change the model; all other names are estimator options,
    checked against the chosen estimators by :func:`prepare_estimators`.
    """
    model = load_model(model_ref)
    parameters: dict[str, float] = {}
    options: dict[str, str] = {}
    for text in values:
        name, sep, value = text.partition("=")
        name = name.strip()
        if not sep or not name:
            raise OptionError(f"--set: {excerpt(text)} is not NAME=VALUE")
        if name in parameters or name in options:
            raise OptionError(f"--set {excerpt(name)[1:-1]}: given twice")
        if name in model.parameters:
            try:
                parameters[name] = float(value)
            except ValueError as err:
                raise OptionError(f"--set {name}: {excerpt(value)} is not a number") from err
        else:
            options[name] = value.strip()
    if parameters:
        model = load_model(model_ref, parameters=parameters)
    return model, Overrides(MappingProxyType(parameters), MappingProxyType(options))


def prepare_estimators(
    model: HybridModel,
    names: Sequence[str | None],
    overrides: Overrides,
    *,
    given_by: str = "--estimator",
) -> list[Prepared]:
    """Resolve estimators (``None``: the model's default) and their options before any work.

    Each estimator gets the ``--set`` options it declares; a name that is neither a model
    parameter nor an option of any chosen estimator is an :class:`OptionError` listing both
    and suggesting the closest name.
    """
    chosen = [resolve_estimator(model, name, given_by=given_by) for name in names]
    declared = {e.name: [i.name for i in e.describe_options()] for e in chosen}
    for name, value in overrides.options.items():
        if not any(name in known for known in declared.values()):
            options = "; ".join(f"options of {e}: {', '.join(k)}" for e, k in declared.items())
            candidates = [*model.parameters, *(n for k in declared.values() for n in k)]
            raise OptionError(
                f"--set {excerpt(name)[1:-1]}={excerpt(value)[1:-1]}: neither a parameter of "
                f"model {model.origin or model.name} (parameters: "
                f"{', '.join(model.parameters) or 'none'}) nor an estimator option ({options})"
                f"{closest(name, candidates)}"
            )
    return [
        prepare(
            model,
            e.name,
            {k: v for k, v in overrides.options.items() if k in declared[e.name]},
            given_by=given_by,
        )
        for e in chosen
    ]


def input_paths(
    logs: Sequence[PathLike],
    model_ref: PathLike,
    prepared: Sequence[Prepared],
    read: ReadOptions,
) -> list[tuple[str, PathLike]]:
    """Every file and folder a run reads, named for error messages: no output may touch them.

    The logs, the model file (unless a built-in name), a centres file (the ``centers``
    option, from ``--set`` or the model file) and every ``--msg-dir``.
    """
    paths: list[tuple[str, PathLike]] = [("log", log) for log in logs]
    if os.path.exists(model_ref):
        paths.append(("model file", model_ref))
    for estimator in prepared:
        centers = getattr(estimator.options, "centers", None)
        if centers:
            paths.append(("centres file", centers))
    paths += [("--msg-dir folder", folder) for folder in read.msg_dirs]
    return paths


def read_log(
    log: str | Path,
    model: HybridModel,
    read: ReadOptions,
    notes: dict[str, Any] | None = None,
) -> AlignedSignals:
    """The log's signals for ``model`` on its grid; ``notes`` gets what reading did."""
    return load_signals(
        log,
        states=model.states,
        inputs=model.inputs,
        outputs=model.outputs,
        mode_ids=model.mode_ids,
        dt=model.dt,
        signals=model.signals,
        truth=model.truth,
        maps=read.maps,
        resample=read.resample,
        max_gap=read.max_gap,
        settings=ReadSettings(
            time=read.time, sort=read.sort, recover=read.recover, msg_dirs=read.msg_dirs
        ),
        split_gaps=read.split_gaps,
        drop_nonfinite=read.drop_nonfinite,
        notes=notes,
    )


@dataclass(frozen=True)
class Outcome:
    """What ``analyze`` produced: the report, where it went, and the missed CI gates."""

    report: Report
    out_dir: Path
    gate_failures: list[str]


def gates_for(
    model: HybridModel, fail_under: Sequence[str], fail_over: Sequence[str]
) -> list[Gate]:
    """Parse the CI gates and check that the outputs and states they name exist."""
    gates = parse_gates(fail_under, fail_over)
    validate_gates(gates, output_names=model.outputs, state_names=model.states)
    return gates


def analyze(
    log: str | Path,
    model_ref: str | Path,
    *,
    out_dir: str | os.PathLike[str] | None = None,
    estimator: str | None = None,
    sets: Sequence[str] = (),
    read: ReadOptions | None = None,
    fail_under: Sequence[str] = (),
    fail_over: Sequence[str] = (),
    table_format: str = "csv",
    force: bool = False,
) -> Outcome:
    """Run one estimator over one log and write the outputs of SPEC §8 into ``out_dir``.

    ``out_dir`` defaults to ``<log name>_<estimator>`` in the working directory.  Everything
    the user gave is validated before anything is written; the output directory appears
    complete or not at all.
    """
    model, overrides = parse_sets(sets, model_ref)
    (prepared,) = prepare_estimators(model, [estimator], overrides)
    estimator = prepared.name
    out_dir = Path(out_dir) if out_dir is not None else Path(f"{Path(log).stem}_{estimator}")
    read = read or ReadOptions()
    check_apart([("--out", out_dir)], input_paths([log], model_ref, [prepared], read))
    check_dir_target(out_dir, force=force)
    check_table_format(table_format)
    gates = gates_for(model, fail_under, fail_over)
    reading: dict[str, Any] = {}
    signals = read_log(log, model, read, reading)
    result = prepared.run(model, signals)
    report = write_report(
        out_dir,
        result,
        signals,
        log=str(log),
        model_name=model.name,
        dt=model.dt,
        table_format=table_format,
        force=force,
        reading=reading,
    )
    return Outcome(report=report, out_dir=out_dir, gate_failures=evaluate_gates(report, gates))


@dataclass(frozen=True)
class Comparison:
    """What ``compare`` produced: one report per estimator and the side-by-side table."""

    reports: dict[str, Report]
    table: str
    gate_failures: list[str]


_COLUMNS = (
    "vaf",
    "fit",
    "mse",
    "mode_accuracy",
    "missed_switches",
    "detection_delay_s",
    "samples_per_s",
)


def _row(report: Report) -> dict[str, Any]:
    return {name: metric(report, name) for name in _COLUMNS}  # the gates' metric names


SIGNIFICANT_DIGITS = 4
"""Markdown tables show every number of a column with at least this many significant digits."""


def _column_format(values: Sequence[object]) -> Callable[[object], str]:
    """One format for a whole column of a table for people (CSV files keep raw values).

    Integers get thousands separators.  Floats get the same number of decimals, enough for
    :data:`SIGNIFICANT_DIGITS` digits of the smallest non-zero magnitude (``1,668,410``,
    ``87.39``, ``0.6013``), with thousands separators; a column spanning more than six
    decades, or needing more than six decimals, is written in scientific notation.
    """
    floats = [
        abs(float(v))
        for v in values
        if isinstance(v, float) and not isinstance(v, bool) and math.isfinite(v) and v != 0.0
    ]
    spec = ",.0f"
    if floats:
        small, big = min(floats), max(floats)
        decimals = SIGNIFICANT_DIGITS - 1 - math.floor(math.log10(small))
        wide = decimals > 6 or big / small > 1e6
        spec = ".3e" if wide else f",.{max(decimals, 0)}f"

    def cell(value: object) -> str:
        if value is None:
            return "n/a"
        if isinstance(value, bool):
            return str(value)
        if isinstance(value, int):
            return f"{value:,}"
        if isinstance(value, float):
            return format(value, spec) if math.isfinite(value) else str(value)
        return str(value).replace("|", "\\|")

    return cell


def _cell(value: object) -> str:
    """One value on its own, formatted as :func:`markdown_table` would in a column."""
    return _column_format([value])(value)


def markdown_table(header: Sequence[str], rows: Sequence[Sequence[object]]) -> str:
    """A GitHub-flavoured Markdown table, numbers formatted per column for people.

    Columns holding numbers are right-aligned; see :func:`_column_format` for the digits.
    """
    formats = [_column_format([row[j] for row in rows]) for j in range(len(header))]
    numeric = [
        any(isinstance(row[j], int | float) and not isinstance(row[j], bool) for row in rows)
        for j in range(len(header))
    ]
    lines = [
        "| " + " | ".join(header) + " |",
        "|" + "".join("---:|" if n else "---|" for n in numeric),
    ]
    lines += [
        "| " + " | ".join(f(v) for f, v in zip(formats, row, strict=True)) + " |" for row in rows
    ]
    return "\n".join(lines)


def comparison_markdown(title: str, table: str, reports: Mapping[str, Report]) -> str:
    """``comparison.md``: the table, where each report is, and each estimator's notes."""
    lines = [f"# {title}", "", table, ""]
    lines += [f"- `{name}`: [{name}/report.md]({name}/report.md)" for name in reports]
    for name, report in reports.items():
        if report.notes:
            lines += ["", f"## Notes on `{name}`", "", *(f"- {note}" for note in report.notes)]
    return "\n".join(lines) + "\n"


def compare(
    log: str | Path,
    model_ref: str | Path,
    estimators: Sequence[str],
    *,
    out_dir: str | os.PathLike[str],
    sets: Sequence[str] = (),
    read: ReadOptions | None = None,
    fail_under: Sequence[str] = (),
    fail_over: Sequence[str] = (),
    table_format: str = "csv",
    force: bool = False,
) -> Comparison:
    """Run several estimators on one log: ``<out>/<estimator>/`` reports and a table.

    The table (``comparison.md`` and ``comparison.csv``) has one row per estimator; CI gates
    apply to every estimator.
    """
    if not estimators:
        raise OptionError("--estimators: name at least one estimator")
    if len(set(estimators)) != len(estimators):
        raise OptionError("--estimators: an estimator is named twice")
    model, overrides = parse_sets(sets, model_ref)
    prepared = prepare_estimators(model, estimators, overrides, given_by="--estimators")
    read = read or ReadOptions()
    check_apart([("--out", out_dir)], input_paths([log], model_ref, prepared, read))
    check_dir_target(out_dir, force=force)
    check_table_format(table_format)
    gates = gates_for(model, fail_under, fail_over)
    reading: dict[str, Any] = {}
    signals = read_log(log, model, read, reading)
    results = {p.name: p.run(model, signals) for p in prepared}
    reports: dict[str, Report] = {}
    with atomic_output_dir(out_dir, force=force) as folder:
        for name, result in results.items():
            reports[name] = write_report(
                folder / name,
                result,
                signals,
                log=str(log),
                model_name=model.name,
                dt=model.dt,
                table_format=table_format,
                reading=reading,
            )
        rows = [[name, *_row(report).values()] for name, report in reports.items()]
        table = markdown_table(("estimator", *_COLUMNS), rows)
        (folder / "comparison.md").write_text(
            comparison_markdown(f"{model.name} on {log}", table, reports), encoding="utf-8"
        )
        write_summary_csv(folder / "comparison.csv", ("estimator", *_COLUMNS), rows)
    failures = [
        f"{name}: {failure}"
        for name, report in reports.items()
        for failure in evaluate_gates(report, gates)
    ]
    return Comparison(reports=reports, table=table, gate_failures=failures)


def write_summary_csv(path: Path, header: Sequence[str], rows: Sequence[Sequence[object]]) -> None:
    """A small summary table as CSV (empty cells for missing values)."""
    frame = pl.DataFrame(
        [[None if v is None else v for v in row] for row in rows],
        schema=list(header),
        orient="row",
        infer_schema_length=None,
    )
    frame.write_csv(path)
