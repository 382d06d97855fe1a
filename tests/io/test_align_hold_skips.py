"""Input samples the zero-order hold does not take are counted and said.

An input recorded once per step by a clock that jitters by up to ``dt/2`` (beyond the
``dt/4`` that :func:`~hybridlog.io.resampling.jittered_index` takes as jitter) was held as SPEC
§5 says, the last sample at or before each grid point: wherever a late sample followed an
early one, the early one was never used and the point before took the sample before its
own, a step late.  Half the samples were a step late at random, and nothing said so: the
input had as many samples as the grid has points, so ``reading.faster`` was silent.  A
command toggled and back within one step lost the pulse the same way.  Such samples are now
counted (``reading.skipped``) and report.md says so.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from hybridlog.io import ReadOptions, SignalSpec, load_signals
from hybridlog.report.reading_notes import report_reading_notes

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1",), dt=0.1)


def write(path: Path, inputs: list[float], outputs: list[float]) -> Path:
    """A row per sample; an input's and an output's at one time are combined by ``--sort``."""
    rows = [(t, f"{t:.4f},{k},") for k, t in enumerate(inputs)]
    rows += [(t, f"{t:.4f},,{k}") for k, t in enumerate(outputs)]
    path.write_text("t,u,y\n" + "".join(row + "\n" for _, row in sorted(rows)))
    return path


def test_an_input_jittering_by_up_to_half_a_step_is_warned(tmp_path: Path) -> None:
    offsets = np.tile([-0.04, 0.04], 20)  # early, late: the late ones are held a step
    inputs = [0.0] + [0.1 * k + offsets[k] for k in range(1, 40)]
    log = write(tmp_path / "log.csv", inputs, [0.1 * k for k in range(40)])
    notes: dict[str, Any] = {}
    signals = load_signals(log, SPEC, ReadOptions(sort=True), notes=notes)
    # grid point k takes sample k where it came early, k - 1 where it came late
    taken = signals.inputs[:, 0]
    np.testing.assert_array_equal(taken[1:5], [0, 2, 2, 4])
    assert notes["skipped"] == {"u": {"kind": "input", "samples": 39, "unused": 19, "points": 40}}
    (said,) = (n for n in report_reading_notes(notes) if "not used" in n)
    assert said.startswith(
        "NOTE: input u: 19 of its 39 samples over the 40 sample times analysed are not "
        "used: each sample time takes the last sample at or before it (SPEC §5)"
    )


def test_a_pulse_shorter_than_a_step_is_warned(tmp_path: Path) -> None:
    inputs = [0.0, 0.52, 0.55, 1.0]  # a change at 0.52 s undone at 0.55 s: never on the grid
    log = write(tmp_path / "log.csv", inputs, [0.1 * k for k in range(20)])
    notes: dict[str, Any] = {}
    load_signals(log, SPEC, ReadOptions(max_gap=2.0, sort=True), notes=notes)
    assert notes["skipped"] == {"u": {"kind": "input", "samples": 4, "unused": 1, "points": 20}}


def test_inputs_whose_every_sample_is_taken_are_not_noted(tmp_path: Path) -> None:
    steps = [0.1 * k for k in range(20)]
    for inputs in (
        steps,  # on the grid
        [t + 0.02 for t in steps],  # a constant latency: each a step late, none lost
        [0.0, 0.35, 0.9, 1.3],  # published on change, slower than dt
        [0.0] + [t + (0.02 if k % 2 else 0.0) for k, t in enumerate(steps[1:])],  # jitter
    ):
        notes: dict[str, Any] = {}
        log = write(tmp_path / "log.csv", inputs, steps)
        load_signals(log, SPEC, ReadOptions(sort=True), notes=notes)
        assert "skipped" not in notes, inputs
