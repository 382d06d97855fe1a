"""A reader that closes the console script's stdout or stderr early changes no exit code.

``hybridlog models | head -1`` closes the pipe after one line: the next write fails with
``EPIPE``.  click made that exit code 1 (a missed CI gate) with nothing said, and the command
stopped there.  These run ``python -m hybridlog`` with a stream on a pipe whose reading end
is closed before the process starts (no race with a reader), or closed outright (``>&-``).
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator

import pytest


@pytest.fixture
def closed_pipe() -> Iterator[int]:
    """The writing end of a pipe nobody reads: every write to it fails with ``EPIPE``."""
    read, write = os.pipe()
    os.close(read)
    yield write
    os.close(write)


def _run(*args: str, **streams: int) -> int:
    command = [sys.executable, "-m", "hybridlog", *args]
    return subprocess.run(command, check=False, **streams).returncode  # type: ignore[call-overload,no-any-return]


@pytest.mark.parametrize(
    ("args", "code"),
    [
        (("models",), 0),
        (("models", "three_tank_hstf"), 0),
        (("--help",), 0),
        (("inspect", "--help"), 0),
        (("models", "nope"), 2),  # stdout gone, the error still said and its code kept
    ],
)
def test_a_closed_stdout_pipe_keeps_the_commands_exit_code(
    closed_pipe: int, args: tuple[str, ...], code: int
) -> None:
    assert _run(*args, stdout=closed_pipe, stderr=subprocess.DEVNULL) == code


def test_a_closed_stderr_pipe_keeps_the_error_exit_code(closed_pipe: int) -> None:
    assert _run("models", "nope", stdout=subprocess.DEVNULL, stderr=closed_pipe) == 2


@pytest.mark.parametrize(("args", "code"), [(("models",), 0), (("models", "nope"), 2)])
@pytest.mark.parametrize("stream", ["1", "2"])
def test_a_stream_closed_before_the_start_keeps_the_exit_code(
    stream: str, args: tuple[str, ...], code: int
) -> None:
    """``hybridlog models >&-``: Python starts with ``sys.stdout`` None (was a traceback)."""
    command = f'exec "$@" {stream}>&-'
    script = ["sh", "-c", command, "sh", sys.executable, "-m", "hybridlog", *args]
    result = subprocess.run(script, check=False, capture_output=True, text=True)
    assert result.returncode == code
    assert "Traceback" not in result.stdout + result.stderr


def test_a_stream_closed_before_the_start_is_no_file_of_the_command() -> None:
    """``analyze ... 2>&-`` exited 2 saying nothing: ``sys.stderr`` was ``None`` where the
    progress bars asked it whether it is a terminal, and the next file opened took
    descriptor 2 (what a library or a worker writes to standard error went into it)."""
    code = (
        "import os; from hybridlog.launch import tolerate_closed_output; "
        "tolerate_closed_output(); from hybridlog.cli_progress import _bars_shown; "
        "opened = os.open(os.devnull, os.O_RDONLY); "
        "print(_bars_shown(False), opened > 2, os.readlink('/proc/self/fd/0'))"
    )
    script = ["sh", "-c", 'exec "$@" <&- 2>&-', "sh", sys.executable, "-c", code]
    result = subprocess.run(script, check=False, capture_output=True, text=True)
    assert result.stdout.split() == ["False", "True", os.devnull]


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="no /dev/full")
def test_a_full_stdout_is_said_in_one_line_and_exit_2() -> None:
    """``hybridlog models > file`` on a full disk: "unexpected OSError ... (a bug ...)"."""
    with open("/dev/full", "w") as full:
        result = subprocess.run(
            [sys.executable, "-m", "hybridlog", "models"],
            check=False,
            stdout=full,
            stderr=subprocess.PIPE,
            text=True,
        )
    assert result.returncode == 2
    assert result.stderr == (
        "hybridlog: error: cannot write to standard output (No space left on device)\n"
    )


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="no /dev/full")
def test_an_error_that_cannot_be_said_keeps_its_exit_code() -> None:
    """``hybridlog models nope 2> file`` on a full disk ended 120 (Python's lost traceback)."""
    with open("/dev/full", "w") as full:
        assert _run("models", "nope", stdout=subprocess.DEVNULL, stderr=full.fileno()) == 2
