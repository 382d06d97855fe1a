"""Quality metrics of one estimation run: output fit and state error.

Pure functions over NumPy arrays, and accumulators of the output and state metrics for a
run whose rows come in chunks; they never warn, print or touch files.  A metric that
cannot be computed (no usable sample, no ground truth, a zero denominator, an infinite
prediction) is NaN or infinite here and ``null`` in ``report.json``, with the reason from
:func:`output_metrics`; so is one whose value float64 cannot hold (MSE of errors of 1e200
or 1e-300), the reason saying so.  The errors are scaled before they are squared where
their squares would leave float64's range, so no metric depends on the units of the
signals: VAF and fit not at all, MSE and RMSE as the square and the unit.  The mode
metrics (accuracy, switches, dwell times, detection delays) are
:mod:`hybridlog.report.mode_metrics`.

References
----------
Paper 001 (``papers/001_73b6a953d073a2d8.txt``), section 5: the MSE and VAF formulas.
MATLAB System Identification Toolbox, ``compare``: the fit (NRMSE) formula.

"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Generic, Protocol, Self, TypeVar

import numpy as np
import numpy.typing as npt

from hybridlog.signals import FloatArray

__all__ = [
    "OutputAccumulator",
    "OutputMetrics",
    "StateAccumulator",
    "fit",
    "mean_where_defined",
    "mse",
    "output_metrics",
    "state_rmse",
    "vaf",
]


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


_BLOCK_ROWS = 1 << 16
"""Rows of the run per block, the unit in which the output and state metrics reduce.

A block's usable rows are reduced with the operations (and NumPy's pairwise sums) that
reduced a whole column before the metrics were streamed, so a run of at most one block has
the same bits as then; blocks are then merged (:class:`_Squares`, :class:`_Spread`).  2^16
rows: 512 KiB per array, a block's temporaries in a core's L2 cache.
"""


@dataclass(frozen=True)
class _Squares:
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

    def merged(self, later: _Squares) -> _Squares:
        """The sum of both parts' squares, at the larger scale."""
        scale = max(self.scale, later.scale)
        return _Squares(scale, self.in_units_of(scale) + later.in_units_of(scale))


@dataclass(frozen=True)
class _Spread:
    r"""Count, range, mean and sum of squared deviations of one signal's usable rows.

    ``deviations`` holds :math:`M = \sum_k (v_k - \bar v)^2` as a :class:`_Squares`; the
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
    deviations: _Squares

    @property
    def magnitude(self) -> float:
        """``max |v|``, from the range."""
        return abs(max(self.high, -self.low))

    @property
    def unit(self) -> float:
        """The unit of ``mean`` and ``mean_error``."""
        return _unit(self.magnitude)

    def merged(self, later: _Spread) -> _Spread:
        """The spread of both parts' rows, ``self``'s first."""
        rows = self.rows + later.rows
        low, high = min(self.low, later.low), max(self.high, later.high)
        magnitude = abs(max(high, -low))
        if not 0.0 < magnitude < math.inf:
            return _flat_spread(rows, low, high, magnitude)
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
        return _Spread(rows, low, high, mean, error, _Squares(unit, total))


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


def _range(v: FloatArray) -> tuple[float, float, float]:
    """``min v``, ``max v`` and ``max |v|`` (from the two: no array of magnitudes)."""
    low, high = float(v.min()), float(v.max())
    return low, high, abs(max(high, -low))


def _flat_spread(rows: int, low: float, high: float, magnitude: float) -> _Spread:
    """The spread of values that cannot be scaled: all 0, or one overflowed (``magnitude`` inf)."""
    if magnitude == 0.0:
        return _Spread(rows, low, high, 0.0, 0.0, _Squares(0.0, 0.0))
    return _Spread(rows, low, high, math.nan, math.nan, _Squares(math.inf, math.nan))


def _unit_spread(unit: FloatArray, scale: float, low: float, high: float) -> _Spread:
    """The spread of ``scale * unit`` from ``unit`` (overwritten): ``np.std``'s two passes."""
    n = unit.size
    mean = float(np.sum(unit)) / n
    unit -= mean
    correction = float(np.sum(unit)) / n
    total = float(np.sum(np.square(unit, out=unit)))
    to_unit = scale / _unit(scale)  # in [1, 2): exact
    return _Spread(n, low, high, mean * to_unit, correction * to_unit, _Squares(scale, total))


def _scaled_spread(v: FloatArray, scratch: FloatArray) -> _Spread:
    r"""The spread of ``v`` scaled first, as VAF takes it: the moments of :math:`v / \max|v|`."""
    low, high, magnitude = _range(v)
    if not 0.0 < magnitude < math.inf:
        return _flat_spread(v.size, low, high, magnitude)
    return _unit_spread(np.divide(v, magnitude, out=scratch), magnitude, low, high)


