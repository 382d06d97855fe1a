"""The text beside a figure's panels: its title, the y labels, the rows' mode ids or keys.

A figure's title hangs at a fixed distance below its top (:func:`figure_title`); a y label
naming an output, state or component is cut into lines that fit its panel
(:func:`name_label`); mode ids label their rows as written, or as keys ``[1]``, ``[2]``,
... where too wide (:func:`row_labels`, :class:`Keys`, listed below the panels by
:mod:`hybridlog.report.plot_legends`); the left margin widens to hold them
(:func:`fit_labels_left`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from hybridlog.report.pixel_bins import PANEL_LEFT
from hybridlog.report.plot_data import MAX_PANELS, plain_text

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = [
    "Keys",
    "empty_panel",
    "figure_title",
    "fit_labels_left",
    "name_label",
    "panel_title",
    "row_labels",
]


#: Where a figure's title hangs: this far (inches) below the top, whatever the figure's
#: height (the panels start 0.45 in below it); at the default 0.98 of the height, the title
#: of a tall figure (a ``[components]`` model's modes.png) ran into its first panel.
TITLE_TOP_IN = 0.1


def figure_title(fig: Figure, text: str) -> None:
    """Title ``fig`` with ``text``, hung :data:`TITLE_TOP_IN` below its top."""
    fig.suptitle(text, y=1.0 - TITLE_TOP_IN / fig.get_figheight(), va="top")


def panel_title(fig: Figure, what: str, total: int) -> None:
    """Title ``fig`` with ``what``, and which panels it shows past ``MAX_PANELS`` of ``total``."""
    if total > MAX_PANELS:
        figure_title(fig, f"{what} (first {MAX_PANELS} of {total})")
    else:
        figure_title(fig, what)


#: The ticks, the pads beside the tick labels and the y label, and a margin, in inches.
LABEL_PADS_IN = 0.25


def fit_labels_left(fig: Figure, axes: Sequence[Axes]) -> None:
    """Widen the figure's left margin to the widest y tick label and y label of ``axes``.

    For figures of mode bars and curves of a few values per pixel column (a curve reduced
    to the fixed panel width's pixel columns then has bins finer than the narrower panel's,
    which it draws as faithfully): a component's modes (``one_bank_out``), the joint
    assignments (``partly_open|partly_open|closed|closed|full|growth``) and long mode ids
    were cut off at the fixed margin; so would be the lines of a long output's or state's
    name (:func:`name_label`), whose curves are drawn as faithfully.
    Text is measured by the Agg renderer, without a layout pass; the margin is at most half
    the width (mode ids wider than :data:`KEYED_LABELS_WIDTH` are drawn as keys instead:
    :func:`row_labels`).
    """
    need = max((_labels_width_in(fig, ax) for ax in axes), default=0.0)
    left = min(max(PANEL_LEFT, need / fig.get_figwidth()), 0.5)
    if left > PANEL_LEFT:
        fig.subplots_adjust(left=left)


NAME_LABEL_SIZES = (10.0, 8.0, 6.0)
"""Font sizes (points) a panel's y label naming an output, state or component may take, the
first whose wrapped lines are at most :data:`NAME_LABEL_LINES` (:func:`name_label`)."""
NAME_LABEL_LINES = 4
"""Most lines a y label naming an output, state or component is wrapped to before its font
shrinks (at the smallest of :data:`NAME_LABEL_SIZES` it takes as many as it needs)."""


def name_label(fig: Figure, ax: Axes, name: str, suffix: str = "") -> bool:
    """Label the y axis of ``ax`` with ``name`` (user text) and ``suffix``, within its height.

    A symbol name has no length limit and a component's name may have 64 characters: a
    75-character output's label, drawn upright at 10 pt, was 2.5 times its panel's height
    and ran over the labels of the panels beside it and off the figure.  A label longer
    than the panel is cut into lines that fit it (the name cut anywhere, each line drawn as
    written, :func:`plain_text`; ``suffix``, hybridlog's own text, ends the last), in a
    smaller font (:data:`NAME_LABEL_SIZES`) where it would take more than
    :data:`NAME_LABEL_LINES` lines.  Returns whether it was cut: the figure's left margin
    must then hold the lines (:func:`fit_labels_left`).
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
the figure's width; wider ones are drawn as keys (:func:`row_labels`).  A 60-character mode
id needed more than the half :func:`fit_labels_left` allows and was cut off at the
figure's left edge; widening the margin further would leave the panels no room."""


class Keys:
    """Short keys ``[1]``, ``[2]``, ... of the mode ids too long to label a panel's rows.

    One key per id in a figure, in the order they are first asked for; the figure lists
    them below its panels (:func:`key_handles`, :func:`legend_below`).
    """

    def __init__(self) -> None:
        self.ids: dict[str, str] = {}

    def __call__(self, mode_id: str) -> str:
        """The key of ``mode_id``: the one it was given, else the next."""
        return self.ids.setdefault(mode_id, f"[{len(self.ids) + 1}]")


def _labels_width_in(fig: Figure, ax: Axes) -> float:
    """Inches the y tick labels and the y label of ``ax`` take beside it (with the pads)."""
    renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    ticks = max((t.get_window_extent(renderer).width for t in ax.get_yticklabels()), default=0.0)
    label = ax.yaxis.label.get_window_extent(renderer).width if ax.get_ylabel() else 0.0
    return float((ticks + label) / fig.dpi + LABEL_PADS_IN)


def row_labels(
    fig: Figure, panels: Sequence[tuple[Axes, Sequence[str], str | float | None]], keys: Keys
) -> list[list[str]]:
    """Label the rows of each panel ``(ax, mode_ids, fontsize)``, row ``j`` ``mode_ids[j]``.

    ``fontsize`` ``None`` is the tick labels' own size.  The ids as written
    (:func:`plain_text`) while every panel's fit in :data:`KEYED_LABELS_WIDTH` of the
    figure's width beside its y label (set it first), else, in every panel, their
    :class:`Keys`, which the figure lists below its panels with the ids in full.  Returns
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


def empty_panel(fig: Figure, ax: Axes, text: str) -> None:
    """Write ``text`` in the middle of ``ax`` instead of its axes: a panel with nothing to draw."""
    ax.text(0.5, 0.5, text, ha="center", va="center", transform=ax.transAxes)
    ax.set_axis_off()
