"""``hybridlog inspect``: what a log holds, as a JSON-serialisable dict and as text."""

from __future__ import annotations

import os
import unicodedata
from collections.abc import Iterable, Sequence
from dataclasses import replace
from typing import Any

from hybridlog.errors import LogError, as_text, excerpt, names_apart
from hybridlog.io.formats import open_log
from hybridlog.io.mcap_reader import UnfinishedLogError
from hybridlog.io.options import ReadOptions, log_arguments
from hybridlog.times import format_duration, format_time


def inspect_log(path: str | os.PathLike[str], options: ReadOptions | None = None) -> dict[str, Any]:
    """Describe a log: fields, types, counts, value ranges, time span, rate and gaps.

    An unfinished MCAP file (no footer), or a ROS 2 bag whose MCAP storage file is
    unfinished, is described as far as that file can be read sequentially (the file's own
    description), with the reason in ``problems``; one whose sequential read reaches no
    whole message is a :class:`LogError` saying so.

    Parameters
    ----------
    path:
        The log file (or ROS 2 bag directory).
    options:
        How to read; ``msg_dirs`` lets the fields of custom message types be listed.

    Returns
    -------
    dict
        For tables: ``path, format, rows, columns`` (each ``name, dtype, count, nonfinite,
        min, max`` and the step keys below of the column's own samples, its non-empty
        cells; an entry per field and element of a Parquet struct, list or array column),
        ``time`` (``column, start, end, duration``) or ``None``, the
        time column's steps (``rate_hz``, ``sample_time``, ``min_step``, ``max_step``,
        ``regular``, ``repeated``, ``gaps``, ``gap_count``) and ``problems`` (why the time
        column is unusable, if it is).  For bags and MCAP files: ``path, format`` (and an
        MCAP file's ``profile``), ``messages, topics`` (each ``name, type, encoding, count,
        indexed_count, start, end, duration``, the same step keys, ``nonfinite``, ``values``,
        ``undecodable``, ``header_stamp`` and ``fields``), ``time`` (``start, end,
        duration``), ``problems`` and ``reading`` (and an MCAP file's ``attachments`` and
        ``metadata_records``, :class:`~hybridlog.io.mcap_side_records.SideRecords`).  The
        times are log times;
        ``header_stamp`` is what ``--time header`` reads instead (``start, end``,
        ``offset``: the median of stamp minus log time, ``count``), ``None`` for a topic
        without one, and ``problems`` name the stamps that option refuses or that lie a
        second or more from their log times.
        Only plain ``str``, ``int``, ``float``, ``bool``, ``None``, lists and dicts, so
        ``json.dumps`` takes it as is.

        Timing (:func:`~hybridlog.io.summary.describe_steps`): ``rate_hz`` is the mean rate
        over the span, ``(count - 1) / duration``; ``sample_time`` is the median step, with
        ``min_step`` and ``max_step`` its spread; ``regular`` says whether every step lies
        within a factor 1.5 of the median; a gap is a step longer than 1.5 times the median
        (at most 1000 listed, all counted in ``gap_count``); ``repeated`` counts the samples
        logged at the time of the one before (``analyze`` refuses them unless ``--sort``).
        Steps, spans and gap lengths of float seconds are rounded to the digits the times
        hold (:func:`~hybridlog.io.summary.round_span`: to the microsecond near 1.7e9 s).

        Values: ``count`` counts the samples (non-empty cells, or messages), ``nonfinite``
        those that are NaN, infinite or out of range (``|value| >= 2^480``), which ``analyze``
        refuses in a mapped signal (unless ``--drop-nonfinite``).  A topic's ``values`` lists
        ``name, count, nonfinite`` per field that can hold them (the ``float32``/``float64``
        fields of ROS messages, every number of JSON messages, inside arrays of messages or
        objects too, named with ``[]``; arrays counted element by element); its ``nonfinite``
        is their sum.  Both are ``None`` where the messages cannot be decoded; where only some
        cannot, they are the others' (as are ``fields`` and ``header_stamp``), and
        ``undecodable`` gives how many could not and the earliest one's log time (``count``,
        ``first``; ``None`` where every message was decoded), as ``problems`` does; ``nonfinite`` is
        ``None`` too for a column that is not numeric.  The first number of a column or
        field that ``analyze`` refuses as one a ``float64`` does not hold (an integer beyond
        2^53, a CSV number beyond 1.8e308) is in ``problems``, in ``analyze``'s words, as is
        the first text in a JSON field that holds numbers in other messages, and the first
        cell of a CSV column of numbers that is not one (``line 4, column 'y': '0x10' is not
        a number``; the column's ``dtype`` is then ``string``).

    Raises
    ------
    LogError
        When the file is missing, of an unsupported format, or unreadable (an unfinished
        MCAP file of no readable message too).
    OptionError
        A ``path`` that is no path, or ``options`` that are no :class:`ReadOptions`.
    """
    options = log_arguments(path, options)
    try:
        source = open_log(path, options)
    except UnfinishedLogError as err:
        if not err.readable:
            # nothing to describe: said without the hint at --recover, which inspect lacks
            # (reading on, its sequential read failed as "--recover reads no message")
            raise LogError(f"{os.fspath(path)}: {err.finding}") from None
        source = open_log(err.file, replace(options, recover=True))
        with source:
            info = source.describe()
        # err's message ends with a hint at --recover, an option inspect has no use for
        info["problems"] = [err.finding, *info["problems"]]
        return info
    with source:
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
    if "topics" in info:
        return _format_messages(info)
    lines = [f"{_shown(info['path'])} ({info['format']}, {_count(info['rows'], 'row')})"]
    span = info.get("time")
    if span is not None:
        text = (
            f"time: column {_shown(span['column'], quoted=True)}, {_at(span['start'])} s to "
            f"{_at(span['end'])} s ({_duration(span['duration'])} s)"
        )
        if info.get("sample_time") is None:
            lines.append(text)
        elif info.get("regular", True):
            lines.append(f"{text}, sample time {_duration(info['sample_time'])} s ({_hz(info)})")
        else:
            lines.append(f"{text}, {_hz(info)} on average")
            lines.append(f"timing irregular: {_steps(info)}")
    gaps = info.get("gaps") or []
    count = int(info.get("gap_count", len(gaps)))
    if span is not None:
        if count == 0:
            lines.append("time gaps: none")
        else:
            lines.append(f"time gaps: {_count(count, 'step')} longer than 1.5 x the median step")
            for gap in gaps[:10]:
                lines.append(
                    f"  {_at(gap['start'])} s to {_at(gap['end'])} s "
                    f"({_duration(gap['duration'])} s)"
                )
            if count > 10:
                lines.append(f"  ... {count - 10} more")
        if info.get("repeated"):
            lines.append(
                f"repeated times: {_count(info['repeated'], 'row')} at the time of the one "
                "before (analyze refuses them unless --sort, which combines the rows of a time "
                "into one sample per column)"
            )
    columns = info.get("columns", [])
    time_column = span["column"] if span is not None else None
    header = ("column", "dtype", "count", "nonfinite", "min", "max", "rate_hz", "gaps")
    rows = []
    # two names alike but for their Unicode form (café NFC and NFD) are written apart
    names = names_apart([str(c["name"]) for c in columns])
    for c, name in zip(columns, names, strict=True):
        # the time column's range as times: 1.7e+09 to 1.7e+09 said nothing of a Unix time
        extreme = _at_or_dash if c["name"] == time_column else _num
        rows.append(
            (
                name,
                str(c["dtype"]),
                str(c["count"]),
                _num(c.get("nonfinite")),
                extreme(c["min"]),
                extreme(c["max"]),
                _num(c.get("rate_hz")),
                str(c.get("gap_count", 0)),
            )
        )
    lines.extend(_table(header, rows))
    # a column with a cell in every row has the time's gaps, listed once above: twenty
    # columns repeated the one gap of the time twenty times
    time_gaps = (count, gaps)
    lines.extend(
        _gap_lines(
            [
                c
                for c in columns
                if c["name"] != time_column and (c.get("gap_count"), c.get("gaps")) != time_gaps
            ],
            "gaps in columns (steps between a column's non-empty cells longer than 1.5 x "
            "its median step; columns whose gaps are the time gaps above left out):",
        )
    )
    lines.extend(_nonfinite_lines(columns, time_column or _time_named(columns)))
    problems = info.get("problems") or []
    if problems:
        lines.append("")
        lines.append("problems:")
        lines.extend(f"  {p}" for p in problems)
    return "\n".join(lines)


