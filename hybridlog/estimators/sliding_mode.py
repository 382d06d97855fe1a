r"""Discrete-state reconstruction by second-order sliding modes (paper 003, ``sliding-mode``).

Orani, Pisano, Franceschelli, Giua, Usai, ``papers/003_fa184d5ae47b7376.txt``.  For a
boolean-affine switched system with measured state (eq. (1))

.. math::

    \dot x = G(x, u) + D(x, u)\,\delta(\sigma) + \varepsilon(x, t)

the observer (10) :math:`\dot z = G(x, u) + w` makes the error :math:`e = x - z` a set of
decoupled double integrators :math:`\ddot e_i = \varphi_i + v_i`, :math:`v = -\dot w`
(eqs. (11)-(16)), steered to :math:`e = \dot e = 0` in finite time after every switch by the
suboptimal second-order sliding-mode algorithm (eq. (20))

.. math::

    v_i = -\alpha\,V_M\,\mathrm{sign}\bigl(e_i - \tfrac12 e_i(\xi_{i,j})\bigr),
    \qquad V_M = \Gamma\,\bar\Phi \quad (21)

where :math:`\xi_{i,j}` is the last instant where :math:`\dot e_i = 0` (an extremum of
:math:`e_i`).  :math:`\dot e` is not measured: an extremum is detected where the increment of
:math:`e_i` over one step changes sign, and :math:`e_i(\xi)` is the value there (the
"suboptimal" algorithm's usual implementation, papers/NOTES.md).  ``α`` is 1 in eq. (20) as
printed; the general suboptimal algorithm [19], [22] uses :math:`\alpha = \alpha^*` where
:math:`(e_i - \tfrac12 e_i(\xi))(e_i(\xi) - e_i) > 0` and 1 elsewhere (option ``alpha``).
On the sliding manifold :math:`w = D\delta + \varepsilon` (eq. (29)), so

.. math::

    \tilde\delta = (D^\top D)^{-1} D^\top w \quad (30), \qquad
    \hat\delta_j = [\tilde\delta_j > 0.5] \quad (32), \qquad
    \hat\sigma = \sum_j \hat\delta_j\,2^{L-j} \quad (48).

Discretisation: the observer advances with the model's integration step ``h``
(``integration.step``, ``dt / h`` steps per sample) with the measured state and the input
of the sample held over the sample.  Over one step :math:`\dot z = G(x, u) + w` and
:math:`\dot w = -v` are constant (``x``, ``u`` held, ``v`` decided at the start of the
step), so one Euler step integrates them exactly for those held values whatever the model's
method: ``z += h (G + w)``, ``w += h α V_M sign(·)``.  The whole loop is compiled (numba).
The observer needs the state measured at every sample: a log with an output not measured
at some sample (``AlignedSignals.unmeasured_outputs``: a gap bridged, or an output slower
than the model's ``dt``) is refused, naming it
(:func:`~hybridlog.estimators.capabilities.unmeasured_state`); the paper measures the state
continuously and gives the observer no way to run without it, and the value the alignment
took from the samples around is no measured state.

Result: the mode is :math:`\hat\sigma`; the mode probabilities are the one-hot vector of
:math:`\hat\sigma` (the observer computes no probabilities); the state estimate is the
observer state ``z``; the output prediction of sample ``k`` is ``h`` at ``z(k)`` (made from
the samples before ``k``) in the mode :math:`\hat\sigma(k-1)`; the timeline has the
unthresholded :math:`\tilde\delta` columns ``delta_tilde.<boolean>`` and ``vouched``: 1
where Lemma 1 can vouch for :math:`\hat\sigma`, 0 where the log shows that it cannot
(:func:`unvouched`) or where eq. (30) gave no :math:`\tilde\delta` (``DᵀD`` singular,
:math:`\hat\sigma` held); a run with more than ``max_unvouched`` of its samples at 0 is
refused.
"""

from __future__ import annotations

import math
import time
from fractions import Fraction

import numpy as np
import numpy.typing as npt

from hybridlog.errors import DivergenceError, LogError
from hybridlog.estimators.capabilities import unmeasured_state
from hybridlog.estimators.options import options_dict
from hybridlog.estimators.result import EstimationResult, TimelineColumn
from hybridlog.estimators.sliding_mode_options import SlidingModeOptions
from hybridlog.estimators.vouch import MAX_SHOWN
from hybridlog.jit import compile_for
from hybridlog.model.compiled import ModelFunction, compile_continuous
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.signals import AlignedSignals, FloatArray, IntArray
from hybridlog.times import format_time

