"""User text in report.md and summary.md reads as itself, checked by a CommonMark parser."""

from __future__ import annotations

from itertools import pairwise

from hypothesis import given, settings
from hypothesis import strategies as st
from markdown_it import MarkdownIt

from hybridlog.report.markdown import code_span, escape_markdown
from hybridlog.report.summary_tables import markdown_table

# CommonMark with GitHub's tables and strikethrough: how a CI job summary reads the files.
PARSER = MarkdownIt("commonmark").enable(["table", "strikethrough"])
HOSTILE = ["<b>*x*</b> | y.csv", "_draft_.csv", "[a](b).csv", "`c`", "~~s~~", "&amp;", "a\\|b"]


def _cells(markdown: str) -> list[str]:
    """The text of each body cell; a cell holding anything but plain text fails the test."""
    tokens = PARSER.parse(markdown)
    cells = []
    for before, token in pairwise(tokens):
        if before.type == "td_open" and token.type == "inline":
            kinds = {child.type for child in token.children or []}
            assert kinds <= {"text"}, (markdown, kinds)
            cells.append("".join(child.content for child in token.children or []))
    return cells


text = st.text(
    st.characters(codec="ascii", categories=["L", "N", "P", "S", "Zs"]), min_size=1, max_size=40
).filter(lambda s: s.strip() == s)


@given(st.lists(text, min_size=1, max_size=3))
@settings(max_examples=300, deadline=None)
def test_a_table_cell_shows_the_text_it_was_given(values: list[str]) -> None:
    header = [f"c{i}" for i in range(len(values))]
    assert _cells(markdown_table(header, [values])) == values


def test_names_that_look_like_markup_stay_plain_and_a_line_break_stays_in_its_cell() -> None:
    table = markdown_table(["log"], [[name] for name in [*HOSTILE, "two\nlines.csv"]])
    assert _cells(table) == [*HOSTILE, "two\\nlines.csv"]
    assert escape_markdown("three_tank_hstf.csv") == "three_tank_hstf.csv"  # no needless marks


def test_a_cell_that_would_open_a_block_at_a_line_start_is_written_as_it_is() -> None:
    """``hybridlog cluster`` printed its centres as ``\\-1.208, …`` on the terminal: a table
    cell cannot start a list or a heading, so only a line's start needs the backslash."""
    cells = ["-1.208, 0.5", "# 0", "1. run.csv", "+x"]
    table = markdown_table(["a", "b", "c", "d"], [cells])
    assert table.splitlines()[-1] == "| -1.208, 0.5 | # 0 | 1. run.csv | +x |"
    assert _cells(table) == cells
    assert escape_markdown("-1.208") == "\\-1.208"  # where it starts a list item


@given(text)
@settings(max_examples=200, deadline=None)
def test_a_code_span_shows_the_text_it_was_given(value: str) -> None:
    (paragraph,) = [t for t in PARSER.parse(f"- model: {code_span(value)}") if t.type == "inline"]
    kinds = [child.type for child in paragraph.children or []]
    assert kinds == ["text", "code_inline"]
    assert (paragraph.children or [])[1].content == value


def test_control_characters_are_written_out_not_sent_to_the_terminal() -> None:
    """batch prints summary.md's table: a log named with ESC[31m coloured the terminal."""
    name = "ctl\x01\x1b[31mred\x7f.csv"
    (cell,) = _cells(markdown_table(["log"], [[name]]))
    assert cell == "ctl\\x01\\x1b[31mred\\x7f.csv"
    assert code_span("a\x1bb") == "`a\\x1bb`"
    assert escape_markdown("tab\there") == "tab\there"  # a tab is no command


def _header_cells(markdown: str) -> list[str]:
    """The text of each header cell; a cell holding anything but plain text fails the test."""
    tokens = PARSER.parse(markdown)
    cells = []
    for before, token in pairwise(tokens):
        if before.type == "th_open" and token.type == "inline":
            kinds = {child.type for child in token.children or []}
            assert kinds <= {"text"}, (markdown, kinds)
            cells.append("".join(child.content for child in token.children or []))
    return cells


def test_a_header_cell_named_after_a_symbol_shows_its_name() -> None:
    """comparison.md's column of a state ``_x_`` read ``state_rmse.`` and an emphasised x, a
    column ``state_rmse.__a__`` a bold a; summary.md's gated column likewise."""
    header = ["estimator", "state_rmse._x_", "state_rmse.__a__", "mode_accuracy.*c*"]
    table = markdown_table(header, [["imm", 0.5, 0.25, 1.0]])
    assert _header_cells(table) == header
    assert table.splitlines()[0].startswith("| estimator | state_rmse.\\_x\\_ |")
    plain = markdown_table(["P*/P1*"], [[1.0]], escape_header=False)  # cluster's terminal
    assert plain.splitlines()[0] == "| P*/P1* |"