def _format_messages(info: dict[str, Any]) -> str:
    """The text form of a bag's or MCAP file's description."""
    topics = info["topics"]
    profile = f", profile {_shown(info['profile'], quoted=True)}" if "profile" in info else ""
    kind = info["format"] + profile
    counts = f"{_count(info['messages'], 'message')}, {_count(len(topics), 'topic')}"
    lines = [f"{_shown(info['path'])} ({kind}, {counts})"]
    span = info.get("time")
    if span is not None:
        lines.append(
            f"time: {_at(span['start'])} s to {_at(span['end'])} s "
            f"({_duration(span['duration'])} s)"
        )
    header = ("topic", "type", "count", "nonfinite", "rate_hz", "gaps", "start", "end")
    rows = [
        (
            str(t["name"]),
            str(t["type"] or "-"),
            str(t["count"]),
            _num(t.get("nonfinite")),
            _num(t["rate_hz"]),
            str(t["gap_count"]),
            "-" if t["start"] is None else _at(t["start"]),
            "-" if t["end"] is None else _at(t["end"]),
        )
        for t in topics
    ]
    lines.extend(_table(header, rows))
    lines.extend(_stamp_lines(topics))
    irregular = [t for t in topics if t.get("regular") is False]
    if irregular:
        lines.append("")
        lines.append("irregular timing (rate_hz is the mean rate over the topic's span):")
        lines.extend(f"  {_shown(t['name'])}: {_steps(t)}" for t in irregular)
    repeated = [t for t in topics if t.get("repeated")]
    if repeated:
        lines.append("")
        lines.append(
            "repeated log times (analyze refuses them unless --sort, which keeps the last):"
        )
        lines.extend(
            f"  {_shown(t['name'])}: {_count(t['repeated'], 'message')} "
            "at the time of the one before"
            for t in repeated
        )
    lines.extend(_gap_lines(topics, "gaps (steps longer than 1.5 x the topic's median step):"))
    sparse = [
        (v, decoded)
        for t in topics
        if t.get("encoding") == "json"
        # out of the messages decoded: those that were not are said under problems
        for decoded in [t["count"] - (t.get("undecodable") or {}).get("count", 0)]
        for v in t.get("values") or []
        if "[]" not in v["name"] and v["count"] < decoded
    ]
    if sparse:
        lines.append("")
        lines.append(
            "fields with a number in only some JSON messages (a field a message leaves out is "
            "read from the messages that carry it, at their times; a null is a non-finite value):"
        )
        lines.extend(
            f"  {_shown(v['name'])}: {v['count']} of {count} messages" for v, count in sparse
        )
    lines.extend(_nonfinite_lines([v for t in topics for v in t.get("values") or []]))
    fields = [f for t in topics for f in t["fields"]]
    if fields:
        lines.append("")
        lines.append(
            "fields (message paths for --map; [] takes an index, 0 to n-1 of n elements, [-1] "
            "the last):"
        )
        shown = fields[:40]
        arrays = {a["name"]: a for t in topics for a in t.get("arrays") or []}
        lines.extend(_aligned_words(_field_line(f, arrays) for f in shown))
        if len(fields) > len(shown):
            lines.append(f"  ... {len(fields) - len(shown)} more (see --json)")
    lines.extend(_side_record_lines(info))
    reading = info.get("reading") or {}
    if reading.get("metadata"):
        lines.append("")
        lines.append("metadata.yaml and the storage files disagree (the storage files are read):")
        lines.extend(f"  {remark}" for remark in reading["metadata"])
    if reading.get("unlisted_files"):
        lines.append("")
        lines.append(
            "storage files metadata.yaml does not list (their messages are not read; list them "
            "in metadata.yaml, or inspect each file itself):"
        )
        lines.extend(f"  {name}" for name in reading["unlisted_files"])
    if reading.get("recovered"):
        lines.append("")
        lines.append(
            f"read sequentially: {_count(reading['messages_readable'], 'message')}, "
            f"up to {reading['stopped_at']}"
        )
    problems = info.get("problems") or []
    if problems:
        lines.append("")
        lines.append("problems:")
        lines.extend(f"  {p}" for p in problems)
    return "\n".join(lines)


