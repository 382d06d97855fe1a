"""``analyze``/``compare`` on long work: the note and bar, as ``cluster``; a first compile.

The exact clustering potentials of a long log in many dimensions take minutes; ``hybridlog
cluster`` said so up front and showed a bar, while ``analyze --estimator chiu`` ran the same
potentials in the estimators' worker without a word.  A model's first run compiles its
filters' machine code in the worker's warm-up (up to a minute with ``smoother = "ec"``),
also without a word until it did.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Iterator
from functools import partial
from pathlib import Path

import pytest
from click.testing import CliRunner

from hybridlog import background, cli_progress
from hybridlog.cli import cli
from hybridlog.cluster import potentials, subtractive
from hybridlog.cluster.progress import WorkReporter, reporting
from hybridlog.jobs.analysis import analyze
from tests.support.paths import SAMPLE_LOGS

LOG = SAMPLE_LOGS / "double_cart_case1.csv"
THREE_TANK = SAMPLE_LOGS / "three_tank_hstf.csv"


@pytest.fixture
def long_work(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every exact potential counts as long work (a worker forked now inherits this)."""
    monkeypatch.setattr(potentials, "PAIRS_PER_STEP", 2_000)
    monkeypatch.setattr(subtractive, "_CALIBRATION_S", 0.0)
    monkeypatch.setattr(subtractive, "LONG_WORK_S", 0.0)


