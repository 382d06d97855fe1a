"""A percentage that is not 100 never reads as 100, in report.md or on the terminal.

The ice clutch sample's VAF of 99.99568 % was ``VAF 100.00 %`` on the terminal, and report.md
wrote a VAF of 99.999994 % or a mode accuracy of 2,999,999 of 3,000,000 samples as
``100.0000``: a perfect score the run did not have.  They get the decimals that tell them
from 100; an exact 100 keeps its decimals, and so does every other value.
"""

from dataclasses import replace

import pytest

from hybridlog.cli_lines import summary_line
from hybridlog.report.markdown import format_percent, render_markdown
from hybridlog.report.report_parts import OutputReport
from tests.report.test_report_gates import report


@pytest.mark.parametrize(
    ("value", "decimals", "shown"),
    [
        (99.99568, 2, "99.996"),
        (99.999994, 4, "99.99999"),
        (100.0, 4, "100.0000"),
        (0.0, 2, "0.00"),
        (2e-14, 4, "0.0000"),
        (87.38665, 4, "87.3867"),
        (-29.78573, 2, "-29.79"),
        (None, 4, "n/a"),
    ],
)
def test_a_percentage_gets_the_decimals_that_keep_it_off_100(value, decimals, shown):
    assert format_percent(value, decimals) == shown


def test_report_md_and_the_summary_line_write_no_false_perfect_score():
    near = replace(
        report(),
        outputs={"y1": OutputReport(mse=1e-9, vaf=99.999994, fit=100.0, samples=4)},
        vaf=99.999994,
        fit=100.0,
    )
    near = replace(near, modes=replace(near.modes, accuracy=2_999_999 / 3_000_000))
    markdown = render_markdown(near)
    assert "| y1 | 1e-09 | 99.99999 | 100.0000 |" in markdown
    assert "- mode accuracy: 99.99997%" in markdown
    line = summary_line(near)
    assert "VAF 99.99999 %, fit 100.00 %" in line
    assert "mode accuracy 99.99997 %" in line


def test_summary_tables_write_no_false_perfect_score():
    # batch's and compare's tables rounded a VAF of 99.99568 to 100.00 and a mode accuracy
    # of 0.9999997 to 1.0000; a true 100 and 1 stay as they are
    from hybridlog.report.summary_tables import markdown_table

    table = markdown_table(
        ["log", "vaf", "mode_accuracy"], [["a", 99.99568, 0.9999997], ["b", 87.39, 0.99]]
    )
    assert "| a | 99.996 | 0.9999997 |" in table and "| b | 87.390 | 0.9900000 |" in table
    whole = markdown_table(["log", "vaf", "mode_accuracy"], [["a", 100.0, 1.0], ["b", 87.39, 0.99]])
    assert "| a | 100.00 | 1.0000 |" in whole
