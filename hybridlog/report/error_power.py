"""The power of an error (its mean square), and numbers beyond float64's range.

:class:`ErrorPower` is the sum of squares of some rows of an error, plain and scaled, whose
mean square MSE and RMSE are; :class:`InRange` a positive number that float64 may not
hold, and why a metric of that value is null.

"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass

import numpy as np

from hybridlog.report.scaled_sums import Squares, value_range
from hybridlog.signals import FloatArray

_SAFE_LOW = 2.0**-480
"""Smallest largest error whose plain sum of squares is accurate where it is finite (none
overflowed): the largest square is then a normal number, and what the smaller ones lose by
underflowing is below 2^-1074 each, against a sum of at least 2^-960."""


@dataclass(frozen=True)
class InRange:
    r"""A positive number :math:`f \cdot 2^e` (``fraction`` in [0.5, 1)), held or not.

    ``value`` is the float, ``inf`` above float64's range, NaN below its normal range (a
    subnormal float keeps fewer than 52 bits: a number no one can vouch for).
    """

    fraction: float
    exponent: int

    @classmethod
    def product(cls, scale: float, power: int, factor: float) -> InRange:
        r""":math:`\mathrm{scale}^{\mathrm{power}} \cdot \mathrm{factor}` (both positive).

        Both finite; the product may be as far beyond float64's range as it is.
        """
        fraction, exponent = math.frexp(scale)
        fraction, extra = math.frexp(fraction**power * factor)
        return cls(fraction, extra + power * exponent)

    @property
    def above(self) -> bool:
        """Whether the number is above float64's range (2^1024 or more)."""
        return self.exponent > 1024

    @property
    def below(self) -> bool:
        """Whether the number is below float64's normal numbers (2^-1022)."""
        return self.exponent < -1021

    @property
    def value(self) -> float:
        """The number as a float64: inf above its range, NaN below its normal numbers."""
        if self.above:
            return math.inf
        if self.below:
            return math.nan
        return math.ldexp(self.fraction, self.exponent)

    def times(self, factor: float) -> InRange:
        """The number times a positive ``factor`` of moderate size."""
        fraction, extra = math.frexp(self.fraction * factor)
        return InRange(fraction, self.exponent + extra)

    def decimal(self) -> str:
        """The number in scientific notation, two digits (``1.2e+403``), out of range too."""
        digits = math.log10(self.fraction) + self.exponent * math.log10(2.0)
        power = math.floor(digits)
        mantissa = round(10.0 ** (digits - power), 1)
        if mantissa >= 10.0:
            mantissa, power = mantissa / 10.0, power + 1
        return f"{mantissa:.2g}e{power:+03d}"

    def beyond(self, what: str, sign: str = "", unit: str = "") -> str:
        """Why ``what`` (``sign`` times this number) is null: which side of the range it is."""
        if self.above:
            return (
                f"{what} ≈ {sign}{self.decimal()}{unit} is beyond float64's range "
                f"(at most {sys.float_info.max:.2g})"
            )
        return (
            f"{what} ≈ {sign}{self.decimal()}{unit} is below float64's range "
            f"(normal numbers from {sys.float_info.min:.2g})"
        )


@dataclass(frozen=True)
class ErrorPower:
    r"""Rows and :math:`\sum_k e_k^2` of an error :math:`e = y - \hat y`, plain and scaled.

    ``squares``: the plain sum (it overflows to inf or underflows to 0 with the squares);
    ``size``: the same sum scaled by :math:`\max|e|` (:class:`Squares`), which neither
    does.  The mean square is the plain one where that is accurate (finite, and
    :data:`_SAFE_LOW`: the bits of the whole-column code), the scaled one otherwise,
    so that it does not depend on the units of the signals.  ``infinite``: some ``ŷ`` was
    infinite (a prediction or estimate that diverged), not merely too large to subtract.
    """

    rows: int
    squares: float
    size: Squares
    infinite: bool = False

    @classmethod
    def between(cls, y: FloatArray, y_hat: FloatArray, scratch: FloatArray) -> ErrorPower:
        """The power of ``y - y_hat``: a block's part of :class:`StateAccumulator`."""
        error, work = scratch[0, : y.size], scratch[1, : y.size]
        with np.errstate(over="ignore", invalid="ignore"):
            np.subtract(y, y_hat, out=error)
            squares = float(np.sum(np.multiply(error, error, out=work)))
            size = _error_size(error, squares, work)
        infinite = size.scale == math.inf and bool(np.isinf(y_hat).any())
        return cls(error.size, squares, size, infinite)

    def _mean_of(self, power: int) -> tuple[float, InRange | None]:
        scale = self.size.scale
        if (scale >= _SAFE_LOW and self.squares < math.inf) or scale in (0.0, math.inf):
            mean = self.squares / self.rows
            return (mean if power == 2 else math.sqrt(mean)), None
        factor = self.size.total / self.rows
        number = InRange.product(scale, power, factor if power == 2 else math.sqrt(factor))
        return number.value, (number if number.above or number.below else None)

    def mean_square(self) -> tuple[float, InRange | None]:
        r""":math:`\frac1n \sum_k e_k^2` (``rows`` >= 1), and the number if float64 lacks it.

        The float is then inf above the range, NaN below; inf without that number where an
        error itself overflowed (``size.scale`` inf).
        """
        return self._mean_of(2)

    def root_mean_square(self) -> tuple[float, InRange | None]:
        r""":math:`\sqrt{\frac1n \sum_k e_k^2}`, as :meth:`mean_square` gives it."""
        return self._mean_of(1)

    def merged(self, later: ErrorPower) -> ErrorPower:
        """The power of both parts' rows."""
        return ErrorPower(
            self.rows + later.rows,
            self.squares + later.squares,
            self.size.merged(later.size),
            self.infinite or later.infinite,
        )


def _error_size(error: FloatArray, squares: float, work: FloatArray) -> Squares:
    r"""``squares`` (:math:`\sum e^2` of a block) scaled by :math:`\max|e|`.

    Where the plain sum is accurate (:data:`_SAFE_LOW`) it is only re-expressed; else the
    errors are scaled before they are squared (``work``: scratch).
    """
    size = value_range(error)[2]
    if not 0.0 < size < math.inf:
        return Squares(size, 0.0 if size == 0.0 else math.nan)
    if size >= _SAFE_LOW and squares < math.inf:
        return Squares(size, squares / size / size)
    unit = np.divide(error, size, out=work)
    return Squares(size, float(np.sum(np.square(unit, out=unit))))