def _centred_spread(v: FloatArray, scratch: FloatArray) -> _Spread:
    r"""The spread of ``v`` centred first, as fit takes it: :math:`v - \bar v` over its largest.

    Where the mean or a deviation overflows float64 (values near 10^308), the spread is
    taken scaled first instead (:func:`_scaled_spread`); the same sum, other roundings.
    """
    low, high, magnitude = _range(v)
    if not magnitude:
        return _flat_spread(v.size, low, high, magnitude)
    n = v.size
    mean = float(np.sum(v)) / n
    deviation = np.subtract(v, mean, out=scratch)
    scale = _range(deviation)[2]
    if not math.isfinite(scale):
        return _scaled_spread(v, scratch)
    if scale:
        deviation /= scale
    unit = _unit(magnitude)
    # Summed once scaled: a sum of subnormal deviations divided by n rounds to their grid.
    correction = float(np.sum(deviation)) / n * (scale / unit)
    total = float(np.sum(np.square(deviation, out=deviation)))
    return _Spread(n, low, high, mean / unit, correction, _Squares(scale, total))


_SAFE_LOW = 2.0**-480
"""Smallest largest error whose plain sum of squares is accurate where it is finite (none
overflowed): the largest square is then a normal number, and what the smaller ones lose by
underflowing is below 2^-1074 each, against a sum of at least 2^-960."""


@dataclass(frozen=True)
class _InRange:
    r"""A positive number :math:`f \cdot 2^e` (``fraction`` in [0.5, 1)), held or not.

    ``value`` is the float, ``inf`` above float64's range, NaN below its normal range (a
    subnormal float keeps fewer than 52 bits: a number no one can vouch for).
    """

    fraction: float
    exponent: int

    @classmethod
    def product(cls, scale: float, power: int, factor: float) -> _InRange:
        r""":math:`\mathrm{scale}^{\mathrm{power}} \cdot \mathrm{factor}` (both positive).

        Both finite; the product may be as far beyond float64's range as it is.
        """
        fraction, exponent = math.frexp(scale)
        fraction, extra = math.frexp(fraction**power * factor)
        return cls(fraction, extra + power * exponent)

    @property
    def above(self) -> bool:
        return self.exponent > 1024

    @property
    def below(self) -> bool:
        return self.exponent < -1021

    @property
    def value(self) -> float:
        if self.above:
            return math.inf
        if self.below:
            return math.nan
        return math.ldexp(self.fraction, self.exponent)

    def times(self, factor: float) -> _InRange:
        """The number times a positive ``factor`` of moderate size."""
        fraction, extra = math.frexp(self.fraction * factor)
        return _InRange(fraction, self.exponent + extra)

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
class _ErrorPower:
    r"""Rows and :math:`\sum_k e_k^2` of an error :math:`e = y - \hat y`, plain and scaled.

    ``squares``: the plain sum (it overflows to inf or underflows to 0 with the squares);
    ``size``: the same sum scaled by :math:`\max|e|` (:class:`_Squares`), which neither
    does.  The mean square is the plain one where that is accurate (finite, and
    :data:`_SAFE_LOW`: the bits of the whole-column code), the scaled one otherwise,
    so that it does not depend on the units of the signals.  ``infinite``: some ``ŷ`` was
    infinite (a prediction or estimate that diverged), not merely too large to subtract.
    """

    rows: int
    squares: float
    size: _Squares
    infinite: bool = False

    @classmethod
    def between(cls, y: FloatArray, y_hat: FloatArray, scratch: FloatArray) -> _ErrorPower:
        """The power of ``y - y_hat``: a block's part of :class:`StateAccumulator`."""
        error, work = scratch[0, : y.size], scratch[1, : y.size]
        with np.errstate(over="ignore", invalid="ignore"):
            np.subtract(y, y_hat, out=error)
            squares = float(np.sum(np.multiply(error, error, out=work)))
            size = _error_size(error, squares, work)
        infinite = size.scale == math.inf and bool(np.isinf(y_hat).any())
        return cls(error.size, squares, size, infinite)

    def _mean_of(self, power: int) -> tuple[float, _InRange | None]:
        scale = self.size.scale
        if (scale >= _SAFE_LOW and self.squares < math.inf) or scale in (0.0, math.inf):
            mean = self.squares / self.rows
            return (mean if power == 2 else math.sqrt(mean)), None
        factor = self.size.total / self.rows
        number = _InRange.product(scale, power, factor if power == 2 else math.sqrt(factor))
        return number.value, (number if number.above or number.below else None)

    def mean_square(self) -> tuple[float, _InRange | None]:
        r""":math:`\frac1n \sum_k e_k^2` (``rows`` >= 1), and the number if float64 lacks it.

        The float is then inf above the range, NaN below; inf without that number where an
        error itself overflowed (``size.scale`` inf).
        """
        return self._mean_of(2)

    def root_mean_square(self) -> tuple[float, _InRange | None]:
        r""":math:`\sqrt{\frac1n \sum_k e_k^2}`, as :meth:`mean_square` gives it."""
        return self._mean_of(1)

    def merged(self, later: _ErrorPower) -> _ErrorPower:
        """The power of both parts' rows."""
        return _ErrorPower(
            self.rows + later.rows,
            self.squares + later.squares,
            self.size.merged(later.size),
            self.infinite or later.infinite,
        )


