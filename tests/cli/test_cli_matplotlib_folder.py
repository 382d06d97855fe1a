"""The console script gives matplotlib a folder it can write where its own cannot be.

matplotlib keeps its settings and font list in ``~/.config/matplotlib`` and
``~/.cache/matplotlib``; where those could not be written (a read-only home in CI) every
command that draws printed matplotlib's two-line warning on stderr, under ``-q`` too.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from hybridlog.jit import cache_dir
from hybridlog.launch import writable_matplotlib_folder
from tests.support.paths import SAMPLE_LOGS


def _environment(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> Path:
    blocker = tmp_path / "a file"  # a folder under it can never be made, even by root
    blocker.write_text("")
    monkeypatch.delenv("MPLCONFIGDIR", raising=False)
    monkeypatch.setenv("XDG_CONFIG_HOME", str(blocker / "config"))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.setenv("HYBRIDLOG_CACHE_DIR", str(tmp_path / "hybridlog"))
    return tmp_path / "hybridlog" / "matplotlib"


def test_an_unwritable_matplotlib_folder_is_replaced_by_one_in_hybridlogs_cache(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    expected = _environment(monkeypatch, tmp_path)
    writable_matplotlib_folder()
    assert os.environ["MPLCONFIGDIR"] == str(expected) and not expected.exists()
    monkeypatch.setenv("MPLCONFIGDIR", "/the/users/own")  # a choice the user made stands
    writable_matplotlib_folder()
    assert os.environ["MPLCONFIGDIR"] == "/the/users/own"
    monkeypatch.delenv("MPLCONFIGDIR")
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "config"))  # both writable: unset
    writable_matplotlib_folder()
    assert "MPLCONFIGDIR" not in os.environ


def test_a_quiet_analyze_with_an_unwritable_home_says_nothing(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    cache = cache_dir()  # the compiled code's, warm: a fresh one compiled for seconds
    _environment(monkeypatch, tmp_path)
    monkeypatch.setenv("HYBRIDLOG_CACHE_DIR", str(cache))
    done = subprocess.run(
        [
            *(sys.executable, "-m", "hybridlog", "-q", "analyze"),
            *(str(SAMPLE_LOGS / "three_tank_hstf.csv"), "--model", "three_tank_hstf"),
            *("--estimator", "imm", "--out", str(tmp_path / "report")),
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert (done.returncode, done.stderr) == (0, "")
    assert (tmp_path / "report" / "plots" / "outputs.png").is_file()
