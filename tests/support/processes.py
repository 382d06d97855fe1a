"""Processes from /proc, for the tests of workers that must die with their batch (Linux)."""

from __future__ import annotations

import os
import signal
import subprocess
import time
from pathlib import Path

PROC = Path("/proc")
FORKSERVER = "multiprocessing.forkserver"
RESOURCE_TRACKER = "multiprocessing.resource_tracker"


def _stat(pid: int) -> list[str]:
    """The fields of ``/proc/<pid>/stat`` after the command name (state first)."""
    return (PROC / str(pid) / "stat").read_text().rsplit(")", 1)[1].split()


def alive(pid: int) -> bool:
    """Whether ``pid`` runs (a zombie has exited; only its parent's bookkeeping is left)."""
    try:
        return _stat(pid)[0] != "Z"
    except OSError:
        return False


def cmdline(pid: int) -> str:
    """The command line of ``pid``, arguments joined by spaces ("" once it is gone)."""
    try:
        return (PROC / str(pid) / "cmdline").read_bytes().replace(b"\0", b" ").decode()
    except OSError:
        return ""


def parent_of(pid: int) -> int | None:
    try:
        return int(_stat(pid)[1])
    except OSError:
        return None


def descendants(pid: int) -> dict[int, str]:
    """Living descendants of ``pid`` and their command lines."""
    children: dict[int, list[int]] = {}
    for entry in PROC.iterdir():
        if entry.name.isdigit() and (parent := parent_of(int(entry.name))) is not None:
            children.setdefault(parent, []).append(int(entry.name))
    found: dict[int, str] = {}
    todo = list(children.get(pid, []))
    while todo:
        child = todo.pop()
        if alive(child):
            found[child] = cmdline(child)
        todo += children.get(child, [])
    return found


def is_worker(pid: int) -> bool:
    """Whether ``pid`` is a batch worker: a process forked by multiprocessing's forkserver."""
    parent = parent_of(pid)
    return parent is not None and FORKSERVER in cmdline(parent)


def kill_and_expect_the_family_gone(
    process: subprocess.Popen[bytes] | subprocess.Popen[str],
    family: dict[int, str],
    within_s: float = 5.0,
) -> None:
    """``kill -9`` of ``process``; every process of ``family`` must be gone ``within_s``.

    ``family`` must hold the forkserver and the resource tracker (so the check covers them).
    """
    for kind in (FORKSERVER, RESOURCE_TRACKER):
        assert any(kind in command for command in family.values()), kind
    os.kill(process.pid, signal.SIGKILL)
    process.wait()
    killed_at = time.monotonic()
    while any(alive(pid) for pid in family) and time.monotonic() - killed_at < within_s:
        time.sleep(0.05)
    assert not [family[pid] for pid in family if alive(pid)]