def _side_record_lines(info: dict[str, Any]) -> list[str]:
    """An MCAP file's attachments and metadata records, a line each (none: no lines).

    A metadata record shows its first six entries, each value cut to 40 characters;
    ``--json`` has them all.
    """
    lines: list[str] = []
    attachments = info.get("attachments") or []
    if attachments:
        lines += ["", "attachments (files the log carries; analyze reads only its messages):"]
        for attachment in attachments:
            media = attachment["media_type"]
            lines.append(
                f"  {_shown(attachment['name'])}: {_shown(media) if media else 'no media type'}, "
                f"{_count(attachment['bytes'], 'byte')}, log time {_at(attachment['log_time'])} s"
            )
    records = info.get("metadata_records") or []
    if records:
        lines += [
            "",
            "metadata records (key-value pairs the log carries; analyze reads only its messages):",
        ]
        for record in records:
            pairs = list(record["entries"].items())
            said = ", ".join(f"{_shown(key)} = {excerpt(value, 40)}" for key, value in pairs[:6])
            if len(pairs) > 6:
                said += f", ... {len(pairs) - 6} more (see --json)"
            lines.append(f"  {_shown(record['name'])}: {said or 'no entries'}")
    return lines


def _stamp_lines(topics: list[dict[str, Any]]) -> list[str]:
    """Each topic's ``header.stamp`` span and offset from its log time, where some topic has one.

    The table's times are log times; these are what ``--time header`` reads instead, so the
    topics without a stamp, which it refuses, are named too.
    """
    stamped = [t for t in topics if t.get("header_stamp")]
    if not stamped:
        return []
    lines = ["", "header.stamp (what --time header reads; the times above are log times):"]
    for topic in stamped:
        stamp = topic["header_stamp"]
        offset = stamp["offset"]
        lines.append(
            f"  {_shown(topic['name'])}: {_at(stamp['start'])} s to {_at(stamp['end'])} s, "
            f"{'-' if offset < 0 else '+' if offset else ''}{_duration(abs(offset))} s "
            "from its log time (median)"
        )
    unstamped = [_shown(t["name"]) for t in topics if not t.get("header_stamp")]
    if unstamped:
        lines.append(
            f"  without a usable header.stamp (--time header refuses them): {', '.join(unstamped)}"
        )
    return lines


