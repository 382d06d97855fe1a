"""Label columns of a table log (mode ids) as small integer codes of stripped text.

:func:`label_codes` works on a column's distinct values only; :func:`_as_labels` says how a
cell is written as a label (a whole float as an integer, a Boolean as 0 or 1).
"""

from __future__ import annotations

import numpy as np

from hybridlog.io.exact import EXACT_LIMIT
from hybridlog.polars_import import pl
from hybridlog.signals import IntArray


def _as_labels(column: pl.Series, *, written: bool = False) -> pl.Series:
    """Mode ids as stripped text; integer-valued floats lose their ``.0``.

    A float column (Parquet) holds numbers: each whole one is written as an integer (``1.0``
    is mode ``1`` beside ``2.5``, as in a message log,
    :func:`hybridlog.io.message_paths.as_label`).  So does a column of cells as written
    (``written``: a CSV file, which has no types) whose every cell is a number: each cell
    written as a float (``1.0``, ``2e0``: pandas writes an integer column with a gap so)
    that is whole is read as an integer (but an id beyond 2^53 keeps its digits: a
    ``float64`` would merge it with others, :mod:`~hybridlog.io.exact`), every other cell
    as written.  Cell by cell: a column of ``1.0`` and ``1.5`` was read as written
    throughout when some cell was not whole, and refused naming the first ``1.0`` rather
    than the ``1.5``.  A text column of a typed table (Parquet ``String``) is text, as a
    ROS ``string`` or a JSON string is: ``"1.0"`` there is no mode ``1``.  A Boolean column
    is mode ``0`` or ``1``, as a ROS ``bool`` or a JSON boolean is (it read ``'true'``, no
    mode of a model whose modes are ``0`` and ``1``).  A decimal column holds numbers too:
    a whole one is written without its zero decimals (``1.00`` is mode ``1``; it was
    refused as no mode ``'1.00'``), every digit kept (no ``float64`` on the way).
    """
    if column.dtype == pl.String and written:
        text = column.str.strip_chars()
        cells = text.filter(text != "").drop_nulls()
        if cells.len() and not cells.cast(pl.Float64, strict=False).is_null().any():
            floats = text.cast(pl.Float64, strict=False)
            whole = (
                text.str.contains("[.eE]")
                & floats.is_finite()
                & (floats == floats.round(0))
                & (floats.abs() < EXACT_LIMIT)
            )
            column = pl.select(
                pl.when(whole)
                .then(floats.cast(pl.Int64, strict=False).cast(pl.String))
                .otherwise(text)
            ).to_series()
    if column.dtype == pl.Boolean:  # as a ROS bool or a JSON boolean reads: mode 0 or 1
        column = column.cast(pl.Int8)
    dtype = column.dtype
    # NaN and infinities keep their text ('NaN', 'inf'), which names no mode and is refused
    # with its row: cast to an integer they became empty cells, no sample, and so did a
    # whole number beyond int64
    if dtype.is_float() and bool(column.is_finite().any()):
        whole = column.cast(pl.Int64, strict=False)
        exact = whole.is_not_null() & (whole.cast(pl.Float64) == column)
        column = pl.select(
            pl.when(exact).then(whole.cast(pl.String)).otherwise(column.cast(pl.String))
        ).to_series()
    text = column.cast(pl.String).str.strip_chars()
    if isinstance(dtype, pl.Decimal):  # a number: 1.00 is mode 1, as a float column's 1.0
        text = text.str.replace(r"^(-?[0-9]+)\.0*$", "${1}")
    return pl.select(pl.when(text != "").then(text)).to_series().alias(column.name)


def label_codes(column: pl.Series, *, written: bool = False) -> tuple[IntArray, tuple[str, ...]]:
    """Mode-id codes of a label column: ``(codes, labels)``, code -1 where a cell is empty.

    ``labels`` are the distinct stripped labels (:func:`_as_labels`; ``written`` for a CSV
    file's cells) in order of first appearance; ``codes[i]`` indexes them.  Labels are
    worked out on the column's distinct values only, and each cell becomes a small integer
    code through an ``Enum`` of them: a 10^6-row column of a few mode ids costs a few MB, not
    the string copies of the whole column that stripping and mapping it cell by cell made
    (about 50 MB).
    """
    text = column if column.dtype == pl.String else _as_labels(column)
    distinct = text.unique(maintain_order=True).drop_nulls()
    first: dict[str, int] = {}
    lookup: list[int] = []
    for label in _as_labels(distinct, written=written).to_list():
        lookup.append(-1 if label is None else first.setdefault(label, len(first)))
    lookup.append(-1)  # empty cells (null)
    physical = text.cast(pl.Enum(distinct.to_list())).to_physical()
    index = physical.fill_null(distinct.len()).to_numpy()
    codes: IntArray = np.asarray(lookup, dtype=np.int64)[index]
    return codes, tuple(first)
