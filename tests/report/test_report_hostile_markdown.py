"""Notes in report.md and comparison.md read as themselves, whatever names they quote."""

from __future__ import annotations

import dataclasses
from itertools import pairwise

import pytest
from hypothesis import given, settings

from hybridlog.report import build_report, render_markdown
from hybridlog.report.summary import comparison_markdown

from .test_markdown_text import HOSTILE, PARSER, text
from .test_report_files import DT, make_run

#: Notes as estimators and the reading write them, quoting mode ids and fields of a log.
NOTES = [
    *HOSTILE,
    "cluster 1 (91 samples) -> mode '$x_1$'; SSE with it in mode 'a_b^c|<i>`\\frac`' 354",
    "φ(k) = [y_1(k), y_1(k-1), u(k-1)]; *2* of 5 dimensions constant",
    "WARNING: kappa_1 > 1e+12 on <script>alert(1)</script>",
    "a note\nwith a line break",
]


def _notes_shown(markdown: str, *headings: str) -> list[str]:
    """The text of each list item under a ``## Notes`` heading (or one of ``headings``: a
    report.md's warnings are under ``## Warnings``); markup in one fails the test."""
    tokens = PARSER.parse(markdown)
    shown: list[str] = []
    in_notes = False
    for before, token in pairwise(tokens):
        if before.type == "heading_open":
            in_notes = token.content.startswith(headings or ("Notes",))
        elif in_notes and before.type == "paragraph_open" and token.type == "inline":
            kinds = {child.type for child in token.children or []}
            assert kinds <= {"text"}, (token.content, kinds)
            shown.append("".join(child.content for child in token.children or []))
    return shown


def _report(notes: tuple[str, ...]):  # type: ignore[no-untyped-def]
    result, signals = make_run(40)
    return build_report(
        dataclasses.replace(result, notes=notes), signals, log="run.csv", model_name="m", dt=DT
    )


def _shown(note: str) -> str:
    return note.replace("\n", "\\n")


@pytest.mark.parametrize("note", NOTES)
def test_a_note_in_report_md_and_comparison_md_shows_the_text_it_was_given(note: str) -> None:
    report = _report((note, "plain"))
    assert _notes_shown(render_markdown(report), "Notes", "Warnings") == [_shown(note), "plain"]
    both = comparison_markdown("m on run.csv", "", {"imm": report, "hstf": report})
    assert _notes_shown(both) == [_shown(note), "plain"]  # the notes both have, once


@given(text)
@settings(max_examples=100, deadline=None)
def test_any_note_shows_the_text_it_was_given(note: str) -> None:
    assert _notes_shown(render_markdown(_report((note,)))) == [note]


#: Text that opens a block where it starts a line: a heading, a list, a rule.
BLOCK_STARTS = ["# 0", "###### h", "- a", "+ b", "1. x", "12) y", "---", "= x", "-", "2."]


@pytest.mark.parametrize("start", BLOCK_STARTS)
def test_text_that_starts_a_list_item_stays_its_text(start: str) -> None:
    """A note ``# 0`` was a heading inside report.md's Notes, a log ``1. run.csv`` an
    ordered list inside summary.md's failed logs."""
    from hybridlog.report.summary import batch_markdown
    from hybridlog.report.summary_rows import BatchRow

    assert _notes_shown(render_markdown(_report((start,)))) == [start]
    failed = BatchRow(log=start, folder="f", status="failed", report=None, error=start)
    _, summary = batch_markdown("m · imm", [failed], [])
    tokens = PARSER.parse(summary)
    heading = next(i for i, t in enumerate(tokens) if t.content.startswith("Failed logs"))
    (item,) = [t for t in tokens[heading:] if t.type == "inline"][1:]
    assert {child.type for child in item.children or []} <= {"text"}
    assert "".join(child.content for child in item.children or []) == f"{start}: {start}"