__all__ = [
    "MARGIN",
    "SLIP_WINDOW_S",
    "channel_gains",
    "gain",
    "margin",
    "run_sliding_mode",
    "sliding_mode_steps",
    "unvouched",
]

MARGIN = 0.5
"""Lemma 1's margin (33): the thresholded δ̂ is exact where ``|δ̃_j - δ_j| < 0.5``."""

SLIP_WINDOW_S = 0.02
"""Window of the slip (s): longer than the sampled observer's chattering (a few steps), so
that it averages out, and far shorter than a dwell (0.5 s in the paper's example)."""


def gain(model: HybridModel, options: SlidingModeOptions) -> float:
    """``V_M``: ``v_max``, or ``Γ Φ̄`` (eq. (21)).

    Raises
    ------
    ModelError
        Neither ``v_max`` nor ``drift_bound`` is set (naming the model file's table).
    """
    if options.v_max is not None:
        return options.v_max
    if options.drift_bound is None:
        raise model.error("estimators.sliding-mode", options.missing() or "")
    return options.gamma * options.drift_bound


def channel_gains(
    D: ModelFunction, signals: AlignedSignals, n_booleans: int, v_max: float, mode: str
) -> FloatArray:
    r"""``V_M`` of every channel ``i`` of eq. (16).

    ``uniform``: ``V_M`` for all (eq. (20) as printed).  ``rows``: each SISO subsystem (16)
    gets its own bound, eq. (17) being per channel (:math:`|\varphi_i| \le \Phi_i`):
    :math:`V_{M,i} = V_M\,\|D_{i,:}\|_1 / \max_l \|D_{l,:}\|_1` with ``D`` at the first
    sample where it is finite and of full column rank (47); :math:`\|D_{i,:}\|_1` bounds the jump of
    :math:`\dot e_i` at a switch (25), so every channel's transient (26) scales alike, and a
    channel whose column of ``D`` is small does not chatter more than its share into
    :math:`\tilde\delta` (30).  (A log starting at an empty tank, ``D`` not finite or
    rank-deficient there, fell back to ``uniform`` silently, or gave tank 3 all of V_M.)
    Where no sample has such a ``D`` the gains are ``uniform`` and the run is refused
    (:func:`_refuse_no_reconstruction`).
    """
    x = np.ascontiguousarray(signals.outputs, dtype=np.float64)
    n = x.shape[1]
    if mode == "uniform":
        return np.full(n, float(v_max))
    u = np.ascontiguousarray(signals.inputs, dtype=np.float64)
    d = np.zeros((n, n_booleans))
    for k in range(signals.n_samples):
        with np.errstate(all="ignore"):
            D(0, x[k], u[k], d)
        rows = np.abs(d).sum(axis=1)
        if np.all(np.isfinite(rows)) and np.linalg.matrix_rank(d) == n_booleans:
            scaled: FloatArray = float(v_max) * rows / rows.max()
            return scaled
    return np.full(n, float(v_max))