def _error_size(error: FloatArray, squares: float, work: FloatArray) -> _Squares:
    r"""``squares`` (:math:`\sum e^2` of a block) scaled by :math:`\max|e|`.

    Where the plain sum is accurate (:data:`_SAFE_LOW`) it is only re-expressed; else the
    errors are scaled before they are squared (``work``: scratch).
    """
    size = _range(error)[2]
    if not 0.0 < size < math.inf:
        return _Squares(size, 0.0 if size == 0.0 else math.nan)
    if size >= _SAFE_LOW and squares < math.inf:
        return _Squares(size, squares / size / size)
    unit = np.divide(error, size, out=work)
    return _Squares(size, float(np.sum(np.square(unit, out=unit))))


@dataclass(frozen=True)
class _OutputPart:
    r"""What MSE, VAF and fit need of some usable rows of one output.

    ``power``: :math:`\sum e^2`, plain and scaled by :math:`\max|e|` (MSE, and
    :math:`\lVert e\rVert^2` of fit); ``measured``: the spread of ``y`` centred first
    (fit's :math:`\lVert y - \bar y\rVert`); ``predicted`` and ``error``: the spreads of
    ``ŷ`` and :math:`e = y - \hat y` scaled first (VAF's standard deviations).
    """

    power: _ErrorPower
    measured: _Spread
    predicted: _Spread
    error: _Spread

    @classmethod
    def of(cls, y: FloatArray, y_hat: FloatArray, scratch: FloatArray) -> _OutputPart:
        """The part of one block's usable rows (``y`` finite, ``y_hat`` not NaN); both kept."""
        error, scratch = scratch[0, : y.size], scratch[1, : y.size]
        with np.errstate(over="ignore", invalid="ignore"):
            np.subtract(y, y_hat, out=error)
            squares = float(np.sum(np.multiply(error, error, out=scratch)))
            low, high, size = _range(error)
            if 0.0 < size < math.inf:
                unit = np.divide(error, size, out=error)
                error_size = _Squares(size, float(np.sum(np.square(unit, out=scratch))))
                error_spread = _unit_spread(unit, size, low, high)
            else:
                error_spread = _flat_spread(error.size, low, high, size)
                error_size = error_spread.deviations
            return cls(
                power=_ErrorPower(error.size, squares, error_size),
                measured=_centred_spread(y, scratch),
                predicted=_scaled_spread(y_hat, scratch),
                error=error_spread,
            )

    def merged(self, later: _OutputPart) -> _OutputPart:
        """The part of both parts' rows, ``self``'s first."""
        return _OutputPart(
            power=self.power.merged(later.power),
            measured=self.measured.merged(later.measured),
            predicted=self.predicted.merged(later.predicted),
            error=self.error.merged(later.error),
        )


class _Mergeable(Protocol):
    """A summary of some rows that merges with the summary of the rows after them."""

    def merged(self, later: Self) -> Self: ...


_Part = TypeVar("_Part", bound=_Mergeable)

_Reduce = Callable[[FloatArray, FloatArray, FloatArray], _Part]
"""A block's usable ``y`` and ``ŷ`` (contiguous) to its part, given ``(2, rows)`` scratch."""


def _merged(first: _Part | None, later: _Part | None) -> _Part | None:
    """``first.merged(later)``, a missing part (no usable row) taken as nothing."""
    if first is None:
        return later
    return first if later is None else first.merged(later)


_PIECE_ROWS = 1 << 13
"""Rows selected at a time: temporaries of 64 KiB, below glibc's threshold for mapping an
allocation (128 KiB), so they are reused from the heap, not mapped and faulted in anew."""


def _select(v: FloatArray, usable: npt.NDArray[np.bool_], out: FloatArray) -> None:
    """Write the entries of ``v`` where ``usable``, in order, to ``out`` (as many)."""
    if out.size == v.size:
        out[:] = v
        return
    filled = 0
    for start in range(0, v.size, _PIECE_ROWS):
        piece = v[start : start + _PIECE_ROWS][usable[start : start + _PIECE_ROWS]]
        out[filled : filled + piece.size] = piece
        filled += piece.size


