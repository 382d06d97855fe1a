"""The ``compare`` job: one log through several estimators, a report each and a table.

Each estimator's report in ``<out>/<estimator>/``, and ``comparison.md`` and
``comparison.csv``: a row per estimator with its metrics, gates and warnings, or, for an
estimator whose run failed on the log (:data:`RUN_FAILURES`), the reason
(:func:`compare`, :class:`Comparison`).  comparison.md's sections are
:mod:`hybridlog.report.comparison`'s.

Importing it loads no polars, as :mod:`~hybridlog.jobs.estimation` says why: the report's
writer (:func:`hybridlog.report.write_report`) is imported where the reports are written.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

from hybridlog.errors import (
    DivergenceError,
    HybridlogError,
    OptionError,
    as_text,
    excerpt,
    prefixed,
)
from hybridlog.estimators import ESTIMATORS
from hybridlog.io import ReadOptions
from hybridlog.jobs import arguments
from hybridlog.jobs.estimation import (
    check_memory,
    check_signals,
    estimates,
    estimator_inputs,
    input_paths,
    read_for_estimation,
    warm_up,
)
from hybridlog.jobs.gate_checks import gates_for, modes_given
from hybridlog.jobs.origins import given_in_chunks, given_values, run_values
from hybridlog.jobs.overrides import parse_sets, prepare_estimators, set_reach
from hybridlog.outputs import atomic_output_dir, check_apart, check_dir_target
from hybridlog.outputs.folder_targets import check_outside_batch
from hybridlog.report import Report, recorded_failures
from hybridlog.report.comparison import (
    reach_section,
    sample_counts,
    samples_section,
    unavailable_section,
    unequal_columns,
)
from hybridlog.report.gates import Gate, metric
from hybridlog.report.summary import comparison_markdown
from hybridlog.report.summary_notes import warning_notes
from hybridlog.report.summary_rows import gate_cell, gated_columns, state_columns
from hybridlog.report.summary_tables import markdown_table, write_summary_csv
from hybridlog.report.table_format import check_table_format

if TYPE_CHECKING:
    from hybridlog.estimators.result import EstimationResult


@dataclass(frozen=True)
class Comparison:
    """What ``compare`` produced: one report per estimator and the side-by-side table.

    ``failures``: the estimators whose run failed on the log (it diverged, or could not be
    computed on this log), each with its one-line reason; they have no report.
    ``unlike``: what is not like for like between the estimators, a phrase each (``vaf,
    fit and mse are not over the same samples for every estimator``; the mode metrics of
    an estimator that reads the switching signal, or of offline estimates beside others'
    own), which comparison.md's "What the numbers are over" details.
    ``reach``: each ``--set`` that did not reach every estimator, what it reached and why
    not the others (:func:`set_reach`), which comparison.md's "Given to some estimators
    only" lists.
    """

    reports: dict[str, Report]
    table: str
    gate_failures: list[str]
    failures: dict[str, str] = field(default_factory=dict)
    unlike: list[str] = field(default_factory=list)
    reach: list[str] = field(default_factory=list)

    @property
    def warned(self) -> list[str]:
        """The estimators whose report has a note that warns (:func:`warning_notes`)."""
        return [name for name, report in self.reports.items() if warning_notes(report)]


_COLUMNS = (
    "vaf",
    "fit",
    "mse",
    "mode_accuracy",
    "missed_switches",
    "detection_delay_s",
    "samples_per_s",
)


def _filtered_state_rmse(report: Report, column: str) -> float | None:
    """The filter's own RMSE of a ``state_rmse.<x>`` column: the smoothed run's filter's."""
    state = column.removeprefix("state_rmse.")
    states = report.states if report.smoothing is None else report.smoothing.filtered.states
    own = states.get(state)
    return None if own is None else own.rmse


_SMOOTHING_COLUMNS = ("smoothing", "filtered_mode_accuracy", "smoothing_fallback_weight")
"""Columns added to the comparison when an estimator's estimates were smoothed: the
smoother and mode sequence (``kim-rts, viterbi``; ``none`` for a filter's own estimates), the
filter's own mode accuracy, beside the smoothed one in ``mode_accuracy``, and the share of the
smoothed estimates' weight carried by the steps where the smoother left the forward estimate
standing (report.json's ``smoothing.fallbacks.weight``, 0 to 1, as batch's summary.csv; ``n/a``
where no smoother ran).  For an estimator not smoothed the filter's own mode accuracy is its
``mode_accuracy``: its estimates are its own (it was ``n/a``, so that the filters' own
estimates, like for like, were in two columns)."""


