"""``summary.png`` of a batch: each log's key metrics side by side, failures marked.

Three panels over the logs in natural order: VAF (%), mode accuracy (%) and MSE (log scale
when it spans more than a decade).  In a batch with ``--smooth`` or ``--mode-sequence`` the
mode accuracy is that of the offline estimates (what a ``mode_accuracy`` gate reads), and
its panel says so and shows the filter's own beside it (grey rings, a line to the offline
value: the gain of each log); VAF and MSE are the filter's one-step-ahead prediction either
way.
A log that missed a gate is drawn in red; a log that could not be analysed gets a red cross
at the bottom of every panel; a mode accuracy over part of its log (a true mode that starts
late: summary.csv's ``mode_samples``) is a triangle, not a dot; an analysed log without a
value (no mode accuracy: no true mode, or modes given; an undefined VAF or MSE, report.json's
``null_reasons`` says why) a hollow square at the bottom of the panel, red if it missed a
gate (a ``mode_accuracy`` gate on a log without a true mode): the panel showed nothing of
it.  A panel without any value (every log failed; no log with a true mode) has no y ticks
and says so.  The y ticks are values, never an offset added to them (VAFs of 99.993 % and 99.994 %
read as themselves).  Drawn with matplotlib's Agg canvas (no pyplot, no global state), like
the per-log plots (:mod:`hybridlog.report.plots`).
"""

from __future__ import annotations

import io
import math
import unicodedata
from collections import Counter
from collections.abc import Sequence
from pathlib import Path

from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from hybridlog.errors import excerpt, printable
from hybridlog.report.coverage import mode_coverage
from hybridlog.report.markdown import plural
from hybridlog.report.plot_data import plain_text
from hybridlog.report.plot_figures import PNG_COMPRESS_LEVEL, make_ticks_ahead, matplotlib_defaults
from hybridlog.report.summary_rows import BatchRow

__all__ = ["MAX_LABELS", "prepare_summary_figure", "summary_figure", "write_summary_plot"]

MAX_LABELS = 40
"""Up to this many logs, the x axis names each log; beyond it, it numbers them from 1."""

_OK, _MISSED, _FAILED = "#1f77b4", "#d62728", "#d62728"
_PANELS = (("vaf", "VAF (%)"), ("mode_accuracy", "mode accuracy (%)"), ("mse", "MSE"))
_PARTIAL_MARKER, _PARTIAL_GLYPH = "^", "▲"
"""How a mode accuracy over part of its log is drawn, and named in the panel's label."""
_UNKNOWN_MARKER, _UNKNOWN_GLYPH = "s", "□"
"""How an analysed log without a value is drawn (hollow, at the bottom), and named."""
_UNKNOWN_NAMES = {"mode_accuracy": "no mode accuracy"}
"""What an analysed log without a value of the panel's metric lacks ("undefined" else): no
true mode in the log, or modes it gives rather than estimates (``switching-observer``), whose
report.json's ``null_reasons`` says which."""

_MARK_HEIGHT = 0.04
"""Where the marks at the bottom of a panel sit, in its height (inside it, above its edge)."""
_READY: dict[int, tuple[Figure, list[Axes]]] = {}
"""The empty figure made ahead for a number of logs (:func:`prepare_summary_figure`)."""


def _value(row: BatchRow, metric: str) -> float | None:
    report = row.report
    if report is None:
        return None
    value = {
        "vaf": report.vaf,
        "mode_accuracy": None if report.modes.accuracy is None else 100 * report.modes.accuracy,
        "mse": report.mse,
    }[metric]
    return None if value is None or not math.isfinite(value) else float(value)


def _partial(row: BatchRow) -> bool:
    """Whether the log's mode accuracy is over part of it (:func:`mode_coverage`)."""
    return row.report is not None and mode_coverage(row.report) is not None


