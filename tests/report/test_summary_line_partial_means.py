"""The terminal line says when a mean over the outputs leaves some of them out."""

from __future__ import annotations

import csv
from pathlib import Path

from hybridlog.cli_lines import summary_line
from hybridlog.jobs.analysis import analyze
from tests.support.paths import TANK_CSV


def test_a_mean_that_leaves_out_a_dead_sensor_says_so(tmp_path: Path) -> None:
    # y1 stuck at one value (a dead sensor): its fit is undefined, and the line read
    # "fit 53.18 %", the mean of y2 and y3 alone, as if it were the log's three outputs'
    with TANK_CSV.open(newline="") as handle:
        header, *rows = list(csv.reader(handle))
    column = header.index("y1")
    for row in rows:
        row[column] = rows[0][column]
    log = tmp_path / "stuck.csv"
    with log.open("w", newline="") as handle:
        csv.writer(handle).writerows([header, *rows])
    report = analyze(log, "three_tank_hstf", estimator="imm", out_dir=tmp_path / "out").report
    assert report.outputs["y1"].fit is None and report.fit is not None
    line = summary_line(report)
    assert " fit " in line and " (mean of 2 of 3 outputs; y1's n/a), MSE " in line
    # VAF and MSE are defined for every output: their means are over all three, unmarked
    assert line.count("(mean of") == 1
    assert f"MSE {report.mse:.4g}, mode accuracy" in line
