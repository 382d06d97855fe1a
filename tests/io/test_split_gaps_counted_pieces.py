"""--split-gaps finds a piece sampled at ``dt`` in a log mostly sampled slowly.

Whether the outputs left "no piece of more than one sample" was judged from their median
step: a log sampled every second for 30 s and then every 0.1 s for 2 s (a model with
``dt = 0.1``) has a median step of 1 s, longer than ``max_gap`` (0.5 s), and was refused
with "leaves no piece of more than one sample" though it held a 2 s piece of 21 samples.
The pieces are now counted: the log is refused only when every step is a gap.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, load_signals

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1",), dt=0.1)


def write(path: Path, times: list[float]) -> Path:
    path.write_text("t,u,y\n" + "".join(f"{t:.1f},{k},{10 * k}\n" for k, t in enumerate(times)))
    return path


def test_a_dense_piece_after_a_slow_stretch_is_analysed(tmp_path: Path) -> None:
    times = [float(k) for k in range(31)] + [30 + 0.1 * k for k in range(1, 21)]
    log = write(tmp_path / "log.csv", times)
    notes: dict[str, Any] = {}
    signals = load_signals(log, SPEC, ReadOptions(split_gaps=True), notes=notes)
    np.testing.assert_allclose(signals.time, [30 + 0.1 * k for k in range(21)])
    np.testing.assert_array_equal(signals.outputs[:, 0], 10 * np.arange(30, 51))
    np.testing.assert_array_equal(signals.inputs[:, 0], np.arange(30, 51))
    assert notes["segments"][notes["analysed_segment"]] == {
        "start": 30.0,
        "end": 32.0,
        "duration": 2.0,
    }


def test_a_log_whose_every_step_is_a_gap_is_still_refused(tmp_path: Path) -> None:
    log = write(tmp_path / "log.csv", [float(k) for k in range(10)])
    with pytest.raises(
        LogError,
        match=r"--split-gaps: output 'y' \(column 'y'\) leaves no piece of more than one "
        r"sample; it is sampled every 1 s",
    ):
        load_signals(log, SPEC, ReadOptions(split_gaps=True))


def test_a_max_gap_under_dt_cuts_no_step_of_dt(tmp_path: Path) -> None:
    """--max-gap 0 --split-gaps refused a log sampled at dt ('leaves no piece of more than
    one sample'), which --max-gap 0 alone reads whole; and every input sample held for its
    one step was recorded as a hold longer than max_gap."""
    log = write(tmp_path / "log.csv", [0.1 * k for k in range(10)])
    for split in (False, True):
        notes: dict[str, Any] = {}
        signals = load_signals(log, SPEC, ReadOptions(max_gap=0.0, split_gaps=split), notes=notes)
        np.testing.assert_array_equal(signals.outputs[:, 0], 10 * np.arange(10))
        assert notes == {
            "format": "csv",
            "time": "log",
            "fields": {
                "u": {"field": "u", "from": "default"},
                "y": {"field": "y", "from": "default"},
            },
        }


def test_a_max_gap_under_dt_still_cuts_a_real_gap(tmp_path: Path) -> None:
    times = [0.1 * k for k in range(5)] + [1.0 + 0.1 * k for k in range(8)]
    log = write(tmp_path / "log.csv", times)
    notes: dict[str, Any] = {}
    signals = load_signals(log, SPEC, ReadOptions(max_gap=0.0, split_gaps=True), notes=notes)
    np.testing.assert_allclose(signals.time, [1.0 + 0.1 * k for k in range(8)])
    assert notes["gaps"] == [{"start": 0.4, "end": 1.0}]
