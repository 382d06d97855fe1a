"""summary.md kept within what a CI job summary shows: lists of logs cut, the rest counted.

GitHub shows a step's job summary only up to 1 MiB (1,048,576 bytes) and refuses a longer
one whole ("upload aborted"); README's CI recipe appends summary.md to it.  A batch's
summary.md lists every log in its table, and the failed ones and those that missed a gate
again with why: about 90 bytes a log that passed, some 12,000 logs to the limit, far fewer
with failures.  Past :data:`SUMMARY_BYTES` the lists are cut from their ends, in the order
given (the table's rows first, the logs that passed last in it), each cut said by a line
counting what it left out and naming the summary.csv column that has it: summary.csv
lists every log.  A document within the budget is left as it is.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from itertools import accumulate

__all__ = ["SUMMARY_BYTES", "Listing", "within_budget"]

SUMMARY_BYTES = 1_000_000
"""The most bytes (UTF-8) of summary.md: under GitHub's 1 MiB for a job summary, with room
for what a CI job adds to it."""


@dataclass(frozen=True)
class Listing:
    """Lines of one item each (a log), the last of which may be left out.

    ``more(n)`` is the line said after the items kept when ``n`` were left out.
    """

    items: Sequence[str]
    more: Callable[[int], str]


def _size(line: str) -> int:
    """The bytes of ``line`` in the document, with its line end."""
    return len(line.encode()) + 1


def within_budget(
    parts: Sequence[str | Listing], cut: Sequence[Listing], budget: int = SUMMARY_BYTES
) -> list[str]:
    """The lines of ``parts``, the listings of ``cut`` cut in that order until within ``budget``.

    ``cut`` may name listings that are not among ``parts`` (a section left out): none is cut.

    Each listing of ``cut`` keeps as many of its first items as leave the document within
    ``budget``, down to none, before the next is cut; a listing cut is followed by its
    ``more`` line.  A document the cuts cannot bring within ``budget`` is the one with every
    listing of ``cut`` emptied.
    """
    kept = {id(listing): len(listing.items) for listing in cut}
    fixed = sum(_size(part) for part in parts if isinstance(part, str))
    whole = {
        id(p): list(accumulate((_size(item) for item in p.items), initial=0))
        for p in parts
        if isinstance(p, Listing)
    }
    total = fixed + sum(sums[-1] for sums in whole.values())
    for listing in cut:
        if total <= budget:
            break
        if id(listing) not in whole:  # not among the parts: nothing to cut
            continue
        sums = whole[id(listing)]
        n = len(listing.items)
        room = sums[n] - (total - budget)  # what its lines may take
        k = n
        while k > 0 and sums[k] + _size(listing.more(n - k)) > room:
            k -= 1
        kept[id(listing)] = k
        total += sums[k] - sums[n] + (_size(listing.more(n - k)) if k < n else 0)
    lines: list[str] = []
    for part in parts:
        if isinstance(part, str):
            lines.append(part)
            continue
        n = len(part.items)
        k = kept.get(id(part), n)
        lines += part.items[:k]
        lines += [part.more(n - k)] if k < n else []
    return lines
