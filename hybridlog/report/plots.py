"""PNG plots of one run, drawn with matplotlib's Agg canvas (no pyplot, no global state).

``outputs.png``
    One panel per output: measured ``y`` and the one-step-ahead prediction ``ŷ``; for an
    offline pass, also the output its estimate explains, ``h_q̂(x̂(k|N), u(k))`` (dotted).
``modes.png``
    The estimated mode timeline (and the true one when known) as runs, one row per mode, and
    the mode probabilities: a curve per mode, or past
    :data:`~hybridlog.report.mode_plots.MOST_PROBABILITY_LINES` modes a heat map on the same
    rows; for a ``[components]`` result (``unknown-mode``) one timeline per component
    (``unknown`` in its own colour) and the joint assignment (:mod:`hybridlog.report.mode_plots`).
``states.png``
    One panel per state: the estimate with a ±2σ band (where a variance is defined) and the
    true state when known.

A smoothed run (``result.post_processing``) draws the smoothed estimates as above and the
causal filter's own over them, thin and dashed: its mode runs as a thin bar inside the
estimated one, its mode probabilities and state estimates as dashed curves (translucent
bands where a long run is drawn as bands, below; in a heat map, the middle third of each
mode's row).

The figures are drawn from a run's :class:`~hybridlog.report.plot_data.PlotData` alone
(:func:`draw_plots`): its curves reduced to first/min/max/last per pixel column, its mode
timelines to the pixel columns each mode occupies (:mod:`hybridlog.report.plot_reducer`,
which imports no matplotlib; :func:`write_plots` reduces a whole result and draws it).  A reduced
curve with more than two points per pixel column fills each column from its minimum to its
maximum and is drawn as that band (:func:`~hybridlog.report.plot_curves.draw_curve`); each
panel's x range is the run's time span exactly, so that the bins are its pixel columns
(:func:`~hybridlog.report.plot_time_axis.set_time_span`).  matplotlib is imported when the
first figure is made (:mod:`hybridlog.report.plot_figures`), so code that writes no plot
does not load it.  The text beside the panels is :mod:`hybridlog.report.plot_labels`'s, the
legends :mod:`hybridlog.report.plot_legends`'s.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from hybridlog.background import forked
from hybridlog.estimators.result import EstimationResult
from hybridlog.report.curve_envelopes import Envelope
from hybridlog.report.mode_plots import mode_panel_height, plot_modes
from hybridlog.report.plot_curves import draw_curve
from hybridlog.report.plot_data import MAX_PANELS, PlotData
from hybridlog.report.plot_figures import matplotlib_defaults, new_figure, save
from hybridlog.report.plot_labels import empty_panel, fit_labels_left, name_label, panel_title
from hybridlog.report.plot_legends import legend_above
from hybridlog.report.plot_reducer import reduce_result
from hybridlog.report.plot_time_axis import set_time_span, time_axis
from hybridlog.signals import AlignedSignals, FloatArray

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = [
    "draw_into",
    "draw_plots",
    "figure_shapes",
    "plot_outputs",
    "plot_states",
    "write_plots",
]


def figure_shapes(
    n_outputs: int, n_states: int, components: bool, n_modes: int
) -> list[tuple[int, float]]:
    """The ``(panels, panel height)`` of the figures :func:`draw_plots` draws for a model.

    ``components``: the model describes concurrent components, whose ``modes.png`` (of
    ``unknown-mode``) has a shape that depends on the result; it is left out.  ``n_modes``:
    the model's modes, a row each in ``modes.png`` (:func:`mode_panel_height`).
    """
    shapes = [(min(n_outputs, MAX_PANELS), 2.0), (min(n_states, MAX_PANELS), 2.0)]
    return shapes if components else [*shapes, (2, mode_panel_height(n_modes))]


def draw_into(plot_dir: Path, data: PlotData) -> list[Path]:
    """Create ``plot_dir`` and draw the figures of ``data`` into it (:func:`draw_plots`).

    A module-level function, so that a process's worker can be sent it
    (:func:`hybridlog.background.beside`).
    """
    plot_dir.mkdir()
    return draw_plots(plot_dir, data)


def _panels(what: str, names: tuple[str, ...]) -> tuple[Figure, list[Axes], tuple[str, ...]]:
    """A figure titled ``what`` with one panel per name drawn (at most :data:`MAX_PANELS`)."""
    drawn = names[:MAX_PANELS]
    fig, axes = new_figure(len(drawn))
    panel_title(fig, what, len(names))
    return fig, axes, drawn


LARGEST_DRAWN = 1e300
"""Largest magnitude drawn as it is.  matplotlib's autoscaling and tick locators take the
difference of a panel's limits: values near ±1.8e308 (a prediction or an estimate that
diverged without overflowing) overflowed there, and the RuntimeWarning lost the report.
A panel with a larger value is drawn in units of a power of ten (:func:`_panel_unit`)."""


def _panel_unit(*curves: FloatArray) -> tuple[float, str]:
    """The unit a panel's ``curves`` are drawn in, and what its y label says of it.

    ``(1.0, "")`` while every finite value is at most :data:`LARGEST_DRAWN` in magnitude,
    else ``(10**e, " (×1e<e>)")`` for the power of ten at or below the largest.
    """
    largest = 0.0
    for values in curves:
        finite = values[np.isfinite(values)]
        if finite.size:
            largest = max(largest, float(np.max(np.abs(finite))))
    if largest <= LARGEST_DRAWN:
        return 1.0, ""
    exponent = math.floor(math.log10(largest))
    return 10.0**exponent, f" (×1e{exponent})"


def _in_unit(curve: Envelope, unit: float) -> Envelope:
    if unit == 1.0:
        return curve
    with np.errstate(under="ignore"):
        return curve._replace(values=curve.values / unit)


def plot_outputs(data: PlotData, path: Path) -> Path:
    """Draw measured outputs against their one-step-ahead predictions.

    An offline pass's explained outputs (:class:`~hybridlog.report.plot_data.OutputCurves`)
    are drawn over them, dotted: fitted with every sample, they are no prediction, and the
    title and legend say so.  Writes ``path`` (PNG) and returns it.
    """
    label = data.explained_label
    title = "Outputs: measured vs one-step-ahead prediction" + (
        f" and h(x̂) of the {label} estimate" if label else ""
    )
    fig, axes, names = _panels(title, data.output_names)
    if not names:
        empty_panel(fig, axes[0], "no outputs")
        return save(fig, path)
    set_time_span(axes[0], data.span)
    cut = False
    for ax, curves in zip(axes, data.outputs, strict=True):
        drawn = [c for c in (curves.measured, curves.predicted, curves.explained) if c is not None]
        unit, in_unit = _panel_unit(*(c.values for c in drawn))
        measured, predicted = (_in_unit(c, unit) for c in (curves.measured, curves.predicted))
        draw_curve(ax, measured, lw=0.8, color="0.3", label="measured")
        draw_curve(ax, predicted, lw=0.8, color="tab:blue", ls="--", label="predicted")
        if curves.explained is not None:
            explained = _in_unit(curves.explained, unit)
            draw_curve(ax, explained, lw=0.9, color="tab:orange", ls=":", label=f"{label} h(x̂)")
        cut = name_label(fig, ax, curves.name, in_unit) or cut
    if cut:
        fit_labels_left(fig, axes)
    time_axis(fig, axes[-1], data.time_origin)
    legend_above(fig, axes)
    return save(fig, path)


def plot_states(data: PlotData, path: Path) -> Path:
    """Draw state estimates with ±2σ bands, against the true states when known.

    Writes ``path`` (PNG) and returns it.
    """
    panels = data.states[:MAX_PANELS]
    sigma = " ±2σ" if any(c.band is not None for c in panels) else ""
    truth = " vs truth" if any(c.truth is not None for c in panels) else ""
    # what the panels show: a Luenberger observer has no σ, a log without truth no truth
    fig, axes, names = _panels(f"States: {data.state_label}{sigma}{truth}", data.state_names)
    if not names:
        empty_panel(fig, axes[0], "no states")
        return save(fig, path)
    set_time_span(axes[0], data.span)
    cut = False
    for ax, curves in zip(axes, data.states, strict=True):
        drawn = [c for c in (curves.truth, curves.estimate, curves.filtered) if c is not None]
        band = () if curves.band is None else curves.band[1:]
        unit, in_unit = _panel_unit(*band, *(c.values for c in drawn))
        if curves.band is not None:
            t_band, lo, hi = curves.band
            with np.errstate(under="ignore"):
                lo, hi = lo / unit, hi / unit
            ax.fill_between(
                t_band, np.nan_to_num(lo), np.nan_to_num(hi), where=np.isfinite(lo),
                color="tab:blue", alpha=0.2, label="±2σ",
            )  # fmt: skip
        if curves.truth is not None:
            draw_curve(ax, _in_unit(curves.truth, unit), lw=1.5, color="0.5", label="true")
        estimate = _in_unit(curves.estimate, unit)
        draw_curve(ax, estimate, lw=0.8, color="tab:blue", label=data.state_label)
        if curves.filtered is not None:
            filtered = _in_unit(curves.filtered, unit)
            draw_curve(ax, filtered, lw=0.5, ls="--", color="k", label="filtered")
        cut = name_label(fig, ax, curves.name, in_unit) or cut
    if cut:
        fit_labels_left(fig, axes)
    time_axis(fig, axes[-1], data.time_origin)
    legend_above(fig, axes)
    return save(fig, path)


def draw_plots(plot_dir: Path, data: PlotData) -> list[Path]:
    """Write ``outputs.png``, ``modes.png`` and ``states.png`` of a run into a directory.

    For a result with per-component mode columns (``unknown-mode``) ``modes.png`` is
    :func:`plot_components`.  In the plots' worker process ``states.png`` is drawn in a
    forked child of it while the other two are drawn (:func:`hybridlog.background.forked`):
    the command has little left to do by then, so the second core is free; a 10^6-row
    ``analyze`` ends 0.09 s sooner (eight interleaved runs each, median 2.00 against 2.10 s),
    with the same PNGs.

    Parameters
    ----------
    plot_dir:
        Existing directory to write into.
    data:
        The run's reduced plot data (:mod:`hybridlog.report.plot_data`): all that is drawn.

    Returns
    -------
    list of pathlib.Path
        The files written.

    """
    with matplotlib_defaults():
        # in the plots' worker, states.png in a forked child beside the other two
        states = forked(lambda: plot_states(data, plot_dir / "states.png"))
        outputs = plot_outputs(data, plot_dir / "outputs.png")
        modes = plot_modes(data, plot_dir / "modes.png")
        return [outputs, modes, states()]


def write_plots(plot_dir: Path, result: EstimationResult, signals: AlignedSignals) -> list[Path]:
    """Reduce a whole result and draw its plots into a directory (:func:`draw_plots`).

    Parameters
    ----------
    plot_dir:
        Existing directory to write into.
    result:
        The estimation result.
    signals:
        The aligned signals it was computed from.

    Returns
    -------
    list of pathlib.Path
        The files written.

    """
    return draw_plots(plot_dir, reduce_result(result, signals))
