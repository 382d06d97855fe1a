"""Fixtures shared by the tests of every package."""

from __future__ import annotations

import os
import shutil
from collections.abc import Callable
from pathlib import Path

import pytest

from hybridlog.jit import cache_dir
from tests.support.paths import SAMPLE_LOGS

Main = Callable[[list[str]], tuple[int, str]]


def pytest_configure(config: pytest.Config) -> None:
    """numba's machine code in the user's cache for the whole session (and its subprocesses).

    Tests set ``HYBRIDLOG_CACHE_DIR`` to folders of their own: without this, the first test
    to compile in a process would place the session's machine code in its temporary folder
    (:func:`hybridlog.jit.machine_code_dir`), compiled anew in every session.
    """
    os.environ.setdefault("NUMBA_CACHE_DIR", str(cache_dir() / "numba"))


@pytest.fixture
def hybridlog_main(capsys: pytest.CaptureFixture[str]) -> Main:
    """``hybridlog ARGS`` in this process: its exit code and what it wrote on stderr.

    The console entry point itself (:func:`hybridlog.cli.main`), so what a user sees --
    one-line errors, exit codes, no tracebacks -- is what the test sees.
    """
    from hybridlog.cli import main

    def run(args: list[str]) -> tuple[int, str]:
        capsys.readouterr()
        code = 0
        try:
            main(args)
        except SystemExit as done:
            code = int(done.code or 0)
        return code, capsys.readouterr().err

    return run


@pytest.fixture
def sample_copy(tmp_path: Path) -> Callable[[str], Path]:
    """Copy a sample log (file or bag folder) into the test's folder and return the copy."""

    def copy(name: str) -> Path:
        source = SAMPLE_LOGS / name
        target = tmp_path / Path(name).name
        if source.is_dir():
            shutil.copytree(source, target)
        else:
            shutil.copyfile(source, target)
        return target

    return copy