def _filtered_beside(ax: Axes, rows: Sequence[BatchRow], offline: Sequence[float | None]) -> None:
    """The filter's own mode accuracy of each log (a grey ring), joined to the offline one."""
    shown = [
        (k, 100 * own, offline[k])
        for k, row in enumerate(rows)
        if (own := row.offline_pairs(["mode_accuracy"])[0][2]) is not None and math.isfinite(own)
    ]
    if not shown:
        return
    xs, owns, offs = zip(*shown, strict=True)
    ax.vlines(
        [x for x, off in zip(xs, offs, strict=True) if off is not None],
        [own for own, off in zip(owns, offs, strict=True) if off is not None],
        [off for off in offs if off is not None],
        color="#7f7f7f",
        linewidth=0.8,
        zorder=2,
    )
    ax.scatter(xs, owns, s=16, facecolors="none", edgecolors="#7f7f7f", zorder=2)


def _room_at_bottom(ax: Axes) -> None:
    """Lower the panel's bottom so that its marks at the bottom sit under every value.

    A log not analysed (a cross) or without a value (a hollow square) is drawn at
    :data:`_MARK_HEIGHT` of the panel's height, which autoscaling gives to its lowest
    value: the square of a log without a true mode read as a mode accuracy of 98 % beside
    a dot at 98 %.
    """
    bottom, top = ax.get_ylim()
    if ax.get_yscale() == "log":
        ax.set_ylim(bottom=bottom * (bottom / top) ** 0.1)
    else:
        ax.set_ylim(bottom=bottom - 0.1 * (top - bottom))


@matplotlib_defaults()  # the caller's rcParams draw nothing here
def write_summary_plot(path: Path, title: str, rows: Sequence[BatchRow]) -> None:
    """Draw ``summary.png`` (see the module docstring) into ``path``.

    zlib level 1, as the per-log plots: 200 logs' figure (1600 x 640 pixels) was encoded in
    0.026 s against 0.041 s at Pillow's default, 73 KB against 52 KB; this is the last thing
    a batch does, on one core.
    """
    figure = summary_figure(title, rows)
    figure.savefig(path, dpi=100, format="png", pil_kwargs={"compress_level": PNG_COMPRESS_LEVEL})


@matplotlib_defaults()  # the caller's rcParams draw nothing here
def prepare_summary_figure(n_rows: int) -> None:
    """Make the empty figure of ``summary.png`` for ``n_rows`` logs ahead, and draw once.

    ``batch`` does it in a thread while its workers analyse the logs and the batch process
    only waits (:func:`hybridlog.jobs.batch.run_batch`): the figure, its panels and their
    ticks, and a first PNG drawn (a small figure with text: the font loaded, the PNG writer's
    plugins imported) are then not on the command's path after the last log.  The figure
    made ahead is the one :func:`summary_figure` would make for as many logs; the same
    pixels are drawn on it.
    """
    fig, axes = _empty_figure(n_rows)
    make_ticks_ahead(axes)
    _READY.clear()
    _READY[n_rows] = fig, axes
    first = Figure(figsize=(1.0, 1.0))
    FigureCanvasAgg(first)
    first.suptitle("0123456789", fontsize=10)
    first.savefig(io.BytesIO(), dpi=10, format="png")


def _empty_figure(n_rows: int) -> tuple[Figure, list[Axes]]:
    width = min(6.0 + 0.12 * n_rows, 16.0)
    height = 6.4
    fig = Figure(figsize=(width, height))
    FigureCanvasAgg(fig)
    # margins in inches (a layout engine costs more than the drawing): the y labels, the
    # two-line title, the rotated log names
    below = 1.3 if n_rows <= MAX_LABELS else 0.6
    fig.subplots_adjust(
        left=0.95 / width, right=1 - 0.2 / width, top=1 - 0.6 / height, bottom=below / height
    )
    return fig, list(fig.subplots(len(_PANELS), 1, sharex=True, squeeze=False)[:, 0])


LABEL_CHARS = 24
"""Longest name of a log on the x axis; a longer one is shown by its end (:func:`_log_labels`)."""


