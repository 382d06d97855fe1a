"""Quality metrics of one estimation run: output fit, mode recognition and state error.

Pure functions over NumPy arrays; they never warn, print or touch files.  A metric that
cannot be computed (no usable sample, no ground truth, a zero denominator, a diverged
prediction whose squares overflow float64) is NaN here and ``null`` in ``report.json``,
with the reason from :func:`output_metrics`.

References
----------
Paper 001 (``papers/001_73b6a953d073a2d8.txt``), section 5: the MSE and VAF formulas.
MATLAB System Identification Toolbox, ``compare``: the fit (NRMSE) formula.

"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import TypedDict

import numpy as np
import numpy.typing as npt

from hybridlog.signals import FloatArray, IntArray

__all__ = [
    "DetectionDelays",
    "OutputMetrics",
    "Switch",
    "SwitchDetection",
    "confusion_matrix",
    "detection_delays",
    "dwell_times",
    "fit",
    "mean_of_finite",
    "mode_accuracy",
    "mode_switches",
    "mse",
    "output_metrics",
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


def _magnitude_and_unit(v: FloatArray, *, scratch: bool = False) -> tuple[float, FloatArray]:
    """``v`` as ``m * u`` with ``m = max|v|`` and ``|u| <= 1`` (``u = v`` when ``m = 0``).

    Spreads and norms are taken of ``u`` and multiplied by ``m`` (or divided as ratios):
    squares of ``u`` neither overflow (a diverged prediction) nor underflow (tiny signals)
    float64, where squares of ``v`` itself might.  ``m`` is taken from the largest and
    smallest value (no array of magnitudes); ``scratch``: ``v`` is the caller's temporary,
    divided in place (the same quotients, no second array).
    """
    m = abs(float(np.maximum(v.max(), -v.min()))) if v.size else 0.0
    if not 0.0 < m < np.inf:
        return m, v
    if scratch:
        v /= m
        return m, v
    return m, v / m


def _std_ratio(a: Callable[[], FloatArray], b: FloatArray) -> float:
    """``std(a()) / std(b)`` without overflow or underflow in the squares.

    ``inf`` when ``a()`` overflowed float64; NaN when ``b`` is numerically constant.
    ``a`` makes the numerator's values (a temporary, overwritten); it is called once the
    spread of ``b`` is known, so the two scaled copies are never in memory together.
    """
    mb, ub = _magnitude_and_unit(b)
    spread = float(np.std(ub))
    del ub
    ma, ua = _magnitude_and_unit(a(), scratch=True)
    if ma == 0.0:
        return 0.0
    if ma == np.inf:
        return np.inf
    if not spread > 0.0:
        return np.nan
    ratio = float(np.std(ua)) / spread
    # 0 stays 0 where ma / mb overflows (a constant a against a tiny spread of b).
    return (ma / mb) * ratio if ratio else 0.0


def _norm(scratch: FloatArray) -> float:
    """``‖v‖₂`` of a temporary (squared in place), the same on every CPU.

    NumPy's pairwise sum, not ``np.linalg.norm``: that is BLAS's ``ddot``, whose kernel (and
    so the last bits of every fit) depends on the processor it runs on.
    """
    return math.sqrt(float(np.sum(np.square(scratch, out=scratch))))


def _norm_ratio(a: Callable[[], FloatArray], b: Callable[[], FloatArray]) -> float:
    """``‖a()‖ / ‖b()‖`` without overflow or underflow in the squares.

    ``inf`` when ``a()`` overflowed float64; NaN when ``b()`` is numerically zero.  ``a``
    and ``b`` make temporaries (overwritten), one after the other.
    """
    mb, ub = _magnitude_and_unit(b(), scratch=True)
    size = _norm(ub)
    del ub
    ma, ua = _magnitude_and_unit(a(), scratch=True)
    if ma == 0.0:
        return 0.0
    if ma == np.inf:
        return np.inf
    if not size > 0.0:
        return np.nan
    ratio = _norm(ua) / size
    return (ma / mb) * ratio if ratio else 0.0


@dataclass(frozen=True)
class _Column:
    """One column's rows where both ``y`` and ``ŷ`` are finite, as contiguous arrays."""

    y: FloatArray
    y_hat: FloatArray


