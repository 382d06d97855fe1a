"""``inspect`` names the first cell that is not a number in a CSV column of numbers.

A column of numbers with one bad cell (``0x10``) was shown as ``string`` and nothing more,
and ``analyze`` then refused the log naming the line: ``line 4, column 'y': '0x10' is not
a number``.  inspect now says the same, where and which cell, in its ``problems`` (the text
and ``--json`` alike), and nothing for a column of labels or booleans.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, format_inspection, inspect_log, load_signals

SAID = (
    "line 4, column 'y': '0x10' is not a number; 3 of its 4 cells are numbers: analyze takes "
    "it as mode ids, not as a signal"
)


def test_the_first_bad_cell_of_a_column_of_numbers_is_named_as_analyze_names_it(
    tmp_path: Path,
) -> None:
    log = tmp_path / "log.csv"
    log.write_text("t,u,y\n0,1,2\n0.1,1,3\n0.2,1,0x10\n0.3,1,5\n")
    info = inspect_log(log)
    assert info["problems"] == [SAID]
    assert f"problems:\n  {SAID}" in format_inspection(info)
    # analyze's own words for the same cell
    spec = SignalSpec(inputs=("u",), outputs=("y",), states=("x",), mode_ids=("1",), dt=0.1)
    with pytest.raises(LogError, match=r", line 4, column 'y': '0x10' is not a number$"):
        load_signals(log, spec, ReadOptions())


def test_the_first_of_several_and_its_hint(tmp_path: Path) -> None:
    log = tmp_path / "log.csv"
    log.write_text('t,y\n0,1\n1,"1,5"\n2,x\n3,\n')  # a decimal comma first, then a word
    (problem,) = inspect_log(log)["problems"]
    assert problem.startswith(
        "line 3, column 'y': '1,5' is not a number (a decimal comma? hybridlog reads a point "
        "as the decimal separator); 1 of its 3 cells are numbers"
    )


@pytest.mark.parametrize(
    "cells",
    [
        ["a", "b", "a"],  # labels: no number among them
        ["true", "false", "TRUE"],  # booleans, read as 1 and 0
        ["1", "2", "3"],
    ],
)
def test_a_column_of_labels_or_numbers_alone_has_no_such_problem(
    tmp_path: Path, cells: list[str]
) -> None:
    log = tmp_path / "log.csv"
    log.write_text("t,y\n" + "".join(f"{k},{c}\n" for k, c in enumerate(cells)))
    assert inspect_log(log)["problems"] == []


def test_a_bad_time_cell_is_said_once_as_the_time_problem(tmp_path: Path) -> None:
    log = tmp_path / "log.csv"
    log.write_text("t,y\n0,1\n0x10,2\n2,3\n")
    problems = inspect_log(log)["problems"]
    assert len(problems) == 1 and "'0x10'" in problems[0], problems