def _component_columns(reports: Mapping[str, Report]) -> tuple[str, ...]:
    """``mode_accuracy.<c>`` for each component some report scored (its true mode in the log).

    Shown, each beside ``filtered_mode_accuracy.<c>``, when an estimator's estimates were
    smoothed, as batch's summary.csv shows them (:func:`~hybridlog.report.summary_offline.
    offline_metrics`): the joint accuracy of a ``[components]`` model hides most of a gain.
    """
    components = dict.fromkeys(
        c
        for report in reports.values()
        for c, component in report.modes.components.items()
        if component.accuracy is not None
    )
    return tuple(f"mode_accuracy.{c}" for c in components)


def _filtered_component_accuracy(report: Report, column: str) -> float | None:
    """The filter's own accuracy of a ``mode_accuracy.<c>`` column: the smoothed run's filter's."""
    component = column.removeprefix("mode_accuracy.")
    if report.smoothing is None:
        own = report.modes.components.get(component)
        return None if own is None else own.accuracy
    side = report.smoothing.filtered.components.get(component)
    return None if side is None else side.mode_accuracy


def _smoothing_columns(
    state_columns: Sequence[str], component_columns: Sequence[str] = ()
) -> tuple[str, ...]:
    """:data:`_SMOOTHING_COLUMNS`, with the components' and the states' pairs among them.

    After ``filtered_mode_accuracy``: ``mode_accuracy.<c>`` and ``filtered_mode_accuracy.<c>``
    per component, then a ``filtered_state_rmse.<x>`` per state shown; named as batch's
    summary.csv names them.
    """
    smoother, filtered, fallbacks = _SMOOTHING_COLUMNS
    pairs = [name for c in component_columns for name in (c, f"filtered_{c}")]
    return (smoother, filtered, *pairs, *(f"filtered_{c}" for c in state_columns), fallbacks)


def _smoothing_cells(
    report: Report, state_columns: Sequence[str], component_columns: Sequence[str] = ()
) -> list[Any]:
    smoothing = report.smoothing
    pairs = [
        cell
        for c in component_columns
        for cell in (metric(report, c), _filtered_component_accuracy(report, c))
    ]
    filtered_states = [_filtered_state_rmse(report, column) for column in state_columns]
    if smoothing is None:
        return ["none", report.modes.accuracy, *pairs, *filtered_states, None]
    name = ", ".join(n for n in (smoothing.method, smoothing.mode_sequence) if n)
    fallbacks = smoothing.fallbacks
    weight = None if fallbacks is None else fallbacks.weight
    return [name, smoothing.filtered.mode_accuracy, *pairs, *filtered_states, weight]


RUN_FAILURES: tuple[type[HybridlogError], ...] = (DivergenceError,)
"""What an estimator's run raises when it fails on a log every check accepted: it diverged, its
model left its domain at an estimate, or it met numerical trouble.  In ``compare`` that is the
estimator's result, its row saying why.  Every other error of a run stays bad input (exit 2,
nothing written): a singular covariance (``ModelError``), a log without the switching signal
the estimator needs (``LogError``), ``cluster_modes`` naming fewer modes than chiu finds
clusters (``OptionError``)."""


class _RunFailedError(Exception):
    """An estimator's run failed on the log (:data:`RUN_FAILURES`).

    Raised under ``write_report``, which removes the estimator's half-written folder and lets
    it through to :func:`compare`.
    """

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


def _watched(
    name: str, chunks: Iterator[EstimationResult], *, named: bool
) -> Iterator[EstimationResult]:
    """The chunks of one of the compared estimators, its failure on the log told apart.

    A run failure becomes :class:`_RunFailedError`; another error of its run is raised naming the
    estimator when several are compared (``named``): ``cluster_modes: 2 mode ids for 3
    clusters`` did not say which of ``chiu,kmeans`` failed (the option reaches both); it
    becomes ``--estimators chiu: cluster_modes: ...``.
    """
    try:
        yield from chunks
    except RUN_FAILURES as err:
        raise _RunFailedError(str(err)) from err
    except HybridlogError as err:
        if not named:
            raise
        raise prefixed(err, f"--estimators {name}: ") from err


