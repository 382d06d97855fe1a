"""What a figure's marks mean, off its panels: legends above and below, a colour bar below.

One legend of the panels' entries stands above the first panel (:func:`legend_above`);
the mode probabilities' legend and the keys of long mode ids (``[1]: <mode id>``,
:func:`key_handles`) stand below the panels (:func:`legend_below`), and so does a heat
map's colour bar (:func:`colour_bar_below`): the figure grows to hold them, its panels
keeping their size, so the pixel columns the curves were reduced to are unchanged.
"""

from __future__ import annotations

import textwrap
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from hybridlog.report.plot_data import plain_text
from hybridlog.report.plot_labels import Keys, figure_title

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = [
    "colour_bar_below",
    "key_entry",
    "key_handles",
    "legend_above",
    "legend_below",
    "text_handle",
]


KEY_WRAP_CHARS = 90
"""A mode id in the key below the panels is wrapped to lines of at most this many
characters (a joint assignment of a ``[components]`` model joins one id per component)."""


LEGEND_COLUMNS = 6
"""Most columns of a legend below the panels (:func:`legend_below`)."""


def key_entry(key: str, mode_id: str) -> str:
    """``[1]: <mode id>``, the id wrapped at :data:`KEY_WRAP_CHARS` and drawn as written."""
    lines = textwrap.wrap(
        mode_id, KEY_WRAP_CHARS, break_long_words=True, break_on_hyphens=False
    ) or [mode_id]
    return f"{key}: " + "\n".join(plain_text(line) for line in lines)


#: Space between the lowest panel's x label and a legend below the panels, in inches.
LEGEND_GAP_IN = 0.1


def legend_below(
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
    to, is unchanged.  Call it after the left margin is final (:func:`fit_labels_left`).
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
        figure_title(fig, fig.get_suptitle())


def legend_above(fig: Figure, axes: Sequence[Axes]) -> None:
    """One legend of the entries of every panel of ``axes``, above the first, right-aligned.

    Off the data: a legend in a panel's corner hid the curves and mode bars under it (a
    state's estimate ending at its largest value ran under ``upper right``), and the styles
    are the same in every panel, whose y label names what it shows.  The entries are in one
    row while the panels' width holds them, else in as many rows as needed; where the
    legend reaches the figure's title, the figure grows at its top by the legend's height,
    the panels keeping their size (the pixel columns the curves were reduced to unchanged).
    Call it after the left margin is final (:func:`fit_labels_left`).
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
    figure_title(fig, title.get_text())


def text_handle() -> Any:
    """The handle of a text-only legend entry: draws nothing."""
    from matplotlib.lines import Line2D

    return Line2D([], [], linestyle="none")


def key_handles(keys: Keys) -> tuple[list[Any], list[str]]:
    """Text-only legend entries ``[k]: <mode id>`` of a figure's keys."""
    labels = [key_entry(key, mode_id) for mode_id, key in keys.ids.items()]
    return [text_handle() for _ in labels], labels


#: The colour bar below the panels: its height, its width at most, and the room it takes
#: below the lowest panel's x label (its tick labels and label below it), in inches.
COLOUR_BAR_IN, COLOUR_BAR_WIDTH_IN, COLOUR_BAR_ROOM_IN = 0.12, 3.0, 0.75


def colour_bar_below(fig: Figure, lowest: Axes, mappable: Any, label: str) -> None:
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
