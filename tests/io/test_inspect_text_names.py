"""inspect's text keeps the log's names on their own line and in their column.

A topic named with a newline (MCAP takes any string) split its row of the table in two; an
escape sequence in a topic, type or column name, shown ``\\x1b`` by the CLI only after the
table was laid out, pushed the rest of its row out of line.  Names are now escaped where the
table and the lists are made.
"""

from __future__ import annotations

import json
from pathlib import Path

import polars as pl

from hybridlog.io import format_inspection, inspect_log

NAMES = ["/a\nb", "/\x1b[31mred", "/ok"]


def control_mcap(path: Path) -> Path:
    from mcap.writer import Writer

    with path.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="", library="test")
        schema = writer.register_schema("S\x1b[0m", "jsonschema", b"{}")
        for name in NAMES:
            channel = writer.register_channel(name, "json", schema)
            for k in range(3):
                data = json.dumps({"v\tx": [k, float("nan")][: 1 + (k == 2)]}).encode()
                writer.add_message(channel, k * 10**8, data, k * 10**8)
        writer.finish()
    return path


def assert_aligned(lines: list[str], header: str, column: str) -> None:
    """Each row after ``header`` has its ``column`` cell at the header's offset."""
    at = lines.index(next(line for line in lines if line.startswith(header)))
    offset = lines[at].index(column)
    rows = lines[at + 1 : lines.index("", at)]
    assert rows and all(row[offset - 2 : offset] == "  " and row[offset] != " " for row in rows)


def test_names_with_control_characters_stay_in_their_row_and_column(tmp_path: Path) -> None:
    text = format_inspection(inspect_log(control_mcap(tmp_path / "odd.mcap")))
    assert "\x1b" not in text and "\t" not in text
    lines = text.split("\n")
    table = [line for line in lines if "S\\x1b[0m" in line]
    assert [line.split()[0] for line in table] == ["/\\x1b[31mred", "/a\\nb", "/ok"]
    assert_aligned(lines, "topic ", "type")
    assert "  /a\\nb.v\\tx[]" in lines
    assert "  /a\\nb.v\\tx[]: 1 of 4" in lines  # the NaN, counted under its escaped name


def test_column_names_with_control_characters_stay_in_their_row(tmp_path: Path) -> None:
    log = tmp_path / "odd.parquet"
    pl.DataFrame(
        {"t": [0.0, 1.0, 2.0], "a\nb": [1.0, 2.0, float("nan")], "c\x1bd": [1, 2, 3]}
    ).write_parquet(log)
    text = format_inspection(inspect_log(log))
    assert "\x1b" not in text
    lines = text.split("\n")
    rows = [line.split() for line in lines]  # a column's row: its name, then its dtype
    named = [row[0] for row in rows if row[1:2] in (["float64"], ["int64"])]
    assert named == ["t", "a\\nb", "c\\x1bd"]  # not a line that names the folder pytest-64x
    assert_aligned(lines, "column ", "dtype")
    assert "  a\\nb: 1 of 3" in lines


def test_wide_and_combining_characters_keep_their_row_in_line(tmp_path: Path) -> None:
    """Cells were padded to their count of characters, not to the columns a terminal gives
    them: ``温度`` (two wide characters, four columns) pushed its row two columns right of the
    header's, ``é`` with a combining accent (two characters, one column) one left."""
    log = tmp_path / "names.parquet"
    names = {"温度": 1.0, "😀": 2.0, "e\u0301": 3.0, "abcdef": 4.0}
    pl.DataFrame({"t": [0.0, 1.0], **{n: [v, v] for n, v in names.items()}}).write_parquet(log)
    lines = format_inspection(inspect_log(log)).split("\n")
    # "column" is six columns wide, so every name is padded to six columns and two spaces
    assert any(line.startswith("column  dtype    count") for line in lines)
    for row in ("温度    float64  2", "😀      float64  2", "e\u0301       float64  2"):
        assert any(line.startswith(row) for line in lines), row


def test_an_empty_column_name_is_shown_as_analyze_names_it(tmp_path: Path) -> None:
    # a Parquet column may be named ""; its row began with a blank cell
    log = tmp_path / "blank.parquet"
    pl.DataFrame({"t": [0.0, 1.0], "": [1.0, 2.0]}).write_parquet(log)
    lines = format_inspection(inspect_log(log)).split("\n")
    assert any(line.startswith("''      float64  2") for line in lines), lines


def test_a_column_name_with_spaces_at_either_end_is_shown_quoted(tmp_path: Path) -> None:
    # shown bare, ' y ' lost its spaces in the table, where analyze's error named it ' y '
    log = tmp_path / "spaced.parquet"
    pl.DataFrame({"t": [0.0, 1.0], " y ": [1.0, 2.0], "b c": [3.0, 4.0]}).write_parquet(log)
    lines = format_inspection(inspect_log(log)).split("\n")
    assert any(line.startswith("' y '   float64  2") for line in lines), lines
    assert any(line.startswith("b c     float64  2") for line in lines), lines


def test_an_empty_mcap_profile_is_quoted_once(tmp_path: Path) -> None:
    # "(mcap, profile '''', 9 messages, ...)": the empty name's '' inside the line's quotes
    first = format_inspection(inspect_log(control_mcap(tmp_path / "odd.mcap"))).split("\n")[0]
    assert first.endswith("odd.mcap (mcap, profile '', 9 messages, 3 topics)"), first


def test_columns_alike_but_for_their_unicode_form_are_written_apart(tmp_path: Path) -> None:
    """``café`` with ``é`` one character (NFC) and two (NFD): two rows that printed alike,
    and an error's ``available: 'café', 'café'``."""
    from hybridlog.io.source import closest_names

    composed, decomposed = "caf\u00e9", "cafe\u0301"
    log = tmp_path / "nf.csv"
    log.write_text(f"t,{composed},{decomposed},th\u00e9\n0,1,2,3\n1,2,3,4\n", encoding="utf-8")
    lines = format_inspection(inspect_log(log)).splitlines()
    names = [
        line.split()[0]
        for line in lines[lines.index(next(x for x in lines if x.startswith("column"))) + 1 :]
    ]
    assert names == ["t", "caf\\u00e9", "cafe\\u0301", "th\u00e9"]
    assert closest_names(["u"], ["t", composed, decomposed]) == (
        "available: 't', 'caf\\u00e9', 'cafe\\u0301'"
    )
