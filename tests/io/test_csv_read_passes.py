"""The work a CSV log's read + align does per sample: passes that repeated others are gone."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from hybridlog.io import ReadOptions, SignalSpec, load_signals, time_grid


def _log(folder: Path, rows: int = 50) -> Path:
    t = np.arange(rows) * 0.1
    lines = ["t,u,y", *(f"{a:.1f},{float(np.sin(a))!r},{float(np.cos(a))!r}" for a in t)]
    path = folder / "log.csv"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_a_log_on_its_clock_finds_the_clock_in_one_pass(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The held signals' offsets from the clock's ticks (a modulo over every sample) were
    worked out four times for a log on its clock: the grid's span and the grid each found
    the clock, and each checked the latest first sample against it a second time, though it
    was one of the clock's ticks.  Now once."""
    calls: list[int] = []
    original = time_grid._from_tick

    def counted(time_ns: Any, tick_ns: int, dt_ns: int) -> Any:
        calls.append(time_ns.size)
        return original(time_ns, tick_ns, dt_ns)

    monkeypatch.setattr(time_grid, "_from_tick", counted)
    spec = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("a",), dt=0.1)
    signals = load_signals(_log(tmp_path), spec, ReadOptions())
    assert signals.n_samples == 50
    assert calls == [50]


def test_a_log_off_its_clock_still_starts_on_it(tmp_path: Path) -> None:
    """The skipped pass is only skipped where the start is a tick: an output that starts
    later, off the input's clock, still moves the grid onto the clock."""
    t = np.arange(50) * 0.1
    lines = ["t,u,y"]
    for k, a in enumerate(t):
        lines.append(f"{a:.2f},{k},")
        if k >= 3:
            lines.append(f"{a + 0.01:.2f},,{k}")
    path = tmp_path / "off.csv"
    path.write_text("\n".join(lines) + "\n")
    spec = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("a",), dt=0.1)
    signals = load_signals(path, spec, ReadOptions())
    assert signals.time[0] == pytest.approx(0.3)  # a tick, y (0.31) within dt/2 of it


@pytest.mark.parametrize(
    ("values", "expected"),
    [
        ([], False),
        ([0.5, -3.0, 2.0**53 - 1], False),
        ([0.5, 2.0**53], True),
        ([-(2.0**53), 1.0], True),
        ([1.0, float("nan")], True),  # NaN: beyond_exact looks again (and finds none)
        ([1.0, float("-inf")], True),
    ],
)
def test_any_beyond_exact_agrees_with_beyond_exact(values: list[float], expected: bool) -> None:
    """The 2^53 check of a read column looks at its least and greatest values first (no
    array of N magnitudes); it must never say none when beyond_exact finds one."""
    from hybridlog.io.exact import any_beyond_exact, beyond_exact

    array = np.array(values, dtype=np.float64)
    assert any_beyond_exact(array) is expected
    assert expected or not beyond_exact(array).any()
