"""``hybridlog compare`` gated on a metric its table does not show: the table shows it."""

from __future__ import annotations

import csv
import json
from pathlib import Path

from hybridlog.jobs.compare import compare
from tests.support.paths import ROOT

CART = ROOT / "sample_logs" / "double_cart_case1.csv"


def test_a_gated_metric_the_table_lacks_gets_a_column_of_each_estimators_value(
    tmp_path: Path,
) -> None:
    """Gated on ``state_rmse.x1``, comparison.md/.csv said ``pass (2)`` per estimator but
    not the value the gate read (batch's summaries show it): which estimator was nearer the
    bound was in neither file."""
    out = tmp_path / "cmp"
    compare(
        CART,
        "double_cart_case1",
        ["imm", "hstf"],
        out_dir=out,
        fail_under=["vaf=1", "state_rmse.x1=0"],
        fail_over=["state_rmse.x1=0.05"],
    )
    with (out / "comparison.csv").open(newline="") as file:
        reader = csv.DictReader(file)
        rows = {row["estimator"]: row for row in reader}
        header = reader.fieldnames or []
    # once: every state's RMSE is among the metrics shown (the log has the true states)
    assert header.count("state_rmse.x1") == 1 and header.count("vaf") == 1
    assert header[-2:] == ["gates", "warnings"]
    assert header.index("state_rmse.x1") < header.index("samples_per_s")
    for name, row in rows.items():
        stored = json.loads((out / name / "report.json").read_text())
        assert row["state_rmse.x1"] == repr(stored["states"]["x1"]["rmse"]), name
        assert row["gates"] == "pass (3)"
    lines = (out / "comparison.md").read_text(encoding="utf-8").splitlines()
    column = lines[2].split(" | ").index("state_rmse.x1")
    cells = [line.split(" | ")[column] for line in lines[4:6]]
    assert len(set(cells)) == 2  # imm's 0.015827 and hstf's 0.015834 read apart