def _usable(y2: FloatArray, yh2: FloatArray) -> Iterator[_Column]:
    """Each column's usable rows (both finite), one column at a time.

    The rows are selected straight from the (strided) columns of the 2-D arrays into
    contiguous arrays: one copy of each column, no contiguous copy of the whole column
    before the selection (row 0 never has a prediction, so there is always a selection).
    The columns are yielded one by one, so a caller that reduces each before taking the
    next holds one column pair at a time: at 10^6 rows and three outputs, 16 MB of
    selected rows instead of the 48 MB of all three pairs and the 32 MB of contiguous
    copies they were selected from.
    """
    for j in range(y2.shape[1]):
        y_col, yh_col = y2[:, j], yh2[:, j]
        ok = np.isfinite(y_col)
        ok &= np.isfinite(yh_col)
        yield _Column(y_col[ok], yh_col[ok])
        del ok


def _mse(c: _Column) -> float:
    if not c.y.size:
        return np.nan
    with np.errstate(over="ignore", invalid="ignore"):
        err = c.y - c.y_hat
        err *= err  # squared in place: the same products, one temporary
        return float(np.mean(err))


def _vaf(c: _Column) -> float:
    h = c.y_hat
    if not h.size or np.all(h == h[0]):
        return np.nan  # no usable row, or var(ŷ) = 0: undefined
    with np.errstate(over="ignore", invalid="ignore"):
        ratio = _std_ratio(lambda: c.y - h, h)  # an overflowing error gives inf: VAF 0
        return max(1.0 - ratio * ratio, 0.0) * 100.0


def _fit(c: _Column) -> float:
    y_ok = c.y
    if not y_ok.size or np.all(y_ok == y_ok[0]):
        return np.nan  # no usable row, or ‖y − ȳ‖ = 0: undefined
    with np.errstate(over="ignore", invalid="ignore"):
        # An error that overflows float64 (a diverged prediction) gives -inf.
        error = _norm_ratio(lambda: y_ok - c.y_hat, lambda: y_ok - np.mean(y_ok))
        return (1.0 - error) * 100.0


def _per_column(
    metric: Callable[[_Column], float], y: npt.ArrayLike, y_hat: npt.ArrayLike
) -> FloatArray:
    """``metric`` of each column's usable rows, one column in memory at a time."""
    values = []
    for column in _usable(*_paired(y, y_hat)):
        values.append(metric(column))
        del column  # before the next column is copied out
    return np.array(values, dtype=np.float64)


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
    return _per_column(_mse, y, y_hat)


def vaf(y: npt.ArrayLike, y_hat: npt.ArrayLike) -> FloatArray:
    r"""Variance accounted for, in percent, per output column (paper 001, section 5).

    .. math::

        \mathrm{VAF} = \max\Bigl\{1 - \frac{\operatorname{var}(y - \hat y)}
                                          {\operatorname{var}(\hat y)},\ 0\Bigr\}
                       \cdot 100\,\%

    The denominator is the variance of the *prediction*, as in the paper (not of ``y``).
    Variances are population variances (``ddof=0``) over the rows where both ``y`` and
    ``y_hat`` are finite.  When ``var(ŷ) = 0`` (a constant prediction, or a single usable
    row) the ratio is undefined and so is VAF: NaN, never a guessed 0 or 100
    (:func:`output_metrics` says why).

    Parameters
    ----------
    y:
        Measured outputs, shape ``(N,)`` or ``(N, n_y)``.
    y_hat:
        One-step-ahead predictions, same shape.

    Returns
    -------
    numpy.ndarray
        Shape ``(n_y,)``, values in ``[0, 100]``; NaN where undefined.

    """
    return _per_column(_vaf, y, y_hat)