@pytest.mark.parametrize("command", ["analyze", "compare"])
def test_analyze_and_compare_say_how_long_the_clustering_takes(
    tmp_path: Path, long_work: None, command: str
) -> None:
    chosen = ["--estimator", "chiu"] if command == "analyze" else ["--estimators", "chiu,kmeans"]
    args = [command, str(LOG), "--model", "double_cart_case1", *chosen, "--set", "method=exact"]
    result = CliRunner().invoke(cli, [*args, "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    # compare also notes that --set method=exact reaches chiu alone (kmeans has no method)
    lines = result.stderr.splitlines()
    assert all(line.startswith("hybridlog: note: ") for line in lines), result.stderr
    note = [line for line in lines if line.startswith("hybridlog: note: exact potentials of ")]
    assert len(note) == 1, result.stderr
    assert " on this machine with " in note[0] and "requested)" in note[0]
    quiet = CliRunner().invoke(cli, ["--quiet", *args, "--out", str(tmp_path / "quiet")])
    assert quiet.exit_code == 0 and quiet.stderr == "", quiet.stderr


def _write(path: Path, text: str) -> None:
    with path.open("a", encoding="utf-8") as file:
        file.write(text + "\n")


@contextlib.contextmanager
def _bar(path: Path, total: int, label: str) -> Iterator[partial[None]]:
    _write(path, f"bar {total} {label}")
    yield partial(_advance, path)


def _advance(path: Path, done: int) -> None:
    _write(path, f"advance {done}")


def test_the_estimators_worker_reports_to_the_commands_reporter(
    tmp_path: Path, long_work: None, monkeypatch: pytest.MonkeyPatch
) -> None:
    # the console script runs chiu in its estimators' worker: the reporter goes there
    events = tmp_path / "events.txt"
    started = background.Worker("test-estimates")
    monkeypatch.setitem(background._WORKERS, background.ESTIMATES, started)
    try:
        reporter = WorkReporter(note=partial(_write, events), bar=partial(_bar, events))
        with reporting(reporter):
            analyze(
                LOG,
                "double_cart_case1",
                estimator="chiu",
                sets=["method=exact"],
                out_dir=tmp_path / "out",
            )
    finally:
        started.close()
    lines = events.read_text(encoding="utf-8").splitlines()
    assert lines[0].startswith("exact potentials of "), lines
    assert lines[1].startswith("bar ") and lines[1].endswith(" cluster potentials"), lines
    total = int(lines[1].split()[1])
    assert sum(int(line.split()[1]) for line in lines[2:]) == total


@contextlib.contextmanager
def _wait(path: Path, what: str, why: str) -> Iterator[None]:
    _write(path, f"wait {what} ({why})")
    yield
    _write(path, "waited")


def test_the_warm_up_in_the_worker_says_what_it_compiles(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # a model's first run compiles its filters in the worker's warm-up, up to a minute
    events = tmp_path / "events.txt"
    started = background.Worker("test-estimates")
    monkeypatch.setitem(background._WORKERS, background.ESTIMATES, started)
    try:
        reporter = WorkReporter(
            note=partial(_write, events), bar=partial(_bar, events), wait=partial(_wait, events)
        )
        with reporting(reporter):
            analyze(THREE_TANK, "three_tank_hstf", estimator="imm", out_dir=tmp_path / "out")
    finally:
        started.close()
    assert events.read_text(encoding="utf-8").splitlines() == [
        "wait imm: compiling machine code for model 'three_tank_hstf' (its first run with "
        "these options; later runs load it from the cache)",
        "waited",
    ]


@pytest.mark.parametrize(
    ("shown", "after_s", "lines"), [(True, 0.0, 2), (True, 60.0, 0), (False, 0.0, 0)]
)
def test_a_wait_is_said_on_a_terminal_once_it_outlasts_a_moment(
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    shown: bool,
    after_s: float,
    lines: int,
) -> None:
    monkeypatch.setattr(cli_progress, "WAIT_SHOWN_S", after_s)
    with cli_progress._work_wait(shown, "imm: compiling", "first run"):
        time.sleep(0.3)
    said = capsys.readouterr().err.splitlines()
    assert len(said) == lines, said
    if lines:
        assert said[0] == "imm: compiling (first run)..."
        assert said[1] == "imm: compiling: done in 0 s"


def test_a_wait_that_fails_is_not_said_done(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(cli_progress, "WAIT_SHOWN_S", 0.0)
    with pytest.raises(KeyboardInterrupt), cli_progress._work_wait(True, "imm: compiling", "first"):
        time.sleep(0.3)
        raise KeyboardInterrupt
    assert capsys.readouterr().err.splitlines() == ["imm: compiling (first)..."]


@pytest.mark.parametrize("jobs", [1, 2])
def test_a_batch_says_what_its_first_log_compiles(tmp_path: Path, jobs: int) -> None:
    # batch's bar sat at 0/N while the model compiled in its first log (10-20 s), silently
    from hybridlog.jobs.batch import run_batch
    from tests.jobs.test_workers import _Told

    logs = [tmp_path / "a.csv", tmp_path / "b.csv"]
    for log in logs:
        log.write_bytes(THREE_TANK.read_bytes())
    told = _Told()
    with reporting(WorkReporter(wait=told.wait)):
        outcome = run_batch(
            logs, "three_tank_hstf", estimator="imm", out_dir=tmp_path / "out", jobs=jobs
        )
    assert [log.status for log in outcome.logs] == ["done", "done"]
    begun = "begin imm: compiling machine code for model 'three_tank_hstf' (its first run"
    # each process warms up once; two workers side by side are said once
    assert told.events[0].startswith(begun) and told.events[1] == "ended", told.events
    assert len(told.events) in ((2, 4) if jobs == 2 else (2,)), told.events


def test_a_wait_over_a_bar_clears_its_line_first(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(cli_progress, "WAIT_SHOWN_S", 0.0)
    with cli_progress._work_wait(True, "imm: compiling", "first run", over_bar=True):
        time.sleep(0.3)
    assert capsys.readouterr().err == (
        "\r\x1b[Kimm: compiling (first run)...\n\r\x1b[Kimm: compiling: done in 0 s\n"
    )


def test_a_batch_whose_warm_up_fails_analyses_its_logs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # the warm-up runs on rows of zeros, which a model may refuse where no log does
    from hybridlog.estimators import Prepared
    from hybridlog.jobs.batch import run_batch
    from tests.jobs.test_workers import _Told

    def refuse(self: Prepared, model: object, rows: int = 3) -> None:
        raise ValueError("zeros are out of this model's domain")

    monkeypatch.setattr(Prepared, "warm_up", refuse)
    told = _Told()
    with reporting(WorkReporter(wait=told.wait)):
        outcome = run_batch([THREE_TANK], "three_tank_hstf", out_dir=tmp_path / "out")
    assert [log.status for log in outcome.logs] == ["done"]
    assert len(told.events) == 2 and told.events[1] == "failed", told.events