def _gap_lines(entries: list[dict[str, Any]], title: str) -> list[str]:
    """``title``, then at most five gaps of each topic or column that has some."""
    gapped = [e for e in entries if e.get("gap_count")]
    if not gapped:
        return []
    lines = ["", title]
    for entry in gapped:
        for gap in entry["gaps"][:5]:
            lines.append(
                f"  {_shown(entry['name'])}: {_at(gap['start'])} s to {_at(gap['end'])} s "
                f"({_duration(gap['duration'])} s)"
            )
        if entry["gap_count"] > 5:
            lines.append(f"  {_shown(entry['name'])}: ... {entry['gap_count'] - 5} more")
    return lines


def _table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    """A blank line, then ``header`` and ``rows`` in left-aligned columns (cells :func:`_shown`).

    Cells are padded to the columns a terminal gives them (:func:`_width`), not to their
    count of characters: a column named ``温度`` or ``😀`` pushed the rest of its row one
    column per character to the right, and ``é`` written with a combining accent to the left.
    """
    rows = [[_shown(cell) for cell in row] for row in rows]
    widths = [max(_width(r[i]) for r in [header, *rows]) for i in range(len(header))]
    lines = [""]
    for row in [header, *rows]:
        cells = (cell + " " * (w - _width(cell)) for cell, w in zip(row, widths, strict=True))
        lines.append("  ".join(cells).rstrip())
    return lines


def _field_line(field: str, arrays: dict[str, dict[str, Any]]) -> tuple[str, str]:
    """A field of ``fields`` as shown, and what ``arrays`` says of the array it is or is in.

    ``3 elements: 'j1', 'j2', 'j3' (the first message's)`` of ``/joint_states.name[]``;
    ``transforms[]: 2 elements`` of a field of an array of messages' elements.
    """
    entry = arrays.get(field)
    within = [a for a in arrays if field.startswith(a) and a != field]
    if entry is None and within:
        entry = arrays[max(within, key=len)]
    if entry is None:
        return _shown(field), ""
    count = entry["elements"]
    said = f"{count} element{'' if count == 1 else 's'}"
    if "first" in entry:
        said += ": " + ", ".join(_shown(v, quoted=True) for v in entry["first"])
        said += " (the first message's)"
    if entry["name"] != field:
        said = f"{_shown(entry['name'].rsplit('.', 1)[-1])}: {said}"
    return _shown(field), said


def _aligned_words(rows: Iterable[tuple[str, str]]) -> list[str]:
    """``  name  words`` lines, the words of each in one column where any has words."""
    rows = list(rows)
    width = max(_width(name) for name, _ in rows)
    return [
        f"  {name}{' ' * (width - _width(name))}  {words}".rstrip() if words else f"  {name}"
        for name, words in rows
    ]


