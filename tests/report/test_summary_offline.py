"""A batch's summaries with an offline pass: the filter's own metrics beside the offline ones.

summary.csv had the smoothed mode accuracy under ``mode_accuracy`` with nothing saying so and
the filter's own nowhere; summary.md, summary.png and JUnit showed no gain, per log or over
the batch (issue 12: "both the filtered and the smoothed metrics so users see the gain").
"""

from __future__ import annotations

import csv
import xml.etree.ElementTree as ET
from dataclasses import replace
from pathlib import Path

import pytest
from matplotlib.collections import LineCollection, PathCollection
from matplotlib.colors import to_hex

from hybridlog.report.document import read_report
from hybridlog.report.junit import write_junit
from hybridlog.report.markdown import render_markdown
from hybridlog.report.report_parts import Smoothing, StateReport
from hybridlog.report.summary import batch_markdown, batch_rows_csv
from hybridlog.report.summary_notes import MAX_NAMED
from hybridlog.report.summary_offline import offline_gains, offline_metrics
from hybridlog.report.summary_plot import summary_figure
from hybridlog.report.summary_rows import BatchRow
from tests.report.test_report_gates import _side
from tests.report.test_summary_plot import REPORT, points

METRICS = offline_metrics(["x1"])


def row(log: str, filtered: tuple[float, float], offline: tuple[float, float]) -> BatchRow:
    """An analysed log: (mode accuracy, RMSE of x1) of the filter and of the offline pass."""
    smoothing = Smoothing(
        "kim-rts",
        "argmax",
        "d",
        _side(filtered[0], 0, filtered[1]),
        _side(offline[0], 0, offline[1]),
    )
    report = read_report(REPORT)  # its own modes are the offline ones, as build_report's
    report = replace(report, notes=())  # its warning of 30 samples: not the notes tested here
    report = replace(report, modes=replace(report.modes, accuracy=offline[0]), smoothing=smoothing)
    return BatchRow(log, log, "done", report, None, ())


def rows() -> list[BatchRow]:
    return [
        row("a.csv", (0.5, 1.0), (0.6, 0.8)),  # better on both
        row("b.csv", (0.7, 0.5), (0.6, 0.9)),  # worse on both
        BatchRow("c.csv", "c.csv", "failed", None, "c.csv: broken", ()),
    ]


def test_gains_count_better_equal_and_worse_each_way() -> None:
    mode, rmse = offline_gains(rows(), METRICS)
    assert (mode.metric, mode.logs, mode.better, mode.equal) == ("mode_accuracy", 2, 1, 0)
    assert mode.filtered == pytest.approx(0.6) and mode.offline == pytest.approx(0.6)
    assert mode.change == pytest.approx(0.0)
    assert mode.worse == (("b.csv", 0.6, 0.7),)
    # a lower RMSE is the better one
    assert (rmse.metric, rmse.better, rmse.worse) == ("state_rmse.x1", 1, (("b.csv", 0.9, 0.5),))
    assert rmse.change == pytest.approx((-0.2 + 0.4) / 2)


def test_summary_md_names_the_logs_where_the_offline_estimate_is_worse() -> None:
    _, text = batch_markdown("m · imm · kim-rts, argmax", rows(), [], METRICS)
    assert "| mode_accuracy | filtered_mode_accuracy | report |" in text
    assert "| a.csv | done |  | " in text
    assert "- mode_accuracy (1 of 2): b.csv (0.6 against the filter's 0.7)" in text
    assert "- state_rmse.x1 (1 of 2): b.csv (0.9 against the filter's 0.5)" in text
    many = [row(f"w{k}.csv", (0.9, 1.0), (0.9 - k / 1000, 1.0)) for k in range(1, 26)]
    _, text = batch_markdown("m", many, [], METRICS)
    line = next(li for li in text.splitlines() if li.startswith("- mode_accuracy"))
    assert line.startswith("- mode_accuracy (25 of 25): w25.csv (0.875 against")  # worst first
    assert line.count("against the filter's") == MAX_NAMED
    assert line.endswith("; and 5 more (summary.csv)")
    assert "- state_rmse" not in text  # equal everywhere: nothing worse
    # without an offline pass: as before
    _, text = batch_markdown("m · imm", rows(), [])
    assert "filtered_" not in text and "filter's own" not in text
    # no log with a true mode or state: said, not a table of n/a
    analysed = row("d.csv", (0.5, 1.0), (0.6, 0.8))
    assert analysed.report is not None and analysed.report.smoothing is not None
    unknown = replace(_side(None, None, 0.0), states={"x1": StateReport(rmse=None)})
    smoothing = replace(analysed.report.smoothing, filtered=unknown, smoothed=unknown)
    no_truth = replace(analysed, report=replace(analysed.report, smoothing=smoothing))
    _, text = batch_markdown("m", [no_truth, *rows()[2:]], [], METRICS)
    assert "No analysed log has a true mode or state" in text
    # no log analysed at all (this said so too): not said to lack a truth never read for
    _, text = batch_markdown("m", rows()[2:], [], METRICS)
    assert "No analysed log" not in text
    assert "No log was analysed: there are no offline estimates to compare." in text


