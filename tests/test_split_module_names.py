"""Docs and docstrings name a function of a split module where it now is.

``estimators/smoothing.py`` gave its kernels to ``smoother_kernels.py`` and its code writer to
``smoother_source.py``, both split whole in turn (a module split whole is named nowhere after
it): the kernels' log-space sums, RTS step, Kim's and expectation correction's loops and
Viterbi path to ``log_space.py``, ``rts_steps.py``, ``kim_loop.py``, ``ec_loop.py`` and
``viterbi_path.py``, the writer's Kim's and expectation correction's passes, RTS step, helper
functions, frame and branch tuples to ``kim_source.py``, ``ec_source.py``, ``rts_source.py``,
``generated_helpers.py``, ``backward_frame.py`` and ``branch_tuples.py``; ``report/metrics.py``
its mode metrics to ``mode_metrics.py`` and its state RMSE, blocks of rows, scaled sums and
error powers to ``state_error.py``, ``row_blocks.py``, ``scaled_sums.py`` and ``error_power.py``,
``report/build.py`` its reading notes to ``reading_notes.py`` and its mode scores, offline
sides, null reasons, few-samples warning and model notes to modules of those names,
``cli.py`` its parameter
types, options, lines, progress bars and process handling to ``cli_*.py``, ``io/tables.py``
its CSV checks and frames, Parquet files and columns, the table's shared facts, time columns,
``--sort``'s time order, numbers, ``inspect``'s description and column helpers, ``io/messages.py``
its topics, topic reader, header stamps, ``inspect`` counts, message leaves and JSON helpers,
``io/align.py`` its grid, resampling, output gaps, notes, true modes and ``--split-gaps``
pieces, ``outputs.py`` (now a package re-exporting its public names) its paths, overlaps,
temporaries, records, target checks, staging and publishing, ``jobs/batch.py`` its outcomes,
folder names, job, task of a log, batch folder, plan and summaries, ``model/loader.py`` its
file keys, log fields, mode equations and mode switching, ``report/document.py`` its JSON
values, the report's parts and its reader, ``report/plots.py`` its figures made ahead,
curves, labels, legends, time axis and ``modes.png``, ``jobs/analysis.py`` its ``--set``
overrides, gate checks, estimation steps and ``compare``, ``simulate.py`` its inputs, range
checks, domain checks, run limits and schedule, ``report/summary.py`` its tables, notes,
batch rows and offline pass, ``report/plot_data.py`` its time axis helpers (to
``plot_time_axis.py``), pixel bins, curve envelopes and bands, mode timeline bars and
reducer to modules of their own: after the splits,
``docs/smoothing.md`` still sent readers to ``smoothing.rts_step``,
``smoothing.semidefinite_step`` and ``smoothing._positive_pivots``,
``docs/architecture.md`` to ``report/build.py``'s ``unused_sample_notes`` and
``bridged_cause``, ``docs/studies/smoothing.py`` to ``metrics.detection_delays`` and
``EstimationResult``'s docstring to ``smoothing.NEGLIGIBLE_WEIGHT``, and after the
smoothers' own split ``docs/smoothing.md`` to ``smoother_kernels.rts_step`` and
``docs/architecture.md`` to ``smoother_kernels._kim_rows``: names the old module no longer has.
"""

from __future__ import annotations

import importlib
import importlib.util
import re
import types
from collections.abc import Iterator

import pytest

from tests.support.paths import ROOT

