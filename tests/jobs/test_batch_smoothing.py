"""A batch with ``--smooth`` (issue 12): the flag is a setting that a resumed batch compares."""

from __future__ import annotations

import csv
import json
import statistics
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import pytest

from hybridlog.estimators.result import Fallbacks
from hybridlog.jobs.batch import run_batch
from hybridlog.jobs.batch_outcomes import BatchOutcome
from tests.jobs.test_batch_resume import TANK, statuses, write_logs


def test_changing_smooth_redoes_the_logs_and_the_same_flag_skips_them(tmp_path: Path) -> None:
    logs = write_logs(tmp_path / "logs", ["s1.csv", "s2.csv"])
    out = tmp_path / "out"

    def again(**options: object) -> dict[str, str]:
        return statuses(run_batch(logs, TANK, out_dir=out, estimator="imm", **options))

    assert set(again().values()) == {"done"}
    assert set(again(smooth=True).values()) == {"done"}
    report = json.loads((out / "s1.csv" / "report.json").read_text())
    assert report["smoothing"]["method"] and report["options"]["smooth"] is True
    assert report["batch"]["settings"]["options"]["smooth"] is True
    assert set(again(smooth=True).values()) == {"skipped"}
    summary = (out / "summary.md").read_text().splitlines()[0]
    assert summary == f"# Batch: {TANK} · imm · {report['smoothing']['method']}, argmax"
    # --set smooth=true is the same run as --smooth
    assert set(again(sets=["smooth=true"]).values()) == {"skipped"}
    assert set(again(smooth=True, mode_sequence="viterbi").values()) == {"done"}
    assert set(again(smooth=True, mode_sequence="viterbi").values()) == {"skipped"}
    assert set(again().values()) == {"done"}
    assert "smoothing" not in json.loads((out / "s1.csv" / "report.json").read_text())
    assert (out / "summary.md").read_text().startswith(f"# Batch: {TANK} · imm\n")


def _offline_values(report: dict[str, Any]) -> dict[str, float | None]:
    """summary.csv's offline columns of a log, from its report.json's ``smoothing`` block."""
    smoothing = report["smoothing"]
    values: dict[str, float | None] = {
        "mode_accuracy": smoothing["smoothed"]["mode_accuracy"],
        "filtered_mode_accuracy": smoothing["filtered"]["mode_accuracy"],
    }
    for x in ("x1", "x2", "x3"):
        values[f"state_rmse.{x}"] = smoothing["smoothed"]["states"][x]["rmse"]
        values[f"filtered_state_rmse.{x}"] = smoothing["filtered"]["states"][x]["rmse"]
    return values


