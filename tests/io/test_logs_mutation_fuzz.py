"""Mutation fuzz of every reader: seeded random damage reads or is refused in one line.

See :mod:`tests.io.mutation_fuzz`: each case runs in a worker process with a time limit, so
a hang or a crash is a failure of its own, not of the test run.  A few hundred cases over
every sample log and the MCAP conformance inputs take about 15 s; the module runs as a
script for longer searches.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from hybridlog.errors import LogError
from hybridlog.io import SignalSpec, inspect_log, load_signals
from hybridlog.model.loader import load_model
from tests.io.mutation_fuzz import (
    SUBJECTS,
    Worker,
    conformance_subjects,
    run_cases,
)

DAMAGED = Path(__file__).parents[1] / "data" / "damaged"


def test_damaged_sample_logs_read_or_are_refused_in_one_line(tmp_path: Path) -> None:
    failures = run_cases(SUBJECTS, 13 * 30, tmp_path, seed=7)
    assert not failures, "\n".join(failures)


def test_damaged_conformance_inputs_read_or_are_refused_in_one_line(tmp_path: Path) -> None:
    failures = run_cases(conformance_subjects(), 120, tmp_path, seed=11)
    assert not failures, "\n".join(failures)


def test_the_worker_reports_a_hang_and_a_crash(tmp_path: Path) -> None:
    # The harness itself: a case that never answers, and a worker that dies, are failures,
    # and the next case runs in a new worker.
    log = tmp_path / "log.csv"
    log.write_text("t,u\n0,1\n")
    worker = Worker()
    try:
        assert worker.run(log, log, None, 60.0, selftest="crash") == (
            "crash: the worker died (exit code 3)"
        )
        assert worker.run(log, log, None, 60.0) is None
        assert worker.run(log, log, None, 0.5, selftest="hang") == ("hang: no answer within 0.5 s")
        problem = worker.run(tmp_path / "missing.csv", log, None, 60.0)
        assert problem is None  # refused, naming the file
    finally:
        worker.close()


def test_a_parquet_file_polars_panics_on_is_refused_in_one_line(
    tmp_path: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    # Found by the fuzz (4 bits flipped in a page): polars' reader panicked, which escaped
    # as pyo3_runtime.PanicException (not an Exception) after Rust's message and backtrace.
    log = tmp_path / "three_tank_hstf.parquet"
    shutil.copyfile(DAMAGED / "polars_panics.parquet", log)  # tests/data/damaged/README.md
    capfd.readouterr()
    for read in (
        lambda: inspect_log(log),
        lambda: load_signals(log, SignalSpec.of(load_model("three_tank_hstf"))),
    ):
        with pytest.raises(LogError) as info:
            read()
        message = str(info.value)
        assert message.startswith(f"{log}: not a readable Parquet file (damaged? polars failed")
        assert "\n" not in message
        assert "panicked" not in capfd.readouterr().err