def _log_labels(folders: Sequence[str]) -> list[str]:
    """The x tick labels of the logs' report folders: each folder's end, the logs told apart.

    A folder is shown as written (control characters escaped: the font has no glyph for
    them, and matplotlib warned), a longer one than :data:`LABEL_CHARS` by its last
    characters after ``…``.  Logs of the same name in different folders
    (``robot_a/2024-05-01/recording.mcap``, ``robot_b/...``) ended alike: two ticks of one
    label, nothing to tell which point was which.  The labels that are alike (to the eye:
    ``café.csv`` with ``é`` one character and two, NFC and NFD, are alike) start with the
    log's place on the axis and in summary.csv (``#2 …``).
    """
    written = [excerpt(folder, len(folder) * 6)[1:-1] for folder in folders]

    def end(name: str, chars: int) -> str:
        return name if len(name) <= chars else f"…{name[-(chars - 1) :]}"

    shown = [end(name, LABEL_CHARS) for name in written]
    # alike to the eye: the same name with an accent one character (NFC) and two (NFD)
    alike = Counter(unicodedata.normalize("NFC", label) for label in shown)
    labels = []
    for k, (name, label) in enumerate(zip(written, shown, strict=True)):
        if alike[unicodedata.normalize("NFC", label)] > 1:
            place = f"#{k + 1} "
            label = place + end(name, max(LABEL_CHARS - len(place), 2))
        labels.append(plain_text(label))
    return labels


def _counts(rows: Sequence[BatchRow]) -> str:
    """The title's second line: how many logs, not analysed, and missed a gate.

    An analysed log carries a result per gate given (:attr:`BatchRow.gates`): when none
    does, no gate was given, and the title says so rather than "0 missed a gate (red)",
    which read as gates checked and met.  When no log was analysed, nothing tells.
    """
    failed = sum(1 for row in rows if row.status == "failed")
    parts = [plural(len(rows), "log"), f"{failed:,} not analysed (crosses)"]
    if any(row.gates for row in rows):
        missed = sum(1 for row in rows if row.status != "failed" and row.missed)
        parts.append(f"{missed:,} missed a gate (red)")
    elif failed < len(rows):
        parts.append("no gate given")
    return ", ".join(parts)


TITLE_MIN_CHARS = 12
"""Fewest characters :func:`_title` cuts the title's first line to."""


def _title(fig: Figure, title: str, counts: str) -> None:
    r"""The figure's two-line title: ``title`` (model · estimator ...) over ``counts``.

    The first line is one line within the figure's width: its control characters escaped
    (a model named ``"a\nb"`` made the title three lines, the last over the first panel),
    and a line wider than the figure cut in the middle with ``…`` (a model name of 300
    characters ran off both sides, the estimator's name with it), as the log labels are.
    """
    line = printable(title)
    text = fig.suptitle(f"{plain_text(line)}\n{counts}", fontsize=10)
    renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    room = 0.98 * fig.bbox.width
    while len(line) > TITLE_MIN_CHARS and (width := text.get_window_extent(renderer).width) > room:
        limit = min(int(len(line) * room / width), len(line) - 1)
        line = excerpt(title, max(limit, TITLE_MIN_CHARS))[1:-1]
        text.set_text(f"{plain_text(line)}\n{counts}")


