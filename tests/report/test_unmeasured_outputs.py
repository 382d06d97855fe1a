"""Outputs and true states the log did not measure are not scored (a gap bridged, SPEC §5).

A gap shorter than ``--max-gap`` is bridged: the grid points without a sample within dt/2
take the nearest sample's value (or an interpolated one).  The estimators need a value there,
but it is not a measurement: MSE, VAF and fit used to score the one-step-ahead prediction
against it, estimates.csv wrote it in the measured column, and a true state's stand-in value
counted in its RMSE, all as if measured.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import polars as pl
import pytest

from hybridlog.io.align import align_signals
from hybridlog.io.source import Series, seconds_to_ns
from hybridlog.jobs.analysis import analyze
from hybridlog.report import metrics
from tests.support.paths import TANK_CSV

OUTPUT_GAP = (101, 102, 103)  # data rows (0-based) whose outputs are left empty
TRUTH_GAP = (201, 202)  # data rows whose true x1 is left empty


def _gapped_log(tmp_path: Path) -> tuple[Path, list[list[str]]]:
    with TANK_CSV.open(newline="") as handle:
        header, *rows = list(csv.reader(handle))
    for row in (rows[k] for k in OUTPUT_GAP):
        for name in ("y1", "y2", "y3"):
            row[header.index(name)] = ""
    for row in (rows[k] for k in TRUTH_GAP):
        row[header.index("x1")] = ""
    log = tmp_path / "gapped.csv"
    with log.open("w", newline="") as handle:
        csv.writer(handle).writerows([header, *rows])
    return log, [header, *rows]


def test_bridged_points_are_left_out_of_the_metrics_and_the_measured_columns(
    tmp_path: Path,
) -> None:
    log, (header, *rows) = _gapped_log(tmp_path)
    outcome = analyze(log, "three_tank_hstf", estimator="imm", out_dir=tmp_path / "out")
    report = outcome.report
    n = len(rows)
    table = pl.read_csv(tmp_path / "out" / "estimates.csv")
    for y in ("y1", "y2", "y3"):
        measured = table[y].to_numpy()
        assert np.isnan(measured[list(OUTPUT_GAP)]).all()  # empty cells, not the stand-in
        assert np.isfinite(np.delete(measured, OUTPUT_GAP)).all()
        # Independently: the metrics over the rows the log measured (and row 0 has no
        # prediction), from the log's own cells and the written predictions.
        cells = [r[header.index(y)] for r in rows]
        logged = np.array([float(cell) if cell else np.nan for cell in cells])
        predicted = table[f"{y}_hat"].to_numpy()
        rows_scored = np.isfinite(logged) & np.isfinite(predicted)
        assert report.outputs[y].samples == n - 1 - len(OUTPUT_GAP) == rows_scored.sum()
        error = logged[rows_scored] - predicted[rows_scored]
        assert report.outputs[y].mse == pytest.approx(np.mean(error**2), rel=1e-12)
        assert report.outputs[y].vaf == pytest.approx(
            float(metrics.vaf(logged[rows_scored], predicted[rows_scored])[0]), rel=1e-12
        )
    assert report.states is not None
    assert report.states["x1"].samples == n - len(TRUTH_GAP)
    assert report.states["x2"].samples == n
    assert np.isnan(table["x1_true"].to_numpy()[list(TRUTH_GAP)]).all()
    from hybridlog.cli import _summary_line

    # the terminal's line said the VAF without saying it is over part of the log
    assert " (over 297 of 300 predicted samples), mode accuracy " in _summary_line(report)
    notes = "\n".join(report.notes)
    assert "MSE, VAF and fit leave them out" in notes
    assert "its RMSE leaves them out" in notes


def _series(name: str, seconds: np.ndarray, values: np.ndarray) -> Series:
    return Series(name, seconds_to_ns(seconds), np.asarray(values, dtype=np.float64))


def test_alignment_keeps_the_stand_in_for_the_estimators_and_marks_it() -> None:
    grid = np.arange(12) * 0.5
    kept = np.delete(grid, [5, 6])
    signals = align_signals(
        source="s",
        dt=0.5,
        inputs={"u": _series("u", grid, np.zeros(12))},
        outputs={"y": _series("y", kept, kept), "z": _series("z", grid, grid)},
    )
    assert signals.unmeasured_outputs is not None
    np.testing.assert_array_equal(np.flatnonzero(signals.unmeasured_outputs[:, 0]), [5, 6])
    assert not signals.unmeasured_outputs[:, 1].any()
    assert np.isfinite(signals.outputs).all()  # the estimators' values: nearest samples
    measured = signals.measured_outputs()
    np.testing.assert_array_equal(np.flatnonzero(np.isnan(measured[:, 0])), [5, 6])
    np.testing.assert_array_equal(measured[:, 1], grid)
    part = signals.rows(4, 8)
    assert part.unmeasured_outputs is not None
    np.testing.assert_array_equal(np.isnan(part.measured_outputs()[:, 0]), [0, 1, 1, 0])
    whole = align_signals(
        source="s",
        dt=0.5,
        inputs={"u": _series("u", grid, np.zeros(12))},
        outputs={"y": _series("y", grid, grid)},
    )
    assert whole.unmeasured_outputs is None
    assert whole.measured_outputs() is whole.outputs
