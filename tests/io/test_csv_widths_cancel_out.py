"""A short CSV line and a long one are refused, also where polars reads only some columns.

The record-width check trusted the file's count of commas: equal to ``width - 1`` per line,
it returned, as polars refuses a long line.  polars does so only when it reads every
column; reading some (a log with columns no signal is mapped to), it took a long line's
first fields and read a short line's missing cells as "not measured".  A short line and a
long one (two loggers writing into one file) loaded without a word.
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from unittest import mock

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, csv_lines, inspect_log, load_signals

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=(), dt=0.1)
"""``t``, ``u`` and ``y`` read; ``z`` is no signal's."""

ROWS = ["0.0,1,2,9", "0.1,1,2,9", "0.2,1,2,9", "0.3,1,2,9", "0.4,1,2,9", "0.5,1,2,9"]


def written(tmp_path: Path, rows: list[str], end: str = "\n") -> Path:
    path = tmp_path / "log.csv"
    path.write_bytes(end.join(["t,u,y,z", *rows, ""]).encode())
    return path


def refusal(path: Path) -> str:
    with pytest.raises(LogError) as refused:
        load_signals(path, SPEC, ReadOptions())
    return str(refused.value)


@pytest.mark.parametrize("end", ["\n", "\r\n"])
@pytest.mark.parametrize(
    ("short", "long", "line", "fields"),
    [(2, 3, 4, 2), (3, 2, 4, 6)],  # short then long, long then short
)
def test_a_short_line_and_a_long_one_are_refused(
    tmp_path: Path, end: str, short: int, long: int, line: int, fields: int
) -> None:
    rows = list(ROWS)
    rows[short] = rows[short][:5]  # "0.2,1": 2 fields
    rows[long] += ",7,7"  # 6 fields
    path = written(tmp_path, rows, end)
    assert refusal(path) == f"{path}, line {line}: {fields} fields, but the header names 4 columns"
    with pytest.raises(LogError, match=rf"line {line}: {fields} fields"):
        inspect_log(path)


def test_several_pairs_name_the_first_line(tmp_path: Path) -> None:
    rows = list(ROWS)
    rows[1], rows[2] = "0.1,1,2", "0.2,1,2,9,7"
    rows[3], rows[4] = "0.3,1", "0.4,1,2,9,7,7"
    assert refusal(written(tmp_path, rows)).endswith(
        "line 3: 3 fields, but the header names 4 columns"
    )


def test_blank_lines_among_the_rows_are_read(tmp_path: Path) -> None:
    path = written(tmp_path, ["", ROWS[0], "  ", ROWS[1], "\r", ROWS[2], "\t", ROWS[3]])
    signals = load_signals(path, SPEC, ReadOptions())
    assert signals.n_samples == 4


def test_a_quoted_file_is_counted_by_the_csv_module(tmp_path: Path) -> None:
    path = written(tmp_path, ['0.0,"1",2,9', "0.1,1,2,9", "0.2,1", "0.3,1,2,9,7,7", "0.4,1,2,9"])
    assert refusal(path) == f"{path}, line 4: 2 fields, but the header names 4 columns"


def first_odd_line(data: bytes, width: int) -> tuple[int, int, int] | None:
    """The definition :func:`csv_lines._first_odd_line` computes a block at a time."""
    if b'"' in data:
        return None
    start = 0
    for number, text in enumerate(data.split(b"\n"), start=1):
        fields = text.count(b",") + 1
        if number > 1 and fields != width and text.strip():
            return number, fields, start
        start += len(text) + 1
    return 0, 0, -1


@settings(max_examples=300, deadline=None)
@given(
    data=st.binary(max_size=200).map(lambda b: bytes(b',,\n\n \r1"'[x % 8] for x in b)),
    width=st.integers(1, 4),
    block=st.integers(1, 32),
)
def test_lines_are_counted_across_blocks(data: bytes, width: int, block: int) -> None:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "log.csv"
        path.write_bytes(data)
        with mock.patch.object(csv_lines, "COUNTED_AT_ONCE", block):
            found = csv_lines._first_odd_line(path, width)
    assert found == first_odd_line(data, width)


@pytest.mark.parametrize("end", [b"\n", b"\r\n", b"\r\nabc"])
def test_a_lone_carriage_return_is_found_across_blocks(tmp_path: Path, end: bytes) -> None:
    path = tmp_path / "log.csv"
    path.write_bytes(b"t,u\n0,1\r0.1,2" + end)
    with mock.patch.object(csv_lines, "COUNTED_AT_ONCE", 3):
        assert csv_lines._holds_lone_cr(path, 4)
        assert not csv_lines._holds_lone_cr(path, 0)