def sliding_mode_steps(
    G: ModelFunction,
    D: ModelFunction,
    h: ModelFunction,
    inputs: FloatArray,
    measured: FloatArray,
    step: float,
    substeps: int,
    gains: FloatArray,
    alpha: float,
    threshold: float,
    window: int,
    means: FloatArray,
    predictions: FloatArray,
    deltas: FloatArray,
    slips: FloatArray,
    modes: IntArray,
) -> None:
    r"""The observer over a whole log (see the module doc); compiled with ``compile_for``.

    ``measured`` is the state ``x(k)`` of every sample, ``(N, n)``; ``gains`` the
    ``V_M`` of every channel (:func:`channel_gains`); writes ``z(k)``
    (``means``), ``h(σ̂(k-1), z(k), u(k))`` (``predictions``, row 0 left as it is),
    ``δ̃(k)`` (``deltas``, NaN where ``DᵀD`` is singular), ``σ̂(k)`` (``modes``) and the
    slip ``D⁺ (e(k) - e(k - window)) / (window dt)`` (``slips``: the mean of :math:`D^+\dot e`
    over the last ``window`` samples; infinite before the first full window, where the
    observer has had no time to slide and its σ̂ is its initial 0; NaN where ``DᵀD`` is
    singular; :func:`unvouched`).
    """
    n_samples, n = measured.shape
    n_b = deltas.shape[1]
    z = measured[0].copy()
    w = np.zeros(n)
    extremum = np.zeros(n)  # e_i(ξ_ij): e at the last detected extremum (ξ_i0 = 0, e(0))
    last = np.zeros(n)  # e_i at the previous step
    rise = np.zeros(n)  # the last nonzero increment of e_i
    g = np.zeros(n)
    d = np.zeros((n, n_b))
    normal = np.zeros((n_b, n_b + 2))  # [DᵀD | Dᵀw | Dᵀ ė], eliminated in place
    columns = np.ones(n_b)  # the largest |entry| of each column of D
    rate = 1.0 / (window * step * substeps)  # 1 / the window's length in s
    predicted = np.zeros(predictions.shape[1])
    for i in range(n):
        last[i] = measured[0, i] - z[i]
        extremum[i] = last[i]
    sigma = 0
    for k in range(n_samples):
        x = measured[k]
        u = inputs[k]
        means[k, :] = z
        if k > 0:
            h(sigma, z, u, predicted)
            predictions[k, :] = predicted
        # eq. (30): the least-squares solution of D δ̃ = w, by Gaussian elimination on the
        # normal equations of D with its columns scaled to a largest entry of 1 (a column of
        # 1e300 made DᵀD infinite, which eliminated its boolean and solved for the others
        # as if it were absent); a column that is zero or not finite leaves δ̃ undefined.
        D(0, x, u, d)
        singular = False
        for a in range(n_b):
            largest = 0.0
            for i in range(n):
                if not abs(d[i, a]) <= largest:  # NaN too: then singular below
                    largest = abs(d[i, a])
            if not (largest > 0.0 and largest < np.inf):
                singular = True
                largest = 1.0
            columns[a] = largest
            for i in range(n):
                d[i, a] /= largest
        for a in range(n_b):
            for b in range(n_b):
                acc = 0.0
                for i in range(n):
                    acc += d[i, a] * d[i, b]
                normal[a, b] = acc
            acc = 0.0
            for i in range(n):
                acc += d[i, a] * w[i]
            normal[a, n_b] = acc
            acc = 0.0
            if k >= window:
                for i in range(n):
                    slope = (x[i] - z[i] - measured[k - window, i] + means[k - window, i]) * rate
                    acc += d[i, a] * slope
            normal[a, n_b + 1] = acc
        for col in range(n_b if not singular else 0):
            pivot = col
            for row in range(col + 1, n_b):
                if abs(normal[row, col]) > abs(normal[pivot, col]):
                    pivot = row
            if not abs(normal[pivot, col]) > 0.0:
                singular = True
                break
            if pivot != col:
                for b in range(n_b + 2):
                    normal[col, b], normal[pivot, b] = normal[pivot, b], normal[col, b]
            for row in range(col + 1, n_b):
                factor = normal[row, col] / normal[col, col]
                for b in range(col, n_b + 2):
                    normal[row, b] -= factor * normal[col, b]
        if singular:
            for a in range(n_b):
                deltas[k, a] = np.nan
                slips[k, a] = np.nan
        else:
            for a in range(n_b - 1, -1, -1):
                acc = normal[a, n_b]
                slope = normal[a, n_b + 1]
                for b in range(a + 1, n_b):
                    acc -= normal[a, b] * deltas[k, b]
                    slope -= normal[a, b] * slips[k, b]
                deltas[k, a] = acc / normal[a, a]
                slips[k, a] = slope / normal[a, a]
            for a in range(n_b):  # back from the scaled columns' unknowns
                deltas[k, a] /= columns[a]
                slips[k, a] /= columns[a]
            if k < window:  # no full window yet: not measurable
                for a in range(n_b):
                    slips[k, a] = np.inf
            # eqs. (32), (48): threshold, then σ̂ = Σ δ̂_j 2^(L-j)
            sigma = 0
            for a in range(n_b):
                sigma = 2 * sigma + (1 if deltas[k, a] > threshold else 0)
        modes[k] = sigma
        if k == n_samples - 1:
            break
        # eqs. (10), (20): the observer over (t_k, t_k+1], x(k) and u(k) held.
        G(0, x, u, g)
        for _ in range(substeps):
            for i in range(n):
                e = x[i] - z[i]
                increment = e - last[i]
                if increment * rise[i] < 0.0:  # the increment changed sign: an extremum
                    extremum[i] = last[i]
                if increment != 0.0:
                    rise[i] = increment
                last[i] = e
                s = e - 0.5 * extremum[i]
                scale = alpha if s * (extremum[i] - e) > 0.0 else 1.0
                z[i] += step * (g[i] + w[i])
                if s > 0.0:
                    w[i] += step * scale * gains[i]
                elif s < 0.0:
                    w[i] -= step * scale * gains[i]


