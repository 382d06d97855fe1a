"""The warning that a mode accuracy is below what a constant answer scores on the same log.

A mode accuracy is read against what it would be without an estimator: always answering the
true mode that covers most of the scored samples scores that mode's share (the majority
share, from the report's confusion table).  An estimate below it tells less about the true
mode than that constant does; :func:`chance_level_warning` says so, with both numbers, so a
reader does not take 0.28 on a log whose true mode is '2' 64 % of the time for a weak but
informative estimate.  Paper 001's clustering estimators on the double cart (``chiu``,
``kmeans``; docs/double_cart.md "Beyond sinusoids") reach 0.26-0.43 on a chirp or a 1 rad/s
sine there, exit 0 and no warning before this.
"""

from __future__ import annotations

from hybridlog.report.document import Report
from hybridlog.report.markdown import WARNING_PREFIX

__all__ = ["chance_level_warning"]


def chance_level_warning(report: Report) -> str | None:
    """The warning that the joint mode accuracy is below the majority share, or ``None``.

    ``None`` without a true mode, an accuracy or a confusion table (a ``[components]``
    model's per-component tables are its components', not the joint one's).
    """
    modes = report.modes
    if modes.accuracy is None or not modes.confusion or modes.components:
        return None
    counts = {mode: sum(row.values()) for mode, row in modes.confusion.items()}
    scored = sum(counts.values())
    if scored == 0:
        return None
    frequent = max(counts, key=lambda mode: counts[mode])
    share = counts[frequent] / scored
    if modes.accuracy >= share:
        return None
    return (
        f"{WARNING_PREFIX}mode accuracy {100 * modes.accuracy:.1f} % is below the "
        f"{100 * share:.1f} % that always answering the most frequent true mode "
        f"{frequent!r} scores on these {scored:,} samples: the estimated modes tell less "
        "about the true ones than that constant answer does"
    )