def test_summary_csv_adds_the_columns_only_with_an_offline_pass(tmp_path: Path) -> None:
    path = tmp_path / "summary.csv"
    batch_rows_csv(path, rows())
    with path.open() as file:
        assert next(csv.reader(file)) == [
            "log", "status", "samples", "vaf", "mse", "mode_accuracy", "mode_samples",
            "state_rmse.x1", "state_rmse.x3", "gate_failures", "warnings", "error", "folder",
        ]  # fmt: skip
    batch_rows_csv(path, rows(), METRICS)
    with path.open() as file:
        table = list(csv.DictReader(file))
    assert list(table[0])[5:14] == [
        "mode_accuracy", "mode_samples", "filtered_mode_accuracy", "state_rmse.x1",
        "filtered_state_rmse.x1", "smoothing", "smoothing_fallback_samples",
        "smoothing_fallback_weight", "gate_failures",
    ]  # fmt: skip
    b = table[1]
    assert [b["filtered_mode_accuracy"], b["state_rmse.x1"], b["filtered_state_rmse.x1"]] == [
        "0.7", "0.9", "0.5",
    ]  # fmt: skip
    assert b["smoothing"] == "kim-rts, argmax"
    assert all(table[2][c] == "" for c in ("filtered_mode_accuracy", "state_rmse.x1", "smoothing"))


def test_junit_carries_each_logs_values_and_the_batchs_gains(tmp_path: Path) -> None:
    path = tmp_path / "junit.xml"
    batch = rows()
    batch[1] = replace(batch[1], gates=(("--fail-under vaf=1", None), ("g2", "missed")))
    write_junit(path, "hybridlog batch: m", batch, METRICS)
    suite = ET.parse(path).getroot()[0]
    assert suite[0].tag == "properties"  # before the test cases, as the schemas have it
    gains = {p.get("name"): p.get("value") for p in suite[0]}
    assert gains["smoothing"] == "kim-rts, argmax"
    assert gains["mode_accuracy.worse"] == "1" and gains["state_rmse.x1.better"] == "1"
    assert gains["state_rmse.x1.median_change"] == str(((0.8 - 1.0) + (0.9 - 0.5)) / 2)
    cases = suite.findall("testcase")
    assert [c.get("classname") for c in cases] == ["a.csv", "b.csv", "b.csv", "c.csv"]
    expected = (
        "offline estimates (kim-rts, argmax) against the filter's own:\n"
        "mode_accuracy = 0.6 (the filter's own: 0.7)\n"
        "state_rmse.x1 = 0.9 (the filter's own: 0.5)"
    )
    for case in cases[1:3]:  # every case of the log; no properties where schemas have none
        assert case.findtext("system-out") == expected
        assert case.find("properties") is None
    assert [child.tag for child in cases[2]] == ["failure", "system-out"]  # the schemas' order
    assert cases[3].find("system-out") is None  # the failed log
    write_junit(path, "hybridlog batch: m", rows())
    root = ET.parse(path).getroot()
    assert root.find(".//properties") is None and root.find(".//system-out") is None


def test_summary_png_draws_the_filters_mode_accuracy_beside_the_offline_one() -> None:
    fig = summary_figure("m · imm · kim-rts, argmax", rows())
    ax = fig.axes[1]
    assert ax.get_ylabel() == "mode accuracy (%)\n● offline ○ filter"

    def drawn(colour: str) -> list[tuple[float, float]]:
        return sorted((round(x, 9), round(y, 9)) for x, y in points(ax, colour))

    assert drawn("#1f77b4") == [(0.0, 60.0), (1.0, 60.0)]
    (rings,) = [
        c
        for c in ax.collections
        if isinstance(c, PathCollection) and to_hex(c.get_edgecolor()[0]) == "#7f7f7f"
    ]
    assert len(rings.get_facecolor()) == 0  # rings: no fill
    assert sorted(map(tuple, rings.get_offsets().tolist())) == [(0.0, 50.0), (1.0, 70.0)]
    (joins,) = [c for c in ax.collections if isinstance(c, LineCollection)]
    assert sorted(sorted(p[:, 1]) for p in joins.get_segments()) == [[50.0, 60.0], [60.0, 70.0]]


