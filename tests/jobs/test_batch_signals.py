"""An interrupted ``batch --jobs 2`` leaves no temporary folder and no process behind.

Ctrl-C (``SIGINT`` to the command's process group), ``SIGTERM`` or ``SIGHUP`` to the batch
process (``kill``, a closed terminal), or ``SIGTERM`` to the whole group (a CI runner's
timeout), sent while the workers write their logs' reports: the command ends with 128 + the
signal's number and one line, its workers end before it does, no
``.<log>.hybridlog-tmp-…`` folder is left in the batch folder, and the reports of the logs
finished before the signal stay, so that the next run resumes.  Each signal is sent once a
worker's temporary report folder holds a table (the worker is inside its log, not a fixed
delay later, which a fast machine outruns and a loaded one never reaches).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.support.processes import alive

ROOT = Path(__file__).resolve().parents[2]

LONG_STEPS = "300000"
"""Samples of each long log: about a second of a worker's time, and more on a loaded machine."""

WAIT_S = 180.0
"""Every wait is bounded by this (a loaded machine is slow, never stuck)."""


def _hybridlog(*args: str) -> list[str]:
    return [sys.executable, "-m", "hybridlog", *args]


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``a.parquet``, short (done first), then two long logs, one per worker."""
    folder = tmp_path_factory.mktemp("signals") / "logs"
    for name, steps in (("a", "200"), ("b", LONG_STEPS), ("c", LONG_STEPS)):
        done = subprocess.run(
            _hybridlog("simulate", "three_tank_hstf", "--steps", steps, "--seed", "1",
                       "--out", str(folder / f"{name}.parquet")),
            cwd=ROOT, capture_output=True, text=True, timeout=WAIT_S,
        )  # fmt: skip
        assert done.returncode == 0, done.stderr
    return folder


def _temporaries(out: Path) -> list[Path]:
    return sorted(out.rglob(".*.hybridlog-*"))


def _in_group(group: int) -> list[int]:
    """The processes (not zombies) of process group ``group``."""
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[2]) == group and fields[0] != "Z":
                found.append(int(entry.name))
    return found


SIGNALS = {
    "ctrl-c": (signal.SIGINT, True, "hybridlog: aborted"),
    "sigterm": (signal.SIGTERM, False, "hybridlog: terminated"),
    "sighup": (signal.SIGHUP, False, "hybridlog: terminated"),
    "sigterm-to-the-group": (signal.SIGTERM, True, "hybridlog: terminated"),
}


@pytest.mark.parametrize("how", list(SIGNALS))
def test_an_interrupted_batch_leaves_no_temporaries_and_no_workers(
    logs: Path, tmp_path: Path, how: str
) -> None:
    signum, to_group, line = SIGNALS[how]
    out = tmp_path / "B"
    batch = subprocess.Popen(
        _hybridlog("batch", str(logs), "--model", "three_tank_hstf", "--out", str(out),
                   "--jobs", "2"),
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True,
    )  # fmt: skip
    try:
        deadline = time.monotonic() + WAIT_S
        # the short log done, and a long one's report being written by its worker
        while not (
            (out / "a.parquet" / "report.json").is_file()
            and (busy := list(out.glob(".*.parquet.hybridlog-tmp-*/timeline.csv")))
        ):
            assert batch.poll() is None, "the batch ended before a worker was busy"
            assert time.monotonic() < deadline, f"no worker busy within {WAIT_S} s"
            time.sleep(0.005)
        # the workers' process ids are in their temporary folders' names
        workers = {int(p.parent.name.split("-")[-2]) for p in busy}
        if to_group:
            os.killpg(batch.pid, signum)
        else:
            os.kill(batch.pid, signum)
        _, err = batch.communicate(timeout=WAIT_S)
    finally:
        if batch.poll() is None:
            os.killpg(batch.pid, signal.SIGKILL)
            batch.wait()
    assert batch.returncode == 128 + signum
    assert err.decode().split() == line.split()  # click starts Ctrl-C's line on a new line
    assert not [pid for pid in workers if alive(pid)], "workers outlived the batch"
    left = _temporaries(out)
    assert not left, ([(p.name, sorted(q.name for q in p.rglob("*"))) for p in left], workers, err)
    assert (out / "a.parquet" / "report.json").is_file()
    assert not (out / "summary.md").exists()
    deadline = time.monotonic() + 30  # the forkserver is killed at exit, the tracker follows
    while _in_group(batch.pid) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not _in_group(batch.pid)
    if how == "sigterm":  # the next run resumes: the logs finished are skipped, no more
        simulated = sorted(logs.glob("[!.]*"))  # not simulate's records beside them
        finished = {log.name for log in simulated if (out / log.name / "report.json").is_file()}
        done = subprocess.run(
            _hybridlog("batch", str(logs), "--model", "three_tank_hstf", "--out", str(out),
                       "--jobs", "2"),
            cwd=ROOT, capture_output=True, text=True, timeout=WAIT_S,
        )  # fmt: skip
        assert done.returncode == 0, done.stderr
        statuses = (out / "summary.csv").read_text(encoding="utf-8").splitlines()[1:]
        assert [row.split(",")[:2] for row in statuses] == [
            [str(log), "skipped" if log.name in finished else "done"] for log in simulated
        ]
        assert not _temporaries(out)
