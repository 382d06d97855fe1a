"""A log's warnings (its report's ``WARNING:`` notes) in every summary of a batch and a compare.

``analyze`` prints the innovations' test of ``imm`` on the terminal and every warning in
report.md, but summary.csv, summary.md, JUnit and comparison.md/.csv said nothing of them:
in a batch of 1,000 logs the few with a scaled sensor were found only by opening each
report.md.
"""

from __future__ import annotations

import csv
import xml.etree.ElementTree as ET
from dataclasses import replace
from pathlib import Path

from hybridlog.report.document import Report, read_report
from hybridlog.report.junit import junit_tree
from hybridlog.report.summary import batch_markdown, batch_rows_csv, comparison_markdown
from hybridlog.report.summary_notes import MAX_NAMED, warning_notes
from hybridlog.report.summary_rows import BatchRow
from tests.report.test_summary_plot import REPORT

SCALED = (
    "WARNING: the innovations are larger than the model's noise explains: mean normalised "
    "innovation squared 4.45 over 291 settled samples, expected 3 (10.1 standard scores)"
)
GAP = "WARNING: the true mode has no sample over 12 s: it may have switched there unseen"
TWINS = "NOTE: modes 'a' and 'b' have the same equations and noise"


def noted(*notes: str) -> Report:
    return replace(read_report(REPORT), notes=notes)


def row(name: str, report: Report | None, gates: tuple[tuple[str, str | None], ...] = ()):
    status = "failed" if report is None else "done"
    return BatchRow(name, name, status, report, None if report else f"{name}: broken", gates)


def test_warnings_are_counted_listed_and_put_in_junit(tmp_path: Path) -> None:
    rows = [
        row("clean.csv", noted(TWINS)),
        row("scaled.csv", noted(TWINS, SCALED, GAP)),
        row("broken.csv", None),
        row("gap.csv", noted(GAP, TWINS)),
    ]
    assert warning_notes(rows[1].report) == [SCALED, GAP] and warning_notes(None) == []
    batch_rows_csv(tmp_path / "summary.csv", rows)
    with (tmp_path / "summary.csv").open() as file:
        table = list(csv.DictReader(file))
    assert [r["warnings"] for r in table] == ["0", "2", "", "1"]
    _, text = batch_markdown("m · imm", rows, [])
    section = text.split("## Warnings (2 of 3 analysed logs)\n\n")[1].split("\n\n")[0].splitlines()
    assert section == [
        f"- scaled.csv (2 warnings): {SCALED.removeprefix('WARNING: ')}",
        f"- gap.csv (1 warning): {GAP.removeprefix('WARNING: ')}",
    ]
    cases = list(junit_tree("m", rows).iter("testcase"))
    outputs = [None if (e := c.find("system-out")) is None else e.text for c in cases]
    assert outputs == [None, f"{SCALED}\n{GAP}", None, GAP]


def test_a_warning_every_log_has_is_said_once_and_at_most_20_logs_are_named() -> None:
    """As notes every report has (``common_notes``): once, not per log."""
    many = [row(f"w{k:02}.csv", noted(GAP, SCALED)) for k in range(MAX_NAMED + 3)]
    _, text = batch_markdown("m", [*many, row("g.csv", noted(GAP))], [])
    assert text.count(GAP.removeprefix("WARNING: ")) == 1  # under the notes on every log
    assert "## Warnings (24 of 24 analysed logs)" in text
    every = 'Every analysed log has the warning under "Notes on every analysed log"'
    assert f"{every}; those with others:" in text
    assert text.count(f": {SCALED.removeprefix('WARNING: ')}") == MAX_NAMED
    assert "- and 3 more (the `warnings` column)" in text
    _, alike = batch_markdown("m", [row("a.csv", noted(GAP)), row("b.csv", noted(GAP))], [])
    assert "## Warnings (2 of 2 analysed logs)" in alike and "; none has others." in alike
    assert "- a.csv" not in alike
    _, quiet = batch_markdown("m", [row("a.csv", noted(TWINS)), row("b.csv", None)], [])
    assert "## Warnings" not in quiet


def test_comparison_md_lists_the_estimators_with_warnings() -> None:
    text = comparison_markdown("m on log.csv", "|table|", {"imm": noted(SCALED), "hstf": noted()})
    assert "## Warnings (1 of 2 estimators)" in text
    assert f"- `imm` (1 warning): {SCALED.removeprefix('WARNING: ')}" in text
    assert "`hstf` (" not in text


def test_a_batch_without_warnings_writes_no_system_out() -> None:
    tree = junit_tree("m", [row("a.csv", noted(TWINS))])
    assert ET.tostring(tree.getroot()).count(b"system-out") == 0
