"""Mode metrics of one estimation run: accuracy, confusion, switches, dwell times, detection delays.

Pure functions over arrays of mode indices (and the sample times), for report.json's
``modes`` block (SPEC §8): mode accuracy over all samples; detection delay from each true
switch to the first estimated change *into* the new mode at or after it, before the next
true switch (an estimate already in that mode before the switch has not detected it: a
miss; one whose window a gap in the true mode cuts short is undetermined, not missed).
They never warn, print or touch files; output and state metrics are
:mod:`hybridlog.report.metrics`.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from fractions import Fraction
from typing import TypedDict

import numpy as np
import numpy.typing as npt

from hybridlog.signals import FloatArray, IntArray
from hybridlog.times import format_time

__all__ = [
    "DetectionDelays",
    "Switch",
    "SwitchDetection",
    "confusion_matrix",
    "detection_delays",
    "dwell_times",
    "mode_accuracy",
    "mode_switches",
    "sample_durations",
    "steps_seconds",
]

Switch = TypedDict("Switch", {"t": float, "from": str, "to": str})
"""One change of a mode sequence: at time ``t`` (first sample in the new mode)."""


def _mode_indices(modes: npt.ArrayLike, name: str) -> IntArray:
    """``modes`` as int64 mode indices, 1-D; a value that is no whole number refused.

    A cast alone truncated a mode of 0.5 to 0 and took NaN for a large negative index (with
    a warning), scoring a mode sequence read as floats (a CSV column with a gap) silently.
    """
    arr = np.asarray(modes)
    if arr.ndim != 1:
        raise ValueError(f"{name} must be 1-D; got {arr.ndim} dimensions")
    if arr.dtype.kind not in "biu":
        values = arr.astype(np.float64)
        whole = np.isfinite(values) & (values == np.round(values))
        if not whole.all():
            k = int(np.argmin(whole))
            raise ValueError(f"{name}: {float(values[k])} at sample {k} is not a mode index")
    return np.asarray(arr, dtype=np.int64)  # no copy of int64 indices


def _check_modes(modes: npt.ArrayLike, n_modes: int, name: str) -> IntArray:
    arr = _mode_indices(modes, name)
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

    Raises
    ------
    ValueError
        Arrays that are not 1-D, of different lengths, or a value that is no whole number.

    """
    est = _mode_indices(estimated, "estimated modes")
    tru = _mode_indices(truth, "true modes")
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


def steps_seconds(steps: int, dt: float) -> float:
    """``steps`` sample times ``dt``, in seconds, as the decimal ``dt`` is written.

    ``351 * 0.01`` is 3.5100000000000002 in floating point (the float 0.01 is a little
    above a hundredth, and the product keeps it): a dwell of 351 samples at 10 ms read so
    in report.json.  ``dt`` is taken as its shortest decimal (``repr``: 0.01, as the model
    file writes it), multiplied exactly, then rounded once: 3.51.

    Examples
    --------
    >>> steps_seconds(351, 0.01), steps_seconds(3, 0.1), steps_seconds(2, 1 / 3)
    (3.51, 0.3, 0.6666666666666666)
    """
    numerator, denominator = _written(float(dt))
    return numerator * int(steps) / denominator  # int / int: the exact quotient, rounded once


@functools.lru_cache(maxsize=256)
def _written(dt: float) -> tuple[int, int]:
    """``dt``'s shortest decimal as a fraction in lowest terms (parsed once per ``dt``).

    :func:`steps_seconds` is called once per true switch by :func:`detection_delays`: parsing
    ``repr(dt)`` into a :class:`~fractions.Fraction` each time took 0.7 s of a report with
    30,000 switches.
    """
    exact = Fraction(repr(dt))
    return exact.numerator, exact.denominator


