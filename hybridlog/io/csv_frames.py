"""A CSV log read by polars a block of lines at a time (:func:`.csv_tally.csv_blocks`).

:func:`read_csv_frame` reads the wanted columns as numbers or text, the lines checked first
(:mod:`.csv_lines`); :func:`csv_text_frames` gives them as text block by block, a file
polars cannot parse refused naming why; blank lines are rows of empty cells
(:func:`blank_rows`).
"""

from __future__ import annotations

import csv
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from hybridlog.errors import LogError
from hybridlog.io.csv_encoding import refuse_not_utf8
from hybridlog.io.csv_header import header_names, read_csv_header
from hybridlog.io.csv_lines import check_record_widths, check_truncated, refuse_stray_quote
from hybridlog.io.csv_numbers import parse_floats
from hybridlog.io.csv_tally import csv_blocks
from hybridlog.io.polars_errors import first_line, panics_refused
from hybridlog.polars_import import pl
from hybridlog.signals import IntArray


def first_cell(path: Path, index: int) -> str | None:
    """The first non-empty cell of column ``index`` in the first 1000 data lines of a CSV."""
    try:
        with path.open(newline="", encoding="utf-8-sig") as handle:
            reader = csv.reader(handle)
            next(reader, None)
            for record, _ in zip(reader, range(1000), strict=False):
                if len(record) > index and record[index].strip():
                    return record[index]
    except (UnicodeDecodeError, csv.Error, OSError):
        return None  # the reading proper says what is wrong
    return None


def _read_csv(path: Path, **options: Any) -> pl.DataFrame:
    """``pl.read_csv`` of a log, its blocks of lines (:func:`_csv_frames`) put end to end."""
    return pl.concat(list(_csv_frames(path, **options)))


def _csv_frames(path: Path, **options: Any) -> Iterator[pl.DataFrame]:
    """``pl.read_csv`` of each block of a log's lines (:func:`.csv_tally.csv_blocks`), in turn.

    Given the file, polars maps it into memory whole, and its pages count in the process's
    memory beside the columns read: 9 columns of 10^7 rows read from a 1.3 GB file peaked at
    1.8 GB.  Read from blocks, the file is read once, the blocks' bytes one at a time, and
    its name taken as Python takes it (polars takes only UTF-8 names,
    :func:`~hybridlog.polars_import.polars_file`).  ``columns`` and ``schema_overrides``
    name columns as :func:`read_csv_header` does (no spaces around), and so do the frames'
    columns.
    """
    names = header_names(path)
    written = {name: w for name, w in names.items() if name != w}
    if any('"' in name for name in names):
        written = _polars_names(path, names)
    if written:
        if "columns" in options:
            options["columns"] = [written.get(c, c) for c in options["columns"]]
        if "schema_overrides" in options:
            options["schema_overrides"] = {
                written.get(c, c): t for c, t in options["schema_overrides"].items()
            }
    renamed = {w: name for name, w in written.items()}
    for data in csv_blocks(path):
        with panics_refused(path, "CSV"):
            frame = pl.read_csv(data, **options)
        yield frame.rename(renamed, strict=False) if renamed else frame


def _polars_names(path: Path, names: Mapping[str, str]) -> dict[str, str]:
    """``{name: polars' name}`` of the columns of a CSV log whose names polars reads otherwise.

    A quote in a quoted name is written twice (``"a""b"``, RFC 4180), and polars 2.1 keeps
    both in a header's name (``a""b``) while the ``csv`` module reads the ``a"b`` that
    :func:`header_names` gives: polars then found no column ``a"b``, and the log was
    refused as "not a readable CSV file (unable to find column ...)".  polars' names are
    read from the header line and paired with ``names`` by position.
    """
    try:
        with path.open("rb") as handle:
            line = handle.readline()
    except OSError as err:
        raise LogError(f"{path}: cannot be read ({err.strerror})") from err
    try:
        with panics_refused(path, "CSV"):
            theirs = pl.read_csv(line, n_rows=0, infer_schema=False).columns
    except pl.exceptions.PolarsError:
        theirs = []
    if len(theirs) != len(names):
        return {name: w for name, w in names.items() if name != w}
    return {name: their for name, their in zip(names, theirs, strict=True) if name != their}