class _Column(Generic[_Part]):
    """One column's usable rows, reduced a block of the run's rows at a time.

    A block is :data:`_BLOCK_ROWS` consecutive rows of the run; its usable rows (``y`` and
    ``ŷ`` finite) are reduced to a part (``None`` when none was usable) once the block is
    complete: selected into the columns' shared scratch when one call brings the whole
    block, else from the rows kept (copied) since the block opened.  Closed parts merge
    as a binary counter counts: a part merges with the last closed one while both stand
    for the same number of blocks (1 and 1, then 2 and 2, ...), so the parts merge along
    a balanced binary tree (the pairwise algorithm of Chan, Golub and LeVeque: rounding
    grows with the tree's height, log2 of the number of blocks, not with their number).
    The blocks and the tree depend on the rows alone, never on how they were handed over.
    """

    def __init__(self, reduce: _Reduce[_Part]) -> None:
        self._reduce = reduce
        self._kept = np.empty((2, 0))  # the open block's usable y and ŷ so far, and room
        self._filled = 0
        self._closed: list[tuple[int, _Part | None]] = []  # (log2 of its blocks, part)

    def extend(self, y: FloatArray, y_hat: FloatArray, complete: bool, work: FloatArray) -> None:
        """Take rows of the open block (one column's, any strides); ``complete``: its last.

        ``work``: ``(4, _BLOCK_ROWS)`` scratch, shared by the columns.
        """
        # An infinite ŷ is a prediction that diverged, not a missing one (NaN): it is used,
        # and its error makes MSE and fit infinite (null, "diverged") and VAF 0, so that a
        # filter that blew up is never scored on the rows before it did.
        usable = np.isfinite(y)
        usable &= ~np.isnan(y_hat)
        count = int(np.count_nonzero(usable))
        if complete and not self._filled:  # the whole block: reduced from the caller's rows
            if count:
                _select(y, usable, work[0, :count])
                _select(y_hat, usable, work[1, :count])
            self._close(self._open_part(work[:2, :count], work[2:]))
            return
        filled = self._filled + count
        if filled > self._kept.shape[1]:  # grown by doubling, up to a block
            grown = np.empty((2, min(max(filled, 2 * self._kept.shape[1]), _BLOCK_ROWS)))
            grown[:, : self._filled] = self._kept[:, : self._filled]
            self._kept = grown
        _select(y, usable, self._kept[0, self._filled : filled])
        _select(y_hat, usable, self._kept[1, self._filled : filled])
        self._filled = filled
        if complete:
            self._close(self._open_part(self._kept[:, :filled], work[2:]))
            self._filled = 0

    def _open_part(self, rows: FloatArray, scratch: FloatArray) -> _Part | None:
        return self._reduce(rows[0], rows[1], scratch) if rows.shape[1] else None

    def _close(self, part: _Part | None) -> None:
        height = 0
        while self._closed and self._closed[-1][0] == height:
            part = _merged(self._closed.pop()[1], part)
            height += 1
        self._closed.append((height, part))

    def part(self, scratch: FloatArray) -> _Part | None:
        """The part of every row taken so far (the open block reduced, kept open)."""
        whole = self._open_part(self._kept[:, : self._filled], scratch)
        for _, part in reversed(self._closed):
            whole = _merged(part, whole)
        return whole


class _Columns(Generic[_Part]):
    """The :class:`_Column` of every column of ``(rows, columns)`` pairs ``y``, ``ŷ``.

    The rows of an ``add`` are taken a block at a time (or what completes the open block),
    each column in turn, and a column's block reduced as soon as it is complete, in one
    scratch of four block-sized rows: no temporary is larger, whatever the rows handed
    over, and the only rows kept between calls are the usable ones of an incomplete block
    (none when the calls bring whole blocks of :data:`_BLOCK_ROWS` rows).
    """

    def __init__(self, columns: int, reduce: _Reduce[_Part]) -> None:
        if columns < 0:
            raise ValueError(f"the number of columns must be >= 0; got {columns}")
        self._columns = [_Column(reduce) for _ in range(columns)]
        self._open_rows = 0  # rows of the run in the open block
        self._work = np.empty((4, _BLOCK_ROWS))  # reused: its pages are faulted in once

    def add(self, y: npt.ArrayLike, y_hat: npt.ArrayLike) -> None:
        y2, yh2 = _paired(y, y_hat)
        if y2.shape[1] != len(self._columns):
            raise ValueError(f"expected {len(self._columns)} columns; got {y2.shape[1]}")
        start = 0
        while start < y2.shape[0]:
            stop = min(y2.shape[0], start + _BLOCK_ROWS - self._open_rows)
            self._open_rows = (self._open_rows + stop - start) % _BLOCK_ROWS
            complete = not self._open_rows
            for j, column in enumerate(self._columns):
                column.extend(y2[start:stop, j], yh2[start:stop, j], complete, self._work)
            start = stop

    def parts(self) -> list[_Part | None]:
        return [column.part(self._work[2:]) for column in self._columns]


def _scaled_ratio(a: _Squares, b: _Squares, size: Callable[[float], float]) -> float:
    r""":math:`s_a\,\mathrm{size}(q_a) / (s_b\,\mathrm{size}(q_b))`, no overflow or underflow.

    ``size`` turns a scaled sum of squares into a norm (:func:`math.sqrt`) or a standard
    deviation (``sqrt(q / n)``).  0 when ``a`` is all zero; ``inf`` when it overflowed
    float64; NaN when ``b`` is numerically zero.
    """
    denominator = size(b.total)
    if a.scale == 0.0:
        return 0.0
    if a.scale == math.inf:
        return math.inf
    if not denominator > 0.0:
        return math.nan
    ratio = size(a.total) / denominator
    # 0 stays 0 where the scales' ratio overflows (a constant error against a tiny spread).
    return (a.scale / b.scale) * ratio if ratio else 0.0


