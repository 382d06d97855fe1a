"""summary.md stays within what a CI job summary shows, however many logs a batch has.

GitHub refuses a step's job summary over 1 MiB whole, and README's CI recipe appends
summary.md to it: a batch of 15,000 logs wrote a summary.md of 1.6 MB (every log a row of
its table), one of 6,000 logs that all missed a gate 1.6 MB (each a row and a line of
"Missed gates").  Past ``SUMMARY_BYTES`` the lists are cut from their ends, each cut
counted and pointed to summary.csv, which lists every log.
"""

from __future__ import annotations

from dataclasses import replace

import pytest
from hypothesis import given
from hypothesis import strategies as st

from hybridlog.report.document import read_report
from hybridlog.report.summary import batch_markdown
from hybridlog.report.summary_budget import SUMMARY_BYTES, Listing, within_budget
from hybridlog.report.summary_plot import summary_figure
from hybridlog.report.summary_rows import BatchRow
from tests.report.test_summary_plot import REPORT

GATE = "--fail-under mode_accuracy=0.99"
MISSED = (
    "mode_accuracy = 0.973 is under the bound 0.99 (over 301 samples; the logs of this "
    "plant were recorded with another sensor, the offsets of which are not modelled)"
)


def _rows(passed: int, missed: int, failed: int) -> list[BatchRow]:
    report = read_report(REPORT)
    rows = [
        BatchRow(
            f"runs/day{k // 100}/run{k}.csv",
            f"day{k // 100}_run{k}.csv",
            "done",
            report,
            None,
            ((GATE, None),),
        )
        for k in range(passed)
    ]
    rows += [
        BatchRow(
            f"runs/late/run{k}.csv", f"late_run{k}.csv", "done", report, None, ((GATE, MISSED),)
        )
        for k in range(missed)
    ]
    rows += [
        BatchRow(
            f"runs/bad/run{k}.csv",
            f"bad_run{k}.csv",
            "failed",
            None,
            f"runs/bad/run{k}.csv, line {k + 2}, column 'y1': 'x' is not a number",
            (),
        )
        for k in range(failed)
    ]
    return rows


@pytest.mark.parametrize(
    ("passed", "missed", "failed", "cut"),
    [
        (15_000, 0, 0, ("table",)),
        (0, 6_000, 0, ("table", "misses")),
        (0, 0, 16_000, ("table", "failures")),
        (2_000, 1_000, 5_000, ("table",)),
    ],
)
def test_a_large_batch_summary_fits_a_job_summary(passed, missed, failed, cut) -> None:
    rows = _rows(passed, missed, failed)
    table, text = batch_markdown("m · imm", rows, [GATE])
    assert len(text.encode()) <= SUMMARY_BYTES
    assert table.count("\n") == len(rows) + 1  # the terminal's table: every log
    said = {
        "table": "The table leaves out its last ",
        "misses": "more (summary.csv's `gate_failures` column)",
        "failures": "more (summary.csv's `error` column)",
    }
    assert {name for name, line in said.items() if line in text} == set(cut)
    # what was cut is counted: the rows kept and the rows left out make every log
    kept = sum(line.startswith("| runs/") for line in text.splitlines())
    left = int(text.split("The table leaves out its last ", 1)[1].split(" log")[0].replace(",", ""))
    assert kept + left == len(rows)
    # the table keeps the failed logs first, then those that missed a gate
    shown = [line for line in text.splitlines() if line.startswith("| runs/")]
    if shown:
        assert shown[0].startswith(
            "| runs/bad/" if failed else "| runs/late/" if missed else "| runs/"
        )
    # the sections after the lists are all there
    assert text.rstrip().splitlines()[-1] != ""


def test_a_summary_within_the_budget_is_left_as_it_is() -> None:
    rows = _rows(40, 5, 3)
    _, text = batch_markdown("m · imm", rows, [GATE])
    assert "leaves out" not in text and "more (summary.csv" not in text
    assert text.count("| runs/") == len(rows)


@given(
    st.lists(st.text(alphabet="ab é|", max_size=30), max_size=40),
    st.lists(st.text(alphabet="ab é|", max_size=30), max_size=40),
    st.integers(min_value=0, max_value=2_000),
)
def test_within_budget_keeps_the_first_items_and_counts_the_rest(first, second, budget) -> None:
    a = Listing(first, lambda n: f"- and {n} more")
    b = Listing(second, lambda n: f"- and {n} others")
    lines = within_budget(["# title", a, "## next", b, "end"], [a, b], budget)
    size = len("\n".join(lines).encode()) + 1
    whole = ["# title", *first, "## next", *second, "end"]
    if len("\n".join(whole).encode()) + 1 <= budget:
        assert lines == whole
        return
    # each listing keeps a prefix of its items, and counts the others
    title, rest = lines[0], lines[1:]
    assert title == "# title" and lines[-1] == "end"
    split = rest.index("## next")
    for kept, items, word in (
        (rest[:split], first, "more"),
        (rest[split + 1 : -1], second, "others"),
    ):
        if kept and kept[-1] == f"- and {len(items) - len(kept) + 1} {word}":
            assert kept[:-1] == items[: len(kept) - 1]
        else:
            assert kept == items
    # the second is cut only once the first is empty, and the budget is kept while it can be
    if rest[split + 1 : -1] != second:
        assert rest[:split] == [f"- and {len(first)} more"] or not first
    floor = [
        "# title",
        *([f"- and {len(first)} more"] if first else []),
        "## next",
        *([f"- and {len(second)} others"] if second else []),
        "end",
    ]
    assert size <= max(budget, len("\n".join(floor).encode()) + 1)


def test_no_batch_row_is_lost_from_the_table_that_the_terminal_prints() -> None:
    rows = [replace(row, log=f"é{row.log}") for row in _rows(12_000, 0, 0)]
    table, text = batch_markdown("m · imm", rows, [])
    assert len(text.encode()) <= SUMMARY_BYTES < len(table.encode())


def test_a_large_batch_counts_its_logs_alike_in_the_headline_and_sections() -> None:
    # "**2,000 logs: all analysed** (2000 analysed)": the total grouped its digits, the counts
    # beside it did not, nor the sections' headings, nor summary.png's title
    rows = _rows(1_500, 1_200, 1_100)
    _, text = batch_markdown("m · imm", rows, [GATE])
    assert "**3,800 logs: 2,300 not passed** (2,700 analysed, 1,100 failed, 1,200 missed" in text
    assert "## Failed logs (1,100 of 3,800)" in text
    assert "## Missed gates (1,200 of 3,800)" in text
    title = summary_figure("m · imm", rows).get_suptitle().split("\n")[1]
    assert title == "3,800 logs, 1,100 not analysed (crosses), 1,200 missed a gate (red)"