SPLITS = {
    "hybridlog.estimators.smoothing": (
        "hybridlog.estimators.smoother_kernels",
        "hybridlog.estimators.smoother_source",
    ),
    "hybridlog.estimators.smoother_kernels": tuple(
        f"hybridlog.estimators.{name}"
        for name in (
            "log_space",
            "rts_steps",
            "kim_loop",
            "ec_loop",
            "viterbi_path",
            "kim_source",  # LINEAR_FLOOR
            "ec_source",  # MAX_EC_UNROLLED_MODES
        )
    ),
    "hybridlog.estimators.smoother_source": tuple(
        f"hybridlog.estimators.{name}"
        for name in (
            "kim_source",
            "ec_source",
            "rts_source",
            "generated_helpers",
            "backward_frame",
            "branch_tuples",
        )
    ),
    "hybridlog.report.metrics": tuple(
        f"hybridlog.report.{name}"
        for name in ("mode_metrics", "state_error", "row_blocks", "scaled_sums", "error_power")
    ),
    "hybridlog.report.build": tuple(
        f"hybridlog.report.{name}"
        for name in (
            "reading_notes",
            "mode_scores",
            "offline_sides",
            "null_reasons",
            "few_samples",
            "model_notes",
        )
    ),
    "hybridlog.cli": tuple(
        f"hybridlog.cli_{part}" for part in ("types", "options", "lines", "progress", "process")
    ),
    "hybridlog.io.tables": tuple(
        f"hybridlog.io.{name}"
        for name in (
            "csv_header",
            "csv_lines",
            "csv_frames",
            "csv_numbers",
            "parquet_files",
            "parquet_columns",
            "table_file",
            "table_times",
            "time_column",
            "time_order",
            "table_numbers",
            "table_description",
            "table_labels",
            "column_types",
            "column_summary",
            "polars_errors",
        )
    ),
    "hybridlog.io.messages": tuple(
        f"hybridlog.io.{name}"
        for name in (
            "message_topics",
            "topic_reader",
            "header_stamps",
            "value_counter",
            "message_leaves",
            "json_schemas",
            "json_values",
        )
    ),
    "hybridlog.io.align": tuple(
        f"hybridlog.io.{name}"
        for name in (
            "time_grid",
            "resampling",
            "output_gaps",
            "alignment_notes",
            "true_modes",
            "log_pieces",
        )
    ),
    "hybridlog.outputs": tuple(
        f"hybridlog.outputs.{name}"
        for name in (
            "paths",
            "overlaps",
            "temporaries",
            "records",
            "file_targets",
            "folder_targets",
            "staging",
            "publishing",
        )
    ),
    "hybridlog.jobs.batch": tuple(
        f"hybridlog.jobs.{name}"
        for name in (
            "batch_outcomes",
            "batch_names",
            "batch_job",
            "batch_task",
            "batch_folders",
            "batch_plan",
            "batch_summaries",
        )
    ),
    "hybridlog.model.loader": tuple(
        f"hybridlog.model.{name}"
        for name in ("file_keys", "log_fields", "mode_equations", "mode_switching")
    ),
    "hybridlog.report.document": tuple(
        f"hybridlog.report.{name}" for name in ("report_json", "report_parts", "report_reader")
    ),
    "hybridlog.report.plots": tuple(
        f"hybridlog.report.{name}"
        for name in (
            "plot_figures",
            "plot_curves",
            "plot_labels",
            "plot_legends",
            "plot_time_axis",
            "mode_plots",
        )
    ),
    "hybridlog.jobs.analysis": tuple(
        f"hybridlog.jobs.{name}" for name in ("overrides", "gate_checks", "estimation", "compare")
    ),
    "hybridlog.simulate": tuple(
        f"hybridlog.simulation_{name}"
        for name in ("inputs", "range", "domains", "limits", "schedule")
    ),
    "hybridlog.report.summary": tuple(
        f"hybridlog.report.summary_{part}" for part in ("tables", "notes", "rows", "offline")
    ),
    "hybridlog.report.plot_data": tuple(
        f"hybridlog.report.{name}"
        for name in (
            "plot_time_axis",
            "pixel_bins",
            "curve_envelopes",
            "timeline_bars",
            "plot_reducer",
        )
    ),
}
"""Each split module and the modules that took part of it."""


def _gone(name: str) -> bool:
    """Whether module ``name`` is no more: split whole into the modules that took its parts."""
    return importlib.util.find_spec(name) is None


def _parts(old: str) -> Iterator[str]:
    """The modules that took part of ``old``; of one split whole in turn, the modules of that."""
    for new in SPLITS[old]:
        if new in SPLITS and _gone(new):
            yield from _parts(new)
        else:
            yield new


def _texts() -> list[tuple[str, str]]:
    paths = [
        *ROOT.joinpath("hybridlog").rglob("*.py"),
        *ROOT.joinpath("docs").rglob("*.md"),
        *ROOT.joinpath("docs", "studies").glob("*.py"),
        ROOT / "README.md",
    ]
    return [(str(p.relative_to(ROOT)), p.read_text(encoding="utf-8")) for p in sorted(paths)]


@pytest.mark.parametrize("old", sorted(SPLITS))
def test_a_moved_name_is_not_named_in_its_old_module(old: str) -> None:
    short = old.rsplit(".", 1)[1]
    if _gone(old):  # split whole: any mention of it is stale, a name of it or its file
        gone = re.compile(rf"\b{short}\b")
        stale = [
            f"{where}:{text.count(chr(10), 0, m.start()) + 1}: {m[0]}"
            for where, text in _texts()
            for m in gone.finditer(text)
        ]
        assert not stale, stale
        return
    module = importlib.import_module(old)
    moved = {
        name
        for new in _parts(old)
        for name, value in vars(importlib.import_module(new)).items()
        # a module a new one imports is not moved: ``summary.csv`` is batch's file, not the
        # ``csv`` module that report/summary_tables.py imports
        if not isinstance(value, types.ModuleType) and not hasattr(module, name)
    }
    path = old.removeprefix("hybridlog.").replace(".", "/") + ".py"
    named = re.compile(
        # quoted (`smoothing.rts_step`, ``~hybridlog.report.metrics.x``) or in full: a bare
        # ``metrics.mode_accuracy`` in code is a variable's attribute
        rf"(?:(?<=[`~])(?:hybridlog\.(?:\w+\.)?)?|(?<![\w.])hybridlog\.(?:\w+\.)?){short}\.(\w+)"
        rf"|{re.escape(path)}`?'s `(\w+)`"
    )
    stale = [
        f"{where}:{text.count(chr(10), 0, m.start()) + 1}: {m[0]}"
        for where, text in _texts()
        for m in named.finditer(text)
        if (m[1] or m[2]) in moved
    ]
    assert not stale, stale
