"""The ``analyze`` job: one log through one estimator into one report folder.

This layer joins the others (``io`` → ``model`` → ``estimators`` → ``report``) and is what
the CLI calls; it prints nothing and raises :class:`~hybridlog.errors.HybridlogError`.  The
steps it shares with ``compare`` (:mod:`~hybridlog.jobs.compare`) and ``batch`` are
modules of their own: :mod:`~hybridlog.jobs.overrides` (``--set`` and the estimators'
options), :mod:`~hybridlog.jobs.gate_checks` (the CI gates) and
:mod:`~hybridlog.jobs.estimation` (the log read and checked, the estimator run).

Importing it loads no polars, as :mod:`~hybridlog.jobs.estimation` says why: the report's
writer (:func:`hybridlog.report.write_report`) is imported where the report is written.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

from hybridlog.errors import as_text
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
from hybridlog.jobs.gate_checks import gates_for
from hybridlog.jobs.origins import given_in_chunks, given_values, run_values
from hybridlog.jobs.overrides import parse_sets, prepare_estimators
from hybridlog.outputs import check_apart, check_dir_target
from hybridlog.outputs.folder_targets import check_outside_batch
from hybridlog.report import Report, recorded_failures
from hybridlog.report.table_format import check_table_format


@dataclass(frozen=True)
class Outcome:
    """What ``analyze`` produced: the report, where it went, and the missed CI gates."""

    report: Report
    out_dir: Path
    gate_failures: list[str]


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
    smooth: bool = False,
    mode_sequence: str | None = None,
) -> Outcome:
    """Run one estimator over one log and write the outputs of SPEC §8 into ``out_dir``.

    ``out_dir`` defaults to ``<log name>_<estimator>`` in the working directory.  Everything
    the user gave is validated before anything is written; the output directory appears
    complete or not at all.  ``smooth`` and ``mode_sequence`` are ``--smooth`` and
    ``--mode-sequence`` (:func:`smoothing_overrides`).  An argument of the wrong type (a
    single string for ``sets``) is an ``OptionError`` (:mod:`hybridlog.jobs.arguments`).
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
    arguments.path(out_dir, "out_dir", optional=True)
    arguments.text(estimator, "estimator", optional=True)
    model, overrides = parse_sets(sets, model_ref)
    (prepared,) = prepare_estimators(
        model, [estimator], overrides, smooth=smooth, mode_sequence=mode_sequence
    )
    estimator = prepared.name
    out_dir = Path(out_dir) if out_dir is not None else Path(f"{Path(log).stem}_{estimator}")
    check_apart([("--out", out_dir)], input_paths([log], model_ref, [prepared], read))
    check_dir_target(out_dir, force=force)
    check_outside_batch(out_dir)
    check_table_format(table_format)
    gates = gates_for(model, [prepared], fail_under, fail_over)
    inputs = estimator_inputs(prepared, model)
    warm_up([prepared], model)
    reading: dict[str, Any] = {}
    signals = read_for_estimation(log, model, read, reading)
    check_signals([prepared], model, signals)
    check_memory(log, model, [prepared], signals)
    from hybridlog.report import write_report  # polars: see the module's docstring

    given = given_values(overrides.parameter_texts, prepared)
    report = write_report(
        out_dir,
        given_in_chunks(partial(estimates, prepared, model, signals, inputs), given),
        signals,
        log=as_text(log),
        model_name=model.name,
        dt=model.dt,
        table_format=table_format,
        force=force,
        reading=reading,
        extra=run_values(model, prepared, overrides.parameter_texts),
        model=model,
        gates=gates,
    )
    return Outcome(report=report, out_dir=out_dir, gate_failures=recorded_failures(report))
