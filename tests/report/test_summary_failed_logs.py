"""summary.md's failed logs name each log once.

A log's error names the log, as ``analyze``'s does on the terminal, and the list put the log's
name before it again: ``- alog/bad.csv: alog/bad.csv, line 3, column 'y1': 'x' is not a
number``.
"""

from __future__ import annotations

import pytest

from hybridlog.report.summary import batch_markdown
from hybridlog.report.summary_rows import BatchRow


@pytest.mark.parametrize(
    ("error", "item"),
    [
        (
            "alog/bad.csv, line 3, column 'y1': 'x' is not a number",
            "- alog/bad.csv, line 3, column 'y1': 'x' is not a number",
        ),
        ("alog/bad.csv: no data rows", "- alog/bad.csv: no data rows"),
        # an error that does not start with the log's name, or with a longer name
        ("KeyError: 'reader bug'", "- alog/bad.csv: KeyError: 'reader bug'"),
        ("alog/bad.csv.bak: missing", "- alog/bad.csv: alog/bad.csv.bak: missing"),
    ],
)
def test_a_failed_log_is_named_once(error: str, item: str) -> None:
    failed = BatchRow(log="alog/bad.csv", folder="f", status="failed", report=None, error=error)
    _, summary = batch_markdown("m · imm", [failed], [])
    section = summary.split("## Failed logs (1 of 1)\n\n", 1)[1]
    assert section.splitlines()[0] == item