def summary_figure(title: str, rows: Sequence[BatchRow]) -> Figure:
    """The figure of ``summary.png``: one panel per key metric over the logs."""
    ready = _READY.pop(len(rows), None)
    fig, axes = ready if ready is not None else _empty_figure(len(rows))
    _title(fig, title, _counts(rows))
    positions = range(len(rows))
    offline = any(row.report is not None and row.report.smoothing is not None for row in rows)
    for ax, (metric, label) in zip(axes, _PANELS, strict=True):
        if metric == "mode_accuracy" and offline:
            label = "mode accuracy (%)\n● offline ○ filter"
        values = [_value(row, metric) for row in rows]
        groups = (
            (_OK, [row.passed for row in rows]),
            (_MISSED, [row.status != "failed" and bool(row.missed) for row in rows]),
        )
        # a mode accuracy over part of its log (a true mode that starts late) is a triangle
        partial = [metric == "mode_accuracy" and _partial(row) for row in rows]
        if any(partial):
            label += f"\n{_PARTIAL_GLYPH} over part of the log"
        for colour, keep in groups:
            for marker, over_part in (("o", False), (_PARTIAL_MARKER, True)):
                shown = [
                    (k, v)
                    for k, v in enumerate(values)
                    if keep[k] and v is not None and partial[k] == over_part
                ]
                if shown:
                    xs, ys = zip(*shown, strict=True)
                    ax.scatter(xs, ys, s=16, color=colour, marker=marker, zorder=3)
        # an analysed log without a value (no true mode): a hollow square at the bottom
        unknown = [k for k, row in enumerate(rows) if row.report is not None and values[k] is None]
        if unknown:
            label += f"\n{_UNKNOWN_GLYPH} {_UNKNOWN_NAMES.get(metric, 'undefined')}"
        for colour, keep in groups:
            shown_unknown = [k for k in unknown if keep[k]]
            if shown_unknown:
                ax.scatter(
                    shown_unknown,
                    [_MARK_HEIGHT] * len(shown_unknown),
                    marker=_UNKNOWN_MARKER,
                    s=20,
                    facecolors="none",
                    edgecolors=colour,
                    transform=ax.get_xaxis_transform(),
                    zorder=3,
                    clip_on=False,  # at the panel's bottom edge: drawn whole, not cut in half
                )
        if metric == "mode_accuracy" and offline:  # before the limits are fixed below
            _filtered_beside(ax, rows, values)
        crosses = [k for k, row in enumerate(rows) if row.status == "failed"]
        if crosses:
            ax.scatter(
                crosses,
                [_MARK_HEIGHT] * len(crosses),
                marker="x",
                s=36,
                color=_FAILED,
                transform=ax.get_xaxis_transform(),
                zorder=3,
                clip_on=False,
            )
        positive = [v for v in values if v is not None and v > 0]
        if metric == "mse" and positive and max(positive) > 10 * min(positive):
            ax.set_yscale("log")  # MSEs spanning decades
        elif metric != "mse" and ax.get_ylim()[1] > 100:
            ax.set_ylim(top=101.0)  # percentages: nothing is above 100
        if crosses or unknown:
            _room_at_bottom(ax)
        if all(value is None for value in values):
            _no_values(ax, analysed=any(row.report is not None for row in rows))
        elif ax.get_yscale() == "linear":
            # values themselves on the ticks: close VAFs (99.9929, 99.9936) read "0.0000,
            # 0.0006" under an offset "+9.9993e1" above the panel
            ax.ticklabel_format(axis="y", useOffset=False)
        ax.set_ylabel(label, fontsize=9)
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlim(-0.5, max(len(rows) - 0.5, 0.5))
    if len(rows) <= MAX_LABELS:
        axes[-1].set_xticks(list(positions))
        names = _log_labels([row.folder for row in rows])
        axes[-1].set_xticklabels(names, rotation=60, fontsize=7)  # long paths: their ends
    else:
        _number_logs(axes[-1], len(rows))
    return fig


def _no_values(ax: Axes, *, analysed: bool) -> None:
    """Say so in a panel without a value (every log failed, or none has a true mode).

    Its y axis kept matplotlib's default ticks, ``-0.05`` to ``0.05``, under "mode accuracy
    (%)": a scale of no value, beside marks at its bottom that read as a mode accuracy of
    about 0 %.
    """
    ax.set_yticks([])
    ax.text(
        0.5,
        0.5,
        "no log has a value" if analysed else "no log analysed",
        transform=ax.transAxes,
        ha="center",
        va="center",
        fontsize=9,
        color="#7f7f7f",
    )


def _number_logs(ax: Axes, n_rows: int) -> None:
    """Tick the logs by their number from 1, their row in summary.csv.

    The axis counted the logs' places from 0: its tick ``50`` was the 51st log of the
    summaries (and ``#51`` of :func:`_log_labels`).
    """
    from matplotlib.ticker import MaxNLocator

    numbers = [
        1,
        *(
            int(v)
            for v in MaxNLocator(steps=[1, 2, 5, 10], integer=True).tick_values(1, n_rows)
            if 1 < v <= n_rows
        ),
    ]
    ax.set_xticks([k - 1 for k in numbers], [str(k) for k in numbers])
    ax.set_xlabel("log, numbered as the rows of summary.csv")