def test_the_filters_mode_accuracy_is_inside_the_panel_below_an_offline_one_of_100() -> None:
    """With every offline value near 100 % the panel's top was fixed at 101 % before the
    rings were drawn: a filter's 50 % was outside the panel, not drawn at all."""
    fig = summary_figure(
        "m", [row("a.csv", (0.5, 1.0), (1.0, 0.8)), row("b.csv", (0.7, 1.0), (0.99, 0.8))]
    )
    low, high = fig.axes[1].get_ylim()
    assert low < 50.0 and high == 101.0


def apart(log: str, filtered: tuple[float, int], offline: tuple[float, int]) -> BatchRow:
    """An analysed log whose sides' RMSEs of x1, ``(rmse, samples)``, may cover other samples.

    A ``kbest`` path of ``unknown-mode`` estimates no state while a component on it is
    ``unknown``: its RMSE was over 13 samples, the causal estimate's over 101.
    """
    made = row(log, (0.5, filtered[0]), (0.6, offline[0]))
    assert made.report is not None and made.report.smoothing is not None
    smoothing = made.report.smoothing
    sides = {
        name: replace(side, states={"x1": StateReport(rmse=rmse, samples=samples)})
        for name, side, (rmse, samples) in (
            ("filtered", smoothing.filtered, filtered),
            ("smoothed", smoothing.smoothed, offline),
        )
    }
    return replace(made, report=replace(made.report, smoothing=replace(smoothing, **sides)))


def test_rmses_over_other_samples_are_no_gain_and_are_named(tmp_path: Path) -> None:
    # unknown-mode --mode-sequence kbest on a [components] log: summary.md counted the path's
    # RMSE of 0.082 over 13 samples "better" than the filter's 0.091 over 101, and
    # report.md gave the change -0.0087, where the two RMSEs were over other samples
    batch = [apart("far.csv", (0.09, 101), (0.08, 13)), apart("near.csv", (0.5, 50), (0.9, 50))]
    _, rmse = offline_gains(batch, METRICS)
    assert (rmse.logs, rmse.better, rmse.worse) == (1, 0, (("near.csv", 0.9, 0.5),))
    _, text = batch_markdown("m", batch, [], METRICS)
    assert "- state_rmse.x1 (1): far.csv (13 samples against the filter's 101)" in text
    assert "near.csv (50 samples" not in text
    _, text = batch_markdown("m", batch[:1], [], METRICS)  # the only log with a true x1
    assert "- state_rmse.x1 (1): far.csv (13 samples" in text
    assert "| state_rmse.x1 |" not in text
    far, near = (b.report for b in batch)
    assert far is not None and near is not None
    section = render_markdown(far).split("## Smoothing", 1)[1].split("\n## ", 1)[0]
    line = next(li for li in section.splitlines() if li.startswith("| RMSE x1 |"))
    assert line.split(" | ")[1:] == [
        "0.09 over 101 samples", "0.08 over 13 samples", "n/a (other samples) |"
    ]  # fmt: skip
    assert "over other samples on each side" in section
    section = render_markdown(near).split("## Smoothing", 1)[1]
    assert "| RMSE x1 | 0.5 | 0.9 | +0.4 |" in section and "other samples" not in section
    write_junit(tmp_path / "junit.xml", "hybridlog batch: m", batch, METRICS)
    suite = ET.parse(tmp_path / "junit.xml").getroot()[0]
    said = {c.get("classname"): c.findtext("system-out") for c in suite.findall("testcase")}
    assert (
        "state_rmse.x1 = 0.08 over 13 samples (the filter's own: 0.09 over 101 samples; not "
        "compared)"
    ) in said["far.csv"]
    assert "state_rmse.x1 = 0.9 (the filter's own: 0.5)" in said["near.csv"]


def test_the_median_of_two_huge_rmses_is_a_number() -> None:
    # statistics.median added the two middle values first: 1e308 and 1.5e308 gave inf
    huge = [row("a.csv", (0.5, 1e308), (0.6, 1.5e308)), row("b.csv", (0.5, 1.5e308), (0.6, 1e308))]
    _, rmse = offline_gains(huge, METRICS)
    assert (rmse.filtered, rmse.offline, rmse.change) == (1.25e308, 1.25e308, 0.0)
    # the same as statistics.median where its sum holds
    _, rmse = offline_gains(rows(), METRICS)
    assert (rmse.filtered, rmse.offline) == ((1.0 + 0.5) / 2, (0.8 + 0.9) / 2)