def dwell_times(
    time: npt.ArrayLike, modes: npt.ArrayLike, n_modes: int, dt: float, *, on_grid: bool = False
) -> FloatArray:
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
    on_grid:
        ``time`` is the model's grid ``t0 + k*dt``: every sample stands for ``dt``, which
        the differences of large times (Unix times, held to 2.4e-7 s) cannot give exactly.

    Returns
    -------
    numpy.ndarray
        Seconds per mode, shape ``(n_modes,)``: the sum of :func:`sample_durations` over the
        samples in that mode (``dt`` times their number ``on_grid``).

    """
    m = _check_modes(modes, n_modes, "modes")
    if on_grid:
        counts = np.bincount(m, minlength=n_modes).tolist()
        return np.array([steps_seconds(int(c), dt) for c in counts], dtype=np.float64)
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
        the next true switch; ``None`` when there is none, or when the estimate was already
        in ``to_mode`` before ``t`` (a missed switch).
    miss_reason:
        Why the switch counts as missed (one sentence), ``None`` when it was detected or is
        undetermined.
    delay_s:
        Detection delay in seconds, ``None`` when missed; by default ``detected_t - t``.
        On the model's grid ``t0 + k*dt`` it is given as the steps between the two samples
        times ``dt`` (see :func:`detection_delays`), which the difference of two absolute
        times cannot hold: a Unix time of 1.7e9 s is stored to 2.4e-7 s.
    undetermined_reason:
        Why the log cannot say whether the switch was detected (one sentence): no estimated
        change into ``to_mode`` came before the true mode's record stops (a sample without
        one), and the estimate may have changed into it after that, before the truth left
        the mode.  ``None`` when the switch was detected or missed.

    """

    t: float
    from_mode: str
    to_mode: str
    detected_t: float | None
    miss_reason: str | None = None
    delay_s: float | None = None
    undetermined_reason: str | None = None

    def __post_init__(self) -> None:
        """Fill in ``delay_s`` from the times; refuse a delay of a missed switch."""
        if self.undetermined_reason is not None and (
            self.detected_t is not None or self.miss_reason is not None
        ):
            raise ValueError(
                f"an undetermined switch (t={format_time(self.t)} s) is neither detected nor missed"
            )
        if self.detected_t is None:
            if self.delay_s is not None:
                raise ValueError(
                    f"a missed switch (t={format_time(self.t)} s) has no delay ({self.delay_s})"
                )
        elif self.delay_s is None:
            object.__setattr__(self, "delay_s", self.detected_t - self.t)

    @property
    def detected(self) -> bool:
        """Whether an estimated change into the new mode detected the switch."""
        return self.detected_t is not None

    @property
    def undetermined(self) -> bool:
        """Whether the log cannot say if the switch was detected (a gap in the true mode)."""
        return self.undetermined_reason is not None

    @property
    def missed(self) -> bool:
        """Whether the switch was definitely not detected (neither detected nor undetermined)."""
        return not self.detected and not self.undetermined


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
        """Number of true switches definitely not detected (see :func:`detection_delays`)."""
        return sum(1 for e in self.events if e.missed)

    @property
    def undetermined(self) -> int:
        """Number of true switches the true mode's gaps leave undetermined."""
        return sum(1 for e in self.events if e.undetermined)

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


@functools.lru_cache(maxsize=1 << 12)
def _seconds(t: float) -> str:
    """A time as ``1700000101.01 s``: to the digits it holds, at Unix times too.

    Cached: the reasons of missed switches name the same times again and again (where the
    estimate sat in a mode since t=0 s, every switch into it names that start).
    """
    return f"{format_time(t)} s"


def _miss_reason(
    window_end: float | None,
    mode_id: str,
    since: float | None,
    back: float | None,
    unknown: bool = False,
) -> str:
    """Why no estimated change into ``mode_id`` detected a true switch into it.

    ``window_end``: time of the next true switch (``None``: the end of the log), or with
    ``unknown`` of the first sample without a true mode after it;
    ``since``: when the estimate already sat in the mode, the start of that stay;
    ``back``: then, the time the estimate, having left the mode, changed back into it before
    ``window_end`` (``None``: it did not).
    """
    if window_end is None:
        window = "before the end of the log"
    elif unknown:
        window = f"before the true mode's record stops at t={_seconds(window_end)}"
    else:
        window = f"before the next true switch at t={_seconds(window_end)}"
    if since is None:
        return f"the estimate never changed into mode {mode_id} {window}"
    already = (
        f"the estimate was already in mode {mode_id} (since t={_seconds(since)}) when the "
        "truth switched to it"
    )
    if back is None:
        return f"{already}, and no estimated change into mode {mode_id} followed {window}"
    return (
        f"{already}; its change back into mode {mode_id} at t={_seconds(back)}, after "
        "leaving it, does not detect the switch"
    )


def _undetermined_reason(record_stop: float, mode_id: str) -> str:
    """Why a true switch into ``mode_id`` whose window a gap cut at ``record_stop`` is unknown."""
    return (
        f"the estimate had not changed into mode {mode_id} when the true mode's record stops "
        f"at t={_seconds(record_stop)}, and the log cannot say whether it did before the "
        "truth left the mode"
    )


