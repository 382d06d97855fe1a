"""The figures hybridlog draws on: matplotlib's own defaults, empty figures made ahead, PNGs.

Every figure hybridlog draws (a run's plots, :mod:`hybridlog.report.plots`; batch's
summary; cluster's picture) is drawn under :func:`matplotlib_defaults`.  A run's figures
are made by :func:`new_figure`, with fixed margins in inches, or taken from those
:func:`prepare_figures` made ahead of the same shape, and written by :func:`save` at zlib
level :data:`PNG_COMPRESS_LEVEL`.  matplotlib is imported when the first figure is made
(:func:`import_matplotlib`), so code that writes no plot does not load it.
"""

from __future__ import annotations

import threading
from collections import Counter
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

from hybridlog.report.pixel_bins import FIGURE_DPI, FIGURE_WIDTH_IN, PANEL_LEFT, PANEL_RIGHT

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = [
    "PNG_COMPRESS_LEVEL",
    "make_ticks_ahead",
    "matplotlib_defaults",
    "new_figure",
    "prepare_figures",
    "prepare_plotting",
    "save",
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


_READY: dict[tuple[int, float], list[tuple[Figure, list[Axes]]]] = {}
"""Empty figures made ahead by shape (:func:`prepare_figures`), each taken once by
:func:`new_figure`."""
TICKS_AHEAD = 10
"""Major ticks made ahead per axis of a prepared figure.  Each tick is a handful of artists
(marks, grid line, labels): on the three figures of a 10^6-sample run the axes draw 8 per
axis (3 on the mode rows), and making them took 0.10-0.17 s of the plots' 0.8 s.  With them
made ahead, the three figures were drawn in 0.52-0.54 s against 0.58 s (fresh processes,
two runs each), byte for byte the same PNGs.  An axis whose locator asks for more makes the
rest when drawn."""


def prepare_figures(shapes: Sequence[tuple[int, float]]) -> None:
    """Make the empty figures (margins, panels, shared axes, tick marks) of these shapes ahead.

    ``analyze`` does it while the estimator's compiled loop runs (:func:`prepare_plotting`,
    in the process's worker or a thread): 0.06-0.13 s of axes set-up that is then not on the
    plots' path, which the command waits for at its end.  A figure
    made ahead is the one :func:`new_figure` would make, with :data:`TICKS_AHEAD` major
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

    About 0.3 s of Python, done by :func:`prepare_plotting` beside the estimator's run.
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


def make_ticks_ahead(axes: Sequence[Axes]) -> None:
    """Make :data:`TICKS_AHEAD` major ticks on both axes of each of ``axes`` now.

    matplotlib makes them when it first draws an axis (each a copy of the first tick's
    properties) and reuses them after: made in a figure prepared ahead, they are not on the
    drawing's path, and the same pixels are drawn.
    """
    for ax in axes:
        ax.xaxis.get_major_ticks(TICKS_AHEAD)
        ax.yaxis.get_major_ticks(TICKS_AHEAD)


def new_figure(n_panels: int, panel_height: float = 2.0) -> tuple[Figure, list[Axes]]:
    """A figure of ``n_panels`` panels (at least one) ``panel_height`` inches high, sharing x.

    One that :func:`prepare_figures` made ahead of that shape if any is left, else a new one.
    """
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


def save(fig: Figure, path: Path) -> Path:
    """Write ``fig`` to ``path`` as a PNG (zlib level :data:`PNG_COMPRESS_LEVEL`); return it."""
    fig.savefig(path, dpi=FIGURE_DPI, pil_kwargs={"compress_level": PNG_COMPRESS_LEVEL})
    return path
