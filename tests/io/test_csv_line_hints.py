"""A CSV refusal says what the line shows: a carriage return alone, a decimal comma.

Digits grouped by thousands (``"1,000"``) were hinted a decimal comma alone, which read
one thousand as one once the user wrote ``1.000``: the hint now names both.

A lone carriage return inside the data (a line pasted from classic Mac OS text) joined two
records: "line 2: 5 fields, but the header names 3 columns", without a word of why.  A
quoted ``"1,5"`` (Excel in a locale with a decimal comma) was "'1,5' is not a number".
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, inspect_log, load_signals

SPEC = SignalSpec(inputs=("u",), outputs=("y",), states=("x",), mode_ids=("1", "2"), dt=0.1)


def refusal(path: Path) -> str:
    with pytest.raises(LogError) as refused:
        load_signals(path, SPEC, ReadOptions())
    return str(refused.value)


@pytest.mark.parametrize("line", [2, 4])
def test_a_lone_carriage_return_is_named(tmp_path: Path, line: int) -> None:
    lines = ["t,u,y", "0,1,2", "0.1,2,3", "0.2,3,4", "0.3,4,5", "0.4,5,6"]
    lines[line - 1] += "\r" + lines.pop(line)
    path = tmp_path / "log.csv"
    path.write_bytes("\r\n".join(lines).encode() + b"\r\n")
    expected = (
        f"{path}, line {line}: 5 fields, but the header names 3 columns (a carriage return "
        "alone inside it, a line ending of classic Mac OS: hybridlog reads LF or CRLF line "
        "endings)"
    )
    assert refusal(path) == expected
    with pytest.raises(LogError, match="a carriage return alone"):
        inspect_log(path)


def test_a_lone_carriage_return_in_a_file_with_quotes_is_named(tmp_path: Path) -> None:
    """With a quote in the file the ``csv`` module counted fields, and it ended a line at a
    carriage return alone: the line passed as two records and polars refused the file
    naming no line ("found more fields than defined in 'Schema'"); a short line after it
    was named one line too far on (``sed -n 6p`` showed nothing).
    """
    path = tmp_path / "log.csv"
    path.write_bytes(b't,u,y\n"0",1,2\n0.1,2,3\r0.2,3,4\n0.3,4,5\n')
    assert refusal(path) == (
        f"{path}, line 3: 5 fields, but the header names 3 columns (a carriage return alone "
        "inside it, a line ending of classic Mac OS: hybridlog reads LF or CRLF line endings)"
    )
    path.write_bytes(b't,u,y\n"0",1,2\n0.1,2,3\n0.3,4,5\r\n0.4,5\n0.5,6,7\n')
    assert refusal(path) == f"{path}, line 5: 2 fields, but the header names 3 columns"
    path.write_bytes(b't,u,y\n0,1,2\n0.1,"1\r0.2",3\n0.3,4\n')  # the quoted one is a field
    assert refusal(path) == f"{path}, line 4: 2 fields, but the header names 3 columns"


def test_a_short_line_without_a_carriage_return_says_nothing_of_one(tmp_path: Path) -> None:
    path = tmp_path / "log.csv"
    path.write_bytes(b"t,u,y\r\n0,1,2\r\n0.1,2\r\n0.2,3,4\r\n")
    assert refusal(path) == f"{path}, line 3: 2 fields, but the header names 3 columns"


@pytest.mark.parametrize("cell", ["1,5", "-0,25", ",5", "1,5e3"])
def test_a_decimal_comma_is_named(tmp_path: Path, cell: str) -> None:
    path = tmp_path / "log.csv"
    path.write_text(f't,u,y\n0,1,2\n0.1,"{cell}",3\n0.2,3,4\n')
    assert refusal(path) == (
        f"{path}, line 3, column 'u': '{cell}' is not a number (a decimal comma? hybridlog "
        "reads a point as the decimal separator)"
    )


@pytest.mark.parametrize("cell", ["1,000", "-12,345,678", "1,000.5", "1.234.567,5", "1 000"])
def test_digits_grouped_by_thousands_are_named_as_such(tmp_path: Path, cell: str) -> None:
    """``1,000`` was hinted a decimal comma alone: written ``1.000`` on that advice, one
    thousand read as one."""
    path = tmp_path / "log.csv"
    path.write_text(f't,u,y\n0,1,2\n0.1,"{cell}",3\n0.2,3,4\n')
    assert refusal(path) == (
        f"{path}, line 3, column 'u': '{cell}' is not a number (digits grouped by thousands, "
        "or a decimal comma? hybridlog reads digits alone, with a point as the decimal "
        "separator)"
    )


def test_a_stray_quote_after_a_lone_carriage_return_is_named_at_its_line(tmp_path: Path) -> None:
    """``refuse_stray_quote`` ended a line at a carriage return alone, as polars and ``sed``
    do not: the quote of line 3 was named on line 4."""
    from hybridlog.io.csv_lines import refuse_stray_quote

    log = tmp_path / "q.csv"
    log.write_bytes(b't,u,y\n0.0,1\r,2\n0.1,1"x,2\n')
    with pytest.raises(LogError, match=r"q\.csv, line 3: a quote inside a field"):
        refuse_stray_quote(log)
