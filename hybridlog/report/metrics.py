"""Quality metrics of one estimation run: output fit, mode recognition and state error.

Pure functions over NumPy arrays; they never warn, print or touch files.  A metric that
cannot be computed (no usable sample, no ground truth) is NaN here and ``null`` in
``report.json``.

References
----------
Paper 001 (``papers/001_73b6a953d073a2d8.txt``), section 5: the MSE and VAF formulas.

"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TypedDict

import numpy as np
import numpy.typing as npt

from hybridlog.signals import FloatArray, IntArray

__all__ = [
    "DetectionDelays",
    "Switch",
    "SwitchDetection",
    "confusion_matrix",
    "detection_delays",
    "dwell_times",
    "mean_of_finite",
    "mode_accuracy",
    "mode_switches",
    "mse",
    "sample_durations",
    "state_rmse",
    "vaf",
]

Switch = TypedDict("Switch", {"t": float, "from": str, "to": str})
"""One change of a mode sequence: at time ``t`` (first sample in the new mode)."""


def _as_2d(a: npt.ArrayLike, name: str) -> FloatArray:
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim == 1:
        arr = arr[:, np.newaxis]
    if arr.ndim != 2:
        raise ValueError(f"{name} must be 1-D or 2-D; got {arr.ndim} dimensions")
    return arr


def _paired(y: npt.ArrayLike, y_hat: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
    y2 = _as_2d(y, "y")
    yh2 = _as_2d(y_hat, "y_hat")
    if y2.shape != yh2.shape:
        raise ValueError(f"y has shape {y2.shape} but y_hat has shape {yh2.shape}")
    return y2, yh2


def mse(y: npt.ArrayLike, y_hat: npt.ArrayLike) -> FloatArray:
    r"""Mean square output error per output column (paper 001, section 5).

    .. math::

        \mathrm{MSE} = \frac{1}{N} \sum_{k} \bigl(y(k) - \hat y(k)\bigr)^2

    taken over the rows where both ``y`` and ``y_hat`` are finite (row 0 of an
    :class:`~hybridlog.estimators.result.EstimationResult` has no prediction).

    Parameters
    ----------
    y:
        Measured outputs, shape ``(N,)`` or ``(N, n_y)``.
    y_hat:
        One-step-ahead predictions, same shape.

    Returns
    -------
    numpy.ndarray
        Shape ``(n_y,)``; NaN for a column without a single usable row.

    """
    y2, yh2 = _paired(y, y_hat)
    out = np.full(y2.shape[1], np.nan)
    for j in range(y2.shape[1]):
        ok = np.isfinite(y2[:, j]) & np.isfinite(yh2[:, j])
        if ok.any():
            err = y2[ok, j] - yh2[ok, j]
            out[j] = float(np.mean(err * err))
    return out


def vaf(y: npt.ArrayLike, y_hat: npt.ArrayLike) -> FloatArray:
    r"""Variance accounted for, in percent, per output column (paper 001, section 5).

    .. math::

        \mathrm{VAF} = \max\Bigl\{1 - \frac{\operatorname{var}(y - \hat y)}
                                          {\operatorname{var}(\hat y)},\ 0\Bigr\}
                       \cdot 100\,\%

    The denominator is the variance of the *prediction*, as in the paper (not of ``y``).
    Variances are population variances (``ddof=0``) over the rows where both ``y`` and
    ``y_hat`` are finite.  When ``var(ŷ) = 0`` the ratio is undefined; the limit is used:
    VAF is 100 when the error variance is 0 as well (the prediction explains ``y`` up to a
    constant offset, exactly as the formula scores any constant offset) and 0 otherwise.

    Parameters
    ----------
    y:
        Measured outputs, shape ``(N,)`` or ``(N, n_y)``.
    y_hat:
        One-step-ahead predictions, same shape.

    Returns
    -------
    numpy.ndarray
        Shape ``(n_y,)``, values in ``[0, 100]``; NaN for a column without a usable row.

    """
    y2, yh2 = _paired(y, y_hat)
    out = np.full(y2.shape[1], np.nan)
    for j in range(y2.shape[1]):
        ok = np.isfinite(y2[:, j]) & np.isfinite(yh2[:, j])
        if not ok.any():
            continue
        var_err = float(np.var(y2[ok, j] - yh2[ok, j]))
        var_hat = float(np.var(yh2[ok, j]))
        if var_hat > 0.0:
            out[j] = max(1.0 - var_err / var_hat, 0.0) * 100.0
        else:
            out[j] = 100.0 if var_err == 0.0 else 0.0
    return out


def mean_of_finite(values: npt.ArrayLike) -> float:
    """Mean of the finite entries (the summary MSE/VAF over outputs); NaN when there is none.

    Parameters
    ----------
    values:
        Per-output (or per-state) metric values.

    Returns
    -------
    float
        The arithmetic mean of the finite values, or NaN.

    """
    arr = np.asarray(values, dtype=np.float64).ravel()
    finite = arr[np.isfinite(arr)]
    return float(np.mean(finite)) if finite.size else float("nan")


def _check_modes(modes: npt.ArrayLike, n_modes: int, name: str) -> IntArray:
    arr = np.asarray(modes, dtype=np.int64)
    if arr.ndim != 1:
        raise ValueError(f"{name} must be 1-D; got {arr.ndim} dimensions")
    if arr.size and (arr.min() < 0 or arr.max() >= n_modes):
        raise ValueError(f"{name} holds a mode index outside 0..{n_modes - 1}")
    return arr


def mode_accuracy(estimated: npt.ArrayLike, truth: npt.ArrayLike) -> float:
    """Fraction of all samples whose estimated mode is the true one.

    Parameters
    ----------
    estimated, truth:
        Mode indices per sample, shape ``(N,)``.

    Returns
    -------
    float
        In ``[0, 1]``; NaN for an empty run.

    """
    est = np.asarray(estimated, dtype=np.int64)
    tru = np.asarray(truth, dtype=np.int64)
    if est.shape != tru.shape:
        raise ValueError(f"estimated modes have shape {est.shape} but truth {tru.shape}")
    if est.size == 0:
        return float("nan")
    return float(np.count_nonzero(est == tru)) / float(est.size)


def confusion_matrix(estimated: npt.ArrayLike, truth: npt.ArrayLike, n_modes: int) -> IntArray:
    """Sample counts of (true mode, estimated mode) pairs.

    Parameters
    ----------
    estimated, truth:
        Mode indices per sample, shape ``(N,)``, each in ``0..n_modes-1``.
    n_modes:
        Number of modes.

    Returns
    -------
    numpy.ndarray
        Shape ``(n_modes, n_modes)``; entry ``[i, j]`` counts samples whose true mode is
        ``i`` and estimated mode is ``j`` (rows = truth, columns = estimate).

    """
    est = _check_modes(estimated, n_modes, "estimated modes")
    tru = _check_modes(truth, n_modes, "true modes")
    if est.shape != tru.shape:
        raise ValueError(f"estimated modes have shape {est.shape} but truth {tru.shape}")
    flat = np.bincount(tru * n_modes + est, minlength=n_modes * n_modes)
    return flat.reshape(n_modes, n_modes).astype(np.int64)


def mode_switches(
    time: npt.ArrayLike, modes: npt.ArrayLike, mode_ids: tuple[str, ...] | list[str]
) -> list[Switch]:
    """List the changes of a mode sequence.

    Parameters
    ----------
    time:
        Sample times in seconds, shape ``(N,)``.
    modes:
        Mode index per sample, shape ``(N,)``.
    mode_ids:
        Mode id of each index.

    Returns
    -------
    list of dict
        ``{"t": t_k, "from": id, "to": id}`` for each ``k`` with ``modes[k] != modes[k-1]``;
        ``t_k`` is the time of the first sample in the new mode.

    """
    t = np.asarray(time, dtype=np.float64)
    m = _check_modes(modes, len(mode_ids), "modes")
    idx = np.flatnonzero(m[1:] != m[:-1]) + 1
    return [
        {"t": float(t[k]), "from": str(mode_ids[m[k - 1]]), "to": str(mode_ids[m[k]])} for k in idx
    ]


def sample_durations(time: npt.ArrayLike, dt: float) -> FloatArray:
    """Time each sample stands for: ``t[k+1] - t[k]``, and ``dt`` for the last sample.

    Parameters
    ----------
    time:
        Sample times in seconds, shape ``(N,)``.
    dt:
        The model's sample time, used for the last sample.

    Returns
    -------
    numpy.ndarray
        Shape ``(N,)``; on a regular grid every entry is ``dt`` and the sum is ``N*dt``.

    """
    t = np.asarray(time, dtype=np.float64)
    durations = np.empty_like(t)
    durations[:-1] = np.diff(t)
    durations[-1:] = dt
    return durations


def dwell_times(time: npt.ArrayLike, modes: npt.ArrayLike, n_modes: int, dt: float) -> FloatArray:
    """Total time spent in each mode.

    Parameters
    ----------
    time:
        Sample times in seconds, shape ``(N,)``.
    modes:
        Mode index per sample, shape ``(N,)``.
    n_modes:
        Number of modes.
    dt:
        The model's sample time (duration of the last sample, see :func:`sample_durations`).

    Returns
    -------
    numpy.ndarray
        Seconds per mode, shape ``(n_modes,)``: the sum of :func:`sample_durations` over the
        samples in that mode.

    """
    m = _check_modes(modes, n_modes, "modes")
    return np.bincount(m, weights=sample_durations(time, dt), minlength=n_modes).astype(np.float64)


@dataclass(frozen=True)
class SwitchDetection:
    """How one true mode switch was detected.

    Attributes
    ----------
    t:
        Time of the true switch (first sample in the new true mode).
    from_mode, to_mode:
        Mode ids before and after the switch.
    detected_t:
        Time of the first sample, at or after ``t`` and before the next true switch, whose
        estimated mode is ``to_mode``; ``None`` when there is none (a missed switch).

    """

    t: float
    from_mode: str
    to_mode: str
    detected_t: float | None

    @property
    def delay_s(self) -> float | None:
        """Detection delay in seconds, ``None`` when missed."""
        return None if self.detected_t is None else self.detected_t - self.t


@dataclass(frozen=True)
class DetectionDelays:
    """Detection delays of all true mode switches of a run (see :func:`detection_delays`).

    Attributes
    ----------
    events:
        One entry per true switch, in time order.

    """

    events: tuple[SwitchDetection, ...]

    @property
    def delays_s(self) -> FloatArray:
        """Delays of the detected switches, in seconds."""
        return np.array([e.delay_s for e in self.events if e.delay_s is not None], dtype=float)

    @property
    def detected(self) -> int:
        """Number of true switches detected."""
        return int(self.delays_s.size)

    @property
    def missed(self) -> int:
        """Number of true switches never detected before the next true switch."""
        return len(self.events) - self.detected

    @property
    def mean_s(self) -> float:
        """Mean delay over the detected switches; NaN when none was detected."""
        d = self.delays_s
        return float(np.mean(d)) if d.size else float("nan")

    @property
    def max_s(self) -> float:
        """Largest delay over the detected switches; NaN when none was detected."""
        d = self.delays_s
        return float(np.max(d)) if d.size else float("nan")


def detection_delays(
    time: npt.ArrayLike,
    estimated: npt.ArrayLike,
    truth: npt.ArrayLike,
    mode_ids: tuple[str, ...] | list[str],
) -> DetectionDelays:
    """Delay from each true mode switch to the estimate reaching the new mode.

    For a true switch at sample ``s`` into mode ``m`` (``truth[s] != truth[s-1]``), the
    detection sample is the first ``k`` in ``s <= k < s_next`` (``s_next`` the next true
    switch, or the end of the run) with ``estimated[k] == m``; the delay is
    ``time[k] - time[s]``.  This is the first estimated switch into ``m`` at or after the
    true switch, counted as 0 when the estimate already is ``m`` at ``s`` (an early switch
    is not penalised).  Without such a ``k`` the switch is *missed*; missed switches are
    counted, not given a delay.

    Parameters
    ----------
    time:
        Sample times in seconds, shape ``(N,)``.
    estimated, truth:
        Mode indices per sample, shape ``(N,)``.
    mode_ids:
        Mode id of each index.

    Returns
    -------
    DetectionDelays
        One :class:`SwitchDetection` per true switch.

    """
    t = np.asarray(time, dtype=np.float64)
    n_modes = len(mode_ids)
    est = _check_modes(estimated, n_modes, "estimated modes")
    tru = _check_modes(truth, n_modes, "true modes")
    if not t.shape == est.shape == tru.shape:
        raise ValueError(
            f"time, estimated and true modes differ in shape: {t.shape}, {est.shape}, {tru.shape}"
        )
    starts = np.flatnonzero(tru[1:] != tru[:-1]) + 1
    ends = np.append(starts[1:], tru.size)[: starts.size]
    events = []
    for s, e in zip(starts, ends, strict=True):
        m = tru[s]
        hits = np.flatnonzero(est[s:e] == m)
        events.append(
            SwitchDetection(
                t=float(t[s]),
                from_mode=str(mode_ids[tru[s - 1]]),
                to_mode=str(mode_ids[m]),
                detected_t=float(t[s + hits[0]]) if hits.size else None,
            )
        )
    return DetectionDelays(events=tuple(events))


def state_rmse(state_means: npt.ArrayLike, truth_states: npt.ArrayLike) -> FloatArray:
    r"""Root mean square state error per state.

    .. math::

        \mathrm{RMSE}_i = \sqrt{\tfrac{1}{N_i} \sum_k (\hat x_i(k) - x_i(k))^2}

    over the ``N_i`` rows where both the estimate and the truth of state ``i`` are finite.

    Parameters
    ----------
    state_means:
        Estimated states, shape ``(N, n_x)``.
    truth_states:
        True states, same shape, NaN where unknown (a whole NaN column: no truth).

    Returns
    -------
    numpy.ndarray
        Shape ``(n_x,)``; NaN for a state without truth.

    """
    return np.sqrt(mse(truth_states, state_means))
