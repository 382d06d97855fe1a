"""PNG plots of one run, drawn with matplotlib's Agg canvas (no pyplot, no global state).

``outputs.png``
    One panel per output: measured ``y`` and the one-step-ahead prediction ``ŷ``; for an
    offline pass, also the output its estimate explains, ``h_q̂(x̂(k|N), u(k))`` (dotted).
``modes.png``
    The estimated mode timeline (and the true one when known) as runs, one row per mode, and
    the mode probabilities: a curve per mode, or past :data:`MOST_PROBABILITY_LINES` modes a
    heat map on the same rows; for a ``[components]`` result (``unknown-mode``) one timeline
    per component (``unknown`` in its own colour) and the joint assignment.
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
timelines to the pixel columns each mode occupies (:mod:`hybridlog.report.plot_data`, which
imports no matplotlib; :func:`write_plots` reduces a whole result and draws it).  A reduced
curve with more than two points per pixel column fills each column from its minimum to its
maximum and is drawn as that band (:func:`draw_curve`); each panel's x range is the run's
time span exactly, so that the bins are its pixel columns (:func:`set_time_span`).
matplotlib is imported when the first figure is made, so code that writes no plot does not
load it.
"""

from __future__ import annotations

import math
import textwrap
import threading
from collections import Counter
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from hybridlog.background import forked
from hybridlog.estimators.result import EstimationResult
from hybridlog.report.plot_data import (
    FIGURE_DPI,
    FIGURE_WIDTH_IN,
    MAX_PANELS,
    PANEL_LEFT,
    PANEL_RIGHT,
    Bars,
    Components,
    Envelope,
    ModeTimelines,
    PlotData,
    column_maxima,
    pixel_columns,
    plain_text,
    reduce_result,
    time_label,
    time_unit,
)
from hybridlog.signals import AlignedSignals, FloatArray, IntArray

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

__all__ = [
    "DASHED_BAND_ALPHA",
    "PNG_COMPRESS_LEVEL",
    "draw_curve",
    "draw_plots",
    "figure_shapes",
    "label_time_axis",
    "make_ticks_ahead",
    "matplotlib_defaults",
    "mode_panel_height",
    "plot_components",
    "plot_modes",
    "plot_outputs",
    "plot_states",
    "prepare_figures",
    "set_time_span",
    "write_plots",
]

PNG_COMPRESS_LEVEL = 1
"""zlib level of the PNG files (Pillow's default is 6).  The pixels are the same at any level;
on the three figures of a 10^6-sample run level 1 encoded in half the time (0.10 s against
0.19 s) for files 3 % larger in total (638 KB against 620 KB)."""
_MATPLOTLIB = threading.Lock()
"""Held while one run's figures are drawn: the report may draw them in a thread
(:func:`hybridlog.report.writer.write_report`), and matplotlib's font cache is not safe
to use from two threads at once (a Dask worker runs several logs side by side)."""


@contextmanager
def matplotlib_defaults() -> Iterator[None]:
    """Draw with matplotlib's own defaults, whatever the process's ``rcParams``; one at a time.

    A caller of the library that had set ``rcParams["figure.dpi"] = 50`` or
    ``rcParams["font.size"] = 17`` (a notebook's style), or a ``matplotlibrc`` file, changed
    the report's PNGs: ``outputs.png`` was 1000x716 pixels, not the command's 1000x702.  The
    figures are made and drawn under :func:`matplotlib.style.context` of ``"default"`` (0.7 ms),
    which gives the caller's settings back after; it holds :data:`_MATPLOTLIB`, so that two
    threads' contexts never interleave (the second would save the first's defaults as the
    settings to give back).  Every figure hybridlog draws (reports, batch's summary, cluster's
    plot) is drawn in it.
    """
    from matplotlib import style

    with _MATPLOTLIB, style.context("default"):
        yield


