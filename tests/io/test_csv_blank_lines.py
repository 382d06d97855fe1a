"""A CSV line of nothing but blanks is a blank line, read as an empty one is.

An empty line and ``,,`` were skipped, but a line of spaces, a tab or ``"",,`` was refused
by analyze as an "empty time cell", and inspect said of it "time '' is not a finite number
of seconds"; a time cell of spaces was named the second way by inspect, the first by
analyze.  Line numbers after such a line still count it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, inspect_log, load_signals

SPEC = SignalSpec(inputs=("u",), outputs=("y",), states=("x",), mode_ids=("1", "2"), dt=0.1)
ROWS = [f"{k / 10},{k},{-k}" for k in range(8)]


def write(tmp_path: Path, lines: list[str], newline: str = "\n") -> Path:
    path = tmp_path / "log.csv"
    path.write_bytes(newline.join(["t,u,y", *lines]).encode() + newline.encode())
    return path


@pytest.mark.parametrize("blank", ["", "   ", "\t", ",,", '"",,', " , , "])
@pytest.mark.parametrize("newline", ["\n", "\r\n"], ids=["lf", "crlf"])
def test_a_line_of_blanks_is_skipped(tmp_path: Path, blank: str, newline: str) -> None:
    path = write(tmp_path, [*ROWS[:2], blank, *ROWS[2:]], newline)
    signals = load_signals(path, SPEC, ReadOptions())
    assert np.array_equal(signals.time, np.arange(8) / 10)
    assert np.array_equal(signals.inputs[:, 0], np.arange(8.0))
    info = inspect_log(path)
    assert (info["rows"], info["problems"]) == (8, [])
    # and a bad cell after it is named on its own line
    bad = [*ROWS[:2], blank, *ROWS[2:]]
    bad[5] = "0.4,x,-4"
    with pytest.raises(LogError, match=r"line 7, column 'u': 'x' is not a number$"):
        load_signals(write(tmp_path, bad, newline), SPEC, ReadOptions())


def test_a_time_cell_of_blanks_is_an_empty_time_cell_to_both(tmp_path: Path) -> None:
    lines = ROWS[:]
    lines[2] = "  ,2,-2"
    path = write(tmp_path, lines)
    with pytest.raises(LogError) as refused:
        load_signals(path, SPEC, ReadOptions())
    expected = "line 4, column 't': empty time cell"
    assert str(refused.value) == f"{path}, {expected}"
    assert inspect_log(path)["problems"] == [expected]
