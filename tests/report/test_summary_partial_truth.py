"""A log's mode accuracy over part of it, and notes every report shares, in the summaries.

A true mode that starts late is scored from its first sample on (``modes.samples``); report.md
said so, but summary.csv, summary.md, JUnit and a missed gate gave the log's 1.0 beside the
others' with nothing saying it was over its last two thirds.  The twin-modes note of a model
(every report of it has it) reached no batch summary, and comparison.md repeated it under
each estimator.
"""

from __future__ import annotations

import csv
import xml.etree.ElementTree as ET
from dataclasses import replace
from pathlib import Path

from hybridlog.report.document import Report, read_report
from hybridlog.report.gates import evaluate_gates, parse_gates
from hybridlog.report.junit import write_junit
from hybridlog.report.summary import batch_markdown, batch_rows_csv, comparison_markdown
from hybridlog.report.summary_notes import MAX_NAMED
from hybridlog.report.summary_rows import BatchRow
from tests.report.test_summary_plot import REPORT

TWINS = "NOTE: modes 'a' and 'b' have the same equations and noise"
STARTS = "the true mode starts at t = 1700000010.01 s"


def late(report: Report, scored: int = 20) -> Report:
    """``report`` (30 samples) with a true mode that starts at its 11th, in Unix time."""
    reading = {"truth_starts": {"mode": {"at": 1700000010.01, "samples": scored, "of": 30}}}
    return replace(report, modes=replace(report.modes, samples=scored), reading=reading)


def test_a_late_true_mode_is_said_in_every_summary_and_gate(tmp_path: Path) -> None:
    whole = replace(read_report(REPORT), notes=())  # only the late mode in its JUnit output
    rows = [
        BatchRow("whole.csv", "whole.csv", "done", whole, None, ()),
        BatchRow("late.csv", "late.csv", "done", late(whole), None, ()),
    ]
    batch_rows_csv(tmp_path / "summary.csv", rows)
    with (tmp_path / "summary.csv").open() as file:
        table = list(csv.DictReader(file))
    assert [(r["samples"], r["mode_samples"]) for r in table] == [("30", "30"), ("30", "20")]
    _, text = batch_markdown("m · imm", rows, [])
    assert "## Mode accuracy over part of the log (1 of 2)" in text
    assert f"- late.csv: over 20 of 30 samples ({STARTS})" in text
    assert "whole.csv: over" not in text
    write_junit(tmp_path / "junit.xml", "m", rows)
    outputs = [e.text for e in ET.parse(tmp_path / "junit.xml").iter("system-out")]
    assert outputs == [f"mode_accuracy is over 20 of 30 samples ({STARTS})"]
    (gate,) = parse_gates([], ["mode_accuracy=0.5"])
    assert evaluate_gates(late(whole), [gate]) == [
        f"mode_accuracy = 1 over 20 of 30 samples ({STARTS}) is over the bound 0.5"
    ]
    assert evaluate_gates(whole, [gate]) == ["mode_accuracy = 1 is over the bound 0.5"]


def test_a_components_gate_says_over_which_samples_its_component_is() -> None:
    report = read_report(REPORT)
    own = replace(report.modes, components={}, samples=20)
    reading = {"truth_starts": {"mode.fr2": {"at": 10.0, "samples": 20, "of": 30}}}
    report = replace(
        report,
        modes=replace(report.modes, samples=20, components={"fr1": report.modes, "fr2": own}),
        reading=reading,
    )
    gates = parse_gates([], ["mode_accuracy.fr1=0.5", "mode_accuracy.fr2=0.5"])
    assert evaluate_gates(report, gates) == [
        "mode_accuracy.fr1 = 1 is over the bound 0.5",
        "mode_accuracy.fr2 = 1 over 20 of 30 samples (the true mode.fr2 starts at t = 10 s) "
        "is over the bound 0.5",
    ]


def test_summary_md_names_at_most_max_named_partial_logs() -> None:
    report = late(read_report(REPORT))
    rows = [BatchRow(f"l{k}.csv", f"l{k}.csv", "done", report, None, ()) for k in range(25)]
    _, text = batch_markdown("m", rows, [])
    assert text.count(": over 20 of 30 samples") == MAX_NAMED
    assert "- and 5 more (summary.csv's `mode_samples`)" in text


def _with_notes(*notes: str) -> Report:
    return replace(read_report(REPORT), notes=notes)


def test_a_note_every_report_has_is_written_once() -> None:
    rows = [
        BatchRow(f"s{k}.csv", f"s{k}.csv", "done", _with_notes(TWINS, f"own {k}"), None, ())
        for k in range(100)
    ]
    rows.append(BatchRow("bad.csv", "bad.csv", "failed", None, "bad.csv: broken", ()))
    _, text = batch_markdown("m", rows, [])
    assert text.count(TWINS) == 1 and "## Notes on every analysed log" in text
    assert "own 1" not in text  # a log's own notes stay in its report.md
    reports = {"imm": _with_notes(TWINS, "imm's"), "hstf": _with_notes("hstf's", TWINS)}
    text = comparison_markdown("m on log", "| table |", reports)
    assert text.count(TWINS) == 1 and "## Notes on every estimator" in text
    assert "## Notes on `imm`\n\n- imm's" in text and "## Notes on `hstf`\n\n- hstf's" in text
    alone = comparison_markdown("m on log", "| table |", {"imm": reports["imm"]})
    assert "## Notes on every estimator" not in alone
    assert f"## Notes on `imm`\n\n- {TWINS}\n- imm's" in alone


def test_summary_png_draws_a_mode_accuracy_over_part_of_its_log_as_a_triangle() -> None:
    from matplotlib.markers import MarkerStyle

    from hybridlog.report.summary_plot import summary_figure

    whole = read_report(REPORT)
    rows = [
        BatchRow("whole.csv", "whole.csv", "done", whole, None, ()),
        BatchRow("late.csv", "late.csv", "done", late(whole), None, ()),
    ]
    fig = summary_figure("m · imm", rows)
    vaf_axes, accuracy_axes, _ = fig.axes
    triangle = MarkerStyle("^").get_path().vertices  # scatter draws it at half this size

    def drawn(ax, shape) -> list[float]:
        return [
            float(x)
            for c in ax.collections
            if c.get_paths()[0].vertices.shape == shape.shape
            and (2 * c.get_paths()[0].vertices == shape).all()
            for x, _ in c.get_offsets()
        ]

    assert drawn(accuracy_axes, triangle) == [1.0]  # the late log alone
    assert drawn(vaf_axes, triangle) == []  # its VAF is over the whole log
    assert "▲ over part of the log" in accuracy_axes.get_ylabel()
    assert "over part" not in summary_figure("m · imm", rows[:1]).axes[1].get_ylabel()
