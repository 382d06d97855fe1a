"""``analyze``/``compare --estimator chiu`` on long work: the note and the bar, as ``cluster``.

The exact clustering potentials of a long log in many dimensions take minutes; ``hybridlog
cluster`` said so up front and showed a bar, while ``analyze --estimator chiu`` ran the same
potentials in the estimators' worker without a word.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from functools import partial
from pathlib import Path

import pytest
from click.testing import CliRunner

from hybridlog import background
from hybridlog.cli import cli
from hybridlog.cluster import potentials, subtractive
from hybridlog.cluster.progress import WorkReporter, reporting
from hybridlog.jobs.analysis import analyze
from tests.support.paths import SAMPLE_LOGS

LOG = SAMPLE_LOGS / "double_cart_case1.csv"


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
    note = result.stderr.splitlines()
    assert len(note) == 1 and note[0].startswith("exact potentials of "), result.stderr
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
