"""Logs whose names differ only where a summary escapes a character keep reading apart."""

from __future__ import annotations

import csv
import os
import unicodedata
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from markdown_it import MarkdownIt

from hybridlog.io.writers import write_table
from hybridlog.jobs.batch import run_batch
from tests.support.logfiles import tank_run

# CommonMark with GitHub's tables: how a CI job summary shows summary.md
PARSER = MarkdownIt("commonmark").enable("table")


def _first_column(markdown: str) -> list[str]:
    """The text of the first cell of each body row of the Markdown's tables."""
    tokens = PARSER.parse(markdown)  # a row: tr_open, td_open, inline, td_close, ...
    return [
        "".join(child.content for child in tokens[k + 2].children or [])
        for k in range(len(tokens) - 2)
        if tokens[k].type == "tr_open" and tokens[k + 1].type == "td_open"
    ]


def test_a_name_with_a_control_character_or_byte_and_its_escaped_spelling_stay_two_logs(
    tmp_path: Path,
) -> None:
    r"""``ctl\x01.csv`` (a control character) and ``ctl\\x01.csv`` (a backslash) were one
    test case of junit.xml (the same classname and name, which CI systems merge) and one
    name in summary.md, summary.csv and the gate lines; so were a name with the byte 0xff
    and one spelled ``\xff``."""
    logs = tmp_path / "logs"
    logs.mkdir()
    names = [
        "ctl\x01.csv",
        "ctl\\x01.csv",
        os.fsdecode(b"m\xff.csv"),
        "m\\xff.csv",
    ]
    for name in names:
        write_table(logs / name, tank_run(steps=20, seed=1).columns)
    junit = tmp_path / "junit.xml"
    outcome = run_batch(
        [logs / name for name in names],
        "three_tank_hstf",
        out_dir=tmp_path / "out",
        estimator="imm",
        fail_over=["mse=0"],
        junit=junit,
    )
    assert [o.status for o in outcome.logs] == ["done"] * 4
    classnames = [case.get("classname") for case in ET.parse(junit).getroot().iter("testcase")]
    assert len(set(classnames)) == 4, classnames
    with (tmp_path / "out" / "summary.csv").open(encoding="utf-8", newline="") as file:
        rows = list(csv.DictReader(file))
    assert len({row["log"] for row in rows}) == len({row["folder"] for row in rows}) == 4
    markdown = (tmp_path / "out" / "summary.md").read_text(encoding="utf-8")
    shown = _first_column(markdown)
    assert len(shown) == 4 and len(set(shown)) == 4, shown
    assert len({line.split(": mse")[0] for line in outcome.gate_failures}) == 4


def test_names_alike_but_for_their_unicode_form_are_written_apart_and_said(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``café.csv`` with ``é`` one character (NFC) and two (NFD, as macOS writes names): two
    logs whose rows, gate lines and JUnit test cases read alike, and nothing said so."""
    monkeypatch.chdir(tmp_path)
    composed, decomposed = "caf\u00e9.csv", "cafe\u0301.csv"
    for k, name in enumerate((composed, decomposed)):
        write_table(Path("logs", name), tank_run(steps=20, seed=1 + k).columns)
    Path("logs", "th\u00e9.csv").write_bytes(Path("logs", composed).read_bytes())

    outcome = run_batch(
        ["logs"],
        "three_tank_hstf",
        out_dir="out",
        estimator="imm",
        fail_over=["mse=0"],
        junit="junit.xml",
    )

    assert outcome.notes == [
        "2 logs have names that read alike, differing only in how their letters are encoded "
        "(Unicode NFC and NFD: 'logs/cafe\\u0301.csv' and 'logs/caf\\u00e9.csv'): the "
        "summaries write them with \\u escapes, and their report folders would be one where "
        "the file system takes both names for one (macOS); rename one"
    ]
    with Path("out/summary.csv").open(encoding="utf-8", newline="") as file:
        rows = list(csv.DictReader(file))
    logs = [row["log"] for row in rows]
    assert sorted(logs) == ["logs/caf\\u00e9.csv", "logs/cafe\\u0301.csv", "logs/th\u00e9.csv"]
    # their report folders too: summary.csv's folder, summary.md's report column
    folders = [row["folder"] for row in rows]
    assert sorted(folders) == ["caf\\u00e9.csv", "cafe\\u0301.csv", "th\u00e9.csv"]
    assert "| cafe\\\\u0301.csv/report.md |" in Path("out/summary.md").read_text(encoding="utf-8")
    shown = _first_column(Path("out/summary.md").read_text(encoding="utf-8"))
    assert len({unicodedata.normalize("NFC", name) for name in shown}) == 3, shown
    classnames = [
        case.get("classname") for case in ET.parse("junit.xml").getroot().iter("testcase")
    ]
    assert len({unicodedata.normalize("NFC", name or "") for name in classnames}) == 3


def test_a_line_break_in_a_logs_name_is_written_on_its_gate_line(tmp_path: Path) -> None:
    """The terminal's gate line of ``a\\nb.csv`` read ``a b.csv: ...``, another log's name."""
    logs = tmp_path / "logs"
    logs.mkdir()
    for name in ("a\nb.csv", "a b.csv"):
        write_table(logs / name, tank_run(steps=20, seed=1).columns)
    outcome = run_batch(
        [logs], "three_tank_hstf", out_dir=tmp_path / "out", estimator="imm", fail_over=["mse=0"]
    )
    names = sorted(line.split(": mse")[0].rsplit("/", 1)[-1] for line in outcome.gate_failures)
    assert names == ["a b.csv", "a\\nb.csv"]
