"""Rows left out of the output metrics: report.md says how many, and which rows they are.

Rows without a prediction (NaN) or without a finite measurement are left out; an infinite
prediction is used (it diverged).  report.md said "the others have no finite measurement or
prediction", which read as if the rows of an infinite prediction were left out too.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from hybridlog.report import build_report, render_markdown

from .test_report_files import DT, make_run


def test_report_md_counts_the_rows_left_out_and_says_which_they_are() -> None:
    n = 60
    result, signals = make_run(n, seed=9)
    predictions = result.output_predictions.copy()
    predictions[10:17, 0] = np.nan  # no prediction in 7 rows
    predictions[30, 1] = np.inf  # diverged in one row: used
    report = build_report(
        dataclasses.replace(result, output_predictions=predictions),
        signals,
        log="run.csv",
        model_name="m",
        dt=DT,
    )
    assert report.outputs["y1"].samples == n - 1 - 7
    assert report.outputs["y2"].samples == n - 1
    md = render_markdown(report)
    assert (
        f"- y1: metrics over {n - 8} of {n - 1} samples; the others have no finite "
        "measurement or no prediction (NaN)"
    ) in md
    assert "- y2: metrics over" not in md
    mse = report.outputs["y1"].mse
    kept = np.isfinite(predictions[:, 0])
    expected = float(np.mean((signals.outputs[kept, 0] - predictions[kept, 0]) ** 2))
    assert mse is not None and abs(mse - expected) <= 1e-12 * expected