def _check_separators(estimators: Sequence[str]) -> None:
    """Refuse a name that is several estimators joined by another separator than a comma.

    ``--estimators imm;hstf`` was an unknown estimator ``'imm;hstf'`` with "did you mean
    'hstf'?", as if the user had meant hstf alone.
    """
    for name in estimators:
        parts = [part for part in re.split(r"[;:|/\s]+", name) if part]
        if name not in ESTIMATORS and len(parts) > 1 and all(p in ESTIMATORS for p in parts):
            raise OptionError(
                f"--estimators: {excerpt(name)} is {len(parts)} estimators; separate them with "
                f"commas: {','.join(parts)}"
            )


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
    smooth: bool = False,
    mode_sequence: str | None = None,
) -> Comparison:
    """Run several estimators on one log: ``<out>/<estimator>/`` reports and a table.

    The table (``comparison.md`` and ``comparison.csv``) has one row per estimator; CI gates
    apply to every estimator, and with gates the table gets a ``gates`` column (``pass (2)``
    or the gates the estimator missed) and a column per gated metric it does not show
    already (``state_rmse.x1``: each estimator's value).  ``smooth`` (``--smooth``) and
    ``mode_sequence`` apply to every estimator, each of which must offer them
    (:func:`smoothing_overrides`); when any estimator's estimates were smoothed, the table
    gets a ``smoothing`` column and the filter's own mode accuracy beside the smoothed one.

    Everything the user gave is checked before any estimator runs.  An estimator whose run
    then fails on the log (:data:`RUN_FAILURES`: it diverged) gets no folder, and its row
    empty metrics and, in an ``error`` column, the one-line reason; the others' reports are
    written (:attr:`Comparison.failures`; the command exits 1, as for a batch's failed log).
    """
    arguments.path(log, "log")
    read = arguments.common(
        model_ref,
        sets=sets,
        read=read,
        fail_under=fail_under,
        fail_over=fail_over,
        table_format=table_format,
        force=force,
        smooth=smooth,
        mode_sequence=mode_sequence,
    )
    arguments.texts(estimators, "estimators")
    arguments.path(out_dir, "out_dir")
    if not estimators:
        raise OptionError("--estimators: name at least one estimator")
    _check_separators(estimators)
    twice = sorted({name for name in estimators if list(estimators).count(name) > 1})
    if twice:  # two reports under one folder name
        raise OptionError(f"--estimators: {', '.join(map(excerpt, twice))} named twice")
    model, overrides = parse_sets(sets, model_ref)
    prepared = prepare_estimators(
        model,
        estimators,
        overrides,
        given_by="--estimators",
        smooth=smooth,
        mode_sequence=mode_sequence,
    )
    reach = set_reach(model, prepared, overrides)
    check_apart([("--out", out_dir)], input_paths([log], model_ref, prepared, read))
    check_dir_target(out_dir, force=force)
    check_outside_batch(out_dir)
    check_table_format(table_format)
    gates = gates_for(model, prepared, fail_under, fail_over)
    inputs = {p.name: estimator_inputs(p, model) for p in prepared}
    warm_up(prepared, model)
    reading: dict[str, Any] = {}
    signals = read_for_estimation(log, model, read, reading)
    check_signals(prepared, model, signals)
    check_memory(log, model, prepared, signals)
    reports: dict[str, Report] = {}
    failures: dict[str, str] = {}
    from hybridlog.report import write_report  # polars: see the module's docstring

    with atomic_output_dir(out_dir, force=force) as folder:
        for i, estimator in enumerate(prepared):  # one after the other: one's chunks at a time
            run = partial(
                estimates,
                estimator,
                model,
                signals,
                inputs[estimator.name],
                last=i == len(prepared) - 1,
            )
            chunks = given_in_chunks(run, given_values(overrides.parameter_texts, estimator))
            try:
                reports[estimator.name] = write_report(
                    folder / estimator.name,
                    _watched(estimator.name, chunks, named=len(prepared) > 1),
                    signals,
                    log=as_text(log),
                    model_name=model.name,
                    dt=model.dt,
                    table_format=table_format,
                    reading=reading,
                    extra=run_values(model, estimator, overrides.parameter_texts),
                    model=model,
                    gates=gates,
                )
            except _RunFailedError as failed:  # a result: the others are still compared
                failures[estimator.name] = failed.reason
        missed = {name: recorded_failures(report) for name, report in reports.items()}
        names = [p.name for p in prepared]
        columns, rows = _comparison_rows(names, reports, failures, gates, missed)
        table = markdown_table(columns, rows, distinct=True)  # estimators side by side
        given = list(modes_given(prepared))
        scored, unlike = samples_section(reports, _rmse_states(columns), given)
        shown = [
            c for c in columns if c in _COLUMNS or c in _gated(gates) or c.startswith("state_rmse.")
        ]
        sections = [
            *reach_section(reach),
            *scored,
            *unavailable_section(columns, rows, reports, shown),
        ]
        (folder / "comparison.md").write_text(
            comparison_markdown(
                f"{model.name} on {as_text(log)}",
                table,
                reports,
                failures,
                sections=sections,
                gates=[f"{g.option} {g.spec}" for g in gates],
            ),
            encoding="utf-8",
        )
        write_summary_csv(folder / "comparison.csv", columns, rows)
    failing = [f"{name}: {failure}" for name, missing in missed.items() for failure in missing]
    return Comparison(
        reports=reports,
        table=table,
        gate_failures=failing,
        failures=failures,
        unlike=unlike,
        reach=reach,
    )


