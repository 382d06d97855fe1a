"""The terminal line says when a mean over the outputs leaves some of them out."""

from __future__ import annotations

import csv
import dataclasses
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


# Two components, each with its own state and output; A starts in its unknown mode and no rule
# leaves it, so y1 is never predicted (its metrics n/a) while y2 is on every row.
_UNPREDICTED_OUTPUT_MODEL = """
name = "unpredicted_output"
dt = 1.0
states = ["x1", "x2"]
inputs = ["u1"]
outputs = ["y1", "y2"]

[noise]
process = [0.04, 0.09]
measurement = [0.25, 0.16]

[initial]
state = [1.0, -0.5]
covariance = [0.5, 0.3]

[components.A]
unknown = 0.01
initial = "unknown"

[components.A.modes.a1]
equations = ["x1[k] = 0.9*x1[k-1] + u1[k-1]", "y1 = x1"]

[components.B]
unknown = 0
initial = "b1"

[components.B.modes.b1]
equations = ["x2[k] = 0.7*x2[k-1] + 1", "y2 = x2"]
"""


def test_the_count_of_predicted_samples_is_over_the_outputs_the_means_are_over(
    tmp_path: Path,
) -> None:
    # The line read "MSE 5.816 (mean of 1 of 2 outputs; y1's n/a) (over 0 of 199 predicted
    # samples)": the count was y1's, which no mean is over, for an MSE of y2 over 199 samples.
    model = tmp_path / "m.toml"
    model.write_text(_UNPREDICTED_OUTPUT_MODEL, encoding="utf-8")
    log = tmp_path / "log.csv"
    with log.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["t", "u1", "y1", "y2"])
        for k in range(60):
            writer.writerow([k, 0.1 * (k % 7), 1.0 + 0.01 * (k % 5), 3.3 - 0.02 * (k % 3)])
    report = analyze(log, model, estimator="unknown-mode", out_dir=tmp_path / "out").report
    assert report.outputs["y1"].samples == 0 and report.outputs["y2"].samples == 59
    line = summary_line(report)
    assert "predicted samples" not in line, line  # y2, the only one scored, is over all 59
    assert f"MSE {report.mse:.4g} (mean of 1 of 2 outputs; y1's n/a), mode accuracy" in line

    # outputs scored on different counts (one left unpredicted while its component was
    # unknown): the line gave the smallest as if every output's metrics were over it
    outputs = dict(report.outputs)
    outputs["y1"] = dataclasses.replace(outputs["y1"], samples=40)
    uneven = dataclasses.replace(report, outputs=outputs)
    assert " (over 40 to 59 of 59 predicted samples, by output)" in summary_line(uneven)
    outputs["y2"] = dataclasses.replace(outputs["y2"], samples=40)
    even = dataclasses.replace(report, outputs=outputs)
    assert " (over 40 of 59 predicted samples)" in summary_line(even)
