"""Progress bars: drawn on a terminal, never on a dumb one, a file or with ``--quiet``."""

from __future__ import annotations

import io

import click
import pytest

from hybridlog.cli import cli
from hybridlog.cli_options import _Context
from hybridlog.cli_progress import _progress, _work_progress


class _Terminal(io.StringIO):
    """A stderr that says it is a terminal."""

    def isatty(self) -> bool:
        return True


def _drawn(monkeypatch: pytest.MonkeyPatch, term: str, *, quiet: bool = False) -> str:
    stderr = _Terminal()
    monkeypatch.setattr("sys.stderr", stderr)
    monkeypatch.setenv("TERM", term)
    with _work_progress(quiet, 3, "potentials") as advance:
        advance(3)
    with click.Context(cli, obj=_Context(quiet=quiet)) as ctx, _progress(ctx, 2, "logs") as bar:
        if bar is not None:
            bar("a")
            bar("b")
    return stderr.getvalue()


def test_a_terminal_gets_the_bars(monkeypatch: pytest.MonkeyPatch) -> None:
    drawn = _drawn(monkeypatch, "xterm-256color")
    assert "potentials" in drawn and "logs" in drawn and "2/2" in drawn


@pytest.mark.parametrize(("term", "quiet"), [("dumb", False), ("xterm", True)])
def test_no_bar_on_a_dumb_terminal_or_with_quiet(
    monkeypatch: pytest.MonkeyPatch, term: str, quiet: bool
) -> None:
    """TERM=dumb printed click's cursor escapes (ESC[?25l) as they are, one per update."""
    assert _drawn(monkeypatch, term, quiet=quiet) == ""
