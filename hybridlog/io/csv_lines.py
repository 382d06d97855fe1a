"""The checks of a CSV log's lines before polars reads it, each naming the line.

Every record has as many fields as the header names (:func:`check_record_widths`, counted
by NumPy a block of bytes at a time, or by the ``csv`` module in a file with quotes), no
quoted field runs on past its line, the last line is ended (:func:`check_truncated`: a log
cut off), and a quote stands only where a field can hold one (:func:`refuse_stray_quote`).
"""

from __future__ import annotations

import csv
from collections.abc import Collection, Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from hybridlog.errors import LogError, excerpt
from hybridlog.io.csv_header import RECORD, read_csv_header
from hybridlog.signals import IntArray

COUNTED_AT_ONCE = 1 << 18
"""Bytes of a CSV file :func:`_count_separators` reads and counts at a time (256 KiB: of the
sizes measured, the fastest; 1 MiB took a fifth longer, 4 MiB half as long again)."""


COMMA, NEWLINE, QUOTE, CARRIAGE_RETURN = (ord(c) for c in ',\n"\r')


def refuse_stray_quote(path: Path) -> None:
    """Name the first line with a quote inside an unquoted field (``a"b``), if there is one.

    polars refuses such a file ("CSV malformed") without saying where; the ``csv`` module
    takes the quote as text.  Only called once polars has refused the file.

    Raises
    ------
    LogError
        Naming the line.
    """
    try:
        # lines end at newlines alone, as polars and sed count them (newline="" also ended
        # one at a carriage return alone, and named every line after it one too far on)
        with path.open(newline="\n", encoding="utf-8-sig") as handle:
            for number, line in enumerate(handle, start=1):
                text = line.rstrip("\r\n")
                if '"' in text and RECORD.fullmatch(text) is None:
                    raise LogError(
                        f"{path}, line {number}: a quote inside a field that is not quoted "
                        f'({excerpt(text, 60)}); a field is quoted whole, e.g. "1.5"'
                    )
    except (UnicodeDecodeError, OSError):
        return


def check_record_widths(path: Path, reading: Collection[str] = ()) -> None:
    """Every record has as many fields as the header names; blank lines aside.

    polars reads a record with too few fields as missing values, which would silently turn
    a damaged line into "no sample"; too many fields it refuses without saying where, and
    only when it reads every column: reading some (``columns=``), it takes a long line's
    first fields and drops the others.  Both are errors naming the line.  Without quote
    characters in the file, fields are counted from the comma and newline positions; with
    quotes, by the ``csv`` module.

    ``reading``: the columns polars reads once the check passes.  When they are every column
    of the header, the file's count of commas stands for each line's (one pass of NumPy, the
    common case): a short line and a long one cancel out in that count, and polars refuses
    the long one.  Otherwise (``reading`` empty: once polars has refused a file, to find the
    line) every line's commas are counted (:func:`_first_odd_line`): reading some columns,
    a short line and a long one had loaded as cells not measured and the long one's first
    fields.

    Raises
    ------
    LogError
        Naming the first line whose field count differs from the header's.
    """
    header = read_csv_header(path)
    width = len(header)
    quoted = False
    try:
        if reading and set(header) <= set(reading):
            commas, newlines, quoted, last = _count_separators(path)
            if not quoted and commas == (width - 1) * (newlines + (last != NEWLINE)):
                return  # every line has width - 1 commas, unless a short and a long one
                # cancel out, and polars refuses the long one when it reads every column
        odd = None if quoted else _first_odd_line(path, width)
        if odd is None:  # the file holds a quote
            line, fields, lone_cr = _first_odd_record(path, width)
        else:
            line, fields, start = odd
            lone_cr = line > 0 and _holds_lone_cr(path, start)
    except OSError as err:
        raise LogError(f"{path}: cannot be read ({err.strerror})") from err
    if line:
        why = ""
        if lone_cr:
            why = (
                " (a carriage return alone inside it, a line ending of classic Mac OS: "
                "hybridlog reads LF or CRLF line endings)"
            )
        raise LogError(
            f"{path}, line {line}: {fields} field{'' if fields == 1 else 's'}, but the header "
            f"names {width} columns{why}"
        )


def _holds_lone_cr(path: Path, start: int) -> bool:
    """Whether the line from byte ``start`` of the file holds a carriage return before its end.

    Read :data:`COUNTED_AT_ONCE` bytes at a time up to the line's end: a file of classic Mac
    OS line endings is one line.
    """
    with path.open("rb") as handle:
        handle.seek(start)
        before = b""  # the last byte read: a carriage return that a newline may follow
        while block := handle.read(COUNTED_AT_ONCE):
            text = before + block
            end = text.find(b"\n")
            if end >= 0:
                return b"\r" in text[:end].removesuffix(b"\r")
            if b"\r" in text[:-1]:
                return True
            before = text[-1:]
    return False


