"""Scaled sums of squares and spreads of a signal's rows, merged without over- or underflow.

:class:`Squares` keeps a sum of squares as LAPACK's ``dlassq`` does, :class:`Spread` the
count, range, mean and sum of squared deviations of some rows, which merge with the
pairwise update of Chan, Golub and LeVeque; the metrics of
:mod:`hybridlog.report.metrics` take their ratios.

"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hybridlog.signals import FloatArray


@dataclass(frozen=True)
class Squares:
    r"""A sum of squares :math:`\sum_k v_k^2` kept as :math:`s^2 q` (``scale²·total``).

    The values are divided by ``scale`` (of the order of the largest :math:`|v_k|`) before
    they are squared, so ``total`` neither overflows nor underflows float64 where the
    squares themselves would: the scaled sum of squares of LAPACK's ``dlassq``.  Two such
    sums add at the larger scale,

    .. math::

        s = \max(s_a, s_b), \qquad q = q_a (s_a / s)^2 + q_b (s_b / s)^2,

    where a term that underflows is below 2^-1022 of the other's.  ``scale`` 0: every
    value was 0 (``total`` 0); ``scale`` inf: a value overflowed float64 (``total`` NaN,
    never read: the metric is decided by the infinite scale).

    References
    ----------
    Anderson, E. (2017). Algorithm 978: Safe scaling in the level 1 BLAS. ACM Transactions
    on Mathematical Software 44(1), article 12 (``dlassq``, and Hammarling's scaling).

    """

    scale: float
    total: float

    def in_units_of(self, scale: float) -> float:
        """``total`` re-expressed at ``scale`` (non-zero unless ``self.scale`` is 0 too)."""
        if scale == self.scale:
            return self.total
        ratio = self.scale / scale
        return self.total * (ratio * ratio)

    def merged(self, later: Squares) -> Squares:
        """The sum of both parts' squares, at the larger scale."""
        scale = max(self.scale, later.scale)
        return Squares(scale, self.in_units_of(scale) + later.in_units_of(scale))


@dataclass(frozen=True)
class Spread:
    r"""Count, range, mean and sum of squared deviations of one signal's usable rows.

    ``deviations`` holds :math:`M = \sum_k (v_k - \bar v)^2` as a :class:`Squares`; the
    mean is ``(mean + mean_error) * unit``, a float and what it misses in units of the
    power of two :math:`c` at or below :math:`\max_k |v_k|` (:func:`_unit`): a block's mean
    :math:`m` and the correction :math:`\frac1n \sum_k (v_k - m)` of the corrected two-pass
    algorithm (Chan, Golub and LeVeque 1983, eq. 1.7), kept apart so that the rounding of
    the mean (:math:`\varepsilon |m|`, large beside the spread of a signal far from 0) does
    not enter the merge.  Two parts merge by the pairwise update of the same authors
    (1979, eq. 2.1):

    .. math::

        n = n_a + n_b, \quad \delta = \bar v_b - \bar v_a, \quad
        \bar v = \bar v_a + \delta \frac{n_b}{n}, \quad
        M = M_a + M_b + \delta^2 \frac{n_a n_b}{n},

    with :math:`\delta = (m_b - m_a) + (e_b - e_a)` from the means' two parts (the first
    difference exact where the means are within a factor 2, Sterbenz's lemma) and the new
    mean's two parts from Knuth's exact sum (:func:`_two_sum`).  Everything is evaluated in
    units of :math:`c` of both parts' values, which a part's means reach exactly (powers of
    two): :math:`|\bar v / c| < 2`, :math:`|\delta / c| < 4`,
    :math:`M / c^2 < 16 n`, so nothing overflows, and what underflows (the spread of a part
    some 10^154 times smaller than ``c``) is negligible against :math:`\delta^2 n_a n_b / n`,
    the other part's values reaching ``c``.

    References
    ----------
    Chan, T. F., Golub, G. H. and LeVeque, R. J. (1979). Updating formulae and a pairwise
    algorithm for computing sample variances. Stanford report STAN-CS-79-773.
    Chan, T. F., Golub, G. H. and LeVeque, R. J. (1983). Algorithms for computing the
    sample variance: analysis and recommendations. The American Statistician 37(3),
    242-247.
    Knuth, D. E. The Art of Computer Programming, vol. 2, section 4.2.2 (the exact sum).

    """

    rows: int
    low: float
    high: float
    mean: float
    mean_error: float
    deviations: Squares

    @property
    def magnitude(self) -> float:
        """``max |v|``, from the range."""
        return abs(max(self.high, -self.low))

    @property
    def unit(self) -> float:
        """The unit of ``mean`` and ``mean_error``."""
        return _unit(self.magnitude)

    def merged(self, later: Spread) -> Spread:
        """The spread of both parts' rows, ``self``'s first."""
        rows = self.rows + later.rows
        low, high = min(self.low, later.low), max(self.high, later.high)
        magnitude = abs(max(high, -low))
        if not 0.0 < magnitude < math.inf:
            return flat_spread(rows, low, high, magnitude)
        unit = _unit(magnitude)
        first, second = self.unit / unit, later.unit / unit  # powers of two: exact products
        delta = (later.mean * second - self.mean * first) + (
            later.mean_error * second - self.mean_error * first
        )
        share = later.rows / rows
        mean, error = _two_sum(self.mean * first, self.mean_error * first + delta * share)
        total = (
            self.deviations.in_units_of(unit)
            + later.deviations.in_units_of(unit)
            + delta * delta * (self.rows * share)
        )
        return Spread(rows, low, high, mean, error, Squares(unit, total))


def _unit(magnitude: float) -> float:
    """The power of two at or below a finite ``magnitude``; 0 for 0 (values 0, mean 0)."""
    return math.ldexp(1.0, math.frexp(magnitude)[1] - 1) if magnitude else 0.0


def _two_sum(a: float, b: float) -> tuple[float, float]:
    """``a + b`` rounded and what the rounding lost, which add up to ``a + b`` exactly.

    Knuth's TwoSum (TAOCP vol. 2, 4.2.2, theorem B), for finite ``a`` and ``b``.
    """
    total = a + b
    b_part = total - a
    return total, (a - (total - b_part)) + (b - b_part)


def value_range(v: FloatArray) -> tuple[float, float, float]:
    """``min v``, ``max v`` and ``max |v|`` (from the two: no array of magnitudes)."""
    low, high = float(v.min()), float(v.max())
    return low, high, abs(max(high, -low))


def flat_spread(rows: int, low: float, high: float, magnitude: float) -> Spread:
    """The spread of values that cannot be scaled: all 0, or one overflowed (``magnitude`` inf)."""
    if magnitude == 0.0:
        return Spread(rows, low, high, 0.0, 0.0, Squares(0.0, 0.0))
    return Spread(rows, low, high, math.nan, math.nan, Squares(math.inf, math.nan))


def unit_spread(unit: FloatArray, scale: float, low: float, high: float) -> Spread:
    """The spread of ``scale * unit`` from ``unit`` (overwritten): ``np.std``'s two passes."""
    n = unit.size
    mean = float(np.sum(unit)) / n
    unit -= mean
    correction = float(np.sum(unit)) / n
    total = float(np.sum(np.square(unit, out=unit)))
    to_unit = scale / _unit(scale)  # in [1, 2): exact
    return Spread(n, low, high, mean * to_unit, correction * to_unit, Squares(scale, total))


def scaled_spread(v: FloatArray, scratch: FloatArray) -> Spread:
    r"""The spread of ``v`` scaled first, as VAF takes it: the moments of :math:`v / \max|v|`."""
    low, high, magnitude = value_range(v)
    if not 0.0 < magnitude < math.inf:
        return flat_spread(v.size, low, high, magnitude)
    return unit_spread(np.divide(v, magnitude, out=scratch), magnitude, low, high)


def centred_spread(v: FloatArray, scratch: FloatArray) -> Spread:
    r"""The spread of ``v`` centred first, as fit takes it: :math:`v - \bar v` over its largest.

    Where the mean or a deviation overflows float64 (values near 10^308), the spread is
    taken scaled first instead (:func:`scaled_spread`); the same sum, other roundings.
    """
    low, high, magnitude = value_range(v)
    if not magnitude:
        return flat_spread(v.size, low, high, magnitude)
    n = v.size
    mean = float(np.sum(v)) / n
    deviation = np.subtract(v, mean, out=scratch)
    scale = value_range(deviation)[2]
    if not math.isfinite(scale):
        return scaled_spread(v, scratch)
    if scale:
        deviation /= scale
    unit = _unit(magnitude)
    # Summed once scaled: a sum of subnormal deviations divided by n rounds to their grid.
    correction = float(np.sum(deviation)) / n * (scale / unit)
    total = float(np.sum(np.square(deviation, out=deviation)))
    return Spread(n, low, high, mean / unit, correction, Squares(scale, total))
