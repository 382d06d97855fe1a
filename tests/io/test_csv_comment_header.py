"""A comment line where the header belongs is named as such, not read as the header.

numpy.savetxt(..., header="t,u,y") writes ``# t,u,y``: the time column was named ``# t``
("no time column ... closest: '# t'"); a logger's ``# logged by ...`` line before the header
made inspect say "line 2: 3 fields, but the header names 1 columns".  A header whose first
column is named ``#`` (a row number, as spreadsheets export it) is still a header.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, inspect_log, load_signals

SPEC = SignalSpec(inputs=("u",), outputs=("y",), states=("x",), mode_ids=("1", "2"), dt=0.1)
T = np.round(0.1 * np.arange(10), 10)


@pytest.mark.parametrize(
    ("first", "rest"),
    [
        ("# t,u,y", ""),  # numpy.savetxt's header
        ("# logged by rig 4, 2024-01-01", "t,u,y\n"),
    ],
    ids=["savetxt", "comment-before-header"],
)
def test_a_comment_on_line_1_is_named(tmp_path: Path, first: str, rest: str) -> None:
    path = tmp_path / "log.csv"
    if rest:
        np.savetxt(
            path, np.column_stack([T, T, T]), delimiter=",", header=rest.strip(), comments=""
        )
        path.write_text(first + "\n" + path.read_text())
    else:
        np.savetxt(path, np.column_stack([T, T, T]), delimiter=",", header="t,u,y")
        assert path.read_text().startswith(first + "\n")
    for read in (inspect_log, lambda p: load_signals(p, SPEC, ReadOptions())):
        with pytest.raises(LogError) as refused:
            read(path)
        message = str(refused.value)
        assert message.startswith(f"{path}, line 1: '{first}' starts with '#', a comment; ")
        assert "comments=''" in message


def test_a_column_named_hash_is_a_header(tmp_path: Path) -> None:
    path = tmp_path / "log.csv"
    path.write_text("#,t,u,y\n" + "".join(f"{k},{float(t)!r},{k},{-k}\n" for k, t in enumerate(T)))
    signals = load_signals(path, SPEC, ReadOptions())
    assert np.array_equal(signals.time, T)
    assert np.array_equal(signals.inputs[:, 0], np.arange(10.0))
    assert [c["name"] for c in inspect_log(path)["columns"]] == ["#", "t", "u", "y"]
