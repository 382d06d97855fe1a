"""``hybridlog.allocators``: freed memory goes back to the system (checked in fresh processes)."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from hybridlog.allocators import JEMALLOC_CONF, JEMALLOC_CONF_VARIABLE

RETAINED = """
import sys
import numpy as np
if sys.argv[1] == "set":
    from hybridlog.allocators import return_freed_memory
    assert return_freed_memory()

def anon_mib():
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith("RssAnon:"):
                return int(line.split()[1]) / 1024

np.ones(1 << 20)  # one 8 MiB block freed: glibc raises its threshold above 4 MiB
before = anon_mib()
blocks, pins = [], []
for _ in range(32):  # 128 MiB of 4 MiB columns, small objects allocated between them
    blocks.append(np.ones(1 << 19))
    pins.append(bytearray(4096))  # above pymalloc's 512 bytes: from malloc's heap
del blocks
print(anon_mib() - before)
"""


def _retained_mib(mode: str) -> float:
    done = subprocess.run(
        [sys.executable, "-c", RETAINED, mode], capture_output=True, text=True, check=True
    )
    return float(done.stdout)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc and /proc")
def test_freed_columns_leave_the_resident_set() -> None:
    # Without the setting glibc keeps the freed 4 MiB blocks in its heap (the small
    # objects between them stop it trimming): the measure is able to fail.
    assert _retained_mib("default") > 64
    assert _retained_mib("set") < 8


def test_jemalloc_configuration_only_before_polars_and_never_over_the_users() -> None:
    script = """
import os, sys
from hybridlog.allocators import JEMALLOC_CONF_VARIABLE, return_freed_memory
if sys.argv[1] == "user":
    os.environ[JEMALLOC_CONF_VARIABLE] = "narenas:2"
if sys.argv[1] == "late":
    import polars
return_freed_memory()
import polars
print(os.environ[JEMALLOC_CONF_VARIABLE])
"""
    # This process imported polars, which set the variable: the children start without it.
    env = {k: v for k, v in os.environ.items() if k != JEMALLOC_CONF_VARIABLE}
    seen = {
        mode: subprocess.run(
            [sys.executable, "-c", script, mode],
            capture_output=True,
            text=True,
            check=True,
            env=env,
        ).stdout.strip()
        for mode in ("fresh", "user", "late")
    }
    # polars puts its own settings first and what the variable held after them (later
    # options win): ours, or the user's instead of ours, or nothing once polars is loaded.
    assert seen["fresh"].endswith("," + JEMALLOC_CONF)
    assert seen["user"].endswith(",narenas:2")
    assert JEMALLOC_CONF not in seen["user"]
    assert JEMALLOC_CONF not in seen["late"]
