"""Two CSV times written apart that read as one are refused saying so, not as a repeat.

Seconds are read as a float64, then to the nanosecond: ``1700000004.0000001`` after
``1700000004.0`` (float64 holds 238 ns there) read as the same time, and the log was refused
as one whose time "repeats (t=1700000004 s after t=1700000004 s on line 6)", which the file
does not say.
"""

from __future__ import annotations

from pathlib import Path

import polars as pl
import pytest

from hybridlog.errors import LogError
from hybridlog.io import SignalSpec, load_signals

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1",), dt=1.0)


def _log(path: Path, times: list[str]) -> Path:
    rows = [f"{t},{k},{k}" for k, t in enumerate(times)]
    rows.insert(2, "")  # a blank line: lines and data rows differ
    path.write_text("t,u,y\n" + "\n".join(rows) + "\n")
    return path


@pytest.mark.parametrize(
    ("second", "said"),
    [
        (
            "1700000001.0000001",
            "line 5, column 't': time '1700000001.0000001' reads as the time of "
            "'1700000001.0' on line 3 (t=1700000001 s): float64 seconds near "
            "t=1700000001 s are 238 ns apart, so the two rows have one time",
        ),
    ],
)
def test_epoch_times_float64_cannot_tell_apart(tmp_path: Path, second: str, said: str) -> None:
    log = _log(tmp_path / "burst.csv", ["1700000000.0", "1700000001.0", second, "1700000002.0"])
    with pytest.raises(LogError) as error:
        load_signals(log, SPEC)
    assert said in str(error.value)
    assert "--sort combines such rows" in str(error.value)


def test_times_apart_by_less_than_a_nanosecond(tmp_path: Path) -> None:
    log = _log(tmp_path / "burst.csv", ["0.0", "1.0", "1.0000000001", "2.0"])
    with pytest.raises(LogError, match=r"line 5, column 't': time '1.0000000001' reads as the "):
        load_signals(log, SPEC)


def test_a_time_written_twice_still_repeats(tmp_path: Path) -> None:
    log = _log(tmp_path / "twice.csv", ["0.0", "1.0", "1", "2.0"])
    with pytest.raises(LogError, match=r"line 5, column 't': time repeats \(t=1 s after t=1 s"):
        load_signals(log, SPEC)


def test_parquet_seconds_apart_by_less_than_a_nanosecond(tmp_path: Path) -> None:
    log = tmp_path / "burst.parquet"
    t = [0.0, 1.0, 1.0000000001, 2.0]
    pl.DataFrame({"t": t, "u": [0.0, 1.0, 2.0, 3.0], "y": [0.0, 1.0, 2.0, 3.0]}).write_parquet(log)
    with pytest.raises(LogError, match=r"row 3, column 't': time '1.0000000001' reads as the time"):
        load_signals(log, SPEC)