def margin(threshold: float) -> float:
    r"""Lemma 1's margin (33) for the threshold ``τ`` of eq. (32): ``min(τ, 1 - τ)``.

    Thresholding at ``τ`` is exact where :math:`|\tilde\delta_j - \delta_j|` is below
    ``τ`` (for :math:`\delta_j = 0`) and ``1 - τ`` (for 1): :data:`MARGIN` at ``τ = 0.5``.
    """
    return min(threshold, 1.0 - threshold)


def unvouched(
    deltas: FloatArray,
    slips: FloatArray,
    threshold: float = 0.5,
    window: int = 0,
    modes: IntArray | None = None,
) -> tuple[npt.NDArray[np.bool_], npt.NDArray[np.bool_]]:
    r"""The samples whose :math:`\hat\sigma` Lemma 1 cannot vouch for: (outside, slipping).

    From (11), :math:`\dot e = D\delta + \varepsilon - w`, so at every sample

    .. math::

        \tilde\delta = \delta + D^+\varepsilon - D^+\dot e .

    The thresholding (32) is exact where :math:`|\tilde\delta_j - \delta_j| < 0.5` (33),
    which the log shows to fail, whatever the true δ, at a sample where

    * (outside) some :math:`\tilde\delta_j` lies outside :math:`(-0.5, 1.5)`, 0.5 or more
      from both 0 and 1: no boolean vector is within the margin (a log the model does not
      explain, a disturbance or noise beyond (33), a gain that chatters more than the
      margin); or
    * (slipping) the slip, the mean of :math:`D^+\dot e` over :data:`SLIP_WINDOW_S` (from
      the measured ``e = x - z``, exact where ``D`` is constant over the window), is 0.5 or
      more on some channel: the observer is not on (28) ``e = ė = 0`` (the transient after
      a switch, or a gain too small to slide at all, where :math:`\tilde\delta` stays near
      0 while :math:`D^+\dot e` carries all of δ), or not yet measurable (the first window
      of the log, where σ̂ is the observer's initial 0 until it has had time to slide); so
      is the slip over the window that starts at the sample (``slips[k + window]``,
      ``window`` the slip's in samples: the log is read whole), and a sample is in the
      transient too where σ̂ changes within the half window after it (``modes``).  The
      window before a sample alone takes in only the samples since a switch: its mean of
      :math:`D^+\dot e` reached the margin half a window after the switch, or never in a
      transient shorter than the window, so the first samples of every transient, σ̂ still
      the old mode's, were vouched for (125 on a noise-free log of 12 switches, 149 on
      another of 14, σ̂ wrong on each).

    The margin 0.5 above is ``τ = threshold``'s, :func:`margin`: with ``τ`` off 0.5 a
    :math:`\tilde\delta_j` must lie within ``min(τ, 1 - τ)`` of the boolean it is thresholded
    to, and the slip below it (``threshold = 1e-300`` put every chattering δ̃ near 0 at
    :math:`\hat\delta_j = 1` half of the time, vouched by the fixed margin 0.5: a 46 %
    mode accuracy ran to exit 0).

    Samples where ``DᵀD`` is singular (δ̃ NaN, σ̂ held) are counted apart, not here.
    """
    within = margin(threshold)
    boolean = np.where(deltas > threshold, 1.0, 0.0)
    with np.errstate(invalid="ignore"):  # NaN rows (held) compare False: counted apart
        outside = np.asarray((np.abs(deltas - boolean) >= within).any(axis=1))
    slipping = np.asarray((np.abs(slips) >= within).any(axis=1))
    if 0 < window < slipping.shape[0]:  # the window after the sample: the next one's before
        slipping[:-window] |= slipping[window:]
    if window > 0 and modes is not None and modes.shape[0] > 1:
        # σ̂ changes within half a window after the sample: still in a transient (the lag
        # of σ̂ behind a switch is at most about that, 10 ms on TEST 1)
        changes = np.flatnonzero(np.diff(modes)) + 1
        later = np.searchsorted(changes, np.arange(modes.shape[0]), side="right")
        coming = np.append(changes, np.iinfo(np.int64).max)[later]
        slipping |= coming - np.arange(modes.shape[0]) <= window // 2
    return outside, slipping


