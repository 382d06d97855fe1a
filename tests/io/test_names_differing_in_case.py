"""A column, field or topic named like the wanted one but in another case is pointed at.

A CSV with the header ``T,u,y`` was refused with "no time column ...; closest: 'mode'" (or,
with no near name at all, a list of every column), a Parquet file with a column ``Y1`` for
the output ``y1`` with "closest: 'y3', 'y2', 'x1'": difflib compares characters as they are,
so the one column the user meant was ranked below others or not named at all.  A name equal
but for case now comes first, and the error says names are case-sensitive.
"""

from __future__ import annotations

import csv
from pathlib import Path

import polars as pl
import pytest

from hybridlog.cli import main
from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, load_signals
from hybridlog.io.source import closest_names
from tests.support.logfiles import Channel, float64_cdr, write_mcap

SPEC = SignalSpec(inputs=("u",), outputs=("y1", "y2", "y3"), mode_ids=("1",), dt=1.0)
N = 12


def _write_csv(path: Path, header: list[str]) -> Path:
    with path.open("w", newline="", encoding="utf-8") as stream:
        writer = csv.writer(stream)
        writer.writerow(header)
        for k in range(N):
            writer.writerow([float(k)] + [float(k + i) for i in range(len(header) - 1)])
    return path


def test_a_name_differing_only_in_case_comes_first_and_is_said_to() -> None:
    assert closest_names(["u"], ["U", "y1", "y2"]) == (
        "closest: 'U' (names are case-sensitive: 'U' is not 'u')"
    )
    assert closest_names(["y1"], ["y2", "y3", "x1", "Y1"]).startswith("closest: 'Y1', ")


def test_names_differing_otherwise_get_no_case_note() -> None:
    assert closest_names(["levle"], ["level"]) == "closest: 'level'"


def test_a_csv_time_column_in_capitals_is_named(tmp_path: Path) -> None:
    log = _write_csv(tmp_path / "log.csv", ["T", "u", "y1", "y2", "y3"])
    with pytest.raises(LogError) as info:
        load_signals(log, SPEC)
    assert "closest: 'T'" in str(info.value)
    assert "names are case-sensitive: 'T' is not 't'" in str(info.value)


def test_a_parquet_column_in_capitals_is_named_first(tmp_path: Path) -> None:
    log = tmp_path / "log.parquet"
    frame = {"t": [float(k) for k in range(N)], "u": [1.0] * N}
    frame |= {"Y1": [2.0] * N, "y2": [3.0] * N, "y3": [4.0] * N, "x1": [5.0] * N}
    pl.DataFrame(frame).write_parquet(log)
    with pytest.raises(LogError) as info:
        load_signals(log, SPEC)
    assert "closest: 'Y1', " in str(info.value)
    assert "'Y1' is not 'y1'" in str(info.value)


def test_a_topic_in_capitals_is_named_first(tmp_path: Path) -> None:
    topics = ["/u", "/Y1", "/y2", "/y3"]
    log = write_mcap(
        tmp_path / "log.mcap",
        [Channel(topic) for topic in topics],
        ((c, k * 10**9, float64_cdr(float(k))) for k in range(N) for c in range(len(topics))),
    )
    with pytest.raises(LogError) as info:
        load_signals(log, SPEC, ReadOptions(maps=("y1=/y1.data",)))
    assert "closest: '/Y1'" in str(info.value)


def test_the_cli_names_the_column_in_capitals(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = _write_csv(tmp_path / "log.csv", ["t", "U", "y1", "y2", "y3"])
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as exit_:
        main(["analyze", str(log), "--model", "three_tank_hstf", "--out", str(out)])
    assert exit_.value.code == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1
    assert "closest: 'U' (names are case-sensitive: 'U' is not 'u')" in lines[0]
    assert str(log) in lines[0]
    assert not out.exists()
