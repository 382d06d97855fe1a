r"""A terminal stream whose redrawn lines are cut to the terminal's width (the progress bars).

click's progress bar redraws its line by returning to its start (``\r``); a line longer
than the terminal wraps, and each redraw then returns to the start of its last row only:
on a narrow terminal, or a split pane narrower than the bar's line (label, bar, position
and the item shown beside it: about 110 columns for batch), the screen filled with copies
of the bar.  The bars are sized to the terminal (click's ``width=0``: the bar takes the
columns the rest of the line leaves), and :func:`fitted` cuts every line it is given,
after each ``\r``, to the terminal's width where the rest alone is wider (a narrow
terminal, or stdout redirected, whose width click reads), counting what a terminal shows:
escape sequences (click's hidden cursor, ``ESC[?25l``) and combining marks take no column,
a wide character (CJK, most emoji, in a log's file name) takes two.
"""

from __future__ import annotations

import os
import re
import shutil
import unicodedata
from typing import TextIO, cast

__all__ = ["FittedLines", "fitted"]

_ESCAPE = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")
"""A CSI escape sequence (cursor shown or hidden, line erased): no column on the screen."""


def _width(character: str) -> int:
    """The columns a terminal gives ``character``: 2 East Asian wide, 0 a combining mark."""
    if unicodedata.combining(character) or unicodedata.category(character) in ("Me", "Cf"):
        return 0
    return 2 if unicodedata.east_asian_width(character) in ("W", "F") else 1


def _fit(text: str, room: int) -> tuple[str, int]:
    """The longest start of ``text`` that takes at most ``room`` columns, and its columns."""
    used = 0
    for index, character in enumerate(text):
        width = _width(character)
        if used + width > room:
            return text[:index], used
        used += width
    return text, used


def _cut(line: str, columns: int) -> str:
    """``line`` taking no more than ``columns`` columns; escape sequences kept."""
    kept: list[str] = []
    shown = 0
    at = 0
    for escape in _ESCAPE.finditer(line):
        text, used = _fit(line[at : escape.start()], columns - shown)
        kept += [text, escape.group()]
        shown += used
        at = escape.end()
    kept.append(_fit(line[at:], columns - shown)[0])
    return "".join(kept)


class FittedLines:
    r"""``stream`` (a terminal) with each line written to it cut to the terminal's width.

    The width is read at every write, so a terminal resized during the work is followed.
    Line breaks pass unchanged: only what follows a ``\r`` or starts a line is cut.
    """

    def __init__(self, stream: TextIO) -> None:
        self._stream = stream

    def columns(self) -> int:
        """The terminal's width: ``$COLUMNS``, else the stream's own terminal's, else 80.

        The stream's, not stdout's (``shutil.get_terminal_size``'s): ``hybridlog batch ... >
        out.txt`` draws its bars on stderr, a terminal whose width stdout does not know.
        """
        given = os.environ.get("COLUMNS", "")
        if given.isdecimal() and int(given) > 0:  # isdigit() holds for '²', int() refuses
            return int(given)
        try:
            return os.get_terminal_size(self._stream.fileno()).columns or 80
        except (AttributeError, OSError, ValueError):
            return shutil.get_terminal_size().columns

    def write(self, text: str) -> int:
        """Write ``text``, each of its lines cut to the terminal's width."""
        columns = max(self.columns(), 1)
        fitted = "\n".join(
            "\r".join(_cut(part, columns) for part in line.split("\r")) for line in text.split("\n")
        )
        self._stream.write(fitted)
        return len(text)

    def flush(self) -> None:
        """Flush the terminal's stream."""
        self._stream.flush()

    def isatty(self) -> bool:
        """Whether the stream is a terminal (click draws a bar only there)."""
        return self._stream.isatty()

    def fileno(self) -> int:
        """The stream's file descriptor."""
        return self._stream.fileno()


def fitted(stream: TextIO) -> TextIO:
    """``stream`` as a :class:`FittedLines`, typed as what click's bar writes to."""
    return cast(TextIO, FittedLines(stream))
