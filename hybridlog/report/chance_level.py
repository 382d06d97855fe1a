"""The warning that a mode accuracy is below what a constant answer scores on the same log.

A mode accuracy is read against what it would be without an estimator: always answering the
true mode that covers most of the scored samples scores that mode's share (the majority
share, from the report's confusion table).  An estimate below it tells less about the true
mode than that constant does; :func:`chance_level_warning` says so, with both numbers, so a
reader does not take 0.28 on a log whose true mode is '2' 64 % of the time for a weak but
informative estimate; ``hybridlog cluster`` says the same of its decision rule's accuracy
(:func:`below_majority`).  Paper 001's clustering estimators on the double cart (``chiu``,
``kmeans``; docs/double_cart.md "Beyond sinusoids") reach 0.26-0.43 on a chirp or a 1 rad/s
sine there, exit 0 and no warning before this.
"""

from __future__ import annotations

from collections.abc import Mapping

from hybridlog.report.document import Report
from hybridlog.report.markdown import WARNING_PREFIX

__all__ = ["below_majority", "chance_level_warning"]


def below_majority(accuracy: float, counts: Mapping[str, int]) -> str | None:
    """``mode accuracy 28.3 % is below the 63.5 % ...`` when it is, else ``None``.

    ``counts``: the scored samples of each true mode.  ``hybridlog cluster`` says it of
    its decision rule's accuracy, :func:`chance_level_warning` of a report's.
    """
    scored = sum(counts.values())
    if scored == 0:
        return None
    frequent = max(counts, key=lambda mode: counts[mode])
    share = counts[frequent] / scored
    if accuracy >= share:
        return None
    return (
        f"mode accuracy {100 * accuracy:.1f} % is below the {100 * share:.1f} % that always "
        f"answering the most frequent true mode {frequent!r} scores on these {scored:,} "
        "samples: the estimated modes tell less about the true ones than that constant "
        "answer does"
    )


def chance_level_warning(report: Report) -> str | None:
    """The warning that the joint mode accuracy is below the majority share, or ``None``.

    ``None`` without a true mode, an accuracy or a confusion table (a ``[components]``
    model's per-component tables are its components', not the joint one's).
    """
    modes = report.modes
    if modes.accuracy is None or not modes.confusion or modes.components:
        return None
    counts = {mode: sum(row.values()) for mode, row in modes.confusion.items()}
    below = below_majority(modes.accuracy, counts)
    return None if below is None else f"{WARNING_PREFIX}{below}"
