"""The header line of a CSV log: its column names, checked and without spaces around them.

A header that is empty, data, a comment, separated by semicolons or tabs, with a quote that
is not quoted whole, an unnamed, unprintable or duplicate name is refused naming line 1.
:data:`RECORD` is one record of fields as RFC 4180 writes them (:mod:`.csv_lines`).
"""

from __future__ import annotations

import csv
import re
from pathlib import Path

from hybridlog.errors import LogError, excerpt
from hybridlog.io.csv_encoding import refuse_not_utf8
from hybridlog.io.table_times import TIME_COLUMNS

LONGEST_HEADER = 1 << 20
"""The most characters line 1 is read to: a header longer than that is no log's.  Read to
its end, a file with no line end in its first 300 MB (a binary file, an image of zeros)
took 2.3 times its size in memory and ended in the :mod:`csv` module's error, unexpected."""


def read_csv_header(path: Path) -> tuple[str, ...]:
    """The column names of a CSV file, without the spaces around them (:func:`header_names`)."""
    return tuple(header_names(path))


def header_names(path: Path) -> dict[str, str]:
    """``{name: name as written}`` for the columns of a CSV file, in file order.

    Loggers that write ``t, u, y`` (a space after each comma) give the names ``" u"`` and
    ``" y"``, which no user means: names are taken without the ASCII spaces around them
    (the reading notes say so), unless that would make two of them the same.

    Raises
    ------
    LogError
        As :func:`_header_as_written`, and when two names differ only in spaces around them.
    """
    written = _header_as_written(path)
    names: dict[str, str] = {}
    for as_written in written:
        name = as_written.strip(" ")
        if name in names:
            raise LogError(
                f"{path}, line 1: the header's columns {excerpt(names[name])} and "
                f"{excerpt(as_written)} differ only in the spaces around them: rename one"
            )
        names[name] = as_written
    return names


def _header_as_written(path: Path) -> tuple[str, ...]:
    """Parse line 1 of a CSV file into column names as written, checking them."""
    try:
        with path.open(newline="", encoding="utf-8-sig") as handle:
            line = handle.readline(LONGEST_HEADER)
    except UnicodeDecodeError as err:
        refuse_not_utf8(path)
        raise LogError(f"{path}: not a UTF-8 text file ({err.reason})") from err
    except OSError as err:
        raise LogError(f"{path}: cannot be read ({err.strerror})") from err
    if not line:
        raise LogError(f"{path}: empty file")
    if not line.strip():
        raise LogError(f"{path}, line 1: no header (the first line must name the columns)")
    if line.endswith("\r"):  # newline="" ends a line at "\r\n", "\n" or a lone "\r"
        raise LogError(
            f"{path}, line 1: ends in a carriage return alone (classic Mac OS line endings); "
            "hybridlog reads LF or CRLF line endings: convert the file, e.g. tr '\\r' '\\n'"
        )
    if len(line) == LONGEST_HEADER and not line.endswith("\n"):
        raise LogError(
            f"{path}, line 1: no line end in its first {LONGEST_HEADER:,} characters: not the "
            "header of a CSV file (a binary file, or a file cut off or overwritten?)"
        )
    try:
        names = next(csv.reader([line]))
    except csv.Error as err:  # a field past the module's limit (131,072 characters)
        raise LogError(f"{path}, line 1: cannot be read as a CSV header ({err})") from None
    if names[-1].endswith("\n"):  # the line's end read into a quoted field left open
        raise LogError(
            f"{path}, line 1: the header's column {len(names)} opens a quote that runs on to "
            "line 2; a header names its columns on one line (an unclosed quote?)"
        )
    if '"' in line and RECORD.fullmatch(line.rstrip("\r\n")) is None:
        # t,u"x,y: polars opened a quote at u"x that ran to the end of the file and read
        # the log as 0 rows ("no data rows"), with no word of the quote
        raise LogError(
            f"{path}, line 1: a quote inside a column name that is not quoted "
            f'({excerpt(line.strip(), 60)}); a name with a quote is quoted whole, e.g. "u""x"'
        )
    if line.startswith("#") and not set(TIME_COLUMNS) & {name.strip(" ") for name in names}:
        # a comment line before the header, or numpy.savetxt's header ('# t,u,y'): the
        # columns were named '# t' or after the comment, and the next line "had 3 fields"
        raise LogError(
            f"{path}, line 1: {excerpt(line.strip(), 40)} starts with '#', a comment; the first "
            "line must be the header naming the columns, e.g. t,u,y: remove the comment "
            "lines (numpy.savetxt writes its header so unless given comments='')"
        )
    if len(names) == 1:
        # Excel in locales with a decimal comma writes ';', other tools tabs: one column
        # named 't;u;y' would be listed as the only column, or as text that is not printable
        for separator, word in ((";", "semicolons"), ("\t", "tabs")):
            if separator in line:
                raise LogError(
                    f"{path}, line 1: the header {excerpt(line.strip(), 40)} is separated by "
                    f"{word}; hybridlog reads comma-separated CSV (and a point as the "
                    "decimal separator): convert the file"
                )
    if all(_is_number(name) for name in names):
        raise LogError(
            f"{path}, line 1: no header; {excerpt(line.strip(), 40)} looks like data "
            "(the first line must name the columns, e.g. t,u,y)"
        )
    for position, name in enumerate(names, start=1):
        if not name.strip():
            why = ""
            if position == len(names):
                why = " (a separator at the end of the line?)"
            elif position == 1:
                why = " (pandas' to_csv writes its index so: write with index=False)"
            raise LogError(f"{path}, line 1: column {position} of the header has no name{why}")
        if not name.isprintable():
            if "\x00" in name:
                refuse_not_utf8(path)  # UTF-16 without a byte-order mark, ASCII header
            raise LogError(
                f"{path}, line 1: column {position} of the header, {excerpt(name, 40)}, is not "
                "printable text (a zeroed or binary file?)"
            )
    seen: set[str] = set()
    for name in names:
        if name in seen:
            raise LogError(f"{path}, line 1: duplicate column name {excerpt(name)} in the header")
        seen.add(name)
    return tuple(names)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


_FIELD = r'(?:[^",\r\n]*|\s*"(?:[^"]|"")*"\s*)'


RECORD = re.compile(rf"{_FIELD}(?:,{_FIELD})*")