def test_summaries_of_a_smoothed_batch_give_the_filters_metrics_beside_the_offline_ones(
    tmp_path: Path,
) -> None:
    # batch --smooth wrote the smoothed mode accuracy under summary.csv's mode_accuracy with
    # nothing saying so, and the filter's own nowhere: the gain of smoothing, per log or
    # over the batch, could not be seen without opening every report.json.
    write_logs(tmp_path / "logs", ["s1.csv", "s2.csv", "s3.csv"])
    (tmp_path / "logs" / "s4.csv").write_text("t,u,y1\n0,1,2\n")
    out, junit = tmp_path / "out", tmp_path / "junit.xml"

    def run(**options: object) -> BatchOutcome:
        return run_batch(
            [tmp_path / "logs"], TANK, out_dir=out, estimator="imm", junit=junit, **options
        )

    plain = run()
    assert [o.status for o in plain.logs] == ["done"] * 3 + ["failed"]
    # without an offline pass: each state's RMSE alone, no comparison, no properties
    with (out / "summary.csv").open() as file:
        assert next(csv.reader(file)) == [
            "log", "status", "samples", "vaf", "mse", "mode_accuracy", "mode_samples",
            "state_rmse.x1", "state_rmse.x2", "state_rmse.x3",
            "gate_failures", "warnings", "error", "folder",
        ]  # fmt: skip
    assert "filter's own" not in (out / "summary.md").read_text()
    assert ET.parse(junit).find(".//properties") is None
    assert ET.parse(junit).find(".//system-out") is None

    smoothed = run(smooth=True, fail_under=["mode_accuracy=0.5"])
    resumed = run(smooth=True, fail_under=["mode_accuracy=0.5"])
    assert [o.status for o in smoothed.logs] == ["done"] * 3 + ["failed"]
    assert [o.status for o in resumed.logs] == ["skipped"] * 3 + ["failed"]
    reports = {
        f"s{k}.csv": json.loads((out / f"s{k}.csv" / "report.json").read_text()) for k in (1, 2, 3)
    }
    expected = {name: _offline_values(report) for name, report in reports.items()}
    with (out / "summary.csv").open() as file:
        table = list(csv.DictReader(file))
    assert list(table[0])[5:16] == [
        "mode_accuracy", "mode_samples", "filtered_mode_accuracy",
        "state_rmse.x1", "filtered_state_rmse.x1", "state_rmse.x2", "filtered_state_rmse.x2",
        "state_rmse.x3", "filtered_state_rmse.x3", "smoothing", "smoothing_fallback_samples",
    ]  # fmt: skip
    for row in table[:3]:  # a resumed batch: the numbers of the reports it reused
        name = Path(row["log"]).name
        assert row["status"] == "skipped" and row["smoothing"] == "kim-rts, argmax"
        assert {key: float(row[key]) for key in expected[name]} == expected[name]
    failed = table[3]
    assert failed["status"] == "failed"
    assert all(failed[key] == "" for key in [*expected["s1.csv"], "smoothing"])

    # summary.md: the filter's own beside each log's, the gain over the batch
    text = (out / "summary.md").read_text()
    assert "| mode_accuracy | filtered_mode_accuracy | report |" in text
    own = [v["filtered_mode_accuracy"] for v in expected.values()]
    offline = [v["mode_accuracy"] for v in expected.values()]
    changes = [a - b for a, b in zip(offline, own, strict=True)]
    assert all(c is not None for c in own + offline)
    section = text.split("## Offline estimates against the filter's own")[1]
    line = next(li for li in section.splitlines() if li.startswith("| mode_accuracy |"))
    cells = [c.strip() for c in line.strip("|").split("|")]
    assert cells[1] == "3"
    medians = [statistics.median(own), statistics.median(offline), statistics.median(changes)]
    assert [float(c) for c in cells[2:5]] == pytest.approx(medians, abs=5e-4)
    better = sum(c > 0 for c in changes)
    worse = [name for name, c in zip(expected, changes, strict=True) if c < 0]
    assert cells[5:] == [str(better), str(sum(c == 0 for c in changes)), str(len(worse))]
    for name in worse:
        assert f"logs/{name} (" in section

    # JUnit: each log's values in its cases' output, the batch's gains on the suite
    root = ET.parse(junit).getroot()
    for case in root.iter("testcase"):
        name = Path(case.get("classname", "")).name
        text = case.findtext("system-out")
        if name == "s4.csv":
            assert text is None
            continue
        values = expected[name]
        fallbacks = Fallbacks(**reports[name]["smoothing"]["fallbacks"])
        assert text is not None and text.splitlines()[1:] == [
            f"{metric} = {values[metric]:.6g} (the filter's own: {values[own]:.6g})"
            for metric, own in [
                ("mode_accuracy", "filtered_mode_accuracy"),
                *((f"state_rmse.{x}", f"filtered_state_rmse.{x}") for x in ("x1", "x2", "x3")),
            ]
        ] + ([fallbacks.summary()] if fallbacks.samples else [])
    suite = root.find("testsuite")
    assert suite is not None and suite[0].tag == "properties"
    gains = {p.get("name"): p.get("value") for p in suite[0]}
    assert float(gains["mode_accuracy.median_change"] or "nan") == statistics.median(changes)
    assert gains["mode_accuracy.worse"] == str(len(worse))
