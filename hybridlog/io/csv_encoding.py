"""Where a CSV log stops being UTF-8: the line and column of its first byte that is not.

A CSV log is read as UTF-8.  A logger on Windows writes Latin-1 (``5°`` as the bytes
``35 b0``), Excel's "Unicode text" UTF-16: polars refuses both without saying where, and
Python's decoder says at which byte of a block.  :func:`refuse_not_utf8` names the line and
the column, and for UTF-16 says so.
"""

from __future__ import annotations

import codecs
import csv
from pathlib import Path
from typing import BinaryIO

from hybridlog.errors import LogError, excerpt

READ_AT_ONCE = 1 << 20
"""Bytes decoded at a time while looking for the first byte that is not UTF-8."""

_LINE_KEPT = 1 << 16
"""Bytes of a line kept to tell in which column a bad byte is; past that, no column."""

_BOMS = {codecs.BOM_UTF16_LE: "UTF-16", codecs.BOM_UTF16_BE: "UTF-16"}
_CONVERT = "hybridlog reads UTF-8 text: convert the file"


def refuse_not_utf8(path: Path) -> None:
    """Raise naming the first byte of ``path`` that is not UTF-8; return if there is none.

    Raises
    ------
    LogError
        ``<path>, line N, column 'u': byte 0xb0 is not UTF-8 ...``; for a file that starts
        with a UTF-16 byte-order mark, or with NUL bytes between its first two characters
        (UTF-16 without one), that it is UTF-16.
    """
    try:
        with path.open("rb") as handle:
            start = handle.read(4)
            if start.startswith(tuple(_BOMS)):
                raise LogError(
                    f"{path}: UTF-16 text (it starts with a UTF-16 byte-order mark); "
                    f"{_CONVERT}, e.g. iconv -f UTF-16 -t UTF-8"
                )
            order = _utf16_without_bom(start)
            if order:
                raise LogError(
                    f"{path}: UTF-16 text without a byte-order mark (NUL bytes between its "
                    f"first characters); {_CONVERT}, e.g. iconv -f UTF-16{order} -t UTF-8"
                )
            handle.seek(0)
            found = _first_bad_byte(handle)
    except OSError:
        return  # the reading proper says what is wrong
    if found is None:
        return
    line, before, byte = found
    where = _column(before, _header_text(path), line)
    raise LogError(
        f"{path}, line {line}{where}: byte 0x{byte:02x} is not UTF-8 (text written in "
        f"Latin-1 or another 8-bit encoding?); {_CONVERT}, e.g. iconv -f LATIN1 -t UTF-8"
    )


def _utf16_without_bom(start: bytes) -> str:
    """``LE`` or ``BE`` for four bytes that are two ASCII characters in UTF-16, else ``""``.

    ``t``, NUL, ``,``, NUL is UTF-16LE; a zeroed file (NULs only) is neither.
    """
    even, odd = start[0:4:2], start[1:4:2]
    if len(start) == 4 and odd == b"\0\0" and b"\0" not in even:
        return "LE"
    if len(start) == 4 and even == b"\0\0" and b"\0" not in odd:
        return "BE"
    return ""


def _first_bad_byte(handle: BinaryIO) -> tuple[int, bytes, int] | None:
    """``(line, bytes of that line before it, byte)`` of the first byte that is not UTF-8."""
    decoder = codecs.getincrementaldecoder("utf-8")()
    newlines = 0  # in the bytes decoded so far
    line = b""  # the bytes of the current line decoded so far (up to _LINE_KEPT)
    while True:
        chunk = handle.read(READ_AT_ONCE)
        pending: bytes = decoder.getstate()[0]
        try:
            decoder.decode(chunk, final=not chunk)
        except UnicodeDecodeError as err:
            data = bytes(err.object)
            good = data[: err.start]
            newlines += good.count(b"\n")
            cut = good.rfind(b"\n")
            line = (line + good)[-_LINE_KEPT:] if cut < 0 else good[cut + 1 :]
            return newlines + 1, line, data[err.start]
        if not chunk:
            return None
        seen = pending + chunk
        tail = seen[: len(seen) - len(decoder.getstate()[0])]
        newlines += tail.count(b"\n")
        cut = tail.rfind(b"\n")
        line = (line + tail)[-_LINE_KEPT:] if cut < 0 else tail[cut + 1 :][-_LINE_KEPT:]


def _header_text(path: Path) -> list[str]:
    """The header's names, bytes that are not UTF-8 replaced (only to name a column)."""
    with path.open("rb") as handle:
        first = handle.readline(_LINE_KEPT)
    text = first.decode("utf-8", errors="replace").lstrip("\ufeff").rstrip("\r\n")
    return [name.strip(" ") for name in _fields(text) or []]


def _column(before: bytes, header: list[str], line: int) -> str:
    """``, column 'u'`` for a bad byte after ``before`` on ``line``; ``""`` if unknown."""
    if len(before) >= _LINE_KEPT:
        return ""
    fields = _fields(before.decode("utf-8", errors="replace"))
    if fields is None:  # where the csv module cannot split the line, no column is named
        return ""
    index = max(len(fields), 1) - 1
    if line == 1:
        return f", column {index + 1} of the header"
    if index < len(header):
        return f", column {excerpt(header[index])}"
    return ""


def _fields(text: str) -> list[str] | None:
    """The fields of one line of ``text``; ``None`` where the :mod:`csv` module refuses it.

    A carriage return alone (classic Mac OS line endings, or a stray one) or a NUL byte in an
    unquoted field is an error to the :mod:`csv` module: naming the bad byte's column is a
    courtesy, and it raised in place of the refusal it was to make more precise.
    """
    try:
        return next(csv.reader([text]), [])
    except csv.Error:
        return None
