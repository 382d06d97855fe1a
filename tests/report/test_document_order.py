"""What a reader must see first comes first: warnings, failed logs and missed gates.

report.md listed a report's warnings (a scaled sensor, a true mode with a gap) under "Notes"
at its end, after the runtime, below the tables whose numbers they put in doubt; summary.md
put why a log failed and which gates it missed after the logs scored over part of their
length, the offline pass's comparison and the notes every log has; comparison.md put its
warnings after "What the numbers are over" and did not name the gates its ``gates`` column
counts (``pass (2)``).
"""

from __future__ import annotations

import re

from hybridlog.report.markdown import render_markdown
from hybridlog.report.summary import batch_markdown, comparison_markdown
from tests.report.test_summary_warnings import GAP, SCALED, TWINS, noted, row


def _headings(markdown: str) -> list[str]:
    return re.findall(r"^#+ (.*?)(?: \(.*\))?$", markdown, flags=re.MULTILINE)


def test_report_md_lists_its_warnings_before_the_tables() -> None:
    text = render_markdown(noted(TWINS, SCALED, GAP))
    headings = _headings(text)
    assert headings.index("Warnings") < headings.index("Outputs")
    warnings = text.split("## Warnings\n\n")[1].split("\n\n")[0]
    assert warnings.splitlines() == [f"- {SCALED}", f"- {GAP}"]
    notes = text.split("## Notes\n\n")[1].split("\n\n")[0]
    assert notes.splitlines() == [f"- {TWINS}"]
    assert "## Warnings" not in render_markdown(noted(TWINS))


def test_summary_md_says_why_logs_failed_and_missed_gates_right_after_its_table() -> None:
    missed = (("--fail-under fit=50", "fit = 12 is under the bound 50"),)
    rows = [
        row("clean.csv", noted(TWINS), (("--fail-under fit=50", None),)),
        row("broken.csv", None),
        row("low.csv", noted(TWINS, SCALED), missed),
    ]
    _, text = batch_markdown("m · imm", rows, ["--fail-under fit=50"], ["mode_accuracy"])
    headings = _headings(text)
    assert headings[1:4] == ["Failed logs", "Missed gates", "Warnings"]
    assert headings.index("Warnings") < headings.index("Offline estimates against the filter's own")
    assert headings.index("Warnings") < headings.index("Notes on every analysed log")


def test_comparison_md_names_its_gates_and_lists_warnings_before_the_samples_section() -> None:
    sections = ["", "## What the numbers are over", "", "- vaf: every estimator over 300"]
    text = comparison_markdown(
        "m on log.csv",
        "|table|",
        {"imm": noted(SCALED), "hstf": noted()},
        {"chiu": "diverged"},
        sections=sections,
        gates=["--fail-under fit=50", "--fail-over mse=10"],
    )
    assert text.split("|table|\n\n")[1].startswith(
        "Gates: `--fail-under fit=50`, `--fail-over mse=10`.\n"
    )
    headings = _headings(text)
    assert headings[1:4] == ["Failed estimators", "Warnings", "What the numbers are over"]
    assert "Gates:" not in comparison_markdown("m on log.csv", "|table|", {"imm": noted()})