def detection_delays(
    time: npt.ArrayLike,
    estimated: npt.ArrayLike,
    truth: npt.ArrayLike,
    mode_ids: tuple[str, ...] | list[str],
    dt: float | None = None,
    known: npt.ArrayLike | None = None,
) -> DetectionDelays:
    """Delay from each true mode switch to the estimate *changing into* the new mode (SPEC §8).

    For a true switch at sample ``s`` into mode ``m`` (``truth[s] != truth[s-1]``), the
    detection sample is the first ``k`` in ``s <= k < s_next`` (``s_next`` the next true
    switch, or the end of the run) where the estimate changes into ``m``:
    ``estimated[k] == m`` and ``estimated[k-1] != m``.  The delay is ``time[k] - time[s]``
    (0 when the estimate changes into ``m`` at the very sample the truth does).

    An estimate that already sat in ``m`` before the true switch (``estimated[s-1] == m``)
    has not detected it (SPEC §8: "a miss"), even though it agrees with the truth from ``s``
    on, and neither does a later change back into ``m`` after leaving it: a filter stuck in
    a wrong mode would otherwise be credited with a perfect, instant detection whenever the
    truth happens to enter the mode it is stuck in, and one that flickered out of it and
    back, or a smoother that entered ``m`` a sample early and left it again, with the delay
    of its own recovery.  Such a switch, and one the estimate never changes into ``m`` for,
    is *missed*: counted, given a reason, and not given a delay.

    A window the truth's gaps cut short (it ends at a sample without a true mode, see
    ``known``) is not the switch's whole window: a change into ``m`` inside it detects the
    switch, with its delay, but where none came the log cannot say whether one came after
    the cut, before the truth left ``m``.  Such a switch is *undetermined*: neither detected
    nor missed, counted apart, given a reason (:attr:`SwitchDetection.undetermined_reason`).
    The window is never extended across the gap on the guess that the truth stayed in ``m``.
    An estimate that already sat in ``m`` before the switch missed it whatever follows.

    Parameters
    ----------
    time:
        Sample times in seconds, shape ``(N,)``.
    estimated, truth:
        Mode indices per sample, shape ``(N,)``.
    mode_ids:
        Mode id of each index.
    dt:
        The step of ``time`` when it is the model's grid ``t0 + k*dt``: a delay is then
        ``(k - s) * dt``, what ``time[k] - time[s]`` means but cannot hold when the times
        are large (Unix times: ``1700000008.03 - 1700000008.01`` is 0.020000219 in float64,
        a two-step delay a gate ``detection_delay_s <= 0.02`` would fail).  ``None``: the
        difference of the times.
    known:
        Which samples have a true mode (shape ``(N,)``; ``None``: all); ``truth`` is not
        looked at elsewhere.  A true switch is one between two samples with a true mode:
        where the truth resumes after samples without one in another mode, it switched at
        an unknown time, which no delay can be measured from (no event).  A switch's window
        ends at the first sample without a true mode after it too; a switch not detected
        inside such a cut window is undetermined (above), not missed.

    Returns
    -------
    DetectionDelays
        One :class:`SwitchDetection` per true switch.

    """
    t = np.asarray(time, dtype=np.float64)
    n_modes = len(mode_ids)
    est = _check_modes(estimated, n_modes, "estimated modes")
    if known is None:
        tru = _check_modes(truth, n_modes, "true modes")
        have = None
    else:  # no copy of the truth: its codes where it has none are not looked at
        have = np.asarray(known, dtype=bool)
        tru = np.asarray(truth, dtype=np.int64)
        if have.shape != tru.shape:
            raise ValueError(f"known has shape {have.shape} but the true modes {tru.shape}")
        if tru.size and bool((((tru < 0) | (tru >= n_modes)) & have).any()):
            raise ValueError(f"true modes holds a mode index outside 0..{n_modes - 1}")
    if not t.shape == est.shape == tru.shape:
        raise ValueError(
            f"time, estimated and true modes differ in shape: {t.shape}, {est.shape}, {tru.shape}"
        )
    switched = tru[1:] != tru[:-1]
    if have is not None:
        switched &= have[1:] & have[:-1]
    starts = np.flatnonzero(switched) + 1
    del switched
    # a window ends at the next true switch or the next sample without a true mode
    stops = np.flatnonzero(~have) if have is not None else np.empty(0, dtype=np.int64)
    next_stop = np.append(stops, tru.size)[np.searchsorted(stops, starts)]
    ends = np.minimum(np.append(starts[1:], tru.size)[: starts.size], next_stop)
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
    # Each event's times read at once (a float(t[i]) per event was four NumPy scalar reads a
    # switch: 10^4 switches of a 10^6-row log), the same floats; ``t.tolist()`` of 10^6
    # samples would be 32 MB of floats.  A window's end ``e`` is read only where e < N.
    last = max(est.size - 1, 0)
    end_inside = (ends < est.size).tolist()
    at_start = t[starts].tolist()
    at_end = t[np.minimum(ends, last)].tolist()
    at_hit = t[np.maximum(hit, 0)].tolist()
    at_stay = t[stay].tolist()
    end_known = (
        end_inside if have is None else (have[np.minimum(ends, last)] & (ends < est.size)).tolist()
    )
    events = []
    for s, e_inside, m, before, k, sat, t_s, t_e, t_k, t_stay, e_known in zip(
        starts.tolist(),
        end_inside,
        into.tolist(),
        tru[starts - 1].tolist(),
        hit.tolist(),
        already.tolist(),
        at_start,
        at_end,
        at_hit,
        at_stay,
        end_known,
        strict=True,
    ):
        reason = undetermined = None
        cut = have is not None and e_inside and not e_known
        if k < 0 and not sat and cut:
            undetermined = _undetermined_reason(t_e, ids[m])
        elif k < 0 or sat:
            reason = _miss_reason(
                t_e if e_inside else None,
                ids[m],
                t_stay if sat else None,
                t_k if k >= 0 else None,
                unknown=cut,
            )
        detected = k >= 0 and not sat
        events.append(
            SwitchDetection(
                t=t_s,
                from_mode=ids[before],
                to_mode=ids[m],
                detected_t=t_k if detected else None,
                miss_reason=reason,
                delay_s=steps_seconds(k - s, dt) if dt is not None and detected else None,
                undetermined_reason=undetermined,
            )
        )
    return DetectionDelays(events=tuple(events))
