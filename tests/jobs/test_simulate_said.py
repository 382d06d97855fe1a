"""What ``simulate`` says beside the log it writes: how long long work takes, a short log.

``simulate --steps 1000000`` to an MCAP file or a bag wrote for 40-53 s with nothing on
stderr: a message at a time through the libraries' writers, about 6 µs each (and a
components model's simulation, a Python step of ~40 µs).  The work times itself
(:class:`hybridlog.cluster.progress.TimedWork`); the tests make every write "long" instead
of timing a slow one.  ``--steps 1`` wrote a log of two samples that ``analyze`` refused.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from hybridlog import simulate as simulate_module
from hybridlog.cluster import progress
from hybridlog.cluster.progress import WorkReporter, reporting
from hybridlog.io.bag_writers import PROGRESS_ROWS
from hybridlog.jobs.simulate import simulate_log
from hybridlog.model.cache import load_model


class _Said:
    def __init__(self) -> None:
        self.notes: list[str] = []
        self.bars: list[tuple[int, str]] = []
        self.advanced = 0

    @contextlib.contextmanager
    def bar(self, total: int, label: str) -> Iterator[Any]:
        self.bars.append((total, label))

        def advance(done: int) -> None:
            self.advanced += done

        yield advance


@pytest.mark.parametrize(("out", "long"), [("run.mcap", True), ("run.csv", False)])
def test_a_long_message_log_says_how_long_it_takes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, out: str, long: bool
) -> None:
    monkeypatch.setattr(progress, "CALIBRATION_S", 0.0)
    monkeypatch.setattr(progress, "LONG_WORK_S", -1.0)
    said = _Said()
    steps = 3 * PROGRESS_ROWS
    with reporting(WorkReporter(note=said.notes.append, bar=said.bar)):
        outcome = simulate_log("three_tank_hstf", tmp_path / out, steps=steps)
    rows = outcome.samples
    if not long:  # a table is written at once: nothing to time
        assert (said.notes, said.bars) == ([], [])
        return
    [note] = said.notes
    assert note.startswith(f"writing {tmp_path / out}: about ") and "more on this machine" in note
    assert f"of {rows:,} rows left, 8 messages a row)" in note
    assert said.bars == [(rows, "rows written")] and said.advanced == rows


def test_a_short_write_says_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(progress, "CALIBRATION_S", 0.0)
    monkeypatch.setattr(progress, "LONG_WORK_S", float("inf"))
    said = _Said()
    with reporting(WorkReporter(note=said.notes.append, bar=said.bar)):
        simulate_log("three_tank_hstf", tmp_path / "run.bag", steps=3 * PROGRESS_ROWS)
    assert (said.notes, said.bars) == ([], [])


def test_a_long_components_simulation_says_how_long_it_takes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # a components model steps its joint modes and controller in Python, ~50 µs a step:
    # 10^6 steps of bioplex_pgc took about 45 s with nothing on stderr
    monkeypatch.setattr(progress, "CALIBRATION_S", 0.0)
    monkeypatch.setattr(progress, "LONG_WORK_S", -1.0)
    said = _Said()
    with reporting(WorkReporter(note=said.notes.append, bar=said.bar)):
        outcome = simulate_log("bioplex_pgc", tmp_path / "run.csv", steps=50)
    [note] = said.notes
    assert note.startswith("simulating bioplex_pgc: about ") and "steps left)" in note, note
    assert said.bars == [(outcome.samples, "steps simulated")]
    assert said.advanced == outcome.samples


@pytest.mark.parametrize(("steps", "noted"), [(1, True), (2, False)])
def test_a_log_too_short_to_report_is_said_so(tmp_path: Path, steps: int, noted: bool) -> None:
    # --steps 1 wrote two samples, which analyze then refused as too short
    outcome = simulate_log("three_tank_hstf", tmp_path / "run.csv", steps=steps)
    short = [note for note in outcome.notes if "need at least 3" in note]
    assert short == (
        ["2 samples: analyze, compare and batch need at least 3 (the first sample is the "
         "prior); give --steps 2 or more"] if noted else []
    )  # fmt: skip


@pytest.mark.parametrize("model", ["ice_clutch", "double_cart_case1", "three_tank_hstf"])
def test_a_long_compiled_simulation_says_how_long_it_takes(
    monkeypatch: pytest.MonkeyPatch, model: str
) -> None:
    # the compiled loops ran a whole run in one call: a continuous model of 10^5 integration
    # steps a row ran 2,000 rows for 73 s without a word, and SIGTERM waited it out
    monkeypatch.setattr(progress, "CALIBRATION_S", 0.0)
    monkeypatch.setattr(progress, "LONG_WORK_S", -1.0)
    monkeypatch.setattr(simulate_module, "CHUNK_WORK", 1)  # a row a call
    said = _Said()
    with reporting(WorkReporter(note=said.notes.append, bar=said.bar)):
        log = simulate_module.simulate(load_model(model), steps=60)
    rows = log.time.shape[0]
    [note] = said.notes
    assert note.startswith(f"simulating {model}: about ") and "steps left)" in note, note
    assert said.bars == [(rows, "steps simulated")] and said.advanced == rows
