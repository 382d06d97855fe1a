"""summary.png of a batch: every analysed log drawn, failures marked (issue 9)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
from matplotlib.colors import to_hex

from hybridlog.report.document import read_report
from hybridlog.report.report_parts import Smoothing
from hybridlog.report.summary_plot import summary_figure, write_summary_plot
from hybridlog.report.summary_rows import BatchRow
from tests.report.test_report_gates import _side

REPORT = Path(__file__).parents[1] / "data" / "reports" / "synthetic_extra.report.json"


def rows() -> list[BatchRow]:
    report = read_report(REPORT)
    other = replace(report, vaf=42.0)
    return [
        BatchRow("a.csv", "a.csv", "done", report, None, (("--fail-under vaf=10", None),)),
        BatchRow("b.csv", "b.csv", "done", other, None, (("--fail-under vaf=10", "vaf low"),)),
        BatchRow("c.csv", "c.csv", "failed", None, "c.csv: broken", ()),
    ]


def points(ax, colour: str) -> list[tuple[float, float]]:
    """Data points of ``ax`` drawn in ``colour`` (crosses in axes coordinates for y)."""
    found = []
    for collection in ax.collections:
        colours = collection.get_facecolor()
        if len(colours) == 0:
            colours = collection.get_edgecolor()
        if to_hex(colours[0]) == colour:
            found += [(float(x), float(y)) for x, y in np.asarray(collection.get_offsets())]
    return found


def test_each_log_is_drawn_and_failures_are_red():
    batch = rows()
    fig = summary_figure("model · imm", batch)
    vaf_axes, accuracy_axes, _ = fig.axes
    blue, red = points(vaf_axes, "#1f77b4"), points(vaf_axes, "#d62728")
    assert blue == [(0.0, batch[0].report.vaf)]
    # the log that missed its gate at its value, the unanalysed one as a cross at x = 2
    assert (1.0, 42.0) in red
    assert [x for x, _ in red if x == 2.0] == [2.0]
    labels = [t.get_text() for t in fig.axes[-1].get_xticklabels()]
    assert labels == ["a.csv", "b.csv", "c.csv"]
    assert "1 not analysed" in fig.get_suptitle() and "1 missed a gate" in fig.get_suptitle()
    assert accuracy_axes.get_ylim()[1] <= 101.0


def test_the_png_is_written(tmp_path):
    target = tmp_path / "summary.png"
    write_summary_plot(target, "model · imm", rows())
    assert target.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_figure_made_ahead_draws_the_same_png_and_is_taken_once(tmp_path):
    """``prepare_summary_figure`` (made while a batch's workers run): the same bytes as a
    figure made on the spot, used only for as many logs as it was made for, taken once."""
    from hybridlog.report import summary_plot

    fresh, ahead, other = tmp_path / "fresh.png", tmp_path / "ahead.png", tmp_path / "o.png"
    write_summary_plot(fresh, "model · imm", rows())
    summary_plot.prepare_summary_figure(len(rows()) + 1)  # for another number of logs
    write_summary_plot(other, "model · imm", rows())
    assert summary_plot._READY  # not taken: made for four logs, not three
    summary_plot.prepare_summary_figure(len(rows()))
    made = summary_plot._READY[len(rows())][0]
    assert list(summary_plot._READY) == [len(rows())]  # one kept, the latest
    assert summary_figure("model · imm", rows()) is made and not summary_plot._READY
    summary_plot.prepare_summary_figure(len(rows()))
    write_summary_plot(ahead, "model · imm", rows())
    assert not summary_plot._READY
    assert ahead.read_bytes() == fresh.read_bytes() == other.read_bytes()


def test_the_mode_accuracy_of_a_smoothed_batch_is_labelled_offline():
    """batch --smooth drew the smoothed mode accuracy under the label of the filter's."""
    batch = rows()
    fig = summary_figure("model · imm", batch)
    assert fig.axes[1].get_ylabel() == "mode accuracy (%)"
    smoothing = Smoothing("kim-rts", "argmax", "d", _side(0.5, 0, 1.0), _side(0.6, 0, 1.0))
    batch[0] = replace(batch[0], report=replace(batch[0].report, smoothing=smoothing))
    fig = summary_figure("model · imm · kim-rts, argmax", batch)
    assert fig.axes[1].get_ylabel() == "mode accuracy (%)\n● offline ○ filter"
    assert fig.axes[0].get_ylabel() == "VAF (%)"


def test_a_batch_of_one_log_is_counted_in_the_singular():
    """summary.md and summary.png said '1 logs'."""
    from hybridlog.report.summary import batch_markdown

    one = rows()[:1]
    assert summary_figure("m · imm", one).get_suptitle().split("\n")[1].startswith("1 log, ")
    assert "**1 log: all passed** (1 analysed)." in batch_markdown("m", one, [])[1]
    assert "**3 logs: 2 not passed**" in batch_markdown("m", rows(), [])[1]


def test_a_batch_without_gates_is_not_said_to_have_passed_them():
    """summary.md said "**1 log: all passed**" of a batch given no gate, where summary.png
    said "no gate given": read in a CI job summary, gates checked and met."""
    from hybridlog.report.summary import batch_markdown

    ungated = [replace(row, gates=()) for row in rows()]
    text = batch_markdown("m", ungated[:2], [])[1]
    assert "**2 logs: all analysed** (2 analysed).\n\nNo gate given." in text
    assert "passed" not in text
    assert (
        "**3 logs: 1 not analysed** (2 analysed, 1 failed)." in batch_markdown("m", ungated, [])[1]
    )
    assert "No gate given" not in batch_markdown("m", ungated[2:], [])[1]  # none analysed


def test_close_values_are_ticked_as_themselves_not_as_an_offset():
    """VAFs 99.9929 and 99.9936 were ticked 0.0000 to 0.0006 under "+9.9993e1"."""
    report = read_report(REPORT)
    batch = [
        BatchRow(f"{k}.csv", f"{k}.csv", "done", replace(report, vaf=vaf), None, ())
        for k, vaf in enumerate((99.99292, 99.99360))
    ]
    fig = summary_figure("model · imm", batch)
    fig.canvas.draw()
    vaf_axes = fig.axes[0]
    assert vaf_axes.yaxis.get_offset_text().get_text() == ""
    ticks = [t.get_text() for t in vaf_axes.get_yticklabels() if t.get_text()]
    assert ticks and all(t.startswith("99.99") for t in ticks)


def test_logs_whose_folders_end_alike_are_told_apart():
    """``robot_a/.../recording.mcap`` and ``robot_b/.../recording.mcap`` (24 characters
    alike at their ends) were two ticks of one label."""
    report = read_report(REPORT)
    folders = [
        "robot_alpha/2024-05-01_morning/recording.mcap",
        "robot_bravo/2024-05-01_morning/recording.mcap",
        "short.csv",
        "a_folder_name_longer_than_the_label/x.csv",
    ]
    batch = [BatchRow(f, f, "done", report, None, ()) for f in folders]
    fig = summary_figure("model · imm", batch)
    labels = [t.get_text() for t in fig.axes[-1].get_xticklabels()]
    assert len(set(labels)) == len(labels) and all(len(label) <= 24 for label in labels)
    assert labels[0].startswith("#1 …") and labels[1].startswith("#2 …")
    assert labels[2:] == ["short.csv", "…er_than_the_label/x.csv"]


def test_logs_whose_names_differ_only_in_their_unicode_form_are_told_apart():
    """``café.csv`` with ``é`` one character (NFC) and two (NFD): unequal as text, so not
    numbered, two ticks that read as one label."""
    report = read_report(REPORT)
    folders = ["caf\u00e9.csv", "cafe\u0301.csv", "th\u00e9.csv"]
    batch = [BatchRow(f, f, "done", report, None, ()) for f in folders]
    labels = [t.get_text() for t in summary_figure("m · imm", batch).axes[-1].get_xticklabels()]
    assert labels == ["#1 caf\u00e9.csv", "#2 cafe\u0301.csv", "th\u00e9.csv"]


def test_more_logs_than_names_are_numbered_from_one_as_summary_csv_rows():
    """The axis of 60 logs counted from 0: its tick 50 was the 51st log of summary.csv."""
    report = read_report(REPORT)
    batch = [BatchRow(f"{k}.csv", f"{k}.csv", "done", report, None, ()) for k in range(60)]
    ticks = summary_figure("model · imm", batch).axes[-1].get_xticklabels()
    assert [(t.get_position()[0], t.get_text()) for t in ticks][:3] == [
        (0, "1"),
        (9, "10"),
        (19, "20"),
    ]
    assert ticks[-1].get_text() == "60" and ticks[-1].get_position()[0] == 59


def test_a_batch_without_gates_does_not_count_gates_missed():
    """The title said '0 missed a gate (red)' of a batch given no gate: gates met, to a reader."""
    ungated = [replace(row, gates=()) for row in rows()]
    assert summary_figure("m · imm", ungated).get_suptitle().split("\n")[1] == (
        "3 logs, 1 not analysed (crosses), no gate given"
    )
    met = [replace(row, gates=(("--fail-under vaf=10", None),)) for row in rows()[:2]]
    assert summary_figure("m · imm", met).get_suptitle().endswith(", 0 missed a gate (red)")
    # no log analysed: nothing tells whether a gate was given
    failed = rows()[2:]
    assert (
        summary_figure("m · imm", failed).get_suptitle().endswith("1 log, 1 not analysed (crosses)")
    )
