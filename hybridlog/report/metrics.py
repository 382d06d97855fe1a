"""Quality metrics of one estimation run: output fit (MSE, VAF, fit).

Pure functions over NumPy arrays, and an accumulator of the output metrics for a run whose rows
come in chunks; they never warn, print or touch files. A metric that cannot be computed (no
usable sample, a zero denominator, an infinite prediction) is NaN or infinite here and ``null``
in ``report.json``, with the reason from :func:`output_metrics`; so is one whose value float64
cannot hold (MSE of errors of 1e200 or 1e-300), the reason saying so. The errors are scaled
before they are squared where their squares would leave float64's range, so no metric depends
on the units of the signals: VAF and fit not at all, MSE as the square of the unit. The mode
metrics (accuracy, switches, dwell times, detection delays) are
:mod:`hybridlog.report.mode_metrics`, the state RMSE :mod:`hybridlog.report.state_error`; the
blocks of rows (:mod:`~hybridlog.report.row_blocks`), scaled sums and spreads
(:mod:`~hybridlog.report.scaled_sums`) and error powers (:mod:`~hybridlog.report.error_power`)
they are computed from have modules of their own.

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
from typing import Final

import numpy as np
import numpy.typing as npt

from hybridlog.report.error_power import ErrorPower, InRange
from hybridlog.report.row_blocks import Columns, paired
from hybridlog.report.scaled_sums import (
    Spread,
    Squares,
    centred_spread,
    flat_spread,
    scaled_spread,
    unit_spread,
    value_range,
)
from hybridlog.signals import FloatArray

__all__ = [
    "OutputAccumulator",
    "OutputMetrics",
    "fit",
    "mean_where_defined",
    "mse",
    "output_metrics",
    "vaf",
]


@dataclass(frozen=True)
class _OutputPart:
    r"""What MSE, VAF and fit need of some usable rows of one output.

    ``power``: :math:`\sum e^2`, plain and scaled by :math:`\max|e|` (MSE, and
    :math:`\lVert e\rVert^2` of fit); ``measured``: the spread of ``y`` centred first
    (fit's :math:`\lVert y - \bar y\rVert`); ``predicted`` and ``error``: the spreads of
    ``ŷ`` and :math:`e = y - \hat y` scaled first (VAF's standard deviations).
    """

    power: ErrorPower
    measured: Spread
    predicted: Spread
    error: Spread

    @classmethod
    def of(cls, y: FloatArray, y_hat: FloatArray, scratch: FloatArray) -> _OutputPart:
        """The part of one block's usable rows (``y`` finite, ``y_hat`` not NaN); both kept."""
        error, scratch = scratch[0, : y.size], scratch[1, : y.size]
        with np.errstate(over="ignore", invalid="ignore"):
            np.subtract(y, y_hat, out=error)
            squares = float(np.sum(np.multiply(error, error, out=scratch)))
            low, high, size = value_range(error)
            if 0.0 < size < math.inf:
                unit = np.divide(error, size, out=error)
                error_size = Squares(size, float(np.sum(np.square(unit, out=scratch))))
                error_spread = unit_spread(unit, size, low, high)
            else:
                error_spread = flat_spread(error.size, low, high, size)
                error_size = error_spread.deviations
            return cls(
                power=ErrorPower(error.size, squares, error_size),
                measured=centred_spread(y, scratch),
                predicted=scaled_spread(y_hat, scratch),
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


def _scaled_ratio(a: Squares, b: Squares, size: Callable[[float], float]) -> float:
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


# A prediction whose values lie within this many float64 epsilons of their largest magnitude is
# constant but for rounding: a mixture of equal per-mode predictions, sum(c_j * ŷ_j) with the
# weights' sum 1 only to a few units in the last place, varies so (imm on an output that
# no mode's state enters: 0.9999999999999999 ... 1.0000000000000002).
ROUNDING_EPSILONS: Final = 32


def _constant_prediction(predicted: Spread) -> bool:
    """Whether ``ŷ`` is the same in every row, exactly or to the rounding of its arithmetic.

    Its range at most :data:`ROUNDING_EPSILONS` epsilons of ``max |ŷ|``; var(ŷ) of such
    values is rounding, and VAF's ratio to it only that rounding's (0 where the error
    varies): undefined, as for equal values. Subnormal values are constant only when equal.
    """
    if math.isinf(predicted.magnitude):
        return False
    spread = predicted.high - predicted.low
    return spread <= ROUNDING_EPSILONS * sys.float_info.epsilon * predicted.magnitude


def _vaf(part: _OutputPart) -> float:
    if math.isinf(part.predicted.magnitude):
        return 0.0  # an infinite prediction: var(y − ŷ) is too (the ratio inf)
    if _constant_prediction(part.predicted):
        return math.nan  # var(ŷ) = 0, or only rounding: undefined
    if math.isinf(part.error.magnitude):
        return math.nan  # y − ŷ overflows float64 in some row: not a number to vouch for
    rows = part.power.rows
    ratio = _scaled_ratio(
        part.error.deviations, part.predicted.deviations, lambda q: math.sqrt(q / rows)
    )
    return max(1.0 - ratio * ratio, 0.0) * 100.0


def _fit(part: _OutputPart) -> tuple[float, InRange | None]:
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
    hundred_r = InRange(fraction, exponent).times(100.0)
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
    (a constant prediction, also one constant but for rounding, its values within
    :data:`ROUNDING_EPSILONS` epsilons of ``max |ŷ|``, or a single usable row) the ratio is
    undefined and so is VAF: NaN, never a guessed 0 or 100 (:func:`output_metrics` says
    why).  Computed by :class:`OutputAccumulator`.

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
    if _constant_prediction(part.predicted):
        same = "the same" if part.predicted.high == part.predicted.low else "the same to rounding"
        undefined["vaf"] = (
            f"var(ŷ) = 0: the prediction is {same} in {rows} with a prediction, "
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
            norm = InRange.product(error.scale, 1, math.sqrt(error.total)).decimal()
            spread = InRange.product(measured.scale, 1, math.sqrt(measured.total)).decimal()
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
    plain sum over- or underflows: :class:`ErrorPower`), which is also
    :math:`\lVert e\rVert^2` as :math:`\max|e|^2 \sum (e / \max|e|)^2`, and
    to count, range, corrected mean and sum of squared deviations of ``y`` (centred, then
    scaled by the largest deviation, as fit takes it), ``ŷ`` and ``e`` (scaled by the
    largest magnitude, then centred, as VAF's standard deviations take it).  Blocks merge
    as :class:`Squares` and :class:`Spread` describe (LAPACK's scaled sums of squares;
    Chan, Golub and LeVeque's pairwise update, along a balanced tree of blocks), and

    .. math::

        \mathrm{MSE} = \frac{\sum e^2}{N}, \quad
        \frac{\operatorname{std}(e)}{\operatorname{std}(\hat y)}
            = \frac{s_e \sqrt{q_e / N}}{s_{\hat y} \sqrt{q_{\hat y} / N}}, \quad
        \frac{\lVert e\rVert}{\lVert y - \bar y\rVert}
            = \frac{s_{\lVert e\rVert} \sqrt{q_{\lVert e\rVert}}}{s_y \sqrt{q_y}},

    with each sum of squares :math:`s^2 q` as :class:`Squares` keeps it.

    Accuracy: a run of at most one block (2^16 rows) is reduced with the operations, in
    the order, of the whole-column code that came before, so it has the same bits.  A
    longer one differs from that code by roundings: MSE and fit's ratio
    :math:`r = \lVert e\rVert / \lVert y - \bar y\rVert` agree with it to about 1e-15
    relative (sums of positive terms; the two-part block means keep the merge's
    :math:`\delta` accurate even for a signal 10^9 times farther from 0 than its spread;
    not for one whose values differ only in their last bits, whose ``‖y − ȳ‖`` neither code
    has a digit of: y = 1e6 but for an ulp in two of 7 rows against ŷ = 0 has fit −1.6e18 %,
    taken as −1.3e18 % in blocks of 2 rows).
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
        self._columns = Columns(n_outputs, _OutputPart.of)

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
    y2, yh2 = paired(y, y_hat)
    accumulator = OutputAccumulator(y2.shape[1])
    accumulator.add(y2, yh2)
    return accumulator.result()


def mean_where_defined(values: npt.ArrayLike) -> float:
    """Mean over the outputs (or states) where a metric is defined: the summary MSE/VAF/fit.

    An undefined entry (NaN: VAF of a constant prediction, fit of a constant measurement)
    is left out; an infinite one (MSE or fit of a prediction that diverged so far that its
    error overflows) makes the mean that infinity: the worst output is never left out, so
    a gate on the mean cannot pass while one output diverged.  The mean of finite values is
    finite (it lies between them) even where their sum overflows float64: the fits of two
    outputs of -1.3e308 % each are a mean of -1.3e308 %, taken over the values scaled by the
    largest (``analyze`` had stopped with "numerical trouble ... overflow encountered in
    reduce").

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
    if not finite.size:
        return float("nan")
    with np.errstate(over="ignore"):
        mean = float(np.mean(finite))
    if math.isinf(mean):  # the sum overflowed, not the mean: |mean| <= max |v|
        largest = float(np.max(np.abs(finite)))
        mean = largest * float(np.mean(finite / largest))
    return mean