def _gated(gates: Sequence[Gate]) -> set[str]:
    return {gate.metric for gate in gates}


def _rmse_states(columns: Sequence[str]) -> list[str]:
    """The states whose RMSE the table shows (``state_rmse.x1``: ``x1``)."""
    prefix = "state_rmse."
    return [c.removeprefix(prefix) for c in columns if c.startswith(prefix)]


def _comparison_rows(
    names: Sequence[str],
    reports: Mapping[str, Report],
    failures: Mapping[str, str],
    gates: Sequence[Gate],
    missed: Mapping[str, Sequence[str]],
) -> tuple[tuple[str, ...], list[list[Any]]]:
    """The comparison's columns and its rows, one per estimator in the order given.

    A failed estimator's cells are empty (``n/a``) but its gates (``not analysed``) and the
    ``error`` column, added when any estimator failed, which holds its reason.  ``warnings``:
    the number of the report's notes that warn (:func:`warning_notes`), listed in
    comparison.md.  Where the estimators' numbers are not over the same samples, a column
    per count that differs (``output_samples.y1``, ``mode_samples``, ``state_samples.x1``:
    :func:`~hybridlog.report.comparison.unequal_columns`), after the metrics.
    """
    states = state_columns(reports.values())
    *scores, speed = _COLUMNS
    metrics = (*scores, *states, speed)  # the states' RMSEs beside the other scores
    columns: tuple[str, ...] = ("estimator", *metrics)
    smoothed = any(report.smoothing is not None for report in reports.values())
    components = _component_columns(reports) if smoothed else ()
    smoothing_columns = _smoothing_columns(states, components) if smoothed else ()
    # each estimator's value of a gated metric not shown yet (state_rmse.x1), as batch's
    # summaries show it: 'pass (1)' alone did not say by how much (a gated
    # smoothing_fallback_weight is shown once, among the smoothing columns)
    extra = gated_columns([gate.metric for gate in gates], (*columns, *smoothing_columns))
    # a VAF over 170 samples beside one over 179 read as like for like: the counts that
    # differ get a column
    counts = unequal_columns(reports, _rmse_states((*states, *extra)))
    columns += counts
    columns += smoothing_columns
    columns += extra
    rows: list[list[Any]] = []
    for name in names:
        report = reports.get(name)
        if report is None:
            width = len(columns) - 1
            row: list[Any] = [name, *[None] * width]
        else:
            row = [name, *(metric(report, column) for column in metrics)]
            own = sample_counts(report, _rmse_states((*states, *extra)))
            row += [own.get(column) for column in counts]
            if smoothed:
                row += _smoothing_cells(report, states, components)
            row += [metric(report, column) for column in extra]
        if gates:  # which estimator missed which gate, as a batch's summary shows per log
            row.append("not analysed" if report is None else gate_cell(len(gates), missed[name]))
        row.append(None if report is None else len(warning_notes(report)))  # as summary.csv's
        if failures:
            row.append(failures.get(name, ""))
        rows.append(row)
    if gates:
        columns += ("gates",)
    columns += ("warnings",)
    if failures:
        columns += ("error",)
    return columns, rows
