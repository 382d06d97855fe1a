"""A command is named as a command in what reading records, never as an input.

Commands were held onto the grid by passing them to the alignment among the inputs and
splitting them off after: every note the alignment wrote of them called them inputs.  With
``--split-gaps`` a command sampled only in the piece left out was held across the analysed
one, and report.md said "WARNING: input cmd has no sample ... as an input published only
when it changes is"; a command that started the analysed span late was "input 'cmd'"; a
jittering or fast command was "input cmd".  The model has no input of that name.  The
alignment now takes the commands as commands: held as inputs are, named as commands.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from hybridlog.io import ReadOptions, SignalSpec, load_signals
from hybridlog.report.reading_notes import report_reading_notes

SPEC = SignalSpec(
    inputs=("u",),
    outputs=("y",),
    mode_ids=("a",),
    dt=0.1,
    components={"v": ("open", "closed", "unknown")},
    commands=("cmd",),
)


def write(path: Path, rows: list[tuple[float, str, str, str]]) -> Path:
    path.write_text("t,u,y,cmd\n" + "".join(f"{t:.3f},{u},{y},{c}\n" for t, u, y, c in rows))
    return path


def test_a_command_held_across_split_gaps_is_a_command(tmp_path: Path) -> None:
    rows = [(0.1 * k, str(k), str(k), str(k % 2)) for k in range(30)]
    rows += [(0.1 * k, str(k), str(k), "") for k in range(60, 100)]
    notes: dict[str, Any] = {}
    signals = load_signals(
        write(tmp_path / "log.csv", rows), SPEC, ReadOptions(split_gaps=True), notes=notes
    )
    assert signals.command_names == ("cmd",)
    assert signals.commands is not None
    np.testing.assert_array_equal(signals.commands[:, 0], np.ones(40))  # 29 % 2, held
    assert signals.input_names == ("u",)
    assert notes["held"] == {
        "cmd": {"start": 2.9, "end": 9.9, "seconds": 7.0, "holds": 1, "kind": "command"}
        | {"every": 0.1, "steps": 1.0, "regular": True}
    }
    said = [n for n in report_reading_notes(notes) if "held at its last value" in n]
    assert said == [
        "WARNING: command cmd is sampled every 0.1 s (median), 1 step of dt, held between "
        "samples (zero-order hold), and its longest stretch without a sample is from t = 2.9 "
        "to 9.9 s (7 s): held at its last value there"
    ]


def test_a_command_that_starts_the_span_late_is_named_a_command(tmp_path: Path) -> None:
    rows = [(0.1 * k, str(k), str(k), str(k % 2) if k >= 20 else "") for k in range(40)]
    notes: dict[str, Any] = {}
    load_signals(write(tmp_path / "log.csv", rows), SPEC, notes=notes)
    assert notes["span"]["start"]["signal"] == "command 'cmd' (column 'cmd')"


def test_a_jittering_and_a_fast_command_are_named_commands(tmp_path: Path) -> None:
    jitter = [0.0, 0.02, -0.01, 0.02] * 10
    rows = [(0.1 * k, str(k), str(k), "") for k in range(40)]
    rows += [(0.1 * k + jitter[k], "", "", str(k)) for k in range(39)]
    rows.sort()
    notes: dict[str, Any] = {}
    load_signals(write(tmp_path / "jitter.csv", rows), SPEC, ReadOptions(sort=True), notes=notes)
    assert list(notes["jitter"]) == ["command cmd"]

    rows = [(0.1 * k, str(k), str(k), "") for k in range(40)]
    rows += [(0.05 * k, "", "", str(k)) for k in range(80)]
    rows.sort()
    notes = {}
    load_signals(write(tmp_path / "fast.csv", rows), SPEC, ReadOptions(sort=True), notes=notes)
    assert notes["faster"]["cmd"]["kind"] == "command"
    (said,) = (n for n in report_reading_notes(notes) if "samples over" in n)
    assert said.startswith("NOTE: command cmd has ")
    assert "(the last at or before it, SPEC §5)" in said