def draw_curve(ax: Axes, curve: Envelope, **style: Any) -> list[Line2D]:
    """Draw ``curve`` on ``ax``: a line, or a band where it is reduced and dense.

    A reduced curve (:func:`~hybridlog.report.plot_data.envelope`) with over two points per
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


_READY: dict[tuple[int, float], list[tuple[Figure, list[Axes]]]] = {}
"""Empty figures made ahead by shape (:func:`prepare_figures`), each taken once by
:func:`_new_figure`."""
TICKS_AHEAD = 10
"""Major ticks made ahead per axis of a prepared figure.  Each tick is a handful of artists
(marks, grid line, labels): on the three figures of a 10^6-sample run the axes draw 8 per
axis (3 on the mode rows), and making them took 0.10-0.17 s of the plots' 0.8 s.  With them
made ahead, the three figures were drawn in 0.52-0.54 s against 0.58 s (fresh processes,
two runs each), byte for byte the same PNGs.  An axis whose locator asks for more makes the
rest when drawn."""


MODE_ROW_IN = 0.2
"""Height of a mode's row in ``modes.png``'s timeline, in inches: room for its tick label
(10 pt, 0.14 in) and a gap.  The panel was 2.4 in whatever the number of modes: from 17
modes on, the rows' labels ran into one another (25 modes: 0.096 in a row), and no row
could be told from its neighbours."""
MODE_PANEL_IN = 2.4
"""Height of ``modes.png``'s panels while their modes' rows fit in it (12 modes or fewer)."""
MODE_PANEL_MAX_IN = 16.0
"""Tallest ``modes.png``'s panels grow (80 rows of :data:`MODE_ROW_IN`); with more modes
(a boolean model's 2^n) the rows' labels get a font that fits the row."""
_TICK_LABEL_PT = 10.0
"""matplotlib's default tick label size, in points."""


def mode_panel_height(n_modes: int) -> float:
    """Height in inches of ``modes.png``'s panels for ``n_modes`` rows, every label apart."""
    return min(max(MODE_PANEL_IN, MODE_ROW_IN * n_modes), MODE_PANEL_MAX_IN)


def _row_label_size(panel_height: float, n_rows: int) -> float | None:
    """Font size (points) of the row labels of a panel too short for the default's, or None.

    A label keeps :data:`_TICK_LABEL_PT` while a row is at least :data:`MODE_ROW_IN` high,
    else shrinks with the row, to 70 % of its height.
    """
    row_in = panel_height / max(n_rows, 1)
    if row_in >= MODE_ROW_IN:
        return None
    return min(_TICK_LABEL_PT, 0.7 * row_in * 72.0)


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


def prepare_figures(shapes: Sequence[tuple[int, float]]) -> None:
    """Make the empty figures (margins, panels, shared axes, tick marks) of these shapes ahead.

    ``analyze`` does it while the estimator's compiled loop runs (:func:`prepare_plotting`,
    in the process's worker or a thread): 0.06-0.13 s of axes set-up that is then not on the
    plots' path, which the command waits for at its end.  A figure
    made ahead is the one :func:`_new_figure` would make, with :data:`TICKS_AHEAD` major
    ticks per axis already made (matplotlib makes them when it first draws an axis, as many
    as its locator asks for, and reuses them after); the same pixels are drawn on it.
    """
    wanted = Counter((max(n_panels, 1), panel_height) for n_panels, panel_height in shapes)
    with matplotlib_defaults():
        for key, count in wanted.items():
            ready = _READY.setdefault(key, [])
            while len(ready) < count:  # as many as one run's plots take, however often asked
                fig, axes = _make_figure(*key)
                make_ticks_ahead(axes)
                ready.append((fig, axes))


def import_matplotlib() -> None:
    """Import what the figures are drawn with: matplotlib's figure and Agg canvas.

    About 0.3 s of Python: the console script's worker process does it first thing, while
    the command imports its own modules and reads the log (``hybridlog.cli``).
    """
    import matplotlib.backends.backend_agg
    import matplotlib.figure  # noqa: F401


def prepare_plotting(shapes: Sequence[tuple[int, float]]) -> None:
    """Import what the figures are drawn with, and make the empty figures of ``shapes`` ahead.

    :func:`import_matplotlib` and :func:`prepare_figures`: what
    :func:`hybridlog.report.writer.write_report` has done beside the estimator, before the
    first figure is drawn.
    """
    import_matplotlib()
    prepare_figures(shapes)


def draw_into(plot_dir: Path, data: PlotData) -> list[Path]:
    """Create ``plot_dir`` and draw the figures of ``data`` into it (:func:`draw_plots`).

    A module-level function, so that a process's worker can be sent it
    (:func:`hybridlog.background.beside`).
    """
    plot_dir.mkdir()
    return draw_plots(plot_dir, data)


def make_ticks_ahead(axes: Sequence[Axes]) -> None:
    """Make :data:`TICKS_AHEAD` major ticks on both axes of each of ``axes`` now.

    matplotlib makes them when it first draws an axis (each a copy of the first tick's
    properties) and reuses them after: made in a figure prepared ahead, they are not on the
    drawing's path, and the same pixels are drawn.
    """
    for ax in axes:
        ax.xaxis.get_major_ticks(TICKS_AHEAD)
        ax.yaxis.get_major_ticks(TICKS_AHEAD)


def _new_figure(n_panels: int, panel_height: float = 2.0) -> tuple[Figure, list[Axes]]:
    key = (max(n_panels, 1), panel_height)
    ready = _READY.get(key)
    return ready.pop() if ready else _make_figure(*key)


def _make_figure(n_panels: int, panel_height: float) -> tuple[Figure, list[Axes]]:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    # Fixed margins in inches rather than layout="constrained": the constrained layout
    # measured every tick label and took half of the report's writing time.
    height = 0.8 + panel_height * n_panels
    fig = Figure(figsize=(FIGURE_WIDTH_IN, height))
    FigureCanvasAgg(fig)
    fig.subplots_adjust(
        left=PANEL_LEFT,
        right=PANEL_RIGHT,
        top=1.0 - 0.45 / height,
        bottom=0.45 / height,
        hspace=0.12,
    )
    axes = fig.subplots(n_panels, 1, sharex=True, squeeze=False)[:, 0]
    return fig, list(axes)


def _save(fig: Figure, path: Path) -> Path:
    fig.savefig(path, dpi=FIGURE_DPI, pil_kwargs={"compress_level": PNG_COMPRESS_LEVEL})
    return path


#: Where a figure's title hangs: this far (inches) below the top, whatever the figure's
#: height (the panels start 0.45 in below it); at the default 0.98 of the height, the title
#: of a tall figure (a ``[components]`` model's modes.png) ran into its first panel.
TITLE_TOP_IN = 0.1


def _title(fig: Figure, text: str) -> None:
    fig.suptitle(text, y=1.0 - TITLE_TOP_IN / fig.get_figheight(), va="top")


def _panel_title(fig: Figure, what: str, total: int) -> None:
    if total > MAX_PANELS:
        _title(fig, f"{what} (first {MAX_PANELS} of {total})")
    else:
        _title(fig, what)


#: The ticks, the pads beside the tick labels and the y label, and a margin, in inches.
LABEL_PADS_IN = 0.25


def _fit_labels_left(fig: Figure, axes: Sequence[Axes]) -> None:
    """Widen the figure's left margin to the widest y tick label and y label of ``axes``.

    For figures of mode bars and curves of a few values per pixel column (a curve reduced
    to the fixed panel width's pixel columns then has bins finer than the narrower panel's,
    which it draws as faithfully): a component's modes (``one_bank_out``), the joint
    assignments (``partly_open|partly_open|closed|closed|full|growth``) and long mode ids
    were cut off at the fixed margin; so would be the lines of a long output's or state's
    name (:func:`_name_label`), whose curves are drawn as faithfully.
    Text is measured by the Agg renderer, without a layout pass; the margin is at most half
    the width (mode ids wider than :data:`KEYED_LABELS_WIDTH` are drawn as keys instead:
    :func:`_row_labels`).
    """
    need = max((_labels_width_in(fig, ax) for ax in axes), default=0.0)
    left = min(max(PANEL_LEFT, need / fig.get_figwidth()), 0.5)
    if left > PANEL_LEFT:
        fig.subplots_adjust(left=left)


NAME_LABEL_SIZES = (10.0, 8.0, 6.0)
"""Font sizes (points) a panel's y label naming an output, state or component may take, the
first whose wrapped lines are at most :data:`NAME_LABEL_LINES` (:func:`_name_label`)."""
NAME_LABEL_LINES = 4
"""Most lines a y label naming an output, state or component is wrapped to before its font
shrinks (at the smallest of :data:`NAME_LABEL_SIZES` it takes as many as it needs)."""


def _name_label(fig: Figure, ax: Axes, name: str, suffix: str = "") -> bool:
    """Label the y axis of ``ax`` with ``name`` (user text) and ``suffix``, within its height.

    A symbol name has no length limit and a component's name may have 64 characters: a
    75-character output's label, drawn upright at 10 pt, was 2.5 times its panel's height
    and ran over the labels of the panels beside it and off the figure.  A label longer
    than the panel is cut into lines that fit it (the name cut anywhere, each line drawn as
    written, :func:`plain_text`; ``suffix``, hybridlog's own text, ends the last), in a
    smaller font (:data:`NAME_LABEL_SIZES`) where it would take more than
    :data:`NAME_LABEL_LINES` lines.  Returns whether it was cut: the figure's left margin
    must then hold the lines (:func:`_fit_labels_left`).
    """
    renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    room = ax.get_window_extent(renderer).height
    label = ax.yaxis.label
    ax.set_ylabel(plain_text(name) + suffix)
    if label.get_window_extent(renderer).height <= room:
        return False
    for size in NAME_LABEL_SIZES:
        width = len(name)
        while True:
            lines = [plain_text(name[at : at + width]) for at in range(0, len(name), width)]
            ax.set_ylabel("\n".join(lines) + suffix, fontsize=size)
            height = label.get_window_extent(renderer).height
            if height <= room or width == 1:
                break
            width = max(1, min(width - 1, int(width * room / height)))
        if len(lines) <= NAME_LABEL_LINES:
            break
    return True


KEYED_LABELS_WIDTH = 0.4
"""Widest a panel's row labels (mode ids) and y label may stand beside it, as a fraction of
the figure's width; wider ones are drawn as keys (:func:`_row_labels`).  A 60-character mode
id needed more than the half :func:`_fit_labels_left` allows and was cut off at the
figure's left edge; widening the margin further would leave the panels no room."""
KEY_WRAP_CHARS = 90
"""A mode id in the key below the panels is wrapped to lines of at most this many
characters (a joint assignment of a ``[components]`` model joins one id per component)."""
LEGEND_COLUMNS = 6
"""Most columns of a legend below the panels (:func:`_legend_below`)."""


class _Keys:
    """Short keys ``[1]``, ``[2]``, ... of the mode ids too long to label a panel's rows.

    One key per id in a figure, in the order they are first asked for; the figure lists
    them below its panels (:func:`_key_entries`, :func:`_legend_below`).
    """

    def __init__(self) -> None:
        self.ids: dict[str, str] = {}

    def __call__(self, mode_id: str) -> str:
        return self.ids.setdefault(mode_id, f"[{len(self.ids) + 1}]")


def _labels_width_in(fig: Figure, ax: Axes) -> float:
    """Inches the y tick labels and the y label of ``ax`` take beside it (with the pads)."""
    renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    ticks = max((t.get_window_extent(renderer).width for t in ax.get_yticklabels()), default=0.0)
    label = ax.yaxis.label.get_window_extent(renderer).width if ax.get_ylabel() else 0.0
    return float((ticks + label) / fig.dpi + LABEL_PADS_IN)


def _row_labels(
    fig: Figure, panels: Sequence[tuple[Axes, Sequence[str], str | float | None]], keys: _Keys
) -> list[list[str]]:
    """Label the rows of each panel ``(ax, mode_ids, fontsize)``, row ``j`` ``mode_ids[j]``.

    ``fontsize`` ``None`` is the tick labels' own size.  The ids as written
    (:func:`plain_text`) while every panel's fit in :data:`KEYED_LABELS_WIDTH` of the
    figure's width beside its y label (set it first), else, in every panel, their
    :class:`_Keys`, which the figure lists below its panels with the ids in full.  Returns
    the labels drawn, per panel.
    """

    def label(texts: list[list[str]]) -> list[list[str]]:
        for (ax, _, fontsize), labels in zip(panels, texts, strict=True):
            ax.set_yticks(range(len(labels)), labels)
            if fontsize is not None:
                ax.tick_params(axis="y", labelsize=fontsize)
        return texts

    shown = label([[plain_text(m) for m in mode_ids] for _, mode_ids, _ in panels])
    widest = max((_labels_width_in(fig, ax) for ax, _, _ in panels), default=0.0)
    if widest <= KEYED_LABELS_WIDTH * fig.get_figwidth():
        return shown
    return label([[keys(m) for m in mode_ids] for _, mode_ids, _ in panels])


def _key_entry(key: str, mode_id: str) -> str:
    """``[1]: <mode id>``, the id wrapped at :data:`KEY_WRAP_CHARS` and drawn as written."""
    lines = textwrap.wrap(
        mode_id, KEY_WRAP_CHARS, break_long_words=True, break_on_hyphens=False
    ) or [mode_id]
    return f"{key}: " + "\n".join(plain_text(line) for line in lines)


#: Space between the lowest panel's x label and a legend below the panels, in inches.
LEGEND_GAP_IN = 0.1


def _legend_below(
    fig: Figure,
    handles: Sequence[Any],
    labels: Sequence[str],
    *,
    title: str | None = None,
    text_only: bool = False,
) -> None:
    """Put a legend below the panels, in as many columns as the panels' width holds.

    The figure grows by the legend's height, the panels keeping their size and place
    (in inches from the top); its width, and so the pixel columns the curves were reduced
    to, is unchanged.  Call it after the left margin is final (:func:`_fit_labels_left`).
    """
    renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    pars = fig.subplotpars
    room = (pars.right - pars.left) * fig.bbox.width
    style: dict[str, Any] = {"fontsize": "small", "title_fontsize": "small", "frameon": False}
    if text_only:
        style.update(handlelength=0.0, handletextpad=0.0)
    for ncol in range(min(len(labels), LEGEND_COLUMNS), 0, -1):
        legend = fig.legend(
            handles, labels, loc="lower left", bbox_to_anchor=(pars.left, 0.0), ncol=ncol,
            title=title, alignment="left", **style,
        )  # fmt: skip
        if ncol == 1 or legend.get_window_extent(renderer).width <= room:
            break
        legend.remove()
    _grow_below(fig, legend.get_window_extent(renderer).height / fig.dpi + LEGEND_GAP_IN)


def _grow_below(fig: Figure, extra: float) -> None:
    """Make the figure ``extra`` inches taller at its bottom, the panels keeping their place.

    Their size and their distance from the top (and the title's) are kept, and so their
    width, the pixel columns the curves were reduced to: the room freed is below them.
    """
    pars = fig.subplotpars
    old = fig.get_figheight()
    top_in, bottom_in = (1.0 - pars.top) * old, pars.bottom * old
    new = old + extra
    fig.set_size_inches(fig.get_figwidth(), new)
    fig.subplots_adjust(top=1.0 - top_in / new, bottom=(bottom_in + extra) / new)
    if fig.get_suptitle():
        _title(fig, fig.get_suptitle())


def _legend_above(fig: Figure, axes: Sequence[Axes]) -> None:
    """One legend of the entries of every panel of ``axes``, above the first, right-aligned.

    Off the data: a legend in a panel's corner hid the curves and mode bars under it (a
    state's estimate ending at its largest value ran under ``upper right``), and the styles
    are the same in every panel, whose y label names what it shows.  The entries are in one
    row while the panels' width holds them, else in as many rows as needed; where the
    legend reaches the figure's title, the figure grows at its top by the legend's height,
    the panels keeping their size (the pixel columns the curves were reduced to unchanged).
    Call it after the left margin is final (:func:`_fit_labels_left`).
    """
    entries: dict[str, Any] = {}
    for ax in axes:
        for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
            entries.setdefault(label, handle)
    if not entries:
        return
    renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    first = axes[0]
    room = first.get_window_extent(renderer).width
    for ncol in range(len(entries), 0, -1):
        legend = first.legend(
            list(entries.values()), list(entries), loc="lower right", bbox_to_anchor=(1.0, 1.0),
            ncol=ncol, fontsize="small", frameon=False, borderaxespad=0.1,
        )  # fmt: skip
        if ncol == 1 or legend.get_window_extent(renderer).width <= room:
            break
    title: Any = getattr(fig, "_suptitle", None)  # matplotlib's: suptitle()'s Text, or None
    box = legend.get_window_extent(renderer)
    if title is None or not box.overlaps(title.get_window_extent(renderer)):
        return
    extra = box.height / fig.dpi
    pars, old = fig.subplotpars, fig.get_figheight()
    top_in, bottom_in = (1.0 - pars.top) * old, pars.bottom * old
    new = old + extra
    fig.set_size_inches(fig.get_figwidth(), new)
    fig.subplots_adjust(top=1.0 - (top_in + extra) / new, bottom=bottom_in / new)
    _title(fig, title.get_text())


def _text_handle() -> Any:
    """The handle of a text-only legend entry: draws nothing."""
    from matplotlib.lines import Line2D

    return Line2D([], [], linestyle="none")


def _key_handles(keys: _Keys) -> tuple[list[Any], list[str]]:
    """Text-only legend entries ``[k]: <mode id>`` of a figure's keys."""
    labels = [_key_entry(key, mode_id) for mode_id, key in keys.ids.items()]
    return [_text_handle() for _ in labels], labels


def _empty(fig: Figure, ax: Axes, text: str) -> None:
    ax.text(0.5, 0.5, text, ha="center", va="center", transform=ax.transAxes)
    ax.set_axis_off()


def _panels(what: str, names: tuple[str, ...]) -> tuple[Figure, list[Axes], tuple[str, ...]]:
    """A figure titled ``what`` with one panel per name drawn (at most :data:`MAX_PANELS`)."""
    drawn = names[:MAX_PANELS]
    fig, axes = _new_figure(len(drawn))
    _panel_title(fig, what, len(names))
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


def set_time_span(ax: Axes, span: tuple[float, float] | None) -> None:
    """Set the x range of ``ax`` (and of the axes sharing it) to a run's time ``span`` exactly.

    Without matplotlib's margins, so that the bins of the reduction
    (:class:`~hybridlog.report.plot_data.PixelBins`) are the panel's pixel columns: a band
    (:func:`draw_curve`) then paints the columns the curve reaches and no other.  A run of
    one sample time (or none) keeps matplotlib's range.
    """
    if span is not None and span[1] > span[0]:
        ax.set_xlim(*span)


#: Room kept between the x tick label at a panel's right end and the figure's edge, in pixels.
TICK_LABEL_PAD_PX = 2.0


def _time_axis(fig: Figure, ax: Axes, origin: float) -> None:
    """Label the time axis of ``ax`` (and the panels above it, which share it).

    The times are drawn from ``origin`` (:func:`~hybridlog.report.plot_data.time_origin`),
    which the label names (:func:`~hybridlog.report.plot_data.time_label`), and the ticks
    are written as the numbers they are, never scaled by a power of ten in the corner (a
    10^6 s run read ``0.2`` ... ``1.0`` over ``1e6``).  A tick label at the panels' right end
    is kept inside the figure (:func:`_fit_ticks_right`).  Call it after the left margin is
    final (:func:`_fit_labels_left`).
    """
    label_time_axis(ax, origin)
    _fit_ticks_right(fig, ax)


def label_time_axis(ax: Axes, origin: float) -> None:
    """Label ``ax``'s x axis as times drawn from ``origin``, its ticks plain numbers.

    The label names ``origin`` (:func:`~hybridlog.report.plot_data.time_label`; the caller
    draws ``t - origin``, :func:`~hybridlog.report.plot_data.time_origin`), and no tick is
    scaled by a power of ten or offset in the corner: a Unix-time run read ``1.7000`` ...
    ``1.7010`` over ``1e9``.  An axis spanning less than a millisecond counts in the unit
    the label names (ms, µs, ns ...: :func:`~hybridlog.report.plot_data.time_unit`; the
    ticks of a nanosecond run all read 0).  Every time axis hybridlog draws is labelled
    here, once its x range is set (the reports' figures, :func:`_time_axis`, and
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
    (``1.701`` of ``1.7010``, ``100000`` of ``1000000``).  As :func:`_fit_labels_left`, the
    curves keep their reduction: its bins are then finer than the panels' pixel columns.
    Twice at most: the ticks may move with the width.
    """
    for _ in range(2):
        overhang = _right_overhang_px(fig, ax)
        if overhang <= 0.0:
            return
        fig.subplots_adjust(right=fig.subplotpars.right - overhang / fig.bbox.width)


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
        _empty(fig, axes[0], "no outputs")
        return _save(fig, path)
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
        cut = _name_label(fig, ax, curves.name, in_unit) or cut
    if cut:
        _fit_labels_left(fig, axes)
    _time_axis(fig, axes[-1], data.time_origin)
    _legend_above(fig, axes)
    return _save(fig, path)


def _spans(edges: FloatArray, first: IntArray, last: IntArray) -> list[tuple[float, float]]:
    """``(start, width)`` of the bars over pixel columns ``first[i] .. last[i]``."""
    widths = edges[last + 1] - edges[first]
    return list(zip(edges[first].tolist(), widths.tolist(), strict=True))


def _draw_bars(
    ax: Axes, edges: FloatArray, bars: Bars, *, height: float, color: str, label: str
) -> None:
    """One bar per range of pixel columns a mode occupies, on the mode's row."""
    labelled = False
    for m, (first, last) in enumerate(bars):
        spans = _spans(edges, first, last)
        if spans:
            ax.broken_barh(
                spans, (m - height / 2, height), color=color, label=None if labelled else label
            )
            labelled = True


MOST_PROBABILITY_LINES = 20
"""Most modes whose probabilities ``modes.png`` draws as lines; more are a heat map
(:func:`_probability_heat_map`).  Up to 20 every mode's line has a colour of its own
(:func:`_mode_styles`), which also tells a long run's band apart (:func:`draw_curve`); the
21st mode's had the 1st's colour in another line style, which a band, filled, does not show:
two modes drawn alike, and their legend entries with them.  Past that, 32 modes were 32
crossing curves over a six-column legend no curve could be matched to."""


def _mode_styles(n_modes: int) -> list[dict[str, Any]]:
    """Colour of each mode's probability curve, distinct for up to 20 modes (solid lines).

    matplotlib's colour cycle has 10 colours: the 11th mode's curve took the 1st's colour,
    two curves of one legend entry's look.  Up to 10 modes the cycle's colours (``tab10``),
    up to :data:`MOST_PROBABILITY_LINES` ``tab20``'s (more modes are a heat map); the
    filter's own curves are dashed in their mode's colour.
    """
    from matplotlib import colormaps

    colours = 10 if n_modes <= 10 else 20
    cmap = colormaps[f"tab{colours}"]
    return [{"color": cmap(j % colours), "ls": "-"} for j in range(n_modes)]


HEAT_MAP_CMAP = "viridis"
"""The heat map's colours (:func:`_probability_heat_map`): perceptually uniform and
sequential, dark at 0 and bright at 1, so a cell's lightness reads as its probability (also
in grey print and to colour-blind readers)."""
FILTERED_ROW_PART = 1.0 / 3.0
"""Height of the filter's own probability within a mode's heat-map row: its middle third,
as the filter's mode is a thin bar inside the estimated one in the panel above."""


def _probability_lines(
    ax: Axes, modes: ModeTimelines, shown: Sequence[str], keys: _Keys
) -> tuple[list[Any], list[str], str | None]:
    """One curve per mode's probability on ``ax``, the filter's own dashed in its colour.

    For at most :data:`MOST_PROBABILITY_LINES` modes.  Returns the entries of their legend
    below the panels (handles, labels, title), drawn once the margins are final.
    """
    filtered = modes.filtered_probabilities
    lines = []
    for j, (m, style) in enumerate(zip(shown, _mode_styles(len(shown)), strict=True)):
        (line,) = draw_curve(ax, modes.probabilities[j], lw=0.8, label=f"p({m})", **style)
        lines.append(line)
        if filtered is not None:
            draw_curve(ax, filtered[j], lw=0.5, ls="--", color=line.get_color())
    labels = [
        _key_entry(keys(m), m) if keys.ids else f"p({label})"
        for m, label in zip(modes.mode_ids, shown, strict=True)
    ]
    handles: list[Any] = list(lines)
    if filtered is not None:
        from matplotlib.lines import Line2D

        handles.append(Line2D([], [], lw=0.5, ls="--", color="0.3"))
        labels.append("filtered (dashed, same colours)")
    title = "mode ids of the keys (line: the mode's probability)" if keys.ids else None
    return handles, labels, title


def _heat_map_cells(modes: ModeTimelines, edges: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The heat map of ``modes``' probabilities: ``(row edges, cells)``, one column per bin.

    ``cells[r, c]`` is the probability of row ``r`` in pixel column ``c`` (between
    ``edges[c]`` and ``edges[c + 1]``): its maximum there
    (:func:`~hybridlog.report.plot_data.column_maxima`), NaN where it has none.  Mode ``j``
    owns rows from ``j - 0.5`` to ``j + 0.5``, as its row in the mode panel; with the filter's
    own probabilities (``filtered_probabilities``) they take the middle
    :data:`FILTERED_ROW_PART` of it, the estimate's the rest, above and below.
    """
    estimate = [column_maxima(curve, edges) for curve in modes.probabilities]
    n_modes = len(estimate)
    centres = np.arange(n_modes, dtype=np.float64)
    if modes.filtered_probabilities is None:
        return np.append(centres - 0.5, n_modes - 0.5), np.array(estimate).reshape(n_modes, -1)
    filtered = [column_maxima(curve, edges) for curve in modes.filtered_probabilities]
    half = FILTERED_ROW_PART / 2.0
    rows = np.stack([centres - 0.5, centres - half, centres + half], axis=1).ravel()
    cells = np.stack([estimate, filtered, estimate], axis=1)  # (mode, part, column)
    return np.append(rows, n_modes - 0.5), cells.reshape(3 * n_modes, -1)


def _probability_heat_map(ax: Axes, modes: ModeTimelines, edges: FloatArray) -> Any:
    """Draw ``modes``' probabilities on ``ax`` as a heat map (:func:`_heat_map_cells`).

    For more than :data:`MOST_PROBABILITY_LINES` modes: a row per mode, those of the mode
    panel above (its y range and labels are set by the caller), time on x, each pixel column's
    probability a colour of :data:`HEAT_MAP_CMAP` from 0 to 1; a column without a value is
    left blank.  Drawn from the reduced curves, a cell per pixel column however long the run.
    Returns the drawn image, for its colour bar (:func:`_colour_bar_below`), or for a run
    of one sample time, which has no width to draw, the colours alone.
    """
    from matplotlib import colormaps
    from matplotlib.colors import Normalize
    from matplotlib.image import PcolorImage

    rows, cells = _heat_map_cells(modes, edges)
    cmap = colormaps[HEAT_MAP_CMAP].with_extremes(bad="white")
    norm = Normalize(0.0, 1.0)
    if not edges[-1] > edges[0]:  # a run of one sample time: no cell has a width (nor a bar)
        from matplotlib.cm import ScalarMappable

        return ScalarMappable(norm, cmap)
    # An image on the grid of the columns' own edges, each pixel the cell under its centre
    # (pcolorfast makes it an evenly spaced image where the edges are even within 1 %,
    # which may shift a cell: drawn so, the cells are the bars' pixel columns exactly).
    image = PcolorImage(
        ax, edges, rows, np.ma.masked_invalid(cells), cmap=cmap, norm=norm,
        extent=(edges[0], edges[-1], rows[0], rows[-1]),
    )  # fmt: skip
    ax.add_image(image)
    # a thin line between two modes' rows: neighbours both probable read as two rows
    n_modes = len(modes.mode_ids)
    ax.hlines(np.arange(n_modes - 1) + 0.5, edges[0], edges[-1], colors="white", lw=0.5)
    return image


#: The colour bar below the panels: its height, its width at most, and the room it takes
#: below the lowest panel's x label (its tick labels and label below it), in inches.
COLOUR_BAR_IN, COLOUR_BAR_WIDTH_IN, COLOUR_BAR_ROOM_IN = 0.12, 3.0, 0.75


def _colour_bar_below(fig: Figure, lowest: Axes, mappable: Any, label: str) -> None:
    """A horizontal colour bar of ``mappable`` labelled ``label``, below ``lowest``'s x label.

    The figure grows at its bottom by :data:`COLOUR_BAR_ROOM_IN`, the panels keeping their
    size and place (so a legend below them stays below, under the bar).  Call it last: the
    bar's axes are placed in fractions of the figure's final height.
    """
    renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    box = lowest.xaxis.get_tightbbox(renderer) or lowest.get_window_extent(renderer)
    below = box.y0 / fig.dpi  # the bottom of the x label
    _grow_below(fig, COLOUR_BAR_ROOM_IN)
    height = fig.get_figheight()
    pars = fig.subplotpars
    width = min(COLOUR_BAR_WIDTH_IN / fig.get_figwidth(), pars.right - pars.left)
    # the room freed is right below the x label: from `below` up, where the panels were
    top_in = below + COLOUR_BAR_ROOM_IN - LEGEND_GAP_IN
    bottom = (top_in - COLOUR_BAR_IN) / height
    cax = fig.add_axes((pars.left, bottom, width, COLOUR_BAR_IN / height))
    bar = fig.colorbar(mappable, cax=cax, orientation="horizontal")
    bar.set_label(label, fontsize="small")
    cax.tick_params(labelsize="small")


def plot_modes(data: PlotData, path: Path) -> Path:
    """Draw the estimated mode timeline (vs truth when known) and the mode probabilities.

    The probabilities are a curve per mode, or for more than
    :data:`MOST_PROBABILITY_LINES` modes a heat map, a row per mode beside the mode panel's
    own (:func:`_probability_heat_map`).  Writes ``path`` (PNG) and returns it.  A result
    with per-component mode columns (``unknown-mode``: joint assignments as modes) gets
    :func:`plot_components` instead.
    """
    components = plot_components(data, path)
    if components is not None:
        return components
    modes = data.modes
    n_rows = len(modes.mode_ids) if isinstance(modes, ModeTimelines) else 0
    panel_height = mode_panel_height(n_rows)
    fig, (ax_mode, ax_prob) = _new_figure(2, panel_height=panel_height)
    _title(fig, "Modes")
    if not isinstance(modes, ModeTimelines):  # no samples (components were drawn above)
        _empty(fig, ax_mode, "no samples")
        _empty(fig, ax_prob, "no samples")
        return _save(fig, path)
    set_time_span(ax_mode, data.span)
    n_modes, edges = len(modes.mode_ids), data.edges
    if modes.truth is not None:
        _draw_bars(ax_mode, edges, modes.truth, height=0.8, color="0.8", label="true")
    _draw_bars(ax_mode, edges, modes.estimated, height=0.3, color="tab:red", label=modes.label)
    if modes.filtered is not None:
        _draw_bars(ax_mode, edges, modes.filtered, height=0.08, color="k", label="filtered")
    ax_mode.set_ylabel("mode")
    keys = _Keys()
    size = _row_label_size(panel_height, n_modes)
    if n_modes <= MOST_PROBABILITY_LINES:
        (shown,) = _row_labels(fig, [(ax_mode, modes.mode_ids, size)], keys)
        ax_mode.set_ylim(-0.5, n_modes - 0.5)
        handles, labels, title = _probability_lines(ax_prob, modes, shown, keys)
        ax_prob.set_ylabel("probability")
        image = None
    else:
        image = _probability_heat_map(ax_prob, modes, edges)
        ax_prob.set_ylabel("probability")
        # the mode panel's rows, labelled alike (keys in both where one needs them)
        _row_labels(fig, [(ax_mode, modes.mode_ids, size), (ax_prob, modes.mode_ids, size)], keys)
        for ax in (ax_mode, ax_prob):
            ax.set_ylim(-0.5, n_modes - 0.5)
        handles, labels = _key_handles(keys)
        title = "mode ids of the keys" if keys.ids else None
        if modes.filtered_probabilities is not None:
            handles.append(_text_handle())
            labels.append("filtered: the middle third of each row")
    # Long mode ids were cut off at the fixed margin.  The probabilities' bins, cut for the
    # fixed panel width, are then finer than the narrower panel's pixel columns: each column
    # still shows every extreme of its samples.
    _fit_labels_left(fig, [ax_mode, ax_prob])
    _time_axis(fig, ax_prob, data.time_origin)
    # Both legends off the panels: the bars' above them, the probabilities' below (inside,
    # in the upper right corner, it hid the most probable mode's curve near 1).
    _legend_above(fig, [ax_mode])
    if labels:
        _legend_below(fig, handles, labels, title=title, text_only=image is not None)
    if image is not None:
        _colour_bar_below(fig, ax_prob, image, "probability")
    return _save(fig, path)


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
        _empty(fig, axes[0], "no states")
        return _save(fig, path)
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
        cut = _name_label(fig, ax, curves.name, in_unit) or cut
    if cut:
        _fit_labels_left(fig, axes)
    _time_axis(fig, axes[-1], data.time_origin)
    _legend_above(fig, axes)
    return _save(fig, path)


UNKNOWN_LABEL = "unknown"
UNKNOWN_COLOR = "tab:red"
KNOWN_COLOR = "tab:blue"


def plot_components(data: PlotData, path: Path) -> Path | None:
    """Draw one mode timeline per component and the joint assignment (paper 002).

    For results with labelled ``mode.<component>`` timeline columns (``unknown-mode``,
    :class:`~hybridlog.report.plot_data.Components`); the ``unknown`` mode is drawn in its
    own colour, over the component's true mode where the log has it, with the causal
    filter's own modes as a thin black line over an offline pass's (``--mode-sequence
    kbest``), as in :func:`plot_modes`.  The last panel shows the estimated joint
    assignment over the assignments it (or the filter) visited.  Returns ``None`` (nothing
    written) when the result has no such columns.
    """
    components = data.modes
    if not isinstance(components, Components):
        return None
    visited = components.joint_ids
    fig, axes = _new_figure(len(components.columns) + 1, panel_height=max(1.0, 0.35 * len(visited)))
    _title(fig, "Modes per component and joint assignment")
    set_time_span(axes[0], data.span)
    keys = _Keys()
    for ax, column in zip(axes, components.columns, strict=False):
        n_labels = len(column.labels)
        if column.truth is not None:
            _draw_bars(ax, data.edges, column.truth, height=0.8, color="0.8", label="true")
        height = 0.7 if column.truth is None else 0.3
        labelled: set[str] = set()
        for label_index, (label, (first, last)) in enumerate(
            zip(column.labels, column.bars, strict=True)
        ):
            color = UNKNOWN_COLOR if label == UNKNOWN_LABEL else KNOWN_COLOR
            legend = components.label if label != UNKNOWN_LABEL else f"{components.label} unknown"
            spans = _spans(data.edges, first, last)
            if spans:
                ax.broken_barh(
                    spans,
                    (label_index - height / 2, height),
                    color=color,
                    label=None if legend in labelled else legend,
                )
                labelled.add(legend)
        if column.filtered is not None:
            _draw_bars(ax, data.edges, column.filtered, height=0.08, color="k", label="filtered")
        _name_label(fig, ax, column.name)
        ax.set_ylim(-0.5, n_labels - 0.5)
    joint = axes[-1]
    _draw_bars(joint, data.edges, components.joint, height=0.6, color="0.3", label=components.label)
    if components.joint_filtered is not None:
        _draw_bars(
            joint, data.edges, components.joint_filtered, height=0.08, color="k", label="filtered"
        )
    joint.set_ylabel("joint")
    joint.set_ylim(-0.5, len(visited) - 0.5)
    panels = [
        (ax, column.labels, None) for ax, column in zip(axes, components.columns, strict=False)
    ]
    _row_labels(fig, [*panels, (joint, visited, "x-small")], keys)
    _fit_labels_left(fig, axes)
    _time_axis(fig, joint, data.time_origin)
    # the components' entries (the joint panel's bars, dark grey, are their own key)
    _legend_above(fig, [*axes[:-1], *([joint] if components.joint_filtered is not None else [])])
    if keys.ids:
        _legend_below(fig, *_key_handles(keys), title="mode ids of the keys", text_only=True)
    return _save(fig, path)


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
