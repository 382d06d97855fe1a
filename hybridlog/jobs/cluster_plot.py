"""The picture ``hybridlog cluster`` draws: regression vectors, centres and the decided modes.

Left: the regression vectors φ(k) in the plane of their first two components (``y(k)`` and
the next one), coloured by the cluster the decision rule (eqs. (2)–(3)) gives them, with the
subtractive-clustering centres (black crosses) and the k-means centres (red pluses).
Right: ``y(k)`` over time coloured the same way, the decision variables ``y_i*`` as
horizontal lines, and the true mode when the log has it; times are drawn as the reports'
figures draw them (a Unix-time log from its first sample, the label naming it,
:func:`~hybridlog.report.plot_time_axis.label_time_axis`).  With more than
:data:`MAX_CLUSTER_COLOURS` clusters (a small radius gives hundreds) one colour and one legend
entry per cluster would repeat colours and bury the axes under the legend: the samples are
then coloured by the mode their cluster decides (grey when unlabelled), and the decision
variables are ticks at the right edge.  Agg canvas, no pyplot.

The same clusters give the same bytes in every format (:func:`save_reproducibly`): matplotlib
stamps an SVG with the time it was drawn and random element ids, and a PDF with its creation
date, so two runs on one log wrote different pictures where the PNG and centers.json agreed.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
from matplotlib import rc_context
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from hybridlog.report.plot_data import plain_text
from hybridlog.report.plot_figures import matplotlib_defaults
from hybridlog.report.plot_time_axis import label_time_axis, time_origin
from hybridlog.signals import FloatArray, IntArray

__all__ = ["MAX_CLUSTER_COLOURS", "plot_clusters", "save_reproducibly"]

_MAX_POINTS = 20_000

MAX_CLUSTER_COLOURS = 10
"""Most clusters drawn one colour and one legend entry each (matplotlib's ten colours)."""


_UNDATED: Mapping[str, Mapping[str, None]] = {
    ".svg": {"Date": None},
    ".pdf": {"CreationDate": None},
}
"""The metadata of each format that would record when the picture was drawn, left out."""


def save_reproducibly(fig: Figure, path: Path, *, dpi: int) -> None:
    """Save ``fig`` to ``path`` (format from its suffix) as the same bytes every time.

    No date in an SVG's or PDF's metadata, and the SVG's element ids hashed with a fixed
    salt (matplotlib salts them with a random UUID, and ``SOURCE_DATE_EPOCH`` set in the
    environment would put that date back).
    """
    metadata = dict(_UNDATED.get(path.suffix.lower(), {}))
    with rc_context({"svg.hashsalt": "hybridlog"}):
        fig.savefig(path, dpi=dpi, metadata=metadata or None)


def _groups(
    n_clusters: int, cluster_modes: Sequence[str] | None
) -> tuple[list[int], list[str], list[str]]:
    """Group of each cluster, and each group's colour and legend text."""
    if n_clusters <= MAX_CLUSTER_COLOURS:
        labels = [
            f"cluster {c + 1}" + ("" if cluster_modes is None else f" -> mode '{cluster_modes[c]}'")
            for c in range(n_clusters)
        ]
        return list(range(n_clusters)), [f"C{c}" for c in range(n_clusters)], labels
    if cluster_modes is None:
        return [0] * n_clusters, ["grey"], [f"{n_clusters} clusters (not labelled)"]
    modes = list(dict.fromkeys(cluster_modes))
    group = [modes.index(m) for m in cluster_modes]
    counts = [group.count(g) for g in range(len(modes))]
    labels = [f"mode '{m}' ({n} clusters)" for m, n in zip(modes, counts, strict=True)]
    return group, [f"C{g % 10}" for g in range(len(modes))], labels


@matplotlib_defaults()  # the caller's rcParams draw nothing here
def plot_clusters(
    path: Path,
    *,
    time: FloatArray,
    phi: FloatArray,
    names: Sequence[str],
    clusters: IntArray,
    centers: FloatArray,
    cluster_modes: Sequence[str] | None,
    decision_values: FloatArray,
    mode_ids: Sequence[str],
    kmeans_centers: FloatArray | None = None,
    truth: Sequence[str | None] | None = None,
    accuracy: str | None = None,
) -> Path:
    """Draw the clusters to ``path`` (PNG, SVG or PDF, from its suffix).

    Parameters
    ----------
    time:
        Times of the rows of ``phi``.
    phi:
        Regression vectors, shape ``(N, d)``.
    names:
        Component names of φ.
    clusters:
        Cluster of each row (decision rule).
    centers:
        Subtractive-clustering centres ``(c, d)``.
    cluster_modes:
        Mode id of each cluster, or ``None`` when the clusters are not labelled.
    decision_values:
        ``y_i*`` of the first output, shape ``(c,)``.
    mode_ids:
        The model's modes, in its order: the true mode's levels, bottom up.
    kmeans_centers:
        k-means centres, or ``None``.
    truth:
        True mode id of each row (``None`` for a row before a true mode that starts late:
        no line there), or ``None``.
    accuracy:
        The decision rule's mode accuracy on the log in words (over which samples, for a
        true mode that starts late), drawn above both panels; ``None``: none.
    """
    fig = Figure(figsize=(12.0, 4.8), layout="constrained")
    FigureCanvasAgg(fig)
    left, right = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.0, 1.6]})
    step = max(1, phi.shape[0] // _MAX_POINTS)
    other = 1 if phi.shape[1] > 1 else 0
    group, colours, labels = _groups(len(centers), cluster_modes)
    origin = time_origin(float(time[0]), float(time[-1])) if time.size else 0.0
    time = time - origin
    of_group = np.asarray(group, dtype=np.int64)[clusters]
    for g, (colour, label) in enumerate(zip(colours, labels, strict=True)):
        chosen = np.flatnonzero(of_group == g)[::step]
        left.scatter(phi[chosen, 0], phi[chosen, other], s=4, color=colour, label=plain_text(label))
        right.scatter(time[chosen], phi[chosen, 0], s=3, color=colour)
    few = len(centers) <= MAX_CLUSTER_COLOURS
    for c, value in enumerate(np.asarray(decision_values, dtype=float)):
        colour = colours[group[c]]
        if few:
            right.axhline(float(value), color=colour, lw=0.8, ls="--")
        else:  # hundreds of lines would hide the samples: a tick at the right edge each
            right.plot(
                [1.0, 1.02],
                [value, value],
                color=colour,
                lw=0.8,
                transform=right.get_yaxis_transform(),
                clip_on=False,
            )
    left.scatter(
        centers[:, 0], centers[:, other], marker="x", s=90, color="black", label="Chiu centres"
    )
    if kmeans_centers is not None:
        left.scatter(
            kmeans_centers[:, 0],
            kmeans_centers[:, other],
            marker="+",
            s=120,
            color="red",
            label="k-means centres",
        )
    left.set_xlabel(names[0])
    left.set_ylabel(names[other])
    left.legend(fontsize=7, loc="best")
    left.set_title("regression vectors and centres")
    label_time_axis(right, origin)
    right.set_ylabel(names[0])
    where = "dashed" if few else "ticks at the right edge"
    right.set_title(f"decided cluster per sample ({where}: decision variables y*)")
    if truth is not None:
        # the model's order: sorted as text, mode "10" came below mode "2"
        seen = {m for m in truth if m is not None}
        ids = [m for m in mode_ids if m in seen]
        levels = [math.nan if m is None else ids.index(m) for m in truth]
        twin = right.twinx()
        twin.step(time, levels, where="post", color="grey", lw=0.8)
        twin.set_yticks(range(len(ids)), [plain_text(f"true {m}") for m in ids])
    if accuracy is not None:
        fig.suptitle(plain_text(accuracy), fontsize=9)
    save_reproducibly(fig, path, dpi=100)
    return path