def least_share(count: int, total: int) -> float:
    """The least share of two significant digits that is not below ``count / total``.

    What a refusal tells to give: ``count / total`` rounded to nearest could fall below it
    (20 of 1,990 samples, 0.01005, shown as 0.01, which is refused again).
    """
    share = Fraction(count, total)
    step = Fraction(10) ** (math.floor(math.log10(count / total)) - 1)
    least = math.ceil(share / step) * step
    while float(least) * total < count:  # the float given is what the check multiplies
        least += step
    return float(least)


def _samples(count: int) -> str:
    """``"0 samples"``, ``"1 sample"``, ``"1,234 samples"``: a refusal's count of each reason.

    A reason on no sample read "δ̃ 0.5 or more from every boolean vector on 0", the noun
    left for the reader to guess.
    """
    return f"{count:,} sample{'' if count == 1 else 's'}"


def _refuse_unvouched(
    model: HybridModel,
    signals: AlignedSignals,
    outside: npt.NDArray[np.bool_],
    slipping: npt.NDArray[np.bool_],
    singular: npt.NDArray[np.bool_],
    largest: float,
    within: float = MARGIN,
) -> None:
    """Refuse a run whose σ̂ Lemma 1 cannot vouch for on more than ``largest`` of the samples.

    ``within``: Lemma 1's margin at the run's threshold (:func:`margin`).

    ``singular``: the samples where eq. (30) gave no δ̃ (``DᵀD`` singular or ``D`` not
    finite), whose σ̂ is the one held from before: nothing there vouches for it.  They were
    left out of the share and marked vouched in the timeline, so a log whose ``D`` was
    singular on 7,401 of 8,001 samples ran to exit 0 with a held σ̂ "vouched" on all but 36.

    The first window of the log is never vouched for (``unvouched``): a ``largest`` below its
    share refuses every log of this length, and says so (``max_unvouched = 0.001`` on TEST 1
    blamed the model, its noise or V_M for 205 unvouched samples, 20 of them unavoidable).

    Raises
    ------
    DivergenceError
        Naming the model, the share, and how many samples fail for each reason.
    """
    count = int((outside | slipping | singular).sum())
    n_samples = signals.n_samples
    if n_samples == 0 or count <= largest * n_samples:
        return
    window = max(1, round(SLIP_WINDOW_S / model.timebase.dt))
    if n_samples <= 2 * window:
        raise DivergenceError(
            f"{model.origin or model.name}: sliding-mode cannot vouch for σ̂ on {count:,} of "
            f"{n_samples:,} samples ({100 * count / n_samples:.1f} % > max_unvouched = "
            f"{largest:g}): the log is too short for the observer to slide and show it (its "
            f"first {window} samples, {SLIP_WINDOW_S:g} s, are its initial σ̂ = 0 before the "
            f"slip D⁺ė can be measured); a log of more than {2 * window} samples is needed"
        )
    if largest * n_samples < window:
        raise DivergenceError(
            f"{model.origin or model.name}: sliding-mode cannot vouch for σ̂ on {count:,} of "
            f"{n_samples:,} samples ({100 * count / n_samples:.1f} % > max_unvouched = "
            f"{largest:g}), and would not on any log of {n_samples:,} samples: its first "
            f"{window} samples ({SLIP_WINDOW_S:g} s, {100 * window / n_samples:.2g} %) are "
            "never vouched for (σ̂ is the observer's initial 0 before the slip D⁺ė can be "
            f"measured); give max_unvouched = {least_share(window, n_samples):g} or more"
        )
    held = int(singular.sum())
    if held:
        return _refuse_held(model, n_samples, count, largest, outside, slipping, held, within)
    raise DivergenceError(
        f"{model.origin or model.name}: sliding-mode cannot vouch for σ̂ on {count:,} of "
        f"{n_samples:,} samples ({100 * count / n_samples:.1f} % > max_unvouched = {largest:g}): "
        f"δ̃ {within:g} or more from every boolean vector on {_samples(int(outside.sum()))}, "
        f"the observer not sliding (|D⁺ė| ≥ {within:g} in {SLIP_WINDOW_S:g} s either side, "
        f"σ̂ settling, or in the first) on {_samples(int(slipping.sum()))}, so (33) "
        "fails there; the model does not explain the log, or its noise, disturbance or V_M is "
        "more than the observer tolerates"
    )


