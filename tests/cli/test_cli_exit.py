"""The console script ends its process without the interpreter's teardown, losing nothing.

``hybridlog.cli.main`` without ``argv`` (the console script, ``python -m hybridlog``) runs the
atexit handlers, flushes both streams and calls ``os._exit`` with the command's exit code.
These run it in a child process, with stdout and stderr on pipes and
``PYTHONUNBUFFERED`` unset (both streams buffered).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from hybridlog.model.builtins import builtin_text

SCRIPT = """
import atexit, sys
atexit.register(lambda: print("atexit ran"))
sys.argv = ["hybridlog", *sys.argv[1:]]
from hybridlog.cli import main
main()
print("not reached: the process ends in main()")
"""


def _console(*args: str) -> subprocess.CompletedProcess[str]:
    buffered = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}
    return subprocess.run(
        [sys.executable, "-c", SCRIPT, *args], capture_output=True, text=True, env=buffered
    )


def test_output_is_flushed_atexit_handlers_run_and_nothing_after_main() -> None:
    done = _console("models", "three_tank_hstf")
    assert done.returncode == 0, done.stderr
    # the whole model text (fully buffered on a pipe: lost without the flush), then the
    # handler registered before the command, and nothing of the caller after main()
    assert done.stdout == builtin_text("three_tank_hstf").rstrip("\n") + "\natexit ran\n"


def test_exit_codes_are_the_commands(tmp_path: Path) -> None:
    log = tmp_path / "tank.csv"
    made = _console("simulate", "three_tank_hstf", "--steps", "60", "--out", str(log))
    assert made.returncode == 0 and log.exists(), made.stderr
    # a missed gate: exit 1 from inside the command, its line on stderr
    missed = _console(
        "analyze", str(log), "--model", "three_tank_hstf", "--out", str(tmp_path / "a"),
        "--fail-under", "vaf=101",
    )  # fmt: skip
    assert missed.returncode == 1, missed.stderr
    assert "gate failed: vaf" in missed.stderr and missed.stdout.endswith("atexit ran\n")
    assert (tmp_path / "a" / "report.json").exists()
    # bad input: exit 2, one line
    bad = _console("analyze", str(tmp_path / "missing.csv"), "--model", "three_tank_hstf")
    assert bad.returncode == 2
    assert bad.stderr.count("\n") == 1 and "missing.csv" in bad.stderr


def test_a_profiler_around_the_console_script_still_gets_its_output(tmp_path: Path) -> None:
    """``python -m cProfile -m hybridlog ...`` writes its statistics after ``main`` returns."""
    stats = tmp_path / "run.prof"
    done = subprocess.run(
        [sys.executable, "-m", "cProfile", "-o", str(stats), "-m", "hybridlog", "models"],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr
    assert "three_tank_hstf" in done.stdout and stats.stat().st_size > 0
