"""``--sort`` of a table log: its rows in time order, the rows of one time one sample per column.

:func:`sorted_rows` puts the rows in time order, :func:`count_repeats` counts the rows at the
time of the one before, :func:`last_at_each_time` picks a column's sample at each time (its
last), and :func:`superseded_notes` says what was dropped: the reading's notes
``sorted``, ``rows_combined``, ``duplicates_dropped`` and ``values_superseded``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from hybridlog.io.source import last_of_each_time
from hybridlog.polars_import import pl
from hybridlog.signals import FloatArray, IntArray


def sorted_rows(
    frame: pl.DataFrame, rows: IntArray, time_ns: IntArray
) -> tuple[pl.DataFrame, IntArray, IntArray, int]:
    """Rows in time order (stable: rows of one time stay in file order).

    With how many rows were out of order (``sorted.rows_out_of_order``; 0: left as they
    were).
    """
    steps = np.diff(time_ns)
    if steps.size and (steps < 0).any():
        order = np.argsort(time_ns, kind="stable")
        out_of_order = int((steps < 0).sum())
        return frame[pl.Series(order)], rows[order], time_ns[order], out_of_order
    return frame, rows, time_ns, 0


def count_repeats(time_ns: IntArray) -> int:
    """How many rows of sorted ``time_ns`` repeat the time of the one before.

    Rows of one time are one sample per column (:func:`last_at_each_time`): a logger of
    sparse signals writes a row per signal, ``0.1,1,`` then ``0.1,,10``, and both values
    are samples at t = 0.1; the reading notes them as ``rows_combined``.
    """
    return int(np.count_nonzero(time_ns[1:] == time_ns[:-1]))


def last_at_each_time(
    time_ns: IntArray, repeats: bool, values: FloatArray | None = None
) -> np.ndarray[Any, np.dtype[np.bool_]] | None:
    """Which of a column's samples (at sorted ``time_ns``) to keep.

    The last at each time (with ``values``, ``--drop-nonfinite``: the last usable one,
    and the unusable ones for it to drop, :func:`~.source.last_of_each_time`); ``None``
    when every sample is kept, which is so when no time ``repeats``.  The rows of the
    others are those :func:`superseded_notes` is given.
    """
    if not repeats or time_ns.size < 2:
        return None
    last = last_of_each_time(time_ns, values)
    if last.all():
        return None
    return last


def superseded_notes(superseded: dict[str, IntArray], kept: list[IntArray]) -> dict[str, Any]:
    """The notes of what ``--sort`` dropped of the rows of a repeated time.

    ``superseded``: per column, the rows of its samples not kept; ``kept``: the rows of
    each column's samples kept.  ``duplicates_dropped``: rows none of whose cells read was
    kept (a row written twice); ``values_superseded``: per column, the values replaced by a
    later row's at the same time in rows that gave others.  Rows that each give other
    columns (a row per signal) lose nothing and are only counted in ``rows_combined``.
    """
    notes: dict[str, Any] = {}
    giving = np.unique(np.concatenate(kept)) if kept else np.zeros(0, dtype=np.int64)
    dropped_rows = np.setdiff1d(np.unique(np.concatenate(list(superseded.values()))), giving)
    if dropped_rows.size:
        notes["duplicates_dropped"] = int(dropped_rows.size)
    replaced = {
        name: int(np.count_nonzero(~np.isin(rows, dropped_rows)))
        for name, rows in superseded.items()
    }
    replaced = {name: count for name, count in replaced.items() if count}
    if replaced:
        notes["values_superseded"] = replaced
    return notes