def _refuse_held(
    model: HybridModel,
    n_samples: int,
    count: int,
    largest: float,
    outside: npt.NDArray[np.bool_],
    slipping: npt.NDArray[np.bool_],
    held: int,
    within: float,
) -> None:
    """The refusal of :func:`_refuse_unvouched` when some samples had no δ̃ (σ̂ held).

    Raises
    ------
    DivergenceError
        Naming the model, the share, and the samples of each reason.
    """
    raise DivergenceError(
        f"{model.origin or model.name}: sliding-mode cannot vouch for σ̂ on {count:,} of "
        f"{n_samples:,} samples ({100 * count / n_samples:.1f} % > max_unvouched = {largest:g}): "
        f"D(x, u) of eq. (30) singular or not finite at the measured state (σ̂ held) on "
        f"{_samples(held)}, δ̃ {within:g} or more from every boolean vector on "
        f"{_samples(int(outside.sum()))}, not sliding on {_samples(int(slipping.sum()))}; "
        "eq. (47) needs D of full column rank"
    )


def _refuse_runaway_error(
    model: HybridModel, signals: AlignedSignals, means: FloatArray, v_max: float
) -> None:
    r"""Refuse a run whose observer error outgrew the measured state: it never slid.

    The observer exists to drive :math:`e = x - z` to zero after every switch (eqs.
    (14)-(21)), and ``x`` is measured, so its error is known at every sample.  Where
    :math:`|e_i|` exceeds the largest :math:`|x_i|` of the log the estimate ``z_i`` is
    further from the state than zero is: the gain is too large for the step (the
    discretised eq. (20) chatters with an amplitude of about :math:`4 V_M h^2`), or too
    small to hold the drift (:math:`V_M < \bar\Phi`, eq. (19)), and neither ``z`` nor
    :math:`\tilde\delta` (30) can be vouched for.

    Raises
    ------
    DivergenceError
        Naming the model, the state, the time and size of the error, and ``V_M h^2``.
    """
    measured = signals.outputs
    error = np.abs(measured - means)
    scale = np.abs(measured).max(axis=0, initial=0.0)
    runaway = error > scale
    if not runaway.any():
        return
    row, column = divmod(int(np.argmax(runaway)), runaway.shape[1])
    step = model.timebase.step
    raise DivergenceError(
        f"{model.origin or model.name}: sliding-mode diverged at t = "
        f"{format_time(signals.time[row])} s "
        f"(sample {row}): the observer error |x - z| of {model.states[column]} reached "
        f"{error[row, column]:.3g}, more than the largest |{model.states[column]}| measured "
        f"({scale[column]:.3g}); V_M = {v_max:.3g}, V_M*h^2 = {v_max * step * step:.3g} at "
        f"h = {step:g} s (eq. (20) discretised chatters by about 4*V_M*h^2; a V_M too small "
        "lets e drift): change v_max, or gamma and drift_bound"
    )


def _refuse_no_reconstruction(
    model: HybridModel, signals: AlignedSignals, deltas: FloatArray, D: ModelFunction
) -> None:
    r"""Refuse a run where eq. (30) gave :math:`\tilde\delta` at no sample at all.

    Where :math:`D(x, u)^\top D(x, u)` is singular (or ``D`` is not finite: a measured state
    outside the model's domain, ``sqrt`` of a negative level) :math:`\hat\sigma` is held
    from the sample before.  Held at every sample, the mode timeline is the observer's
    initial :math:`\hat\sigma = 0` throughout: no reconstruction, whose mode accuracy and
    switches would be reported as if it were one.

    Raises
    ------
    DivergenceError
        Naming the model, the measured state and input of the first sample, and whether
        ``D`` is not finite or rank-deficient there.
    """
    if 0 in deltas.shape or not np.isnan(deltas).any(axis=1).all():
        return
    x = np.ascontiguousarray(signals.outputs[0], dtype=np.float64)
    u = np.ascontiguousarray(signals.inputs[0], dtype=np.float64)
    d = np.zeros((model.n_states, deltas.shape[1]))
    with np.errstate(all="ignore"):
        D(0, x, u, d)
    why = "not finite" if not np.isfinite(d).all() else "not of full column rank"
    values = [
        f"{name} = {value:.6g}"
        for name, value in (
            *zip(model.states, x.tolist(), strict=True),
            *zip(model.inputs, u.tolist(), strict=True),
        )
    ]
    point = ", ".join(values[:MAX_SHOWN]) + (", …" if len(values) > MAX_SHOWN else "")
    raise DivergenceError(
        f"{model.origin or model.name}: sliding-mode reconstructed no discrete state: "
        f"D(x, u) of eq. (30) is singular or not finite at all {signals.n_samples:,} samples "
        f"({why} at t = {format_time(signals.time[0])} s: {point}), so σ̂ would stay at its "
        "initial value; eq. (47) needs D of full column rank at the measured state"
    )


