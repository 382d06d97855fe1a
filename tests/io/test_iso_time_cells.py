"""ISO 8601 times in a CSV time column: RFC 3339's spellings read, a bad one named for what it is.

``2024-03-01t12:00:00`` (RFC 3339 allows a lowercase ``t``) and an offset of hours alone
(``+05``) were "not a number"; ``2024-02-30T00:00:00`` was "not a date and time written like
'2024-02-30T00:00:00'", like itself; ``2024-03-01T12:00`` "not a number", without a word of
the seconds it lacks.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, inspect_log, load_signals

SPEC = SignalSpec(inputs=("u",), outputs=("y",), states=("x",), mode_ids=("1", "2"), dt=0.1)
NOON = 1709294400  # 2024-03-01T12:00:00Z
N = 20


def log(tmp_path: Path, times: list[str]) -> Path:
    path = tmp_path / "log.csv"
    path.write_text("t,u,y\n" + "".join(f"{t},{k},{-k}\n" for k, t in enumerate(times)))
    return path


@pytest.mark.parametrize(
    ("written", "offset_s"),
    [("2024-03-01t12:00:{s:04.1f}", 0), ("2024-03-01T12:00:{s:04.1f}+05", -5 * 3600)],
    ids=["lowercase-t", "offset-of-hours"],
)
def test_rfc3339_spellings_are_read(tmp_path: Path, written: str, offset_s: int) -> None:
    path = log(tmp_path, [written.format(s=k / 10) for k in range(N)])
    signals = load_signals(path, SPEC, ReadOptions())
    expected_ns = (NOON + offset_s) * 10**9 + 100_000_000 * np.arange(N)
    assert np.array_equal(signals.time, expected_ns / 1e9)
    assert np.array_equal(signals.inputs[:, 0], np.arange(N, dtype=float))
    assert inspect_log(path)["time"]["start"] == NOON + offset_s


def _refusal(path: Path) -> str:
    with pytest.raises(LogError) as refused:
        load_signals(path, SPEC, ReadOptions())
    message = str(refused.value)
    assert inspect_log(path)["problems"] == [message.removeprefix(f"{path}, ")]
    return message


@pytest.mark.parametrize("line", [2, 7])
def test_a_day_that_does_not_exist_is_named_so(tmp_path: Path, line: int) -> None:
    times = [f"2024-02-28T00:00:{k / 10:04.1f}" for k in range(N)]
    times[line - 2] = "2024-02-30T00:00:00.5"
    assert _refusal(log(tmp_path, times)) == (
        f"{tmp_path / 'log.csv'}, line {line}, column 't': '2024-02-30T00:00:00.5' is not a "
        "date and time (ISO 8601): no such day of its month, or hour, minute or second of a day"
    )


def test_a_time_without_seconds_says_so(tmp_path: Path) -> None:
    message = _refusal(log(tmp_path, [f"2024-03-01T12:{k:02d}" for k in range(N)]))
    assert message.endswith(
        "line 2, column 't': '2024-03-01T12:00' is not a number (a date and time is read "
        "with its seconds, e.g. 2024-01-01T00:00:00)"
    )
