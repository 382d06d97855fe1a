"""The time axis of every figure hybridlog draws: a run's span exactly, plain tick labels.

A panel's x range is the run's time span (:func:`set_time_span`); the times are drawn from
an origin the label names (:func:`time_origin`, :func:`time_label`), their ticks plain
numbers in a unit that reads (:func:`time_unit`; :func:`label_time_axis`, also ``hybridlog
cluster``'s picture), the one at the panels' right end kept inside the figure
(:func:`time_axis`).  Importing it imports no matplotlib: the plots' reduction
(:class:`~hybridlog.report.pixel_bins.PixelBins`) takes its times' origin from here.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from hybridlog.times import format_time

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = [
    "label_time_axis",
    "set_time_span",
    "time_axis",
    "time_label",
    "time_origin",
    "time_unit",
]


RELATIVE_FROM_S = 1e6
"""A run starting this far from 0 (seconds, either way) is drawn from its first sample
(:func:`time_origin`): a log stamped in Unix time (1.7e9 s) had x ticks ``1.7000``,
``1.7002``, ... over a ``1e9`` in the corner, which placed a switch no closer than 200,000 s."""
RELATIVE_SPAN_RATIO = 1e4
"""A run starting this many of its spans from 0 is drawn from its first sample too: a 10 ms
excerpt at t = 500 s needs seven digits a tick, which matplotlib wrote as an offset."""


def time_origin(start: float, end: float) -> float:
    """The time the figures' x axes count from: ``0.0``, or ``start`` for absolute times.

    ``start`` when it is at least :data:`RELATIVE_FROM_S` or :data:`RELATIVE_SPAN_RATIO`
    spans ``end - start`` from 0, whose ticks would not read as times (see those); the
    axis is then labelled with it (:func:`time_label`).  The drawn times are ``t - start``,
    exact for float times within a factor of two of ``start`` (Sterbenz), and so within the
    run's reduction to pixel columns.
    """
    if abs(start) >= RELATIVE_FROM_S or abs(start) >= RELATIVE_SPAN_RATIO * (end - start):
        return start
    return 0.0


SHORT_SPAN_S = 1e-3
"""A time axis spanning less than this (seconds) counts in a smaller unit (:func:`time_unit`)."""
_PREFIXES = {0: "", -3: "m", -6: "µ", -9: "n", -12: "p", -15: "f"}
"""SI prefixes of the time axes' units, by the power of ten of a second they stand for."""


def time_unit(span: float) -> int:
    """The power of ten of a second that a time axis spanning ``span`` seconds counts in.

    ``0`` (seconds) for a span of :data:`SHORT_SPAN_S` or more; else the SI prefix's
    (ms, µs, ns, ps, fs) in which the span reads as at least 1: matplotlib writes a tick
    below 1e-8 as 0, so every tick of a run of 300 samples 1 ps apart read ``0.00000000000``.
    """
    if not span > 0.0 or span >= SHORT_SPAN_S:
        return 0
    return max(min(_PREFIXES), 3 * math.floor(math.log10(span) / 3))


def time_label(origin: float, unit: int = 0) -> str:
    """The x label of times drawn from ``origin`` (:func:`time_origin`), in ``10**unit`` s.

    ``unit`` is :func:`time_unit`'s power of ten (0: seconds); ``origin`` is in seconds.
    """
    name = f"{_PREFIXES[unit]}s"
    if origin == 0.0:
        return f"t ({name})"
    return f"t − t₀ ({name}), t₀ = {format_time(origin)} s"


def set_time_span(ax: Axes, span: tuple[float, float] | None) -> None:
    """Set the x range of ``ax`` (and of the axes sharing it) to a run's time ``span`` exactly.

    Without matplotlib's margins, so that the bins of the reduction
    (:class:`~hybridlog.report.pixel_bins.PixelBins`) are the panel's pixel columns: a band
    (:func:`draw_curve`) then paints the columns the curve reaches and no other.  A run of
    one sample time (or none) keeps matplotlib's range.
    """
    if span is not None and span[1] > span[0]:
        ax.set_xlim(*span)