def _refuse_non_finite(
    model: HybridModel, signals: AlignedSignals, means: FloatArray, G: ModelFunction, v_max: float
) -> None:
    r"""Refuse a run whose observer state ``z`` is not finite, naming why.

    Over a sample ``z += h (G(x, u) + w)`` with the measured ``x`` held: ``z`` turns
    non-finite where ``G`` is not finite at the log's state (``log(x)`` of a level measured
    below 0: the expression and the sample named, :func:`~hybridlog.model.escape.escape_error`;
    ``G`` is mode '0''s ``dx``, every boolean 0), else where ``z`` outgrew float64.  The
    refusal said "the observer state is not finite", naming neither.

    Raises
    ------
    DivergenceError
        Always.
    """
    from hybridlog.model.escape import Escape, escape_error

    row = int(np.argmin(np.isfinite(means).all(axis=1)))
    where = (
        f"sliding-mode diverged at t = {format_time(signals.time[row])} s (sample {row}): the "
        "observer state is not finite"
    )
    if row > 0:
        x = np.ascontiguousarray(signals.outputs[row - 1], dtype=np.float64)
        u = np.ascontiguousarray(signals.inputs[row - 1], dtype=np.float64)
        g = np.zeros(model.n_states)
        with np.errstate(all="ignore"):
            G(0, x, u, g)
        if np.isfinite(x).all() and not np.isfinite(g).all():
            escape = Escape("dx", 0, -1, x, u, g)
            at = (
                f"the drift G of observer (10) at sample {row - 1} "
                f"(t = {format_time(signals.time[row - 1])} s)"
            )
            raise DivergenceError(str(escape_error(model, escape, at, where, "measured state")))
    raise DivergenceError(
        f"{model.origin or model.name}: {where}: z + h (G(x, u) + w) outgrew float64 with G "
        f"finite at the measured state (V_M = {v_max:.3g})"
    )


