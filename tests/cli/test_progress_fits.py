"""Progress bars never draw a line wider than the terminal (hybridlog/fitted_lines.py).

A wrapped line is redrawn from its last row only: on a 20-column terminal batch's bar (about
110 columns) filled the screen with copies of itself.
"""

import io
import re

import click
import pytest

from hybridlog import cli, cli_progress
from hybridlog.fitted_lines import fitted

ESCAPE = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")
LABEL = "analysing nightly_runs/three_tank_hstf_with_a_long_name.csv"


class Terminal(io.StringIO):
    """What a terminal was sent; it says it is one."""

    def isatty(self) -> bool:
        return True


def widest(written: str) -> int:
    """The most columns any drawn line takes (escape sequences take none)."""
    return max(
        len(ESCAPE.sub("", part)) for line in written.split("\n") for part in line.split("\r")
    )


def draw(file: io.StringIO) -> None:
    with click.progressbar(
        length=3, label=LABEL, file=file, show_pos=True, item_show_func=lambda item: item
    ) as bar:
        for name in ("a.csv", "b_with_a_much_longer_name.parquet", "c.mcap"):
            bar.update(1, name)


@pytest.mark.parametrize("columns", [20, 50, 200])
def test_a_bars_lines_fit_the_terminal_and_keep_its_escapes(monkeypatch, columns):
    monkeypatch.setenv("COLUMNS", str(columns))
    plain, terminal = Terminal(), Terminal()
    draw(plain)
    draw(fitted(terminal))  # type: ignore[arg-type]
    written = terminal.getvalue()
    assert widest(plain.getvalue()) > 20  # what click alone draws
    assert widest(written) <= columns
    assert "\x1b[?25l" in written and "\x1b[?25h" in written  # the cursor hidden, shown
    if columns == 200:  # room for all of it: nothing cut
        assert written == plain.getvalue()


def test_the_commands_bars_are_fitted(monkeypatch):
    monkeypatch.setenv("COLUMNS", "20")
    monkeypatch.delenv("TERM", raising=False)
    terminal = Terminal()
    monkeypatch.setattr("sys.stderr", terminal)
    with cli_progress._work_progress(False, 4, LABEL) as advance:
        advance(2)
    with (
        click.Context(cli.cli),
        cli_progress._progress(click.get_current_context(), 2, LABEL) as step,
    ):
        assert step is not None
        step("a_log_with_a_long_name.csv")
    assert LABEL[:10] in terminal.getvalue()
    assert widest(terminal.getvalue()) <= 20


def test_wide_characters_take_two_columns(monkeypatch):
    # a log named in CJK: each character takes two columns, the line wrapped at 20
    monkeypatch.setenv("COLUMNS", "20")
    terminal = Terminal()
    lines = fitted(terminal)  # type: ignore[arg-type]
    lines.write("\r\x1b[?25l夜間試験の記録ファイル一覧表.csv  e\u0301t\u00e9")
    lines.write("\rab\u0301c\u0302" + "d" * 30)
    first, second = terminal.getvalue().split("\r")[1:]
    assert first == "\x1b[?25l夜間試験の記録ファイ"  # 10 wide characters: 20 columns
    assert second == "ab\u0301c\u0302" + "d" * 17  # combining accents take no column


def test_a_columns_value_int_cannot_read_is_not_a_width(monkeypatch):
    monkeypatch.setenv("COLUMNS", "\u00b2")  # str.isdigit() holds for '²'; int() raised
    assert fitted(Terminal()).write("\rbar") == 4  # type: ignore[attr-defined]
