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

The IMM's ``z`` is that of the mode nearest to ``y(k)`` (its ``γᵀ S⁻¹ γ`` is the row's
``surprise``), which on settled samples is the mode the filter holds; the mode-mixed
innovation of §11.6.6 differs from it only by the other modes' weights.  The HSTF keeps
none: its likelihood's ``S_i`` is faded by ``λ_i`` (paper 000 eq. (35)), which grows with the
innovations so as to make them consistent, and it predicts at the mean of the modes'
predictions (eq. (12)), so its innovations are biased on a log of its own model (measured:
``y1``'s mean innovation −10 on ``sample_logs/three_tank_hstf.csv``).

The thresholds (:data:`NIS_WARNING`, :data:`BIAS_WARNING`) are set from measurements: on
logs simulated from the built-in models (three-tank at measurement variance 0.5 and 60, the
double cart, seeds 0..12) every score stayed within ±3.5; the three-tank log scaled by 1.5
scores 13-19, with 3× the measurement noise 25-140.  Real logs rarely match a model's noise
exactly, so a failed test is a warning, not a refusal.  An offset on a sensor the filter can
absorb into a state (``y1 + 50`` on the three-tank, whose process noise lets each level move
0.7 per step) leaves the innovations unbiased (scores within ±5): it is not seen.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from hybridlog.signals import FloatArray

__all__ = [
    "BIAS_WARNING",
    "MIN_SAMPLES",
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
"""A NIS standard score past this warns (too large: the innovations exceed the model's)."""

BIAS_WARNING = 6.0
"""An output's bias standard score past this (either sign) warns."""


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
        Its expectation under the model, ``m`` (the number of outputs).
    nis_score:
        ``(ε̄ − m) / sqrt(2m/N)``.
    bias:
        Per output, the mean whitened innovation ``z̄_b`` (expected 0).
    bias_scores:
        Per output, ``z̄_b sqrt(N)``.
    """

    samples: int
    nis: float
    nis_expected: float
    nis_score: float
    bias: dict[str, float]
    bias_scores: dict[str, float]

    def warnings(self) -> tuple[str, ...]:
        """One line per failed test (empty when the innovations are the model's)."""
        found = []
        if self.nis_score > NIS_WARNING:
            found.append(
                f"the innovations are larger than the model's noise explains: mean normalised "
                f"innovation squared {self.nis:.3g} over {self.samples} settled samples, "
                f"expected {self.nis_expected:g} ({self.nis_score:.1f} standard scores; "
                "a scaled sensor, or more noise than the model's?)"
            )
        biased = [
            f"{name} {self.bias[name]:+.3g} ({score:+.1f})"
            for name, score in self.bias_scores.items()
            if abs(score) > BIAS_WARNING
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
            "bias": dict(self.bias),
            "bias_scores": dict(self.bias_scores),
            "bias_warning": BIAS_WARNING,
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

    def add(self, whitened: FloatArray, probabilities: FloatArray) -> None:
        """Take the next rows: ``L⁻¹ γ`` (NaN: none) and the mode probabilities of each row."""
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
                & np.isfinite(whitened).all(axis=1)
            )
        taken = whitened[settled]
        self._count += int(taken.shape[0])
        self._squares += float((taken * taken).sum())
        self._sums += taken.sum(axis=0)

    def result(self) -> Consistency | None:
        """The tests over every row taken; ``None`` below :data:`MIN_SAMPLES` settled ones."""
        n, m = self._count, len(self._names)
        if n < MIN_SAMPLES or m == 0:
            return None
        nis = self._squares / n
        means = self._sums / n
        return Consistency(
            samples=n,
            nis=nis,
            nis_expected=float(m),
            nis_score=(nis - m) / math.sqrt(2.0 * m / n),
            bias=dict(zip(self._names, (float(v) for v in means), strict=True)),
            bias_scores=dict(
                zip(self._names, (float(v) * math.sqrt(n) for v in means), strict=True)
            ),
        )
