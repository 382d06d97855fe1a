"""Header stamps set by clocks that disagree, as ``--time header`` finds them.

Each mapped topic's median of ``header.stamp`` minus log time (``reading.stamp_offsets``) is
the delay from stamp to recorder; topics logged together whose offsets differ by
:data:`~hybridlog.io.options.FAR_STAMP_S` or more were stamped by different clocks (one
simulated from 0, one a Unix time; two machines not synchronised).  :func:`clocks_disagree`
says so in words, for report.md's warning and for the refusal of signals those clocks put
apart in time (:func:`hybridlog.io.load.load_signals`).
"""

from __future__ import annotations

from collections.abc import Mapping

from hybridlog.errors import excerpt
from hybridlog.io.options import FAR_STAMP_S
from hybridlog.times import format_duration

__all__ = ["clocks_disagree"]


def clocks_disagree(offsets: Mapping[str, float]) -> str | None:
    """``the topics' header stamps disagree by … s against their log times (…)``, or ``None``.

    ``offsets``: each topic's median stamp minus log time in seconds.  ``None`` for fewer
    than two topics or a spread under :data:`~hybridlog.io.options.FAR_STAMP_S`.
    """
    if len(offsets) < 2:
        return None
    latest = max(offsets, key=lambda topic: offsets[topic])
    earliest = min(offsets, key=lambda topic: offsets[topic])
    spread = offsets[latest] - offsets[earliest]
    if spread < FAR_STAMP_S:
        return None
    times = offsets.values()
    each = ", ".join(
        f"{excerpt(topic)} {'+' if offset > 0 else ''}{format_duration(offset, *times)} s"
        for topic, offset in sorted(offsets.items(), key=lambda item: -item[1])
    )
    return (
        f"the topics' header stamps disagree by {format_duration(spread, *times)} s against "
        f"their log times (stamp minus log time, the median: {each}): different clocks "
        "stamped them (simulated time, another machine's)"
    )
