r"""Whether a filter's innovations over a whole log are what its model says they should be.

A sensor with an offset (``y1 + 50``), a scale error (``1.5 y``) or noise the model does not
know makes no single sample implausible (:func:`~hybridlog.estimators.vouch.check_surprise`
refuses only a sample no mode explains): the filter absorbs the error into its state.  The
innovations still show it, over the log.  For a filter consistent with its model the
whitened innovation ``z(k) = L(k)⁻¹ γ(k)`` (``S(k) = L(k) L(k)ᵀ``) is white, zero-mean and of
unit covariance, so (Bar-Shalom, Li, Kirubarajan, *Estimation with Applications to Tracking
and Navigation*, 2001, §5.4.2, the normalised innovation squared test):

.. math::

    \bar\epsilon = \frac1N \sum_k z(k)^T z(k),\qquad N\bar\epsilon \sim \chi^2_{N m},
    \qquad E[\bar\epsilon] = m,

and each output's mean ``z̄_b = (1/N) Σ_k z_b(k)`` is ``N(0, 1/N)`` (the zero-mean test of
§5.4.2).  Both are taken here as standard scores, ``(ε̄ − m) / sqrt(2m/N)`` and
``z̄_b sqrt(N)``, over the samples where the filter's mode is settled: one mode holds at
least :data:`SETTLED` of the probability at the sample and the one before, the same mode
(around a switch the mode-conditioned innovation of the old mode is not the model's).

A sample where the log measured only some outputs (``AlignedSignals.unmeasured_outputs``: a
gap bridged, a sensor sampled slower than the model's ``dt``; NaN in the log) is tested on
those: the filter updates on them alone, with their own sub-matrix of ``S``, so the row's
``z`` is the measured ones' and its ``zᵀz`` is ``χ²`` with ``m_k`` (the number measured)
degrees of freedom.  The test sums over the rows: ``Σ_k z(k)ᵀz(k)`` is ``χ²`` with ``Σ_k m_k``,
expected ``Σ m_k`` and of variance ``2 Σ m_k``, and each output's mean is over the rows that
measured it.  Such rows had been left out: with ``y2`` measured on every 12th row of
``sample_logs/three_tank_hstf.csv``'s log only 25 rows were left, no test and no word of it
(now 289 settled rows, a mean NIS 2.08 of the 2.09 expected).  A log with fewer than
:data:`MIN_SAMPLES` settled rows that measured an output has no test, and the report says so.

The IMM's ``z`` is that of the mode nearest to ``y(k)`` (its ``γᵀ S⁻¹ γ`` is the row's
``surprise``), which on settled samples is the mode the filter holds; the mode-mixed
innovation of §11.6.6 differs from it only by the other modes' weights.  The HSTF keeps
none: its likelihood's ``S_i`` is faded by ``λ_i`` (paper 000 eq. (35)), which grows with the
innovations so as to make them consistent, and it predicts at the mean of the modes'
predictions (eq. (12)), so its innovations are biased on a log of its own model (measured:
``y1``'s mean innovation −10 on ``sample_logs/three_tank_hstf.csv``).

A test warns where its score passes its threshold *and* the difference matters: a mean NIS
of at least :data:`NIS_EFFECT` ``m`` (a score above :data:`NIS_WARNING`) or at most
:data:`NIS_QUIET_EFFECT` ``m`` (a score below ``−NIS_WARNING``), a mean whitened innovation of
at least :data:`BIAS_EFFECT`.  A score grows with ``sqrt(N)``: without the second condition a
log of 10^6 samples simulated from the three-tank model itself warned of a bias
(``y2`` +0.013, 12.9 standard scores: the EKF's own linearisation bias).  Measured 2026-12-05
on logs of the built-in models (700 samples, seeds 0..7; 10^5 samples, seeds 0..2): mean NIS
0.35-1.04 ``m``, mean whitened innovations within ±0.1 (±0.02 at 10^5 samples); the
three-tank log scaled by 1.5: 1.68-2.05 ``m``, with 3× the measurement noise's standard
deviation 2.2-3.2 ``m``; the offsets ``y1 + 50`` that are seen: 0.25-0.35.

The thresholds (:data:`NIS_WARNING`, :data:`BIAS_WARNING`) are set from measurements: on
logs simulated from the built-in models (three-tank at measurement variance 0.5 and 60, the
double cart, seeds 0..12) every score stayed within ±3.5 but the NIS scores of the double cart
case 1, whose ``S`` exceeds the innovations' spread (−7.5 to −10: below ``m``, too little
below it to warn, 0.36-0.53 ``m``); the three-tank log scaled by 1.5 scores 13-19, with 3× the
measurement noise 25-140 (scores grow with ``sqrt(N)``: 21-34 and 25-74 over 700 samples,
seeds 0..3).  Real logs rarely match a model's noise exactly, so a failed test is a warning,
not a refusal.  An offset on a sensor the filter can absorb into a state (``y1 + 50`` on the
three-tank, whose process noise lets each level move 0.7 per step) mostly leaves the
innovations unbiased: bias scores past 6 on 3 of the 29 logs below, within ±5.2 on the
others.  It is mostly not seen.

Innovations far *smaller* than the model's noise predicts (measured 2026-12-06 by
``docs/studies/quiet_innovations.py``, ``imm`` through the registry as ``analyze`` runs it,
seeds 0..9): a log in other units than its model, zeroed or flat, or a model whose measurement
noise is far too large.  The filter absorbs part of a scale error into its state, so the mean
NIS falls by less than the scale's square, and ``x̂`` settles where the log is flat.
Mean NIS / ``m`` over the settled samples:

==========================  ===========  ===============  ===========  ===========  =========
log                         clean        × 1e-3, 1e-2,    × 1e-300,    outputs at   R × 100
                                         0.1              zero         their mean
==========================  ===========  ===============  ===========  ===========  =========
three-tank, 300 steps       0.87-1.01    0.0010-0.049     0.00081      0.018-0.049  0.080-0.13
three-tank, R = 60, 700     0.83-0.95    0.023-0.038 ¹    untested ¹   0.017-0.060  untested ¹
double cart 1, 100 steps    0.36-0.53    refused ²        refused ²    refused ²    0.080-0.089
double cart 1, 600 steps    0.41-0.51    refused ²        refused ²    refused ²    0.083-0.089
double cart 2, 100 steps    0.69-1.07    refused ²        refused ²    refused ²    0.0083-0.015
double cart 2, 600 steps    0.76-0.97    refused ²        refused ²    refused ²    0.010-0.012
one-mode test model, 600    0.97-1.06    0.105-0.121      0.121        0.126-0.29   0.027-0.046
==========================  ===========  ===============  ===========  ===========  =========

¹ Fewer than :data:`MIN_SAMPLES` settled samples (no mode holds 0.9 where the log is flat
under a noise of variance 60): × 1e-3, 1e-2, × 1e-300, zero and R × 100 on all 10 logs,
× 0.1 on 1.  ² Refused (``check_surprise``: no mode explains a sample; the sensor's deviation
is 0.001), as is × 1e3 on every scenario.  Clean logs over more seeds: the double cart case 1
at 100 steps 0.34-0.64 ``m`` (seeds 0..99), at 50 steps 0.29-0.79 (scores −3.2 and above at
the low end), at 10^5 steps 0.47; case 2 at 100 steps 0.53-1.19; the three-tank 0.65-1.04 (at
its noise, seeds 0..39: scores down to −7.1, so the score alone would warn) and 0.66-0.95
(variance 60); the one-mode model at 100 steps 0.75-1.25.  So the wrong units, the zeroed
and vanishing logs and R × 100 score at most 0.133 ``m``, clean logs at least 0.29 ``m``:
:data:`NIS_QUIET_EFFECT` = 0.2 (their geometric middle) with the score below ``−NIS_WARNING``
warns on every tested wrong-unit, zeroed and vanishing log, on R × 100 but the 100-step double
cart case 1's (scores −5.3 to −5.4: 68-70 settled samples of one output) and on 28 of the 30
logs held at their mean tested (the one-mode model's 0.20 and 0.29 do not: a flat log its
input barely moves is not far from the model), and on none of the 550 clean logs.

One output in other units is not seen (measured 2026-12-06, ``per_output`` of the same study):
only ``y1`` × 1e-3 on the three-tank log leaves the mean NIS at 0.55-0.83 ``m``.  An
output's marginal whitened innovation ``γ_b / sqrt(S_bb)`` (the first output's ``z_1``; the
study puts each output first, a relabelling) is ``N(0, 1)``: its mean square is 1.  It does
not part such logs from clean ones (clean: seeds 0..39; one output scaled: seeds 0..9):

========================  ===================  ==================================  ==============
log                       clean, each output   the output × 1e-3, 1e-2, 0.1        the others
========================  ===================  ==================================  ==============
three-tank, 300 steps     0.645-1.18 (≥ −4.2)  0.051-0.459 (−11.3 to −6.5)         0.65-1.27
three-tank, R = 60, 700   0.428-1.07 (≥ −5.0)  0.022-0.262 (−12.0 to −4.2) ¹       0.53-1.70
one-mode test model, 600  0.836-1.12 (≥ −2.8)  ``y1`` 0.54-1.03, ``y2`` 0.20-0.24  ``y1`` 1.4-1.9
========================  ===================  ==================================  ==============

(scores in brackets; ¹ 3 of the 30 ``y1`` logs untested).  A clean log's ``y1`` at variance 60
(0.428) is below the three-tank's scaled ``y3`` (0.459): no effect threshold parts them, and
the scores alone would warn of clean logs as they grow with ``sqrt(N)``.  The one-mode model
absorbs a scaled ``y1`` (its position) into its state, and a scaled ``y2`` (its velocity)
makes ``y1``'s innovations *larger* (scores up to +16): a per-output test would name the
wrong output.  The three-tank's ``y1`` × 1e-3 alone (0.13-0.20 against clean 0.645-1.18)
would be seen; no per-output test was added.

What is not seen, and why (measured 2026-12-04 on ``imm`` runs; the whiteness test of the same
§5.4.2 was tried and not added).  That test takes the time-averaged autocorrelation of the
whitened innovations, ``ρ̄(l) = Σ_k z(k)ᵀ z(k+l) / sqrt(Σ_k z(k)ᵀ z(k) Σ_k z(k+l)ᵀ z(k+l))``
(``N(0, 1/N)`` for a consistent filter), here as the score ``ρ̄(l) sqrt(N)`` over the pairs of
settled samples, pooled and per output, at lags 1..10.  Logs: the three-tank at its model's
noise (300 steps, seeds 0..13) and at measurement variance 60 (schedule
``1:100,2:100,3:100,1:100,3:100,2:100,1:100``, seeds 0..14), the double cart cases 1 and 2
(600 steps, seeds 0..12).  Clean three-tank logs score within ±1.8 pooled and ±3.1 per
output, but the double cart case 1 is not white on logs of its own model: its lag-1 score is
+1.7 to +4.3 on all 13 logs, at most 4.9 over lags 1..3 (its NIS score −7.5 to −9.3: the
IMM's ``S`` exceeds the innovations' spread); case 2 within ±3.2.  Each three-tank log with
``y1 + 10``, ``y1 − 10``, ``y1 + 50``, ``y1 + 0.05 t``, or an inflow of 10 or 40 cm³ a step
its ``u`` does not have (174 logs) scores at most 3.4 pooled and 5.9 per output; 4 of the
174 pass the clean double cart's 4.9 (5.0 to 5.9; one, ``y1 + 50`` at the model's noise, has
a bias score of 10.5): no threshold parts them from the clean logs.  Testing every sample
instead of the settled ones changes nothing (lag 1, seeds 0..5: at most 2.4).  Why: the
filter absorbs the offset into the level within ``1/K`` steps (``K``, a level's steady gain
in mode 1: 0.62 at the model's noise, 0.087 at variance 60), after which the offset shows
only through the dynamics (the outflow of a level 10 cm too high is off by about 0.1 cm a
step, the process noise's deviation 0.7), as a constant innovation bias of about
``c = 0.1 / K / sqrt(S) ≈ 0.13`` whitened.  The bias test scores a constant bias
``c sqrt(N)``, the (uncentred) whiteness test only ``c² sqrt(N) / (1 + c²)``: the mean sees
it first, and the transients at the switches (the offset moves from ``d`` to ``d/i`` in the
level of mode ``i``, ``h = i x``) are too few to show.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from hybridlog.signals import FloatArray

__all__ = [
    "BIAS_EFFECT",
    "BIAS_WARNING",
    "MIN_SAMPLES",
    "NIS_EFFECT",
    "NIS_QUIET_EFFECT",
    "NIS_WARNING",
    "SETTLED",
    "Consistency",
    "ConsistencyAccumulator",
]

SETTLED = 0.9
"""The probability one mode must hold at a sample and the one before for it to be tested."""

MIN_SAMPLES = 30
"""Fewer settled samples than this: no test (the scores' normal approximation is poor)."""

NIS_WARNING = 6.0
"""A NIS standard score past this warns: above it, innovations larger than the model's (with
:data:`NIS_EFFECT`); below its negative, smaller (with :data:`NIS_QUIET_EFFECT`)."""

BIAS_WARNING = 6.0
"""An output's bias standard score past this (either sign) warns (with :data:`BIAS_EFFECT`)."""

NIS_EFFECT = 1.25
"""And the mean NIS must be at least this times ``m``: a difference that matters, not only one
a long log makes significant (an EKF's own linearisation gives a 10^6-sample log of its own
model a NIS a few percent off ``m``, scores of ±10 and more)."""

NIS_QUIET_EFFECT = 0.2
"""Or the mean NIS at most this times ``m`` (with a score below ``−NIS_WARNING``): a log in
other units than its model (outputs × 1e-3, 1e-2, 0.1), zeroed or flat, or a model whose
measurement noise is 100× the log's, scores 0.0008-0.13 ``m`` on the built-in models' logs
and a one-mode test model's; clean logs 0.29-1.25 ``m`` (the double cart case 1 lowest, its
``S`` exceeding the innovations' spread).  Measured by ``docs/studies/quiet_innovations.py``;
the module's docstring has the numbers."""

BIAS_EFFECT = 0.1
"""And the mean whitened innovation at least this (a tenth of the innovation's standard
deviation): the EKF's own bias on the three-tank model, about 0.01, scores 12 over 10^6
samples of a log simulated from the model itself."""

_BLOCK = 1 << 14
"""Settled rows summed together: sums of fixed blocks of the run's settled rows, in order."""


@dataclass(frozen=True)
class Consistency:
    """The whole-log innovation tests of one run (:class:`ConsistencyAccumulator`).

    Attributes
    ----------
    samples:
        Settled samples tested.
    nis:
        Mean normalised innovation squared ``ε̄`` over them.
    nis_expected:
        Its expectation under the model, ``m`` (the number of outputs), or where some were
        not measured at every sample, the mean number measured, ``Σ_k m_k / N``.
    nis_score:
        ``(ε̄ − m) / sqrt(2m/N)`` (``(N ε̄ − Σ m_k) / sqrt(2 Σ m_k)``).
    bias:
        Per output, the mean whitened innovation ``z̄_b`` (expected 0) over the samples
        that measured it (``N_b``); an output with fewer than :data:`MIN_SAMPLES` has none.
    bias_scores:
        Per output, ``z̄_b sqrt(N_b)``.
    largest:
        The largest ``|z_b|`` of the settled samples: the innovations' size where their
        squares are too small for a double (``ε̄`` 0 or ``m / ε̄`` infinite).
    measured:
        Per output, the settled samples that measured it (all of them but where the log
        did not: a gap bridged, an output sampled slower than the model's ``dt``).
    """

    samples: int
    nis: float
    nis_expected: float
    nis_score: float
    bias: dict[str, float]
    bias_scores: dict[str, float]
    largest: float = math.nan
    measured: dict[str, int] = field(default_factory=dict)

    def warnings(self) -> tuple[str, ...]:
        """One line per failed test (empty when the innovations are the model's)."""
        found = []
        if self.nis_score > NIS_WARNING and self.nis >= NIS_EFFECT * self.nis_expected:
            found.append(
                f"the innovations are larger than the model's noise explains: mean normalised "
                f"innovation squared {self.nis:.3g} over {self.samples} settled samples, "
                f"expected {self.nis_expected:g} ({self.nis_score:.1f} standard scores; "
                "a scaled sensor, or more noise than the model's?)"
            )
        if self.nis_score < -NIS_WARNING and self.nis <= NIS_QUIET_EFFECT * self.nis_expected:
            ratio = self.nis_expected / self.nis if self.nis > 0.0 else math.inf
            if math.isfinite(ratio):
                times = f"{ratio:.3g} times in variance"
            elif self.largest == 0.0:
                times = "all of them 0"
            else:  # squares below a double's range: 'inf times', or '0' of innovations of 1e-200
                times = f"all of them within {self.largest:.3g} standard deviations of 0"
            found.append(
                f"the innovations are smaller than the model's noise predicts ({times}): mean "
                f"normalised innovation squared {self.nis:.3g} over {self.samples} settled "
                f"samples, expected {self.nis_expected:g} ({self.nis_score:.1f} standard "
                "scores; outputs in other units than the model's, a noise model far too "
                "large, or a flat signal?)"
            )
        biased = [
            f"{name} {self.bias[name]:+.3g} ({score:+.1f})"
            for name, score in self.bias_scores.items()
            if abs(score) > BIAS_WARNING and abs(self.bias[name]) >= BIAS_EFFECT
        ]
        if biased:
            found.append(
                "the innovations are biased: mean whitened innovation (standard score) "
                f"{', '.join(biased)} over {self.samples} settled samples, expected 0 "
                "(a sensor offset or an input the model does not know?)"
            )
        return tuple(found)

    def to_dict(self) -> dict[str, object]:
        """The statistics and their expectations, as ``report.json``'s ``consistency``."""
        return {
            "samples": self.samples,
            "nis": self.nis,
            "nis_expected": self.nis_expected,
            "nis_score": self.nis_score,
            "nis_warning": NIS_WARNING,
            "nis_effect": NIS_EFFECT,
            "nis_quiet_effect": NIS_QUIET_EFFECT,
            "bias": dict(self.bias),
            "bias_scores": dict(self.bias_scores),
            "measured": dict(self.measured),
            "bias_warning": BIAS_WARNING,
            "bias_effect": BIAS_EFFECT,
            "settled": SETTLED,
            "warnings": list(self.warnings()),
        }


class ConsistencyAccumulator:
    """Sums of a run's whitened innovations, chunk after chunk, over its settled samples."""

    def __init__(self, output_names: tuple[str, ...]) -> None:
        self._names = output_names
        self._count = 0
        self._squares = 0.0
        self._sums = np.zeros(len(output_names))
        self._before: FloatArray | None = None
        # the settled rows, summed a block of _BLOCK of them at a time: the same sums, to the
        # bit, however the run's rows arrive (whole, or in chunks of any size)
        self._block = np.empty((_BLOCK, len(output_names)))
        self._filled = 0
        self._largest = 0.0
        self._settled = 0  # settled rows, measured or not
        self._measured = np.zeros(len(output_names), dtype=np.int64)  # per output, rows

    def add(self, whitened: FloatArray, probabilities: FloatArray) -> None:
        """Take the next rows: ``L⁻¹ γ`` (NaN: not measured) and each row's mode probabilities.

        A row where only some outputs are measured holds the measured ones' ``L⁻¹ γ``: the
        filter updated on them alone, with their own sub-matrix of ``S`` (the kernels' ``H``,
        ``γ`` and ``R`` of an output left out are 0, 0 and the identity's, so ``S`` is block
        diagonal and its Cholesky factor's measured block is that of ``S``'s measured block).
        """
        rows = whitened.shape[0]
        if rows == 0:
            return
        previous = (
            np.vstack([self._before, probabilities[:-1]])
            if self._before is not None
            else np.vstack([np.full((1, probabilities.shape[1]), np.nan), probabilities[:-1]])
        )
        self._before = probabilities[-1:].copy()
        with np.errstate(invalid="ignore"):
            settled = (
                (probabilities.max(axis=1) >= SETTLED)
                & (previous.max(axis=1) >= SETTLED)
                & (probabilities.argmax(axis=1) == previous.argmax(axis=1))
            )
        self._settled += int(np.count_nonzero(settled))
        taken = whitened[settled & np.isfinite(whitened).any(axis=1)]
        if taken.size:
            self._largest = max(self._largest, float(np.nanmax(np.abs(taken))))
        start = 0
        while start < taken.shape[0]:
            stop = min(taken.shape[0], start + _BLOCK - self._filled)
            self._block[self._filled : self._filled + stop - start] = taken[start:stop]
            self._filled += stop - start
            start = stop
            if self._filled == _BLOCK:
                self._close_block()

    def _close_block(self) -> None:
        block = self._block[: self._filled]
        measured = np.isfinite(block)
        if measured.all():  # every output measured (most logs): no copy
            values = block
            self._measured += self._filled
        else:
            values = np.where(measured, block, 0.0)
            self._measured += np.count_nonzero(measured, axis=0)
        self._count += self._filled
        self._squares += float((values * values).sum())
        self._sums += values.sum(axis=0)
        self._filled = 0

    def result(self) -> Consistency | None:
        """The tests over every row taken; ``None`` below :data:`MIN_SAMPLES` settled ones.

        A row's NIS is over the outputs measured there (``m_k`` of them, ``χ²`` with ``m_k``
        degrees of freedom): ``ε̄`` is the mean over the rows, expected ``Σ m_k / N``, its
        score ``(Σ_k ε_k − Σ_k m_k) / sqrt(2 Σ_k m_k)``; an output's bias is over the rows
        that measured it, and tested only where it has :data:`MIN_SAMPLES` of them.
        """
        if self._filled:
            self._close_block()
        n, m = self._count, len(self._names)
        if n < MIN_SAMPLES or m == 0:
            return None
        freedom = int(self._measured.sum())
        tested = [b for b in range(m) if self._measured[b] >= MIN_SAMPLES]
        means = {self._names[b]: float(self._sums[b] / self._measured[b]) for b in tested}
        return Consistency(
            samples=n,
            nis=self._squares / n,
            nis_expected=freedom / n,
            nis_score=(self._squares - freedom) / math.sqrt(2.0 * freedom),
            bias=means,
            bias_scores={
                self._names[b]: means[self._names[b]] * math.sqrt(float(self._measured[b]))
                for b in tested
            },
            largest=self._largest,
            measured=dict(zip(self._names, (int(c) for c in self._measured), strict=True)),
        )

    def untested(self) -> str | None:
        """Why :meth:`result` has no test (a note for the report), or ``None`` when it has one."""
        if self._filled:
            self._close_block()
        if self._count >= MIN_SAMPLES or not self._names:
            return None
        measured = (
            f" ({self._settled - self._count:,} of them measured no output)"
            if self._settled > self._count
            else ""
        )
        return (
            f"the innovations' whole-log test did not run: {self._count:,} settled samples "
            f"with a measured output{measured}, fewer than the {MIN_SAMPLES} it needs "
            f"(settled: one mode holds at least {SETTLED:g} of the probability at the sample "
            "and the one before)"
        )
