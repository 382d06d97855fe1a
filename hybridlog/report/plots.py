"""PNG plots of one run, drawn with matplotlib's Agg canvas (no pyplot, no global state).

``outputs.png``
    One panel per output: measured ``y`` and the one-step-ahead prediction ``ŷ``.
``modes.png``
    The estimated mode sequence (and the true one when known) and the mode probabilities.
``states.png``
    One panel per state: the estimate with a ±2σ band (where a variance is defined) and the
    true state when known.

Long runs are thinned for drawing only: curves keep every ``ceil(N / MAX_POINTS)``-th sample,
while the mode sequences are drawn exactly from their change points.  At most
``MAX_PANELS`` outputs/states are drawn.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from hybridlog.estimators.result import EstimationResult
from hybridlog.signals import AlignedSignals, FloatArray, IntArray

__all__ = ["MAX_PANELS", "MAX_POINTS", "plot_modes", "plot_outputs", "plot_states", "write_plots"]

MAX_POINTS = 4000
MAX_PANELS = 16
_DPI = 100


def _stride(n: int) -> int:
    return max(1, math.ceil(n / MAX_POINTS))


def _thin(a: FloatArray) -> FloatArray:
    """Every ``_stride``-th sample, always keeping the last one."""
    n = a.shape[0]
    step = _stride(n)
    if step == 1:
        return a
    idx = np.append(np.arange(0, n, step), n - 1) if (n - 1) % step else np.arange(0, n, step)
    return a[idx]


def _new_figure(n_panels: int, panel_height: float = 2.0) -> tuple[Figure, list[Axes]]:
    # Fixed margins in inches rather than layout="constrained": the constrained layout
    # measured every tick label and took half of the report's writing time.
    height = 0.8 + panel_height * max(n_panels, 1)
    fig = Figure(figsize=(10.0, height))
    FigureCanvasAgg(fig)
    fig.subplots_adjust(
        left=0.09, right=0.98, top=1.0 - 0.45 / height, bottom=0.45 / height, hspace=0.12
    )
    axes = fig.subplots(max(n_panels, 1), 1, sharex=True, squeeze=False)[:, 0]
    return fig, list(axes)


def _save(fig: Figure, path: Path) -> Path:
    fig.savefig(path, dpi=_DPI)
    return path


def _panel_title(fig: Figure, what: str, total: int) -> None:
    if total > MAX_PANELS:
        fig.suptitle(f"{what} (first {MAX_PANELS} of {total})")
    else:
        fig.suptitle(what)


def _empty(fig: Figure, ax: Axes, text: str) -> None:
    ax.text(0.5, 0.5, text, ha="center", va="center", transform=ax.transAxes)
    ax.set_axis_off()


def _panels(what: str, names: tuple[str, ...]) -> tuple[Figure, list[Axes], tuple[str, ...]]:
    """A figure titled ``what`` with one panel per name drawn (at most :data:`MAX_PANELS`)."""
    drawn = names[:MAX_PANELS]
    fig, axes = _new_figure(len(drawn))
    _panel_title(fig, what, len(names))
    return fig, axes, drawn


def plot_outputs(result: EstimationResult, signals: AlignedSignals, path: Path) -> Path:
    """Draw measured outputs against their one-step-ahead predictions.

    Writes ``path`` (PNG) and returns it; the measured outputs come from ``signals``.
    """
    title = "Outputs: measured vs one-step-ahead prediction"
    fig, axes, names = _panels(title, result.output_names)
    if not names:
        _empty(fig, axes[0], "no outputs")
        return _save(fig, path)
    t = _thin(result.time)
    for j, (ax, y) in enumerate(zip(axes, names, strict=True)):
        ax.plot(t, _thin(signals.outputs[:, j]), lw=0.8, color="0.3", label=f"{y} measured")
        ax.plot(
            t,
            _thin(result.output_predictions[:, j]),
            lw=0.8,
            color="tab:blue",
            ls="--",
            label=f"{y} predicted",
        )
        ax.set_ylabel(y)
        ax.legend(loc="upper right", fontsize="small")
    axes[-1].set_xlabel("t (s)")
    return _save(fig, path)


def _mode_steps(time: FloatArray, modes: IntArray) -> tuple[FloatArray, FloatArray]:
    """Exact step curve of a mode sequence from its change points only."""
    change = np.flatnonzero(modes[1:] != modes[:-1]) + 1
    idx = np.concatenate(([0], change))
    t = np.append(time[idx], time[-1])
    m = np.append(modes[idx], modes[-1]).astype(np.float64)
    return t, m


def plot_modes(result: EstimationResult, signals: AlignedSignals, path: Path) -> Path:
    """Draw the estimated mode timeline (vs truth when known) and the mode probabilities.

    Writes ``path`` (PNG) and returns it; the true mode comes from ``signals``.
    """
    fig, (ax_mode, ax_prob) = _new_figure(2, panel_height=2.4)
    fig.suptitle("Modes")
    ids = [str(m) for m in result.mode_ids]
    if result.n_samples == 0:
        _empty(fig, ax_mode, "no samples")
        _empty(fig, ax_prob, "no samples")
        return _save(fig, path)
    if signals.truth_modes is not None:
        t_true, m_true = _mode_steps(result.time, signals.truth_modes)
        ax_mode.step(t_true, m_true, where="post", lw=2.5, color="0.7", label="true")
    t_est, m_est = _mode_steps(result.time, result.modes)
    ax_mode.step(t_est, m_est, where="post", lw=1.0, color="tab:red", label="estimated")
    ax_mode.set_yticks(range(len(ids)), ids)
    ax_mode.set_ylim(-0.5, len(ids) - 0.5)
    ax_mode.set_ylabel("mode")
    ax_mode.legend(loc="upper right", fontsize="small")
    t = _thin(result.time)
    for j, m in enumerate(ids):
        ax_prob.plot(t, _thin(result.mode_probabilities[:, j]), lw=0.8, label=f"p({m})")
    ax_prob.set_ylabel("probability")
    ax_prob.set_xlabel("t (s)")
    ax_prob.legend(loc="upper right", fontsize="small", ncol=min(len(ids), 6))
    return _save(fig, path)


def plot_states(result: EstimationResult, signals: AlignedSignals, path: Path) -> Path:
    """Draw state estimates with ±2σ bands, against the true states when known.

    Writes ``path`` (PNG) and returns it; the true states come from ``signals``.
    """
    fig, axes, names = _panels("States: estimate ±2σ vs truth", result.state_names)
    if not names:
        _empty(fig, axes[0], "no states")
        return _save(fig, path)
    t = _thin(result.time)
    for i, (ax, x) in enumerate(zip(axes, names, strict=True)):
        mean = _thin(result.state_means[:, i])
        # max() keeps NaN (no variance defined) and clips tiny negative round-off.
        sigma = np.sqrt(np.maximum(_thin(result.state_variances[:, i]), 0.0))
        band = np.isfinite(sigma) & np.isfinite(mean)
        if band.any():
            lo = np.where(band, mean - 2.0 * sigma, 0.0)
            hi = np.where(band, mean + 2.0 * sigma, 0.0)
            ax.fill_between(t, lo, hi, where=band, color="tab:blue", alpha=0.2, label="±2σ")
        if signals.truth_states is not None and np.isfinite(signals.truth_states[:, i]).any():
            ax.plot(t, _thin(signals.truth_states[:, i]), lw=1.5, color="0.5", label="true")
        ax.plot(t, mean, lw=0.8, color="tab:blue", label="estimate")
        ax.set_ylabel(x)
        ax.legend(loc="upper right", fontsize="small")
    axes[-1].set_xlabel("t (s)")
    return _save(fig, path)


def write_plots(plot_dir: Path, result: EstimationResult, signals: AlignedSignals) -> list[Path]:
    """Write ``outputs.png``, ``modes.png`` and ``states.png`` into a directory.

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
    return [
        plot_outputs(result, signals, plot_dir / "outputs.png"),
        plot_modes(result, signals, plot_dir / "modes.png"),
        plot_states(result, signals, plot_dir / "states.png"),
    ]