def _count_separators(path: Path) -> tuple[int, int, bool, int]:
    """The file's commas, its newlines, whether it holds a quote, and its last byte (-1: none).

    Read :data:`COUNTED_AT_ONCE` bytes at a time into one buffer and counted by NumPy: 35 ms
    for a 112 MiB file, against 0.21 s for reading it whole and counting with ``bytes.count``
    (which also held the file's bytes beside polars' reading of it).
    """
    buffer = bytearray(COUNTED_AT_ONCE)
    block = np.frombuffer(buffer, dtype=np.uint8)  # a view: it sees what is read into buffer
    commas = newlines = 0
    quoted = False
    last = -1
    with path.open("rb", buffering=0) as handle:
        while size := handle.readinto(buffer):
            part = block[:size]
            commas += int(np.count_nonzero(part == COMMA))
            newlines += int(np.count_nonzero(part == NEWLINE))
            quoted = quoted or bool((part == QUOTE).any())
            last = int(part[-1])
    return commas, newlines, quoted, last


def _first_odd_line(path: Path, width: int) -> tuple[int, int, int] | None:
    """Line number, field count and first byte of the first odd line of a file without quotes.

    Odd: not the header, not blank, and without ``width`` fields.  ``(0, 0, -1)`` when there
    is none, ``None`` when the file holds a quote (:func:`_first_odd_record` counts its
    fields then).

    Read :data:`COUNTED_AT_ONCE` bytes at a time into one buffer and counted a line at a
    time by :class:`_LineCommas`.  The file read whole had held its bytes and, for 10^7
    lines, 0.3 GB of positions beside them.
    """
    buffer = bytearray(COUNTED_AT_ONCE)
    block = np.frombuffer(buffer, dtype=np.uint8)  # a view: it sees what is read into buffer
    lines = _LineCommas(width)
    found = None
    with path.open("rb", buffering=0) as handle:
        while size := handle.readinto(buffer):
            part = block[:size]
            if (part == QUOTE).any():
                return None
            if found is None:
                found = lines.first_odd(part)
    return found or lines.last_odd() or (0, 0, -1)


class _LineCommas:
    """The commas of each line of a file given a block at a time (:func:`_first_odd_line`).

    In each block the separators (commas and newlines) are found once, and a line's commas
    are the separators between its newline and the one before: 0.14 s for the 112 MiB
    benchmark file, where NumPy's positions of the commas and of the newlines, paired by
    ``searchsorted``, took 0.20 s.  The line that runs on past a block is carried into the
    next: its number, first byte, commas so far, and whether it is blanks alone so far
    (looked at only while it has no comma).
    """

    def __init__(self, width: int) -> None:
        self.width = width
        self.line, self.start, self.commas, self.blank = 1, 0, 0, True
        self.offset = 0  # the file's bytes before the block

    def first_odd(self, part: np.ndarray[Any, np.dtype[np.uint8]]) -> tuple[int, int, int] | None:
        """Number, fields and first byte of the first odd line ending in the next block."""
        newline = part == NEWLINE
        separators = np.flatnonzero((part == COMMA) | newline)
        ends = np.flatnonzero(newline[separators])  # the newlines among the separators
        if not ends.size:
            self.commas += separators.size
            self.blank = self.blank and not self.commas and not part.tobytes().strip()
            self.offset += part.size
            return None
        counts = np.diff(ends, prepend=-1) - 1  # the commas of each line ending in the block
        counts[0] += self.commas
        stops = separators[ends]  # the lines' newlines, in the block
        starts = np.concatenate(([self.start - self.offset], stops[:-1] + 1))
        found = None
        for index in _odd_lines(part, counts, starts, stops, self.width):
            if self.line + index > 1 and (  # not the header
                counts[index] or not _blank(part, starts[index], stops[index], self.blank)
            ):
                found = self.line + index, int(counts[index]) + 1, self.offset + int(starts[index])
                break
        self.line += ends.size
        self.start = self.offset + int(stops[-1]) + 1
        self.commas = separators.size - int(ends[-1]) - 1
        self.blank = not self.commas and not part[stops[-1] + 1 :].tobytes().strip()
        self.offset += part.size
        return found

    def last_odd(self) -> tuple[int, int, int] | None:
        """The last line's number, fields and first byte if it is odd and has no line ending."""
        odd = self.commas != self.width - 1 and (self.commas or not self.blank)
        if self.offset > self.start and self.line > 1 and odd:
            return self.line, self.commas + 1, self.start
        return None


def _blank(part: np.ndarray[Any, np.dtype[np.uint8]], start: int, stop: int, before: bool) -> bool:
    """Whether ``part[start:stop]`` is blanks alone, ``before``: the line's bytes before ``part``.

    ``start`` is negative for a line that began in a block before.
    """
    return (before or start >= 0) and not part[max(start, 0) : stop].tobytes().strip()


