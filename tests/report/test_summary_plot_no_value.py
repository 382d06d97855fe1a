"""summary.png marks an analysed log without a value: no mode accuracy (none true, or given).

The mode-accuracy panel drew nothing for a log without a true mode, even when it missed a
``mode_accuracy`` gate (red in the other panels, absent in the one the gate was on).
"""

from __future__ import annotations

from dataclasses import replace

from matplotlib.colors import to_hex

from hybridlog.report.document import read_report
from hybridlog.report.summary_plot import summary_figure
from hybridlog.report.summary_rows import BatchRow
from tests.report.test_summary_plot import REPORT


def _marks(ax, colour: str) -> list[float]:
    """x of the hollow marks of ``ax`` edged in ``colour``."""
    return [
        float(x)
        for c in ax.collections
        if len(c.get_facecolor()) == 0 and to_hex(c.get_edgecolor()[0]) == colour
        for x, _ in c.get_offsets()
    ]


def test_a_log_without_a_true_mode_is_marked_in_the_mode_accuracy_panel() -> None:
    whole = read_report(REPORT)
    no_truth = replace(whole, modes=replace(whole.modes, accuracy=None))
    gate = "--fail-under mode_accuracy=0.9"
    lower = replace(whole, modes=replace(whole.modes, accuracy=0.5))
    rows = [
        BatchRow("a.csv", "a.csv", "done", whole, None, ((gate, None),)),
        BatchRow("n.csv", "n.csv", "done", no_truth, None, ((gate, "not available"),)),
        BatchRow("m.csv", "m.csv", "done", no_truth, None, ()),
        BatchRow("low.csv", "low.csv", "done", lower, None, ((gate, "0.5 is under 0.9"),)),
    ]
    fig = summary_figure("m · imm", rows)
    vaf, accuracy, _ = fig.axes
    assert _marks(accuracy, "#d62728") == [1.0] and _marks(accuracy, "#1f77b4") == [2.0]
    assert accuracy.get_ylabel() == "mode accuracy (%)\n□ no mode accuracy"
    assert not _marks(vaf, "#d62728") and vaf.get_ylabel() == "VAF (%)"
    # the marks sit below every value, not at the lowest one's height
    low = accuracy.transData.transform((0, 50.0))[1]
    assert accuracy.transAxes.inverted().transform((0, low))[1] > 0.06
    fig.canvas.draw()  # the glyph is in the font (a missing one warns: an error here)


def test_a_panel_without_any_value_has_no_scale_and_says_so() -> None:
    """Every log failed, or none with a true mode (logs from the field): the panel kept
    matplotlib's ticks -0.05 to 0.05 under "mode accuracy (%)", a scale of nothing beside
    the marks at its bottom, which read as a mode accuracy near 0 %."""
    whole = read_report(REPORT)
    no_truth = replace(whole, modes=replace(whole.modes, accuracy=None))
    fields = [
        BatchRow("a.csv", "a.csv", "done", no_truth, None, ()),
        BatchRow("b.csv", "b.csv", "failed", None, "b.csv: broken", ()),
    ]
    vaf, accuracy, mse = summary_figure("m · imm", fields).axes
    assert len(vaf.get_yticks()) > 0 and len(mse.get_yticks()) > 0 and not vaf.texts
    assert len(accuracy.get_yticks()) == 0
    assert [t.get_text() for t in accuracy.texts] == ["no log has a value"]
    failed = [BatchRow("b.csv", "b.csv", "failed", None, "b.csv: broken", ())] * 2
    for ax in summary_figure("m · imm", failed).axes:
        assert len(ax.get_yticks()) == 0
        assert [t.get_text() for t in ax.texts] == ["no log analysed"]
