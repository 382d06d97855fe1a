"""``modes.png``: a run's mode timelines as runs, one row per mode, and the mode probabilities.

The estimated timeline (over the true one when known, and under the causal filter's own
for a smoothed run) and the probabilities: a curve per mode, or past
:data:`MOST_PROBABILITY_LINES` modes a heat map on the same rows (:func:`plot_modes`); for
a ``[components]`` result (``unknown-mode``) one timeline per component and the joint
assignment (:func:`plot_components`).  The panels are as tall as their rows need
(:func:`mode_panel_height`).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from hybridlog.report.curve_envelopes import column_maxima
from hybridlog.report.plot_curves import draw_curve
from hybridlog.report.plot_data import Components, ModeTimelines, PlotData
from hybridlog.report.plot_figures import new_figure, save
from hybridlog.report.plot_labels import (
    Keys,
    empty_panel,
    figure_title,
    fit_labels_left,
    name_label,
    row_labels,
)
from hybridlog.report.plot_legends import (
    colour_bar_below,
    key_entry,
    key_handles,
    legend_above,
    legend_below,
    text_handle,
)
from hybridlog.report.plot_time_axis import set_time_span, time_axis
from hybridlog.report.timeline_bars import Bars
from hybridlog.signals import FloatArray, IntArray

if TYPE_CHECKING:
    from matplotlib.axes import Axes

__all__ = [
    "mode_panel_height",
    "plot_components",
    "plot_modes",
]


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
    ax: Axes, modes: ModeTimelines, shown: Sequence[str], keys: Keys
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
        key_entry(keys(m), m) if keys.ids else f"p({label})"
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
    (:func:`~hybridlog.report.curve_envelopes.column_maxima`), NaN where it has none.  Mode ``j``
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
    Returns the drawn image, for its colour bar (:func:`colour_bar_below`), or for a run
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
    fig, (ax_mode, ax_prob) = new_figure(2, panel_height=panel_height)
    figure_title(fig, "Modes")
    if not isinstance(modes, ModeTimelines):  # no samples (components were drawn above)
        empty_panel(fig, ax_mode, "no samples")
        empty_panel(fig, ax_prob, "no samples")
        return save(fig, path)
    set_time_span(ax_mode, data.span)
    n_modes, edges = len(modes.mode_ids), data.edges
    if modes.truth is not None:
        _draw_bars(ax_mode, edges, modes.truth, height=0.8, color="0.8", label="true")
    _draw_bars(ax_mode, edges, modes.estimated, height=0.3, color="tab:red", label=modes.label)
    if modes.filtered is not None:
        _draw_bars(ax_mode, edges, modes.filtered, height=0.08, color="k", label="filtered")
    ax_mode.set_ylabel("mode")
    keys = Keys()
    size = _row_label_size(panel_height, n_modes)
    if n_modes <= MOST_PROBABILITY_LINES:
        (shown,) = row_labels(fig, [(ax_mode, modes.mode_ids, size)], keys)
        ax_mode.set_ylim(-0.5, n_modes - 0.5)
        handles, labels, title = _probability_lines(ax_prob, modes, shown, keys)
        ax_prob.set_ylabel("probability")
        image = None
    else:
        image = _probability_heat_map(ax_prob, modes, edges)
        ax_prob.set_ylabel("probability")
        # the mode panel's rows, labelled alike (keys in both where one needs them)
        row_labels(fig, [(ax_mode, modes.mode_ids, size), (ax_prob, modes.mode_ids, size)], keys)
        for ax in (ax_mode, ax_prob):
            ax.set_ylim(-0.5, n_modes - 0.5)
        handles, labels = key_handles(keys)
        title = "mode ids of the keys" if keys.ids else None
        if modes.filtered_probabilities is not None:
            handles.append(text_handle())
            labels.append("filtered: the middle third of each row")
    # Long mode ids were cut off at the fixed margin.  The probabilities' bins, cut for the
    # fixed panel width, are then finer than the narrower panel's pixel columns: each column
    # still shows every extreme of its samples.
    fit_labels_left(fig, [ax_mode, ax_prob])
    time_axis(fig, ax_prob, data.time_origin)
    # Both legends off the panels: the bars' above them, the probabilities' below (inside,
    # in the upper right corner, it hid the most probable mode's curve near 1).
    legend_above(fig, [ax_mode])
    if labels:
        legend_below(fig, handles, labels, title=title, text_only=image is not None)
    if image is not None:
        colour_bar_below(fig, ax_prob, image, "probability")
    return save(fig, path)


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
    fig, axes = new_figure(len(components.columns) + 1, panel_height=max(1.0, 0.35 * len(visited)))
    figure_title(fig, "Modes per component and joint assignment")
    set_time_span(axes[0], data.span)
    keys = Keys()
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
        name_label(fig, ax, column.name)
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
    row_labels(fig, [*panels, (joint, visited, "x-small")], keys)
    fit_labels_left(fig, axes)
    time_axis(fig, joint, data.time_origin)
    # the components' entries (the joint panel's bars, dark grey, are their own key)
    legend_above(fig, [*axes[:-1], *([joint] if components.joint_filtered is not None else [])])
    if keys.ids:
        legend_below(fig, *key_handles(keys), title="mode ids of the keys", text_only=True)
    return save(fig, path)