def fit(y: npt.ArrayLike, y_hat: npt.ArrayLike) -> FloatArray:
    r"""Fit in percent per output column: the NRMSE of MATLAB's ``compare``.

    .. math::

        \mathrm{fit} = \Bigl(1 - \frac{\lVert y - \hat y\rVert_2}
                                      {\lVert y - \bar y\rVert_2}\Bigr) \cdot 100\,\%

    over the rows where both ``y`` and ``y_hat`` are finite, ``ȳ`` the mean of ``y`` over
    those rows.  100 is a perfect prediction, 0 is no better than predicting the mean, and
    a worse prediction is negative (not clamped, as in ``compare``).  Unlike VAF, the
    denominator does not depend on the prediction, so a worse predictor never scores
    better.  NaN when ``y`` is constant over the usable rows (``‖y − ȳ‖ = 0``).

    Parameters
    ----------
    y:
        Measured outputs, shape ``(N,)`` or ``(N, n_y)``.
    y_hat:
        One-step-ahead predictions, same shape.

    Returns
    -------
    numpy.ndarray
        Shape ``(n_y,)``, values in ``(-inf, 100]`` (``-inf`` when the prediction diverged
        so far that its error overflows float64); NaN where undefined.

    """
    return _per_column(_fit, y, y_hat)


@dataclass(frozen=True)
class OutputMetrics:
    """MSE, VAF and fit of one output, and why any of them is undefined.

    Attributes
    ----------
    samples:
        Rows used: where both the measurement and the one-step-ahead prediction are finite.
    mse, vaf, fit:
        See :func:`mse`, :func:`vaf`, :func:`fit`; NaN where undefined.
    undefined:
        ``{metric: reason}`` for each of ``mse``, ``vaf``, ``fit`` that is NaN.

    """

    samples: int
    mse: float
    vaf: float
    fit: float
    undefined: Mapping[str, str]


def output_metrics(y: npt.ArrayLike, y_hat: npt.ArrayLike) -> tuple[OutputMetrics, ...]:
    """:func:`mse`, :func:`vaf` and :func:`fit` of every output column, with reasons for NaNs.

    Parameters
    ----------
    y:
        Measured outputs, shape ``(N,)`` or ``(N, n_y)``.
    y_hat:
        One-step-ahead predictions, same shape.

    Returns
    -------
    tuple of OutputMetrics
        One per column.

    """
    out = []
    for column in _usable(*_paired(y, y_hat)):
        values = {"mse": _mse(column), "vaf": _vaf(column), "fit": _fit(column)}
        n = column.y.size
        undefined: dict[str, str] = {}
        if n == 0:
            why = "no sample has both a measurement and a one-step-ahead prediction"
            undefined = {"mse": why, "vaf": why, "fit": why}
        else:
            rows = "the only row" if n == 1 else f"all {n:,} rows"
            if not np.isfinite(values["vaf"]):
                undefined["vaf"] = (
                    f"var(ŷ) = 0: the prediction is the same in {rows} with a prediction, "
                    "so VAF = 1 − var(y − ŷ)/var(ŷ) is undefined"
                )
            if not np.isfinite(values["fit"]):
                undefined["fit"] = (
                    f"‖y − mean(y)‖ = 0: the measurement is the same in {rows} with a "
                    "prediction, so fit = 1 − ‖y − ŷ‖/‖y − mean(y)‖ is undefined"
                )
            for name in ("mse", "fit"):
                if np.isinf(values[name]):
                    largest = float(np.max(np.abs(column.y_hat)))
                    undefined[name] = (
                        f"the prediction diverged (|ŷ| up to {largest:.3g}): its error "
                        "overflows float64"
                    )
        out.append(OutputMetrics(samples=n, **values, undefined=undefined))
        del column  # before the next column is copied out
    return tuple(out)


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
    pairs = tru * n_modes
    pairs += est  # one temporary of N codes, not two
    flat = np.bincount(pairs, minlength=n_modes * n_modes)
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
    np.subtract(t[1:], t[:-1], out=durations[:-1])  # np.diff, without a second array
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
    """How one true mode switch was detected, or why it was not.

    Attributes
    ----------
    t:
        Time of the true switch (first sample in the new true mode).
    from_mode, to_mode:
        Mode ids before and after the switch.
    detected_t:
        Time of the first estimated change *into* ``to_mode`` at or after ``t`` and before
        the next true switch; ``None`` when there is none (a missed switch).
    miss_reason:
        Why the switch counts as missed (one sentence), ``None`` when it was detected.

    """

    t: float
    from_mode: str
    to_mode: str
    detected_t: float | None
    miss_reason: str | None = None

    @property
    def detected(self) -> bool:
        """Whether an estimated change into the new mode detected the switch."""
        return self.detected_t is not None

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
        """Number of true switches not detected (see :func:`detection_delays`)."""
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


