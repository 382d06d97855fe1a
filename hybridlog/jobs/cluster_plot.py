"""The picture ``hybridlog cluster`` draws: regression vectors, centres and the decided modes.

Left: the regression vectors φ(k) in the plane of their first two components (``y(k)`` and
the next one), coloured by the cluster the decision rule (eqs. (2)–(3)) gives them, with the
subtractive-clustering centres (black crosses) and the k-means centres (red pluses).
Right: ``y(k)`` over time coloured the same way, the decision variables ``y_i*`` as
horizontal lines, and the true mode when the log has it.  Agg canvas, no pyplot.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from hybridlog.signals import FloatArray, IntArray

__all__ = ["plot_clusters"]

_MAX_POINTS = 20_000


def plot_clusters(
    path: Path,
    *,
    time: FloatArray,
    phi: FloatArray,
    names: Sequence[str],
    clusters: IntArray,
    centers: FloatArray,
    cluster_labels: Sequence[str],
    decision_values: FloatArray,
    kmeans_centers: FloatArray | None = None,
    truth: Sequence[str] | None = None,
) -> Path:
    """Draw the clusters to ``path`` (PNG).

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
    cluster_labels:
        Legend text of each cluster (e.g. ``"1 → mode '2'"``).
    decision_values:
        ``y_i*`` of the first output, shape ``(c,)``.
    kmeans_centers:
        k-means centres, or ``None``.
    truth:
        True mode id of each row, or ``None``.
    """
    fig = Figure(figsize=(12.0, 4.8), layout="constrained")
    FigureCanvasAgg(fig)
    left, right = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.0, 1.6]})
    step = max(1, phi.shape[0] // _MAX_POINTS)
    other = 1 if phi.shape[1] > 1 else 0
    colours = [f"C{c % 10}" for c in range(len(centers))]
    for c in range(len(centers)):
        chosen = np.flatnonzero(clusters == c)[::step]
        left.scatter(
            phi[chosen, 0], phi[chosen, other], s=4, color=colours[c], label=cluster_labels[c]
        )
        right.scatter(time[chosen], phi[chosen, 0], s=3, color=colours[c])
        right.axhline(float(decision_values[c]), color=colours[c], lw=0.8, ls="--")
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
    right.set_xlabel("t (s)")
    right.set_ylabel(names[0])
    right.set_title("decided cluster per sample (dashed: decision variables y*)")
    if truth is not None:
        ids = sorted(set(truth))
        twin = right.twinx()
        twin.step(time, [ids.index(m) for m in truth], where="post", color="grey", lw=0.8)
        twin.set_yticks(range(len(ids)), [f"true {m}" for m in ids])
    fig.savefig(path, dpi=100)
    return path