def _width(text: str) -> int:
    """How many terminal columns printable ``text`` takes (as POSIX ``wcswidth``).

    Wide and full-width characters (CJK, most emoji: East Asian width ``W`` or ``F``) take
    two, combining marks and other zero-width characters (categories ``Mn``, ``Me``) none.
    """
    return sum(
        0
        if unicodedata.category(c) in ("Mn", "Me")
        else 2
        if unicodedata.east_asian_width(c) in ("W", "F")
        else 1
        for c in text
    )


def _shown(name: object, *, quoted: bool = False) -> str:
    r"""A name from the log as one line of printable text: ``\n``, ``\x1b`` and the like escaped.

    Topic, type, field and column names are the log's own: a newline in a topic's name split
    its row of the table in two, and an escape sequence, shown ``\x1b`` only after the table
    was laid out, pushed its row out of line.  An empty name (a Parquet column may have
    one) is shown ``''``, as analyze's errors name it, not as a blank cell, and so is a name
    with spaces at either end (``' y '``: shown bare, its spaces were lost in the table, where
    analyze's error names it ``' y '``).  ``quoted``: in single quotes whatever the name, for
    text that quotes it (an MCAP file's empty profile was printed ``profile ''''``).
    """
    text = as_text(name)
    shown = "".join(
        c if c.isprintable() else c.encode("unicode_escape").decode("ascii") for c in text
    )
    return f"'{shown}'" if quoted or not text or text != text.strip() else shown


def _hz(steps: dict[str, Any]) -> str:
    """The mean rate of a description's steps, ``"- Hz"`` when it has none."""
    return f"{_num(steps.get('rate_hz'))} Hz"


def _steps(steps: dict[str, Any]) -> str:
    """``median step 0.001 s (1000 Hz), steps 0.001 s to 3 s``: how irregular steps spread."""
    median = steps["sample_time"]
    rate = f" ({_num(1 / median)} Hz)" if median else ""
    return (
        f"median step {_duration(median)} s{rate}, "
        f"steps {_duration(steps['min_step'])} s to {_duration(steps['max_step'])} s"
    )


def _time_named(columns: list[dict[str, Any]]) -> str | None:
    """The table's time column when its times could not be read (no span to name it)."""
    from hybridlog.io.table_times import TIME_COLUMNS

    names = {c["name"] for c in columns}
    return next((name for name in TIME_COLUMNS if name in names), None)


def _nonfinite_lines(entries: list[dict[str, Any]], time_column: str | None = None) -> list[str]:
    """The columns or message fields holding NaN, infinite or out-of-range values, and how many.

    ``--drop-nonfinite`` drops values, never a time: the time column's count says so.
    """
    bad = [e for e in entries if e.get("nonfinite")]
    if not bad:
        return []
    lines = [
        "",
        "non-finite values (NaN, inf; analyze refuses them in a mapped signal unless "
        "--drop-nonfinite; counted with them, values out of range: |value| >= 2^480):",
    ]
    lines.extend(
        f"  {_shown(e['name'])}: {e['nonfinite']} of {e['count']}"
        + (" (the time: refused even with --drop-nonfinite)" if e["name"] == time_column else "")
        for e in bad
    )
    return lines


def _count(count: int, noun: str) -> str:
    """``"1 topic"``, ``"2 topics"``: a count with its (regular) noun in agreement."""
    return f"{count} {noun}" if count == 1 else f"{count} {noun}s"


def _num(value: Any) -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:.6g}"
    return str(value)


def _duration(seconds: float | None) -> str:
    """A step, span or gap length in fixed point (``-`` for ``None``).

    Already rounded to the digits its times hold (:func:`~hybridlog.io.summary.round_span`);
    ``.6g`` wrote a gap of 123456.25 s as 123456 s, and 1.5e-05 s in exponent form
    (:func:`~hybridlog.times.format_duration`).
    """
    return "-" if seconds is None else format_duration(seconds)


def _at_or_dash(seconds: float | None) -> str:
    """:func:`_at` of a time, ``"-"`` for ``None``."""
    return "-" if seconds is None else _at(seconds)


def _at(seconds: float) -> str:
    """A time stamp in fixed point, to the digits its float holds (at most the nanosecond).

    Written to the microsecond, a bag's times logged 500 ns or 4 ns apart read as one
    (``time: 1 s to 1 s (0.000000004 s)``) beside a span that says otherwise
    (:func:`~hybridlog.times.format_time`: the microsecond near the Unix epoch's 1.7e9 s).
    """
    return format_time(seconds)