def _seconds(t: float) -> str:
    return f"{t:.9g} s"


def _miss_reason(window_end: float | None, mode_id: str, since: float | None) -> str:
    """Why no estimated change into ``mode_id`` detected a true switch into it.

    ``window_end``: time of the next true switch (``None``: the end of the log);
    ``since``: when the estimate already sat in the mode, the start of that stay.
    """
    window = (
        f"before the next true switch at t={_seconds(window_end)}"
        if window_end is not None
        else "before the end of the log"
    )
    if since is None:
        return f"the estimate never changed into mode {mode_id} {window}"
    return (
        f"the estimate was already in mode {mode_id} (since t={_seconds(since)}) when the "
        f"truth switched to it, and no estimated change into mode {mode_id} followed {window}"
    )


def detection_delays(
    time: npt.ArrayLike,
    estimated: npt.ArrayLike,
    truth: npt.ArrayLike,
    mode_ids: tuple[str, ...] | list[str],
) -> DetectionDelays:
    """Delay from each true mode switch to the estimate *changing into* the new mode (SPEC §8).

    For a true switch at sample ``s`` into mode ``m`` (``truth[s] != truth[s-1]``), the
    detection sample is the first ``k`` in ``s <= k < s_next`` (``s_next`` the next true
    switch, or the end of the run) where the estimate changes into ``m``:
    ``estimated[k] == m`` and ``estimated[k-1] != m``.  The delay is ``time[k] - time[s]``
    (0 when the estimate changes into ``m`` at the very sample the truth does).

    An estimate that already sat in ``m`` before the true switch has not detected it, even
    though it agrees with the truth from ``s`` on: a filter stuck in a wrong mode would
    otherwise be credited with a perfect, instant detection whenever the truth happens to
    enter the mode it is stuck in.  Such a switch, and one the estimate never changes into
    ``m`` for, is *missed*: counted, given a reason, and not given a delay.

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
    into = tru[starts]
    # Samples where the estimate changes: estimated[k] != estimated[k-1].
    changes = np.flatnonzero(est[1:] != est[:-1]) + 1
    # The first change into the switch's mode at or after its start, per mode at once; it
    # detects the switch when it comes before the next true switch.
    hit = np.full(starts.size, -1, dtype=np.int64)
    for m in range(n_modes):
        switches = np.flatnonzero(into == m)
        into_m = changes[est[changes] == m]
        first = np.searchsorted(into_m, starts[switches])
        found = first < into_m.size
        k = into_m[first[found]]
        inside = k < ends[switches[found]]
        hit[switches[found][inside]] = k[inside]
    # For a miss where the estimate already sat in the mode: the start of that stay, the
    # last change of the estimate at or before the sample before the switch (or sample 0).
    stay = np.append(0, changes)[np.searchsorted(changes, starts - 1, side="right")]
    already = est[starts - 1] == into
    ids = [str(m) for m in mode_ids]
    events = []
    for s, e, m, before, k, sat, first_in_mode in zip(
        starts.tolist(),
        ends.tolist(),
        into.tolist(),
        tru[starts - 1].tolist(),
        hit.tolist(),
        already.tolist(),
        stay.tolist(),
        strict=True,
    ):
        reason = None
        if k < 0:
            reason = _miss_reason(
                float(t[e]) if e < est.size else None,
                ids[m],
                float(t[first_in_mode]) if sat else None,
            )
        # float(t[i]) per event, not t.tolist(): 10^6 samples would be 32 MB of floats
        events.append(
            SwitchDetection(
                t=float(t[s]),
                from_mode=ids[before],
                to_mode=ids[m],
                detected_t=float(t[k]) if k >= 0 else None,
                miss_reason=reason,
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
