"""A batch gated on a metric its summaries did not show gets that metric's column.

summary.csv and summary.md showed each log's samples, VAF, MSE and mode accuracy only: a
batch gated on ``fit`` (or ``fit.y1``, ``state_rmse.x1``) gave a log's fit only as the
message of a missed gate, rounded, and nothing for a log that passed it.
"""

from __future__ import annotations

import csv
import json
from dataclasses import replace
from pathlib import Path

import polars as pl

from hybridlog.report.document import read_report
from hybridlog.report.summary import batch_markdown, batch_rows_csv
from hybridlog.report.summary_rows import BatchRow
from tests.report.test_summary_plot import REPORT


def _rows() -> list[BatchRow]:
    report = read_report(REPORT)
    return [
        BatchRow("a.csv", "a.csv", "done", report, None, (("--fail-under fit=0", None),)),
        BatchRow("b.csv", "b.csv", "done", replace(report, fit=None), None, ()),
        BatchRow("c.csv", "c.csv", "failed", None, "c.csv: empty file", ()),
    ]


def test_summary_csv_holds_each_gated_metric_once_as_the_report_has_it(tmp_path: Path) -> None:
    path = tmp_path / "summary.csv"
    batch_rows_csv(path, _rows(), gated=["fit", "vaf", "fit", "state_rmse.x1"])
    with path.open(encoding="utf-8", newline="") as file:
        header = next(csv.reader(file))
    # each state's RMSE the reports have is shown (x2 has none), so only fit is added
    assert header[header.index("mode_samples") + 1 : header.index("gate_failures")] == [
        "state_rmse.x1",
        "state_rmse.x3",
        "fit",
    ]
    table = pl.read_csv(path)
    data = json.loads(REPORT.read_text(encoding="utf-8"))
    assert table["fit"].to_list() == [data["fit"], None, None]
    assert table["state_rmse.x1"].to_list()[0] == data["states"]["x1"]["rmse"]


def test_summary_md_shows_the_gated_metric_beside_the_others() -> None:
    _, text = batch_markdown("m · imm", _rows(), ["--fail-under fit=0"], gated=["fit"])
    assert "| log | status | gates | samples | vaf | mse | mode_accuracy | fit | report |" in text
    _, plain = batch_markdown("m · imm", _rows(), [])
    assert "| fit |" not in plain