def run_sliding_mode(
    model: HybridModel,
    signals: AlignedSignals,
    options: SlidingModeOptions | None = None,
    *,
    jit: bool = True,
) -> EstimationResult:
    """Reconstruct the discrete state of a boolean-affine model from its measured state.

    Parameters
    ----------
    model:
        A continuous-time boolean-affine model whose outputs are its states (``h = x``).
    signals:
        The log; its outputs are the measured state.
    options:
        :class:`SlidingModeOptions`; the defaults when ``None``.
    jit:
        Compiled loop (default) or the same code in plain Python (tests).

    Raises
    ------
    ModelError
        The model is not continuous-time and boolean-affine, its state is not measured, it
        has more booleans than states (eq. (2)), or no gain is set; or (its subclass
        :class:`~hybridlog.errors.DivergenceError`) the observer diverged: its state not
        finite, or its error larger than the measured state (:func:`_refuse_runaway_error`);
        or ``D`` was singular or not finite at every sample
        (:func:`_refuse_no_reconstruction`).
    LogError
        The log did not measure an output at some sample
        (:func:`~hybridlog.estimators.capabilities.unmeasured_state`): the observer runs
        on the measured state, never on a value taken from the samples around.
    """
    options = options or SlidingModeOptions()
    affine = model.boolean_affine
    if not model.is_continuous or affine is None:
        raise model.error(
            "booleans",
            "sliding-mode needs a continuous-time boolean-affine model (paper 003, eq. (1))",
        )
    xs, _ = model.symbols()
    for mode in model.modes:
        if list(mode.h) != xs:
            raise model.error(
                "dynamics.h",
                f"sliding-mode needs the state measured (h = {', '.join(model.states)})",
            )
    if len(affine.booleans) > model.n_states:
        raise model.error(
            "booleans",
            f"sliding-mode needs at most as many booleans as states (eq. (2)); "
            f"{len(affine.booleans)} > {model.n_states}",
        )
    unmeasured = unmeasured_state(model, signals)
    if unmeasured is not None:
        raise LogError(f"{signals.source}: estimator 'sliding-mode' {unmeasured}")
    v_max = gain(model, options)
    start = time.perf_counter()
    code = compile_continuous(model, jit=jit)
    assert code.G is not None and code.D is not None
    gains = channel_gains(code.D, signals, len(affine.booleans), v_max, options.channel_gains)
    n_samples = signals.n_samples
    means = np.zeros((n_samples, model.n_states))
    predictions = np.full((n_samples, model.n_outputs), np.nan)
    deltas = np.zeros((n_samples, len(affine.booleans)))
    slips = np.full((n_samples, len(affine.booleans)), np.nan)
    modes = np.zeros(n_samples, dtype=np.int64)
    window = max(1, round(SLIP_WINDOW_S / model.timebase.dt))
    arguments = (
        code.G,
        code.D,
        code.h,
        np.ascontiguousarray(signals.inputs, dtype=np.float64),
        np.ascontiguousarray(signals.outputs, dtype=np.float64),
        model.timebase.step,
        model.timebase.substeps,
        gains,
        float(options.alpha),
        float(options.threshold),
        window,
        means,
        predictions,
        deltas,
        slips,
        modes,
    )
    loop = compile_for(sliding_mode_steps, arguments) if jit else sliding_mode_steps
    compile_s = time.perf_counter() - start
    start = time.perf_counter()
    loop(*arguments)
    runtime = time.perf_counter() - start
    if not np.isfinite(means).all():
        _refuse_non_finite(model, signals, means, code.G, v_max)
    _refuse_no_reconstruction(model, signals, deltas, code.D)
    _refuse_runaway_error(model, signals, means, v_max)
    outside, slipping = unvouched(deltas, slips, options.threshold, window, modes)
    held = np.asarray(np.isnan(deltas).any(axis=1))  # no δ̃: σ̂ held, vouched by nothing
    within = margin(options.threshold)
    _refuse_unvouched(model, signals, outside, slipping, held, options.max_unvouched, within)
    flagged = outside | slipping | held
    probabilities = np.zeros((n_samples, model.n_modes))
    probabilities[np.arange(n_samples), modes] = 1.0
    singular = int(held.sum())
    notes = [
        f"V_M = {v_max:g} (per channel: {', '.join(f'{g:.3g}' for g in gains)}), "
        f"α* = {options.alpha:g}, threshold {options.threshold:g}; "
        f"observer step {model.timebase.step:g} s",
        "mode probabilities are the one-hot vector of σ̂ (the observer computes none); "
        "state variances are undefined (NaN)",
        "the output prediction is the observer state z, which w drives onto the measured "
        "state whatever the model's D (eqs. (10), (20)): VAF, fit and MSE say how closely it "
        "slides, not whether the model or σ̂ is right (a C1 of 1e300 scores as high)",
    ]
    notes.append(
        f"σ̂ not vouched for by Lemma 1 on {int(flagged.sum()):,} of {n_samples:,} samples "
        f"({100 * flagged.mean() if n_samples else 0.0:.1f} %; refused above max_unvouched = "
        f"{options.max_unvouched:g}): δ̃ {within:g} or more from every boolean vector (33), or "
        f"the observer not sliding (|D⁺ė| over {SLIP_WINDOW_S:g} s before or after ≥ "
        f"{within:g}, (28), or σ̂ changing within {SLIP_WINDOW_S / 2:g} s after), or D(x, u) "
        "singular (σ̂ held): the transient after each switch, and more with noise, a "
        "disturbance or a model that does not fit"
    )
    if singular:
        notes.append(
            f"D(x, u) was singular on {singular} samples (δ̃ NaN there, σ̂ held and not "
            "vouched for): eq. (4) fails"
        )
    return EstimationResult(
        estimator="sliding-mode",
        options=options_dict(options),
        time=signals.time,
        mode_ids=model.mode_ids,
        state_names=model.states,
        output_names=model.outputs,
        modes=modes,
        mode_probabilities=probabilities,
        state_means=means,
        state_variances=np.full((n_samples, model.n_states), np.nan),
        output_predictions=predictions,
        runtime_s=runtime,
        compile_s=compile_s,
        notes=tuple(notes),
        timeline_columns=(
            *(
                TimelineColumn(f"delta_tilde.{name}", np.ascontiguousarray(deltas[:, j]))
                for j, name in enumerate(affine.booleans)
            ),
            TimelineColumn("vouched", np.where(flagged, 0.0, 1.0)),
        ),
    )