def _vaf(part: _OutputPart) -> float:
    if math.isinf(part.predicted.magnitude):
        return 0.0  # an infinite prediction: var(y − ŷ) is too (the ratio inf)
    if part.predicted.high == part.predicted.low:
        return math.nan  # var(ŷ) = 0: undefined
    if math.isinf(part.error.magnitude):
        return math.nan  # y − ŷ overflows float64 in some row: not a number to vouch for
    rows = part.power.rows
    ratio = _scaled_ratio(
        part.error.deviations, part.predicted.deviations, lambda q: math.sqrt(q / rows)
    )
    return max(1.0 - ratio * ratio, 0.0) * 100.0


def _fit(part: _OutputPart) -> tuple[float, _InRange | None]:
    r"""Fit, and where float64 cannot hold it the number :math:`100 r` it is short of 100."""
    if part.measured.high == part.measured.low:
        return math.nan, None  # ‖y − ȳ‖ = 0: undefined
    error, measured = part.power.size, part.measured.deviations
    if error.scale == math.inf:  # an infinite prediction (diverged), or y − ŷ overflowed
        return (-math.inf if math.isinf(part.predicted.magnitude) else math.nan), None
    if error.scale == 0.0:
        return 100.0, None
    if not measured.total > 0.0:  # a spread lost to rounding: numerically constant
        return math.nan, None
    # r = ‖e‖ / ‖y − ȳ‖ as (s_e / s_y)·(√q_e / √q_y), the scales' ratio kept as a power of
    # two: a ratio of 1e200-sized errors to a spread of 1e-200 is a number, not inf.
    ratio = math.sqrt(error.total) / math.sqrt(measured.total)
    error_fraction, error_exponent = math.frexp(error.scale)
    measured_fraction, measured_exponent = math.frexp(measured.scale)
    fraction, exponent = math.frexp(error_fraction / measured_fraction * ratio)
    exponent += error_exponent - measured_exponent
    hundred_r = _InRange(fraction, exponent).times(100.0)
    if hundred_r.above:
        return -math.inf, hundred_r
    # the same roundings as (s_e / s_y)·ratio where that is a normal number
    return (1.0 - math.ldexp(fraction, exponent)) * 100.0, None


def mse(y: npt.ArrayLike, y_hat: npt.ArrayLike) -> FloatArray:
    r"""Mean square output error per output column (paper 001, section 5).

    .. math::

        \mathrm{MSE} = \frac{1}{N} \sum_{k} \bigl(y(k) - \hat y(k)\bigr)^2

    taken over the rows where ``y`` is finite and ``y_hat`` is not NaN (row 0 of an
    :class:`~hybridlog.estimators.result.EstimationResult` has no prediction), the errors
    scaled by the largest before they are squared where the plain squares would overflow
    or underflow float64.  Computed by :class:`OutputAccumulator`.

    Parameters
    ----------
    y:
        Measured outputs, shape ``(N,)`` or ``(N, n_y)``.
    y_hat:
        One-step-ahead predictions, same shape.

    Returns
    -------
    numpy.ndarray
        Shape ``(n_y,)``; NaN for a column without a single usable row and for an MSE
        below float64's normal numbers (2.2e-308), inf for one above its range or of an
        infinite prediction (:func:`output_metrics` says which).

    """
    return np.array([m.mse for m in output_metrics(y, y_hat)], dtype=np.float64)


