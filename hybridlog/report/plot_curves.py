"""A curve drawn in a panel: a line, or where a reduced curve is dense the band it fills.

A reduced curve (:func:`~hybridlog.report.curve_envelopes.envelope`) with more than two points per
pixel column fills each column from its minimum to its maximum and is drawn as that band,
one outlined polygon; a finite point between two that are not is drawn as a dot
(:func:`draw_curve`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from hybridlog.report.curve_envelopes import Envelope
from hybridlog.report.pixel_bins import pixel_columns
from hybridlog.signals import FloatArray

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.lines import Line2D

__all__ = ["DASHED_BAND_ALPHA", "draw_curve"]


def draw_curve(ax: Axes, curve: Envelope, **style: Any) -> list[Line2D]:
    """Draw ``curve`` on ``ax``: a line, or a band where it is reduced and dense.

    A reduced curve (:func:`~hybridlog.report.curve_envelopes.envelope`) with over two points per
    pixel column is a long run: its zigzag through each bin's first, minimum, maximum and
    last sample fills the bin's column from minimum to maximum.  The band (:func:`_band`)
    fills the same columns as one polygon, outlined with the line's width, instead of
    stroking thousands of column-high segments: on a 10^6-sample run the three figures' 15
    zigzags took 0.31 s to draw, the bands 0.08 s.  The line returned carries the style (the
    legend shows it); for a band it holds no points.

    A finite point between two that are not (an output measured every other sample, its
    other samples NaN: :meth:`~hybridlog.signals.AlignedSignals.measured_outputs`) bounds no
    segment, so the line alone would not show it: such points are marked with dots
    (:func:`_mark_lone_points`), and no line is drawn across the NaN beside them.
    """
    if not curve.reduced or curve.time.shape[0] <= 2 * pixel_columns():
        lines = ax.plot(curve.time, curve.values, **style)
        _mark_lone_points(ax, curve, lines[0])
        return lines
    lines = ax.plot([], [], **style)
    _band(ax, curve, lines[0])
    return lines


def _lone_points(values: FloatArray) -> npt.NDArray[np.bool_]:
    """Where ``values`` is finite and neither neighbour is: points a line draws nothing at."""
    finite = np.isfinite(values)
    alone = finite.copy()
    alone[1:] &= ~finite[:-1]
    alone[:-1] &= ~finite[1:]
    return alone


def _mark_lone_points(ax: Axes, curve: Envelope, line: Line2D) -> None:
    """Dot each of ``curve``'s :func:`_lone_points` in ``line``'s colour, width and order.

    An output the log measured at a third of the model's rate was a blank panel in
    ``outputs.png``: each measured sample sat between two unmeasured ones (NaN), and a line
    through NaN breaks on both sides of it.
    """
    alone = _lone_points(curve.values)
    if not alone.any():
        return
    ax.plot(
        curve.time[alone], curve.values[alone], linestyle="none", marker="o",
        markersize=max(2.5 * line.get_linewidth(), 1.5), markeredgewidth=0,
        color=line.get_color(), alpha=line.get_alpha(), zorder=line.get_zorder(),
    )  # fmt: skip


DASHED_BAND_ALPHA = 0.7
"""Opacity of the band of a dashed line (the prediction over the measurement, the filter over
the smoother): a dashed zigzag of column-high segments covers its band almost wholly and hid
the curve under it, a translucent band lets it show through."""


def _band(ax: Axes, curve: Envelope, line: Line2D) -> None:
    """Fill each bin of a reduced ``curve`` over its time span from its minimum to its maximum.

    A bin without a finite value is a gap.  Colour, width, opacity and drawing order are the
    line's; the band of a dashed line is :data:`DASHED_BAND_ALPHA` opaque.  Drawn without
    antialiasing: smoothing the edges of a band a pixel column wide would only cost time.
    """
    points = curve.values.reshape(-1, 4)
    with np.errstate(invalid="ignore"):
        low = np.fmin.reduce(points, axis=1)
        high = np.fmax.reduce(points, axis=1)
    times = curve.time.reshape(-1, 4)[:, [0, 3]].ravel()
    alpha = line.get_alpha()
    if line.get_linestyle() not in ("-", "solid"):
        alpha = DASHED_BAND_ALPHA * (1.0 if alpha is None else alpha)
    ax.fill_between(
        times, np.repeat(np.nan_to_num(low), 2), np.repeat(np.nan_to_num(high), 2),
        where=np.repeat(np.isfinite(low), 2), color=line.get_color(), alpha=alpha,
        linewidth=line.get_linewidth(), antialiased=False, zorder=line.get_zorder(),
    )  # fmt: skip
