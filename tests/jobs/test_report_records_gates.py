"""The gates ``analyze`` and ``compare`` check are recorded in each run's report.

A missed gate was said on stderr and in the exit code alone: report.json and report.md,
which CI keeps as artifacts, did not say which bound was missed, nor that one was set.
"""

from __future__ import annotations

import csv
import json
import math
import re
from pathlib import Path

from hybridlog.jobs.analysis import analyze
from hybridlog.jobs.compare import compare
from hybridlog.report import read_report, render_markdown
from hybridlog.report.gates import GATES_KEY, gate_records, parse_gates
from tests.support.paths import ROOT, TANK_CSV

CART = ROOT / "sample_logs" / "double_cart_case1.csv"


def test_analyze_records_each_gate_met_or_missed_in_report_json_and_md(tmp_path: Path) -> None:
    out = tmp_path / "run"
    outcome = analyze(
        CART,
        "double_cart_case1",
        estimator="imm",
        out_dir=out,
        fail_under=["vaf=1", "mode_accuracy=0.99999"],
        fail_over=["mse=1e9"],
    )
    stored = json.loads((out / "report.json").read_text())
    records = stored["gates"]
    assert [r["gate"] for r in records] == [
        "--fail-under vaf=1",
        "--fail-under mode_accuracy=0.99999",
        "--fail-over mse=1e9",
    ]
    assert [r["passed"] for r in records] == [True, False, True]
    assert records[0]["value"] == stored["vaf"] and records[2]["value"] == stored["mse"]
    assert records[1]["value"] == stored["modes"]["accuracy"]
    assert records[1]["failure"] == outcome.gate_failures[0]
    assert outcome.gate_failures == [records[1]["failure"]]
    assert records[1]["failure"].endswith("is under the bound 0.99999")
    text = (out / "report.md").read_text(encoding="utf-8")
    gates = text.split("## Gates\n\n", 1)[1].split("\n\n", 1)[0].splitlines()
    assert gates[0].startswith("- `--fail-under vaf=1`: met (vaf = ")
    missed = records[1]["failure"]
    assert gates[1] == f"- `--fail-under mode_accuracy=0.99999`: **missed**: {missed}"
    assert text.index("## Gates") < text.index("## Outputs")
    # read back, the report renders the same section
    assert render_markdown(read_report(out / "report.json")) == text


def test_a_run_without_gates_records_none(tmp_path: Path) -> None:
    out = tmp_path / "run"
    analyze(CART, "double_cart_case1", estimator="imm", out_dir=out)
    assert "gates" not in json.loads((out / "report.json").read_text())
    assert "## Gates" not in (out / "report.md").read_text(encoding="utf-8")


def test_compare_records_the_gates_in_each_estimators_report(tmp_path: Path) -> None:
    out = tmp_path / "cmp"
    compare(CART, "double_cart_case1", ["imm", "hstf"], out_dir=out, fail_over=["mse=1e-12"])
    for name in ("imm", "hstf"):
        (record,) = json.loads((out / name / "report.json").read_text())["gates"]
        assert record["gate"] == "--fail-over mse=1e-12" and record["passed"] is False
        assert record["failure"] in (out / "comparison.md").read_text(encoding="utf-8")


def test_a_met_gate_reads_on_its_side_of_the_bound_and_a_count_stays_a_count(
    tmp_path: Path,
) -> None:
    """``--fail-over vaf=99.97209383`` was ``met (vaf = 99.9721)``: over the bound as printed.

    A met gate's value now has the digits that tell it from its bound, as a missed one's
    message has; ``missed_switches`` was recorded as ``0.0`` beside the report's ``0``.
    """
    out = tmp_path / "run"
    analyze(CART, "double_cart_case1", estimator="imm", out_dir=out)
    report = read_report(out / "report.json")
    assert report.vaf is not None
    above, below = math.nextafter(report.vaf, math.inf), math.nextafter(report.vaf, -math.inf)
    gates = parse_gates([f"vaf={below!r}"], [f"vaf={above!r}", "missed_switches=1000"])
    text = render_markdown(report.with_extra({GATES_KEY: gate_records(report, gates)}))
    lines = text.split("## Gates\n\n", 1)[1].split("\n\n", 1)[0].splitlines()
    shown = [float(re.findall(r"met \(vaf = ([0-9.]+)\)", line)[0]) for line in lines[:2]]
    assert shown[0] >= below and shown[1] <= above  # each on its side of its bound
    (count,) = [r["value"] for r in gate_records(report, gates) if r["metric"] != "vaf"]
    assert report.modes.detection is not None
    assert count == report.modes.detection.missed and isinstance(count, int)


def test_a_met_gate_over_part_of_the_log_says_over_which_samples(tmp_path: Path) -> None:
    # the true mode on the first 4 of 301 rows: a missed gate said "over 4 of 301 samples",
    # a met one read "met (mode_accuracy = 0.75 ...)" as if it were the whole log's
    with TANK_CSV.open(newline="") as handle:
        header, *rows = list(csv.reader(handle))
    for row in rows[4:]:
        row[header.index("mode")] = ""
    log = tmp_path / "few.csv"
    with log.open("w", newline="") as handle:
        csv.writer(handle).writerows([header, *rows])
    out = tmp_path / "run"
    analyze(log, "three_tank_hstf", estimator="imm", out_dir=out)
    report = read_report(out / "report.json")
    assert report.modes.samples == 4 and report.modes.accuracy is not None
    bound = report.modes.accuracy / 2
    gates = parse_gates([f"mode_accuracy={bound!r}", "vaf=1"], [])
    text = render_markdown(report.with_extra({GATES_KEY: gate_records(report, gates)}))
    lines = text.split("## Gates\n\n", 1)[1].split("\n\n", 1)[0].splitlines()
    assert ": met (mode_accuracy = " in lines[0]
    assert " over 4 of 301 samples (the true mode has no sample from t = " in lines[0]
    assert " over " not in lines[1]  # vaf is over the whole log: nothing to add
