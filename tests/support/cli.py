"""Running the CLI in the test's own process."""

from __future__ import annotations

import pytest

from hybridlog.cli import main


def run_main(args: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    """``hybridlog ARGS`` through ``main``: the exit code and what was printed (out + err)."""
    capsys.readouterr()
    try:
        main(args)
    except SystemExit as exit_:
        code = int(exit_.code or 0)
    else:
        code = 0
    captured = capsys.readouterr()
    return code, captured.out + captured.err
