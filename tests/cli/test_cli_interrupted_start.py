"""Ctrl-C while the console script starts: one line and exit 130, no traceback of imports.

Before the CLI installs its handling (``hybridlog.cli.main``), a ``KeyboardInterrupt`` in
the imports printed Python's traceback; so did the batch workers' forkserver, which Ctrl-C
reaches too (the terminal's whole process group), in its first 0.1 s, before its warm-up
blocks ``SIGINT``.
"""

from __future__ import annotations

import subprocess
import sys
import types

import pytest

from hybridlog import launch


class _Interrupted(types.ModuleType):
    def __getattr__(self, name: str) -> object:
        raise KeyboardInterrupt


def test_ctrl_c_while_the_cli_is_imported_is_one_line(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setitem(sys.modules, "hybridlog.cli", _Interrupted("hybridlog.cli"))
    monkeypatch.setattr(sys, "argv", ["hybridlog", "models"])
    with pytest.raises(SystemExit) as ended:
        launch.main()
    assert ended.value.code == 130
    assert capsys.readouterr().err == "hybridlog: aborted\n"


FORKSERVER_SIGINT = """
import multiprocessing.forkserver, signal
from hybridlog.jobs.workers import start_forkserver
start_forkserver()
pid = multiprocessing.forkserver._forkserver._forkserver_pid
status = open(f"/proc/{pid}/status").read()
ignored = int(next(l for l in status.splitlines() if l.startswith("SigIgn:")).split()[1], 16)
own = signal.getsignal(signal.SIGINT) is signal.default_int_handler
print(bool(ignored >> (signal.SIGINT - 1) & 1), own)
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_the_forkserver_starts_with_sigint_ignored_and_the_caller_keeps_its_own() -> None:
    shown = subprocess.run(
        [sys.executable, "-c", FORKSERVER_SIGINT], capture_output=True, text=True, check=True
    )
    assert shown.stdout.split() == ["True", "True"]


DROPPED_WHILE_IMPORTED = """
import sys, types
from hybridlog import launch

class _Dropped:
    def __del__(self):  # Python drops what a finaliser raises: "Exception ignored in"
        raise KeyboardInterrupt

class _Cli(types.ModuleType):
    def __getattr__(self, name):
        _Dropped()  # Ctrl-C came inside the import system's weakref callback
        return lambda: print("ran to the end")

sys.modules["hybridlog.cli"] = _Cli("hybridlog.cli")
sys.argv = ["hybridlog", "models"]
launch.main()
"""


def test_ctrl_c_python_drops_while_the_cli_is_imported_still_aborts() -> None:
    # `compare` Ctrl-C'd 65 ms after it started printed "Exception ignored in: <function
    # _get_module_lock.<locals>.cb ...>", a traceback, then wrote its reports and exited 0
    ended = subprocess.run(
        [sys.executable, "-c", DROPPED_WHILE_IMPORTED], capture_output=True, text=True
    )
    assert (ended.returncode, ended.stdout, ended.stderr) == (130, "", "hybridlog: aborted\n")
