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
from hybridlog.cli import main
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