def read_csv_strings(path: Path, columns: list[str], *, checked: bool = False) -> pl.DataFrame:
    """Read ``columns`` as text (:func:`csv_text_frames`) put end to end."""
    return pl.concat(list(csv_text_frames(path, columns, checked=checked)))


def csv_text_frames(
    path: Path, columns: list[str], *, checked: bool = False
) -> Iterator[pl.DataFrame]:
    """``columns`` of each block of a log's lines as text; a file polars cannot parse refused.

    ``checked``: the caller already ran :func:`check_truncated` and
    :func:`check_record_widths`.

    Raises
    ------
    LogError
        Naming the file, and the line of a byte that is not UTF-8 or a stray quote.
    """
    if not checked:
        check_truncated(path)
        check_record_widths(path, columns)
    frames = _csv_frames(path, columns=columns, infer_schema=False)
    while True:
        try:
            frame = next(frames, None)
        except pl.exceptions.PolarsError as err:
            refuse_not_utf8(path)
            refuse_stray_quote(path)
            check_record_widths(path)
            raise LogError(f"{path}: not a readable CSV file ({first_line(err)})") from err
        if frame is None:
            return
        yield frame


def read_csv_frame(
    path: Path, columns: list[str], as_float: set[str], time_column: str
) -> pl.DataFrame:
    """Read ``columns``: those in ``as_float`` as ``Float64``, the others as text.

    A column of ``true`` and ``false`` reads as 1 and 0, but for ``time_column``
    (:func:`parse_floats`).

    The fast path lets polars parse the numbers; when that fails the columns are read as
    text and converted here, which tolerates surrounding blanks and finds the bad cell.
    """
    schema = {c: pl.Float64 if c in as_float else pl.String for c in columns}
    check_truncated(path)
    check_record_widths(path, columns)
    try:
        frame = _read_csv(path, columns=columns, schema_overrides=schema, infer_schema=False)
    except pl.exceptions.PolarsError:
        text = read_csv_strings(path, columns, checked=True)
        rows: IntArray = np.arange(text.height, dtype=np.int64)
        return text.with_columns(
            [
                parse_floats(path, text.get_column(c), rows, booleans=c != time_column)
                for c in columns
                if c in as_float
            ]
        )
    return frame


def empty_cells(column: pl.Series) -> np.ndarray[Any, np.dtype[np.bool_]]:
    """Which cells are empty: null, or text of nothing but blanks (`` ``, a tab, ``""``)."""
    if column.dtype == pl.String:
        empty: np.ndarray[Any, np.dtype[np.bool_]] = (
            (column.str.strip_chars() == "").fill_null(True).to_numpy()
        )
        return empty
    return column.is_null().to_numpy()


def blank_csv_rows(path: Path) -> np.ndarray[Any, np.dtype[np.bool_]]:
    """Rows that polars read from blank lines (:func:`blank_rows`), a block at a time.

    Read whole as text, a log of 10^7 rows of 9 columns with one blank line took 4 GB here.
    """
    columns = list(read_csv_header(path))
    blank = [blank_rows(frame) for frame in csv_text_frames(path, columns, checked=True)]
    return np.concatenate(blank)


def blank_rows(frame: pl.DataFrame) -> np.ndarray[Any, np.dtype[np.bool_]]:
    """Rows of a CSV frame read as text whose every cell is empty (:func:`empty_cells`).

    A line of spaces or a tab, ``,,`` and ``"",,`` are blank lines as an empty one is: the
    record-width check lets them through as such (:func:`check_record_widths`).
    """
    blank: np.ndarray[Any, np.dtype[np.bool_]] = (
        frame.select(pl.all_horizontal((pl.all().str.strip_chars() == "").fill_null(True)))
        .to_series()
        .to_numpy()
    )
    return blank
