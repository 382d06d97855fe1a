"""``hybridlog.allocators``: polars' jemalloc set to return freed pages (fresh processes)."""

from __future__ import annotations

import os
import subprocess
import sys

from hybridlog.allocators import JEMALLOC_CONF, JEMALLOC_CONF_VARIABLE


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
