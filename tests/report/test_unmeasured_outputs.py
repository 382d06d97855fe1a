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
    from hybridlog.cli_lines import summary_line

    # the terminal's line said the VAF without saying it is over part of the log
    assert " (over 297 of 300 predicted samples), mode accuracy " in summary_line(report)
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


def test_the_warning_says_an_output_is_a_slower_topic_not_that_dt_may_be_wrong() -> None:
    """Each output on its own topic: y1 at the model's rate less one message, y2 at half it,
    y3 at a third, on a clock at Unix-epoch times.  Every warning asked "is the model's dt
    the log's?", of a dt that was right; it now says how often the output was sampled."""
    from hybridlog.report.reading_notes import report_reading_notes

    t = 1.7e9 + np.arange(61) * 0.1
    y1 = np.delete(t, 30)
    notes: dict[str, object] = {}
    align_signals(
        source="s",
        dt=0.1,
        inputs={"u": _series("u", t, np.zeros(t.size))},
        outputs={
            "y1": _series("y1", y1, np.zeros(y1.size)),
            "y2": _series("y2", t[::2], np.zeros(31)),
            "y3": _series("y3", t[::3], np.zeros(21)),
        },
        notes=notes,
    )
    assert notes["bridged"] == {
        "y1": {"points": 1, "of": 61, "every": 0.1, "steps": 1.0},
        "y2": {"points": 30, "of": 61, "every": 0.2, "steps": 2.0},
        "y3": {"points": 40, "of": 61, "every": 0.3, "steps": 3.0},
    }
    y1_note, y2_note, y3_note = report_reading_notes(notes)
    assert "of 61 sample times (it is sampled every dt, with samples missing there): " in y1_note
    assert "(it is sampled every 0.2 s (median), 2 steps of dt): " in y2_note
    assert "(it is sampled every 0.3 s (median), 3 steps of dt): " in y3_note
    assert not any("is the model's dt the log's?" in note for note in (y1_note, y2_note, y3_note))


def test_true_state_gaps_drop_nonfinite_made_are_said_so_not_blamed_on_dt(
    tmp_path: Path,
) -> None:
    """NaN cells of a true state ``--drop-nonfinite`` dropped: sampled every dt, some missing.

    The true state's warning asked "is the model's dt the log's?" whatever made its gaps,
    where the output's, by the same median sample step, said the real cause.
    """
    from hybridlog.io.options import ReadOptions

    with TANK_CSV.open(newline="") as handle:
        header, *rows = list(csv.reader(handle))
    for k in (50, 51, 120):
        rows[k][header.index("y1")] = "nan"
    for k in (60, 61, 62, 150):
        rows[k][header.index("x1")] = "nan"
    log = tmp_path / "nan_cells.csv"
    with log.open("w", newline="") as handle:
        csv.writer(handle).writerows([header, *rows])
    report = analyze(
        log,
        "three_tank_hstf",
        estimator="imm",
        out_dir=tmp_path / "out",
        read=ReadOptions(drop_nonfinite=True),
    ).report
    assert report.reading is not None
    assert report.reading["truth_bridged"]["x1"] == {
        "points": 4,
        "of": 301,
        "every": 1.0,
        "steps": 1.0,
    }
    cause = "(it is sampled every dt, with samples missing there)"
    (output,) = [n for n in report.notes if n.startswith("WARNING: output y1 ")]
    (state,) = [n for n in report.notes if n.startswith("WARNING: true state x1 ")]
    assert cause in output and cause in state
    assert "is the model's dt the log's?" not in state


def test_a_gap_entry_of_an_earlier_version_without_its_step_still_asks_about_dt() -> None:
    from hybridlog.report.reading_notes import report_reading_notes

    (state,) = report_reading_notes({"truth_bridged": {"x1": {"points": 2, "of": 11}}})
    assert "(is the model's dt the log's?)" in state