def _odd_lines(
    part: np.ndarray[Any, np.dtype[np.uint8]],
    counts: IntArray,
    starts: IntArray,
    stops: IntArray,
    width: int,
) -> list[int]:
    """Lines (indices into ``counts``) without ``width - 1`` commas but for empty ones.

    An empty line (or a carriage return alone, of a CRLF file) is blank: left out here by
    NumPy, so that a file with a blank line between rows is not looked at a line at a time.
    """
    odd = np.flatnonzero(counts != width - 1)
    if not odd.size:
        return []
    length = stops[odd] - starts[odd]
    cr = part[np.maximum(stops[odd] - 1, 0)] == CARRIAGE_RETURN
    empty = (counts[odd] == 0) & (odd > 0) & ((length == 0) | ((length == 1) & cr))
    kept: list[int] = odd[~empty].tolist()
    return kept


def _first_odd_record(path: Path, width: int) -> tuple[int, int, bool]:
    """Like :func:`_first_odd_line` for files with quoted fields, by the ``csv`` module.

    Line number, field count, and whether a carriage return alone stands inside the line
    (``(0, 0, False)``: none odd).  Lines end at newlines alone, as polars and ``sed`` count
    them: a carriage return alone had ended a line for the ``csv`` module, so that a line
    ``0.1,1,2`` CR ``0.2,1,2`` passed as two records (polars then refused the file naming no
    line), and every line after it was named one too far on.

    A quoted field that runs over more than one line is refused here: no value of a log
    needs a line break, so it is an unclosed quote (which swallows the rest of the file
    into one record), and every line number reported later counts one record per line.

    A quote where a field cannot hold one (``"1.5"x``: text after a closing quote) is refused
    here too, naming its line: polars refuses it without saying where.

    Raises
    ------
    LogError
        Naming the line the multi-line field starts on and the line it runs to, or the line
        of a misplaced quote.
    """
    ended = 0
    lone: set[int] = set()  # the lines with a carriage return alone
    try:
        with path.open(newline="\n", encoding="utf-8-sig") as handle:
            reader = csv.reader(_lone_crs_as_text(handle, lone), strict=True)
            next(reader, [])
            ended = reader.line_num
            for record in reader:
                if reader.line_num > ended + 1:
                    _runs_on(path, ended, reader.line_num)
                ended = reader.line_num
                if record and len(record) != width and any(f.strip() for f in record):
                    return reader.line_num, len(record), reader.line_num in lone
    except UnicodeDecodeError:
        return 0, 0, False  # polars then says what it cannot parse
    except csv.Error as err:
        if reader.line_num > ended + 1:
            _runs_on(path, ended, reader.line_num)
        raise LogError(
            f"{path}, line {reader.line_num}: a quote where a field cannot hold one ({err}); "
            'a field is quoted whole, e.g. "1.5"'
        ) from None
    return 0, 0, False


def _lone_crs_as_text(lines: Iterable[str], lone: set[int]) -> Iterator[str]:
    """``lines`` (ended by newlines alone), a carriage return alone inside one a blank.

    polars reads such a carriage return as a character of its field; the ``csv`` module
    would refuse it in a field not quoted.  The numbers of those lines are added to ``lone``.
    """
    for number, line in enumerate(lines, start=1):
        text = line.removesuffix("\n").removesuffix("\r")
        if "\r" in text:
            lone.add(number)
            line = text.replace("\r", " ") + line[len(text) :]
        yield line


def _runs_on(path: Path, ended: int, line: int) -> None:
    """Refuse a quoted field that runs from the line after ``ended`` on to ``line``."""
    raise LogError(
        f"{path}, line {ended + 1}: a quoted field runs on to line {line}; a log's values "
        "fit on one line (an unclosed quote?)"
    )


def check_truncated(path: Path) -> None:
    """Reject a file whose last line has no line ending.

    That is what a log cut off while being written looks like: with fewer fields than the
    header polars would read the missing cells as empty, and with all of them the last
    number may itself be cut short (``69.78`` read as ``6``), which nothing in the line
    shows.  Every CSV writer ends its last line; a file that does not cannot be vouched for.
    """
    with path.open("rb") as handle:
        handle.seek(0, 2)
        size = handle.tell()
        handle.seek(max(0, size - 65536))
        tail = handle.read()
    if not tail or tail.endswith((b"\n", b"\r")):
        return
    last = tail.rsplit(b"\n", 1)[-1].decode("utf-8", errors="replace")
    fields = next(csv.reader([last]), [])
    width = len(read_csv_header(path))
    with path.open("rb") as handle:
        line = sum(chunk.count(b"\n") for chunk in iter(lambda: handle.read(1 << 20), b""))
    if line == 0:
        return  # the header alone: refused as a log without rows
    shown = f"{len(fields)} of {width} fields" if len(fields) < width else "all its fields"
    raise LogError(
        f"{path}, line {line + 1}: the last line ({shown}) has no line ending, so the file "
        "may have been cut off inside it; if that line is whole, end the file with a newline"
    )