def vaf(y: npt.ArrayLike, y_hat: npt.ArrayLike) -> FloatArray:
    r"""Variance accounted for, in percent, per output column (paper 001, section 5).

    .. math::

        \mathrm{VAF} = \max\Bigl\{1 - \frac{\operatorname{var}(y - \hat y)}
                                          {\operatorname{var}(\hat y)},\ 0\Bigr\}
                       \cdot 100\,\%

    The denominator is the variance of the *prediction*, as in the paper (not of ``y``).
    Variances are population variances (``ddof=0``) over the rows where ``y`` is finite
    and ``y_hat`` is not NaN (an infinite ``y_hat`` diverged: VAF 0).  When ``var(ŷ) = 0``
    (a constant prediction, or a single usable row) the ratio is undefined and so is VAF:
    NaN, never a guessed 0 or 100 (:func:`output_metrics` says why).  Computed by
    :class:`OutputAccumulator`.

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
    return np.array([m.vaf for m in output_metrics(y, y_hat)], dtype=np.float64)


def fit(y: npt.ArrayLike, y_hat: npt.ArrayLike) -> FloatArray:
    r"""Fit in percent per output column: the NRMSE of MATLAB's ``compare``.

    .. math::

        \mathrm{fit} = \Bigl(1 - \frac{\lVert y - \hat y\rVert_2}
                                      {\lVert y - \bar y\rVert_2}\Bigr) \cdot 100\,\%

    over the rows where ``y`` is finite and ``y_hat`` is not NaN, ``ȳ`` the mean of ``y`` over
    those rows.  100 is a perfect prediction, 0 is no better than predicting the mean, and
    a worse prediction is negative (not clamped, as in ``compare``).  Unlike VAF, the
    denominator does not depend on the prediction, so a worse predictor never scores
    better.  NaN when ``y`` is constant over the usable rows (``‖y − ȳ‖ = 0``).  Computed
    by :class:`OutputAccumulator`.

    Parameters
    ----------
    y:
        Measured outputs, shape ``(N,)`` or ``(N, n_y)``.
    y_hat:
        One-step-ahead predictions, same shape.

    Returns
    -------
    numpy.ndarray
        Shape ``(n_y,)``, values in ``(-inf, 100]`` (``-inf`` when the prediction is
        infinite in some row, or the fit is below float64's range); NaN where undefined.

    """
    return np.array([m.fit for m in output_metrics(y, y_hat)], dtype=np.float64)


@dataclass(frozen=True)
class OutputMetrics:
    """MSE, VAF and fit of one output, and why any of them is undefined.

    Attributes
    ----------
    samples:
        Rows used: where the measurement is finite and the one-step-ahead prediction is
        not NaN (none was made); an infinite prediction diverged, and counts.
    mse, vaf, fit:
        See :func:`mse`, :func:`vaf`, :func:`fit`; NaN where undefined.
    undefined:
        ``{metric: reason}`` for each of ``mse``, ``vaf``, ``fit`` that is not finite.
    out_of_range:
        The metrics among them whose value exists but float64 cannot hold (MSE of errors
        of 1e200, inf; of errors of 1e-300, NaN; a fit below -1.8e308, -inf): never left
        out of a mean over outputs as an undefined one is.

    """

    samples: int
    mse: float
    vaf: float
    fit: float
    undefined: Mapping[str, str]
    out_of_range: frozenset[str] = frozenset()


def _output_metrics(part: _OutputPart | None) -> OutputMetrics:
    """The metrics of one output from the part of all its rows, with reasons for NaNs."""
    if part is None:
        why = "no sample has both a measurement and a one-step-ahead prediction"
        undefined = {"mse": why, "vaf": why, "fit": why}
        return OutputMetrics(0, math.nan, math.nan, math.nan, undefined=undefined)
    mse, mse_number = part.power.mean_square()
    fit, fit_number = _fit(part)
    values = {"mse": mse, "vaf": _vaf(part), "fit": fit}
    n = part.power.rows
    rows = "the only row" if n == 1 else f"all {n:,} rows"
    undefined = {}
    if part.predicted.high == part.predicted.low and not math.isinf(part.predicted.magnitude):
        undefined["vaf"] = (
            f"var(ŷ) = 0: the prediction is the same in {rows} with a prediction, "
            "so VAF = 1 − var(y − ŷ)/var(ŷ) is undefined"
        )
    if part.measured.high == part.measured.low or not part.measured.deviations.total > 0.0:
        undefined["fit"] = (
            f"‖y − mean(y)‖ = 0: the measurement is the same in {rows} with a "
            "prediction, so fit = 1 − ‖y − ŷ‖/‖y − mean(y)‖ is undefined"
        )
    out_of_range: set[str] = set()
    if math.isinf(part.predicted.magnitude):
        for name in ("mse", "fit"):
            if math.isinf(values[name]):
                undefined[name] = (
                    "the prediction diverged (infinite in some rows): its error overflows float64"
                )
    elif math.isinf(part.error.magnitude):
        # finite y and ŷ whose difference is not a float64: no error metric can be computed
        why = (
            f"y − ŷ is beyond float64's range in some rows (|ŷ| up to "
            f"{part.predicted.magnitude:.3g}, |y| up to {part.measured.magnitude:.3g}), so "
            "its metrics cannot be computed"
        )
        for name in ("mse", "vaf", "fit"):
            if name not in undefined:
                undefined[name] = why
                out_of_range.add(name)
    else:
        if mse_number is not None:
            errors = f"errors |y − ŷ| up to {part.error.magnitude:.3g}"
            undefined["mse"] = f"{mse_number.beyond('MSE')}: {errors}"
            out_of_range.add("mse")
        if fit_number is not None:
            error, measured = part.power.size, part.measured.deviations
            norm = _InRange.product(error.scale, 1, math.sqrt(error.total)).decimal()
            spread = _InRange.product(measured.scale, 1, math.sqrt(measured.total)).decimal()
            undefined["fit"] = (
                f"{fit_number.beyond('fit', '−', ' %')}: ‖y − ŷ‖ ≈ {norm} against "
                f"‖y − mean(y)‖ ≈ {spread}"
            )
            out_of_range.add("fit")
    return OutputMetrics(
        samples=n, **values, undefined=undefined, out_of_range=frozenset(out_of_range)
    )


class OutputAccumulator:
    r"""MSE, VAF and fit of every output of a run whose rows arrive in consecutive chunks.

    ``add`` the rows in order, any number per call (the arrays are read, never kept);
    ``result``, at any point, gives what :func:`output_metrics` gives for all the rows
    added so far at once.  The rows are reduced in blocks of 2^16 rows of the run (each
    output's usable rows in the block: both ``y`` and ``ŷ`` finite), so the result depends
    on the rows alone, bit for bit, never on how they were split among the calls.  It
    holds a scratch of four block-sized rows (2 MiB, reused by every block, so its pages
    are faulted in once), one summary per output, and the usable rows of an incomplete
    block (none when every call brings whole blocks, as chunks of 2^16 rows do); no
    other temporary is larger than one output's block, whatever the rows of one call.

    A block's usable rows are reduced to their error power :math:`\sum e^2`
    (:math:`e = y - \hat y`, plain, the bits of MSE as it always was, and scaled where the
    plain sum over- or underflows: :class:`_ErrorPower`), which is also
    :math:`\lVert e\rVert^2` as :math:`\max|e|^2 \sum (e / \max|e|)^2`, and
    to count, range, corrected mean and sum of squared deviations of ``y`` (centred, then
    scaled by the largest deviation, as fit takes it), ``ŷ`` and ``e`` (scaled by the
    largest magnitude, then centred, as VAF's standard deviations take it).  Blocks merge
    as :class:`_Squares` and :class:`_Spread` describe (LAPACK's scaled sums of squares;
    Chan, Golub and LeVeque's pairwise update, along a balanced tree of blocks), and

    .. math::

        \mathrm{MSE} = \frac{\sum e^2}{N}, \quad
        \frac{\operatorname{std}(e)}{\operatorname{std}(\hat y)}
            = \frac{s_e \sqrt{q_e / N}}{s_{\hat y} \sqrt{q_{\hat y} / N}}, \quad
        \frac{\lVert e\rVert}{\lVert y - \bar y\rVert}
            = \frac{s_{\lVert e\rVert} \sqrt{q_{\lVert e\rVert}}}{s_y \sqrt{q_y}},

    with each sum of squares :math:`s^2 q` as :class:`_Squares` keeps it.

    Accuracy: a run of at most one block (2^16 rows) is reduced with the operations, in
    the order, of the whole-column code that came before, so it has the same bits.  A
    longer one differs from that code by roundings: MSE and fit's ratio
    :math:`r = \lVert e\rVert / \lVert y - \bar y\rVert` agree with it to about 1e-15
    relative (sums of positive terms; the two-part block means keep the merge's
    :math:`\delta` accurate even for a signal 10^9 times farther from 0 than its spread).
    VAF's ratio :math:`r = \operatorname{std}(e) / \operatorname{std}(\hat y)` takes the
    spreads of :math:`v / \max|v|`, as that code did: the division rounds each value by up
    to :math:`\varepsilon` relative, up to :math:`\kappa \varepsilon` of its deviation
    from the mean, :math:`\kappa = \max|v| / \operatorname{std}(v)`; a block's maximum
    is not the run's, so for a signal far from 0 beside its spread :math:`r^2` may differ
    by some :math:`\kappa \varepsilon` relative, both codes being about that far from the
    exact value (1e-8 at :math:`\kappa = 10^9`, 1e-15 at :math:`\kappa \approx 1`).  VAF
    and fit are :math:`100 (1 - r^2)` and :math:`100 (1 - r)`: a relative difference in
    ``r`` is an absolute one in them (about 1e-13 percentage points for 1e-15), not a small
    relative one where they are near 0 (cancellation).  Two inputs that code got wrong:
    measurements near 10^308, whose sum or deviation from the mean overflows (it divided
    by an infinite norm and reported fit 100, or undefined), are right in any run, a
    block then taking the spread of ``y`` scaled first; subnormal values (below
    2.2e-308), whose mean it rounded to their coarse grid (``y = [5e-324, 0]`` against
    ``ŷ = 0``: fit 0, not -41.4), keep its bits in a run of one block and are right in a
    longer one.

    Parameters
    ----------
    n_outputs:
        The columns of ``y`` and ``y_hat``.

    References
    ----------
    Chan, T. F., Golub, G. H. and LeVeque, R. J. (1983). Algorithms for computing the
    sample variance: analysis and recommendations. The American Statistician 37(3),
    242-247.
    Anderson, E. (2017). Algorithm 978: Safe scaling in the level 1 BLAS. ACM Transactions
    on Mathematical Software 44(1), article 12.

    """

    def __init__(self, n_outputs: int) -> None:
        self._columns = _Columns(n_outputs, _OutputPart.of)

    def add(self, y: npt.ArrayLike, y_hat: npt.ArrayLike) -> None:
        """Take the next rows of the run.

        Parameters
        ----------
        y:
            Measured outputs, shape ``(rows, n_outputs)``, or ``(rows,)`` for one output;
            any number of rows, 0 too.
        y_hat:
            One-step-ahead predictions, same shape.

        """
        self._columns.add(y, y_hat)

    def result(self) -> tuple[OutputMetrics, ...]:
        """The metrics of every row added so far (more may be added after).

        Returns
        -------
        tuple of OutputMetrics
            One per output, as :func:`output_metrics` gives them.

        """
        return tuple(_output_metrics(part) for part in self._columns.parts())


def output_metrics(y: npt.ArrayLike, y_hat: npt.ArrayLike) -> tuple[OutputMetrics, ...]:
    """:func:`mse`, :func:`vaf` and :func:`fit` of every output column, with reasons for NaNs.

    One :class:`OutputAccumulator` given all the rows: temporaries of a block's size
    (2^16 rows of one output), whatever the rows.

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
    y2, yh2 = _paired(y, y_hat)
    accumulator = OutputAccumulator(y2.shape[1])
    accumulator.add(y2, yh2)
    return accumulator.result()


def mean_where_defined(values: npt.ArrayLike) -> float:
    """Mean over the outputs (or states) where a metric is defined: the summary MSE/VAF/fit.

    An undefined entry (NaN: VAF of a constant prediction, fit of a constant measurement)
    is left out; an infinite one (MSE or fit of a prediction that diverged so far that its
    error overflows) makes the mean that infinity: the worst output is never left out, so
    a gate on the mean cannot pass while one output diverged.

    Parameters
    ----------
    values:
        Per-output (or per-state) metric values.

    Returns
    -------
    float
        The arithmetic mean of the defined values (infinite if one is); NaN when none is.

    """
    arr = np.asarray(values, dtype=np.float64).ravel()
    infinite = set(arr[np.isinf(arr)].tolist())
    if infinite:
        return infinite.pop() if len(infinite) == 1 else float("nan")
    finite = arr[np.isfinite(arr)]
    return float(np.mean(finite)) if finite.size else float("nan")


def _rmse(part: _ErrorPower) -> tuple[float, str | None]:
    """A state's RMSE from the power of its errors, and why it is not finite (or ``None``).

    The reason follows "the estimate of state x" in a sentence.
    """
    value, number = part.root_mean_square()
    if number is not None:
        largest = f"{part.size.scale:.3g}"
        return value, f"is off by at most {largest}: {number.beyond('RMSE')}"
    if part.infinite:
        return math.inf, "diverged: its error overflows float64"
    if not math.isfinite(value):  # finite estimate and truth whose difference overflowed
        return math.nan, (
            "and the truth differ by more than float64 holds in some rows, so RMSE is not computed"
        )
    return value, None


class StateAccumulator:
    r"""The state RMSE of a run whose rows arrive in consecutive chunks (:func:`state_rmse`).

    Like :class:`OutputAccumulator`, whose error power (:math:`\sum e^2` per block of 2^16
    usable rows, blocks summed along a balanced tree) it keeps, and nothing else: the
    result depends on the rows alone, never on how they were split, and is bit for bit
    :func:`state_rmse`'s before streaming for a run of at most 2^16 rows.

    Parameters
    ----------
    n_states:
        The columns of the state arrays.

    """

    def __init__(self, n_states: int) -> None:
        self._columns = _Columns(n_states, _ErrorPower.between)

    def add(self, state_means: npt.ArrayLike, truth_states: npt.ArrayLike) -> None:
        """Take the next rows of the run.

        Parameters
        ----------
        state_means:
            Estimated states, shape ``(rows, n_states)``; any number of rows, 0 too.
        truth_states:
            True states, same shape, NaN where unknown.

        """
        self._columns.add(truth_states, state_means)

    def result(self) -> FloatArray:
        """The RMSE of every row added so far (more may be added after).

        Returns
        -------
        numpy.ndarray
            Shape ``(n_states,)``; NaN for a state without a usable row or whose RMSE
            float64 cannot hold, inf for one whose estimate went infinite (diverged);
            :meth:`undefined` says why.

        """
        values = [math.nan if p is None else _rmse(p)[0] for p in self._columns.parts()]
        return np.array(values, dtype=np.float64)

    def undefined(self) -> tuple[str | None, ...]:
        """Why each state's RMSE is not a finite number though it has usable rows.

        Returns
        -------
        tuple of str or None
            Per state: ``None`` for a finite RMSE or one without a usable row (the caller
            knows why: no truth, or no estimate where there is); else why, a phrase that
            follows "the estimate of state x" ("diverged: its error overflows float64",
            "is off by at most 1e-320: RMSE ≈ 1e-320 is below float64's range ...").

        """
        return tuple(None if p is None else _rmse(p)[1] for p in self._columns.parts())

    def samples(self) -> tuple[int, ...]:
        """Rows the RMSE of each state is over so far: a finite truth and an estimate not NaN.

        Returns
        -------
        tuple of int
            One count per state; 0 for a state without a usable row (RMSE NaN).

        """
        return tuple(0 if p is None else p.rows for p in self._columns.parts())


def state_rmse(state_means: npt.ArrayLike, truth_states: npt.ArrayLike) -> FloatArray:
    r"""Root mean square state error per state.

    .. math::

        \mathrm{RMSE}_i = \sqrt{\tfrac{1}{N_i} \sum_k (\hat x_i(k) - x_i(k))^2}

    over the ``N_i`` rows where the truth of state ``i`` is finite and its estimate is not
    NaN (an infinite estimate diverged: RMSE inf); computed by :class:`StateAccumulator`,
    with the errors scaled before they are squared where their squares would leave
    float64's range (errors of 1e200 or 1e-300: RMSE 1e200 or 1e-300, not inf or 0).

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
    truth, means = _paired(truth_states, state_means)
    accumulator = StateAccumulator(truth.shape[1])
    accumulator.add(means, truth)
    return accumulator.result()
