"""The console script runs NumPy's OpenBLAS on one thread unless the user chose otherwise."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

PROBE = """
import atexit, os, sys

def probe():  # after the command: the console script runs atexit handlers, then ends
    import numpy as np
    np.ones((300, 300)) @ np.ones((300, 300))  # large enough for OpenBLAS to use its pool
    print(os.environ.get("OPENBLAS_NUM_THREADS"), len(os.listdir("/proc/self/task")))

atexit.register(probe)
sys.argv = ["hybridlog", "--version"]
from hybridlog.launch import main  # the console script's entry
main()
"""

FORKSERVER = """
import os, sys
import hybridlog.jobs.workers as workers

def spy():  # the environment the batch workers' forkserver is started with
    print(os.environ.get("OPENBLAS_NUM_THREADS"), flush=True)
    start()

start, workers.start_forkserver = workers.start_forkserver, spy
sys.argv = ["hybridlog", "batch", "a.csv", "b.csv", "--model", "nonexistent", "--jobs", "2"]
from hybridlog.launch import main
main()
"""


def _probe(**environment: str) -> list[str]:
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"} | environment
    done = subprocess.run(
        [sys.executable, "-c", PROBE], capture_output=True, text=True, check=True, env=env
    )
    return done.stdout.split()[-2:]


@pytest.mark.skipif(
    not sys.platform.startswith("linux") or (os.cpu_count() or 1) < 2,
    reason="counts the threads in /proc; a pool needs two cores",
)
def test_the_console_script_gives_openblas_one_thread_and_keeps_a_users_choice() -> None:
    assert _probe() == ["1", "1"]  # no pool thread beside the main one
    value, threads = _probe(OPENBLAS_NUM_THREADS="2")
    assert value == "2" and int(threads) == 2  # the user's setting stands: a pool thread


def test_the_batch_forkserver_starts_with_openblas_on_one_thread() -> None:
    # It is started before the CLI is imported (hybridlog.launch); its numpy, loaded once
    # there, is every worker's.
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    done = subprocess.run(
        [sys.executable, "-c", FORKSERVER], capture_output=True, text=True, env=env
    )
    assert done.returncode == 2, done.stderr  # the model does not exist
    assert done.stdout.split() == ["1"]
