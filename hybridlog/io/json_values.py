"""The values of decoded JSON messages: numbers as written, counts, keys left out.

A number too large for a float64 kept with its text (:class:`BeyondFloat`), so that
``analyze`` refuses it as written; ``inspect``'s walk over a JSON message counting its numbers,
non-finite values, nulls, text and integers a float64 does not hold (:func:`count_json`);
and where a message of sparse signals leaves out a key of a path (:func:`absent_key`).
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from hybridlog.io.exact import EXACT_LIMIT, inexact
from hybridlog.io.json_schemas import MAX_JSON_DEPTH
from hybridlog.io.message_paths import Step, spell_field
from hybridlog.signals import MAX_MAGNITUDE


class BeyondFloat(float):
    """A JSON number too large for a float64: infinite, with the text it was written as."""

    written: str


def float_or_written(text: str) -> float:
    """``json``'s ``parse_float`` keeping the text of a number that overflows to infinity."""
    value = float(text)
    if math.isfinite(value):
        return value
    beyond = BeyondFloat(value)
    beyond.written = text
    return beyond


def int_or_written(text: str) -> int | float:
    """``json``'s ``parse_int``: an integer beyond a float64's range kept as its text."""
    value = int(text)
    try:
        float(value)
    except OverflowError:
        beyond = BeyondFloat(math.inf if value > 0 else -math.inf)
        beyond.written = text
        return beyond
    return value


@dataclass(frozen=True)
class JsonFound:
    """What :func:`count_json` notes of one JSON message beyond its counts."""

    unheld: dict[str, str]
    """Path -> why the first integer there is not held by a float64 (beyond 2^53)."""
    texts: set[str]
    """The paths holding text (a string, or a string among an array's elements)."""
    nulls: Counter[str]
    """Path -> the nulls there (JSON's NaN and inf), added up over the messages."""
    booleans: set[str]
    """The paths outside arrays holding a boolean."""


def count_json(
    value: object,
    path: str,
    counts: dict[str, list[int]],
    fields: dict[str, None],
    depth: int,
    found: JsonFound,
) -> str | None:
    """Add the numbers of a decoded JSON value to ``counts``; ``[]`` marks array elements.

    Objects inside arrays are walked as the array's elements (``.poses[].x``), every number
    counted whatever the nesting up to :data:`MAX_JSON_DEPTH` levels.  The paths of numbers
    (booleans too) and text are added to ``fields``, those of text to ``found.texts`` too;
    an integer a ``float64`` does not hold (beyond 2^53) is noted in ``found.unheld``, the
    first of each path; the nulls of each path are added up in ``found.nulls`` (counted as
    non-finite values where the path holds numbers).  Returns ``None``, or the path at which
    the value nests deeper than that (nothing more is counted).
    """
    if depth > MAX_JSON_DEPTH:
        return path or "the message"
    if isinstance(value, Mapping):
        for key, item in value.items():
            too_deep = count_json(
                item, f"{path}.{spell_field(key)}", counts, fields, depth + 1, found
            )
            if too_deep is not None:
                return too_deep
    elif isinstance(value, list):
        numbers = [item for item in value if _is_json_number(item)]
        if None in value:
            found.nulls[f"{path}[]"] += value.count(None)
        if any(isinstance(item, str | bool) for item in value) or numbers:
            fields[f"{path}[]"] = None  # text and booleans are fields, uncounted
        if any(isinstance(item, str) for item in value):
            found.texts.add(f"{path}[]")
        if numbers:
            entry = counts.setdefault(f"{path}[]", [0, 0])
            entry[0] += len(numbers)
            entry[1] += sum(map(_is_nonfinite, numbers))
            _note_json_unheld(numbers, f"{path}[]", found.unheld)
        for item in value:
            if isinstance(item, Mapping | list):
                too_deep = count_json(item, f"{path}[]", counts, fields, depth + 1, found)
                if too_deep is not None:
                    return too_deep
    elif _is_json_number(value) and path:
        fields[path] = None
        entry = counts.setdefault(path, [0, 0])
        entry[0] += 1
        entry[1] += _is_nonfinite(value)
        _note_json_unheld([value], path, found.unheld)
    elif isinstance(value, str | bool) and path:
        fields[path] = None
        if isinstance(value, str):
            found.texts.add(path)
        elif "[]" not in path:  # an index of an array may hold booleans, another numbers
            found.booleans.add(path)
    elif value is None and path:
        found.nulls[path] += 1
    return None


def _note_json_unheld(numbers: Sequence[object], path: str, unheld: dict[str, str]) -> None:
    """Note in ``unheld`` the first of ``numbers`` (of ``path``) a float64 does not hold."""
    if path in unheld:
        return
    for number in numbers:
        if isinstance(number, int) and abs(number) > EXACT_LIMIT:
            reason = inexact(number)
            if reason is not None:
                unheld[path] = reason
                return


def _is_json_number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _is_nonfinite(value: object) -> bool:
    """A JSON number analyze refuses: NaN, infinite or out of range as a float64.

    An integer of more than 308 digits is infinite there (analyze refuses it as beyond the
    range of a float64, as the CSV reader does a cell of such digits, which inspect counts);
    a number of magnitude :data:`~hybridlog.signals.MAX_MAGNITUDE` or more (1e300) is out of
    range, refused as :func:`~hybridlog.io.source.usable_values` has it.
    """
    if not isinstance(value, int | float):
        return False
    try:
        number = float(value)
    except OverflowError:
        return True
    return not (math.isfinite(number) and abs(number) < MAX_MAGNITUDE)


def absent_key(message: object, steps: Sequence[Step]) -> tuple[int, list[str]] | None:
    """Where a decoded JSON message leaves out a key of ``steps``: ``(step index, its keys)``.

    ``None`` when every key is there (what is wrong is then something else: an index out of
    range, a step into a number), or when ``steps`` run into something not an object first.
    """
    value = message
    for depth, step in enumerate(steps):
        if isinstance(step, int):
            if not isinstance(value, list) or not -len(value) <= step < len(value):
                return None
            value = value[step]
        elif isinstance(value, Mapping):
            if step not in value:
                return depth, [str(k) for k in value]
            value = value[step]
        else:
            return None
    return None
