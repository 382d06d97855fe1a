"""A second batch into a batch folder another batch is running into is refused.

Before, two batches run into one --out at once (two CI jobs, a cron run overlapping the
last) both exited 0: with other options each redid the logs the other had just written, and
the summary.csv of the last to finish named numbers that were not those of the report.json
files it links to (59 of 60 logs in a run by hand).  Now the batch process locks the folder
until its summaries are written; another batch is refused before it writes anything.  The
other batch is stood for here by a lock taken on the folder as a batch takes it (no race).
"""

from __future__ import annotations

import fcntl
import os
from collections.abc import Iterator
from pathlib import Path

import pytest

import hybridlog.jobs.batch as batch
from hybridlog.errors import OutputError
from hybridlog.io.writers import write_table
from hybridlog.jobs.batch import run_batch
from tests.support.logfiles import tank_run

TANK = "three_tank_hstf"


def _contents(out: Path) -> dict[str, bytes]:
    return {p.relative_to(out).as_posix(): p.read_bytes() for p in out.rglob("*") if p.is_file()}


@pytest.fixture
def logs(tmp_path: Path) -> list[Path]:
    (tmp_path / "logs").mkdir()
    return [
        write_table(tmp_path / "logs" / f"s{k}.csv", tank_run(steps=20, seed=k).columns)
        for k in (1, 2)
    ]


def _held(folder: Path) -> Iterator[None]:
    fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    try:
        yield
    finally:
        os.close(fd)


def test_a_batch_into_a_folder_another_batch_runs_into_is_refused(
    logs: list[Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = tmp_path / "out"
    run_batch(logs, TANK, out_dir=out, estimator="imm")
    before = _contents(out)
    analysed: list[str] = []
    monkeypatch.setattr(batch, "analyze_log", lambda job, log, folder: analysed.append(log))
    other = _held(out)
    next(other)  # another batch holds the folder
    with pytest.raises(OutputError, match=r"another hybridlog batch is running into this folder"):
        run_batch(logs, TANK, out_dir=out, estimator="imm", sets=["transition_stay=0.9"])
    assert analysed == [] and _contents(out) == before
    next(other, None)  # it ended (a kill -9 releases the lock too): the next run goes ahead
    monkeypatch.undo()
    again = run_batch(logs, TANK, out_dir=out, estimator="imm", sets=["transition_stay=0.9"])
    assert {o.status for o in again.logs} == {"done"}


def test_the_lock_is_held_until_the_summaries_are_written(
    logs: list[Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = tmp_path / "out"
    summarise = batch.summarise
    tried: list[bool] = []

    def summarise_while_tried(root: Path, *args: object, **kwargs: object) -> object:
        fd = os.open(root, os.O_RDONLY | os.O_DIRECTORY)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            tried.append(True)  # another batch would get it now
        except BlockingIOError:
            tried.append(False)
        finally:
            os.close(fd)
        return summarise(root, *args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(batch, "summarise", summarise_while_tried)
    run_batch(logs, TANK, out_dir=out, estimator="imm")
    assert tried == [False]
