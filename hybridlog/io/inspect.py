"""``hybridlog inspect``: what a log holds, as a JSON-serialisable dict and as text."""

from __future__ import annotations

import os
from typing import Any

from hybridlog.io.readers import open_log


def inspect_log(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Describe a log: fields, types, counts, value ranges, time span, rate and gaps.

    Parameters
    ----------
    path:
        The log file.

    Returns
    -------
    dict
        For tables: ``path, format, rows, columns`` (each ``name, dtype, count, min, max,
        rate_hz``), ``time`` (``column, start, end, duration``) or ``None``, ``sample_time``
        (median step, s), ``rate_hz``, ``gaps`` (``start, end, duration`` of every step
        longer than 1.5 times the median; at most 1000 listed), ``gap_count`` and
        ``problems`` (why the time column is unusable, if it is).  Only plain ``str``,
        ``int``, ``float``, ``None``, lists and dicts, so ``json.dumps`` takes it as is.

    Raises
    ------
    LogError
        When the file is missing, of an unsupported format, or unreadable.
    """
    with open_log(path) as source:
        return source.describe()


def format_inspection(info: dict[str, Any]) -> str:
    """Render :func:`inspect_log`'s dict as a human-readable text table.

    Parameters
    ----------
    info:
        The dict returned by :func:`inspect_log`.

    Returns
    -------
    str
        Several lines, without a trailing newline.
    """
    lines = [f"{info['path']} ({info['format']}, {info['rows']} rows)"]
    span = info.get("time")
    if span is not None:
        text = (
            f"time: column {span['column']!r}, {_at(span['start'])} s to {_at(span['end'])} s"
            f" ({_num(span['duration'])} s)"
        )
        if info.get("sample_time") is not None:
            text += f", sample time {_num(info['sample_time'])} s ({_num(info['rate_hz'])} Hz)"
        lines.append(text)
    gaps = info.get("gaps") or []
    count = int(info.get("gap_count", len(gaps)))
    if span is not None:
        if count == 0:
            lines.append("gaps: none")
        else:
            lines.append(f"gaps: {count} step(s) longer than 1.5 x the sample time")
            for gap in gaps[:10]:
                lines.append(
                    f"  {_at(gap['start'])} s to {_at(gap['end'])} s ({_num(gap['duration'])} s)"
                )
            if count > 10:
                lines.append(f"  ... {count - 10} more")
    header = ("column", "dtype", "count", "min", "max", "rate_hz")
    rows = [
        (
            str(c["name"]),
            str(c["dtype"]),
            str(c["count"]),
            _num(c["min"]),
            _num(c["max"]),
            _num(c.get("rate_hz")),
        )
        for c in info.get("columns", [])
    ]
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]
    lines.append("")
    for row in [header, *rows]:
        lines.append("  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=True)).rstrip())
    problems = info.get("problems") or []
    if problems:
        lines.append("")
        lines.append("problems:")
        lines.extend(f"  {p}" for p in problems)
    return "\n".join(lines)


def _num(value: Any) -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:.6g}"
    return str(value)


def _at(seconds: float) -> str:
    """A time stamp to the microsecond, readable also at Unix-epoch magnitudes."""
    return f"{seconds:.6f}".rstrip("0").rstrip(".")
