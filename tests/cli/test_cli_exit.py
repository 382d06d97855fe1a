"""The console script ends its process without the interpreter's teardown, losing nothing.

``hybridlog.cli.main`` without ``argv`` (the console script, ``python -m hybridlog``) runs the
atexit handlers, flushes both streams and calls ``os._exit`` with the command's exit code.
These run it in a child process, with stdout and stderr on pipes and
``PYTHONUNBUFFERED`` unset (both streams buffered).
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from hybridlog.model.builtins import builtin_text
from tests.support.models import POLE

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
        "--fail-under", "vaf=100",
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


def _left_running(marker: str) -> list[str]:
    """Processes whose command line holds ``marker``: the command's workers are its forks."""
    left = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                if marker in (entry / "cmdline").read_bytes().decode(errors="replace"):
                    left.append(entry.name)
            except OSError:
                continue
    return left


def test_an_estimator_error_in_the_workers_process_is_one_line(tmp_path: Path) -> None:
    """The estimator runs in the command's worker process: what it raises is the command's
    one-line error, exit 2, no output, and no process left behind."""
    model = tmp_path / "pole.toml"
    model.write_text(POLE)
    rows = ["t,u,y", *(f"{k},{0.0 if k == 11 else 1.0},{2.0}" for k in range(30))]
    log = tmp_path / "pole.csv"
    log.write_text("\n".join(rows) + "\n")
    out = tmp_path / "out"
    done = _console("analyze", str(log), "--model", str(model), "--estimator", "hstf",
                    "--out", str(out))  # fmt: skip
    assert done.returncode == 2, done.stderr
    assert done.stderr.count("\n") == 1 and "diverged at t = 12 s (sample 12)" in done.stderr
    assert not out.exists() and not _left_running(str(out))


@pytest.mark.parametrize("how", ["ctrl-c", "sigterm"])
def test_an_interrupted_analyze_ends_with_its_workers(tmp_path: Path, how: str) -> None:
    """Ctrl-C (SIGINT to the command's process group), or SIGTERM to the command alone (a
    CI job's timeout, ``kill``), while the estimator streams: the command and both its
    workers end, nothing is written and no temporary folder is left (SIGTERM's default
    action left one)."""
    import signal
    import time

    log = tmp_path / "long.parquet"
    made = _console("simulate", "three_tank_hstf", "--steps", "400000", "--out", str(log))
    assert made.returncode == 0, made.stderr
    out = tmp_path / "out"
    command = subprocess.Popen(
        [sys.executable, "-c", SCRIPT, "analyze", str(log), "--model", "three_tank_hstf",
         "--out", str(out)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True,
    )  # fmt: skip
    # Ctrl-C once the tables are being written: the stream has begun (not a fixed delay,
    # which a faster command outruns)
    deadline = time.monotonic() + 60
    while not any(tmp_path.glob(".out.hybridlog-tmp-*/timeline.csv")):
        assert command.poll() is None, "the command ended before its tables were begun"
        assert time.monotonic() < deadline, "no tables begun in 60 s"
        time.sleep(0.005)
    if how == "ctrl-c":
        os.killpg(command.pid, signal.SIGINT)
    else:
        os.kill(command.pid, signal.SIGTERM)
    _, err = command.communicate(timeout=60)
    if how == "ctrl-c":
        assert command.returncode in (130, -signal.SIGINT)
    else:
        assert command.returncode == 143 and err.decode() == "hybridlog: terminated\n"
    assert not out.exists() and not list(tmp_path.glob(".out.hybridlog-*"))
    deadline = time.monotonic() + 10
    while _left_running(str(out)) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not _left_running(str(out))


@pytest.fixture
def ending_signals() -> Iterator[None]:
    """The console script's handlers of SIGINT, SIGTERM and SIGHUP, in this process."""
    from hybridlog import cli_process

    saved = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
    hook = sys.unraisablehook
    cli_process._ENDING.clear()
    cli_process._handle_ending_signals()
    try:
        yield
    finally:
        cli_process._ENDING.clear()
        cli_process._RAISED.clear()
        sys.unraisablehook = hook
        for signum, handler in saved.items():
            signal.signal(signum, handler)


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP])
def test_a_second_signal_does_not_cut_the_removal_of_the_temporary_folder_short(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, ending_signals: None, signum: int
) -> None:
    """Ctrl-C twice, or SIGTERM then another (a CI runner, a user's second ``kill``): the
    second arrives while the first one's unwinding removes the half-written folder.  It is
    dropped: the folder is removed all the same and the command ends on the first (it was
    raised inside the removal, and left the folder)."""
    from hybridlog import cli_process, outputs
    from hybridlog.outputs import staging

    real_rmtree = shutil.rmtree

    def rmtree_interrupted(path: Any, *args: Any, **kwargs: Any) -> None:
        signal.raise_signal(signum)  # the second signal, in the clean-up
        real_rmtree(path, *args, **kwargs)

    monkeypatch.setattr(staging.shutil, "rmtree", rmtree_interrupted)
    expected = KeyboardInterrupt if signum == signal.SIGINT else cli_process._Terminated
    with pytest.raises(expected), outputs.atomic_output_dir(tmp_path / "out") as folder:
        (folder / "report.json").write_text("{}")
        signal.raise_signal(signum)  # the first
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_python_drops_in_a_finaliser_is_raised_after_it(
    ending_signals: None, signum: int, capsys: pytest.CaptureFixture[str]
) -> None:
    """Ctrl-C while numba compiled in a batch's own process (``--jobs 1``) came inside
    llvmlite's ``__del__``, where Python drops an exception ("Exception ignored in"): the
    batch went on to its end, exit 0, and every later Ctrl-C was dropped as the command was
    taken to be ending."""
    from hybridlog import cli_process

    cli_process._handle_ending_signals()  # again: pytest sets its own hook for the test's call

    class Finalised:
        def __del__(self) -> None:
            signal.raise_signal(signum)  # its exception is raised here, and dropped

    expected = KeyboardInterrupt if signum == signal.SIGINT else cli_process._Terminated
    deadline = time.monotonic() + 5
    with pytest.raises(expected):
        Finalised()  # finalised at once
        while time.monotonic() < deadline:
            time.sleep(0.01)
    assert "Exception ignored" not in capsys.readouterr().err


def test_an_ignored_sigint_stays_ignored(ending_signals: None) -> None:
    from hybridlog import cli_process

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    cli_process._handle_ending_signals()
    assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