#: Room kept between the x tick label at a panel's right end and the figure's edge, in pixels.
TICK_LABEL_PAD_PX = 2.0


def time_axis(fig: Figure, ax: Axes, origin: float) -> None:
    """Label the time axis of ``ax`` (and the panels above it, which share it).

    The times are drawn from ``origin`` (:func:`time_origin`), which the label names
    (:func:`time_label`), and the ticks are written as the numbers they are, never scaled by
    a power of ten in the corner (a 10^6 s run read ``0.2`` ... ``1.0`` over ``1e6``).  A
    tick label at the panels' right end is kept inside the figure (:func:`_fit_ticks_right`).
    Call it after the left margin is final (:func:`fit_labels_left`).
    """
    label_time_axis(ax, origin)
    _fit_ticks_right(fig, ax)


def label_time_axis(ax: Axes, origin: float) -> None:
    """Label ``ax``'s x axis as times drawn from ``origin``, its ticks plain numbers.

    The label names ``origin`` (:func:`time_label`; the caller draws ``t - origin``,
    :func:`time_origin`), and no tick is scaled by a power of ten or offset in the corner: a
    Unix-time run read ``1.7000`` ... ``1.7010`` over ``1e9``.  An axis spanning less than a
    millisecond counts in the unit the label names (ms, µs, ns ...: :func:`time_unit`; the
    ticks of a nanosecond run all read 0).  Every time axis hybridlog draws is labelled
    here, once its x range is set (the reports' figures, :func:`time_axis`, and
    ``hybridlog cluster``'s picture).
    """
    lo, hi = ax.get_xlim()
    unit = time_unit(abs(hi - lo))
    ax.set_xlabel(time_label(origin, unit))
    if unit == 0:
        ax.ticklabel_format(axis="x", style="plain", useOffset=False)
        return
    # the power of ten fixed (matplotlib's equal power limits), named by the label alone
    ax.ticklabel_format(axis="x", style="sci", scilimits=(unit, unit), useOffset=False)
    ax.xaxis.get_offset_text().set_visible(False)


def _right_overhang_px(fig: Figure, ax: Axes) -> float:
    """Pixels by which the rightmost x tick label of ``ax`` runs past the figure's edge."""
    from matplotlib.text import Text

    lo, hi = ax.get_xlim()
    locs = [x for x in ax.xaxis.get_majorticklocs() if min(lo, hi) <= x <= max(lo, hi)]
    if not locs:
        return 0.0
    last = max(locs)
    text = ax.xaxis.get_major_formatter().format_ticks(locs)[locs.index(last)]
    font = ax.xaxis.get_major_ticks()[0].label1.get_fontproperties()
    label = Text(text=text, fontproperties=font)
    label.set_figure(fig)
    width = label.get_window_extent(fig.canvas.get_renderer()).width  # type: ignore[attr-defined]
    x = ax.transData.transform((last, 0.0))[0]
    return float(x + width / 2.0 - (fig.bbox.width - TICK_LABEL_PAD_PX))


def _fit_ticks_right(fig: Figure, ax: Axes) -> None:
    """Narrow the panels on the right until the x tick label at their end fits in the figure.

    A tick at the run's end (a span of round length) was cut off at the figure's edge
    (``1.701`` of ``1.7010``, ``100000`` of ``1000000``).  As :func:`fit_labels_left`, the
    curves keep their reduction: its bins are then finer than the panels' pixel columns.
    Twice at most: the ticks may move with the width.
    """
    for _ in range(2):
        overhang = _right_overhang_px(fig, ax)
        if overhang <= 0.0:
            return
        fig.subplots_adjust(right=fig.subplotpars.right - overhang / fig.bbox.width)
