"""``inspect`` of a wide CSV tallies every column at once (:func:`.csv_tally.tally_block`).

A column at a time, a block took about a millisecond a column whatever its rows: a CSV of 3
rows and 20,000 columns took 22.6 s.  The columns tallied together must be described as
each is alone: the description of a wide CSV of varied columns is checked against that of
each column read alone, beside the time, in a CSV of its own.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hybridlog.io import csv_tally
from hybridlog.io.inspect import inspect_log

CELLS = {
    "x": ["1.5", "-2", "3e2", "0", "7"],
    "blanks": ["1", "", " ", "2.5", ""],
    "labels": ["idle", "run", "idle", "stop", "run"],
    "flags": ["true", "FALSE", "", "True", "false"],
    "truths": ["true", "", "TRUE", "true", ""],
    "nan": ["nan", "1", "-inf", "Infinity", "2"],
    "big": ["9007199254740993", "1", "2", "3", "4"],
    "huge": ["1", "1e400", "2", "3", "4"],
    "hex": ["1", "2", "0x10", "4", "5"],
    "flag_among": ["1", "true", "0", "1", "1"],
    "empty": ["", "", "", "", ""],
    "zeros": ["-0", "0", "-0.0", " 0 ", "0"],
    "spaced": [" 4 ", "5 ", " 6", "7", "8"],
    "grouped": ['"1,000"', "2", "3", "4", "5"],
}


def _write(path: Path, names: list[str]) -> Path:
    """A CSV of a time and columns ``names``: those of :data:`CELLS`, numbered."""
    lines = [",".join(["t", *names])]
    for row in range(5):
        cells = (CELLS[name.rstrip("0123456789")][row] for name in names)
        lines.append(",".join([str(row * 0.1), *cells]))
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("block", [csv_tally.CSV_BYTES_AT_ONCE, 9])
def test_a_wide_csv_is_described_as_its_columns_each_alone(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, block: int
) -> None:
    monkeypatch.setattr(csv_tally, "CSV_BYTES_AT_ONCE", block)
    names = list(CELLS) * 2  # the same cells in two places of the block
    names = [f"{name}{index}" for index, name in enumerate(names)]
    wide = inspect_log(_write(tmp_path / "wide.csv", names))
    assert [column["name"] for column in wide["columns"]] == ["t", *names]
    problems: list[str] = []
    for name, column in zip(names, wide["columns"][1:], strict=True):
        alone = inspect_log(_write(tmp_path / f"{name}.csv", [name]))
        assert column == alone["columns"][1], name
        problems += alone["problems"]
    assert wide["problems"] == problems
    kinds = {column["name"].rstrip("0123456789"): column for column in wide["columns"]}
    assert kinds["flags"]["dtype"] == "boolean"
    assert (kinds["truths"]["min"], kinds["truths"]["max"]) == (1.0, 1.0)
    assert kinds["labels"]["dtype"] == kinds["hex"]["dtype"] == "string"
    assert (kinds["nan"]["nonfinite"], kinds["nan"]["min"], kinds["nan"]["max"]) == (3, 1.0, 2.0)
    assert kinds["blanks"]["count"] == 2
    said = {problem.split("'")[1].rstrip("0123456789") for problem in wide["problems"]}
    assert said == {"big", "huge", "hex", "flag_among", "grouped"}, wide["problems"]
    assert len(wide["problems"]) == 2 * len(said)
