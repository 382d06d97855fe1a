"""Fixtures shared by the tests of every package."""

from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path

import pytest

from tests.support.paths import SAMPLE_LOGS

Main = Callable[[list[str]], tuple[int, str]]


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
