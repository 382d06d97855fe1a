"""The output and state metrics as accumulators: rows in chunks, the same bits for every split.

``_reference_*`` below is the whole-column code the accumulators replaced, copied as it was
(each output's usable rows selected at once, every metric one reduction over them): a run of
at most one block (2^16 usable rows) must give its bits, a longer one its values to within
roundings.
"""

from __future__ import annotations

import decimal
import math
import re
import sys
import tracemalloc
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from unittest import mock

import numpy as np
import numpy.typing as npt
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from hybridlog.report import metrics, row_blocks, state_error
from hybridlog.report.metrics import OutputAccumulator, OutputMetrics
from hybridlog.report.state_error import StateAccumulator

NAN = float("nan")
EPS = float(np.finfo(np.float64).eps)
BLOCK = 1 << 16
FloatArray = npt.NDArray[np.float64]


# --- the reference: hybridlog/report/metrics.py before the accumulators ----------------------


def _as_2d(a: npt.ArrayLike) -> FloatArray:
    arr = np.asarray(a, dtype=np.float64)
    return arr[:, np.newaxis] if arr.ndim == 1 else arr


def _magnitude_and_unit(v: FloatArray, *, scratch: bool = False) -> tuple[float, FloatArray]:
    m = abs(float(np.maximum(v.max(), -v.min()))) if v.size else 0.0
    if not 0.0 < m < np.inf:
        return m, v
    if scratch:
        v /= m
        return m, v
    return m, v / m


def _std_ratio(a: Callable[[], FloatArray], b: FloatArray) -> float:
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
    return (ma / mb) * ratio if ratio else 0.0


def _norm(scratch: FloatArray) -> float:
    return math.sqrt(float(np.sum(np.square(scratch, out=scratch))))


def _norm_ratio(a: Callable[[], FloatArray], b: Callable[[], FloatArray]) -> float:
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
    y: FloatArray
    y_hat: FloatArray


def _usable(y2: FloatArray, yh2: FloatArray) -> Iterator[_Column]:
    for j in range(y2.shape[1]):
        y_col, yh_col = y2[:, j], yh2[:, j]
        ok = np.isfinite(y_col)
        ok &= ~np.isnan(yh_col)  # an infinite prediction diverged: used
        yield _Column(y_col[ok], yh_col[ok])
        del ok


def _mse(c: _Column) -> float:
    if not c.y.size:
        return np.nan
    with np.errstate(over="ignore", invalid="ignore"):
        err = c.y - c.y_hat
        err *= err
        return float(np.mean(err))


# --- what changed since: MSE and fit in any unit, and null where float64 cannot hold them ----

decimal.getcontext().prec = 40
SAFE_LOW = 2.0**-480  # largest error from which the plain sum of squares is kept


def _exact_sum_of_squares(v: FloatArray) -> decimal.Decimal:
    return sum((decimal.Decimal(float(x)) ** 2 for x in v), decimal.Decimal(0))


def _in_range(d: decimal.Decimal) -> str | None:
    """``None`` where float64 holds ``d`` (positive), rounded to it, as a normal number; else
    which side (the exact value's rounding decides at the edge: the square root of a mean of
    squares of 2**-1022 is a hair below it in 28 digits and rounds to it)."""
    if d >= decimal.Decimal(2) ** 1024 or math.isinf(float(d)):
        return "beyond"
    if float(d) < sys.float_info.min:
        return "below"
    return None


def _two_digits(d: decimal.Decimal) -> str:
    power = d.adjusted()
    mantissa = round(float(d.scaleb(-power)), 1)
    if mantissa >= 10.0:
        mantissa, power = mantissa / 10.0, power + 1
    return f"{mantissa:.2g}e{power:+03d}"


def _beyond(what: str, d: decimal.Decimal, side: str, sign: str = "", unit: str = "") -> str:
    if side == "beyond":
        return f"{what} ≈ {sign}{_two_digits(d)}{unit} is beyond float64's range (at most 1.8e+308)"
    return (
        f"{what} ≈ {sign}{_two_digits(d)}{unit} is below float64's range "
        "(normal numbers from 2.2e-308)"
    )


def _new_mse(c: _Column, undefined: dict[str, str]) -> tuple[float, bool]:
    """MSE now, and whether float64 cannot hold it (``undefined`` gets the reason)."""
    plain = _mse(c)
    if not c.y.size or np.isinf(c.y_hat).any():
        return plain, False
    with np.errstate(over="ignore"):
        err = c.y - c.y_hat
    largest = float(np.max(np.abs(err)))
    if math.isinf(largest) or largest == 0.0 or (largest >= SAFE_LOW and math.isfinite(plain)):
        return plain, False
    exact = _exact_sum_of_squares(err) / c.y.size
    side = _in_range(exact)
    if side is None:
        return float(exact), False
    undefined["mse"] = f"{_beyond('MSE', exact, side)}: errors |y − ŷ| up to {largest:.3g}"
    return (math.inf if side == "beyond" else math.nan), True


def _new_fit(c: _Column, fit: float, undefined: dict[str, str]) -> tuple[float, bool]:
    """Fit now: beyond float64's range where 100·‖y − ŷ‖/‖y − ȳ‖ is."""
    if math.isnan(fit) or np.isinf(c.y_hat).any():
        return fit, False
    if abs(fit) < 1e300:  # the float ratio is 10^8 times inside the range: so is the exact one
        return fit, False
    with np.errstate(over="ignore"):
        err = c.y - c.y_hat
    if np.isinf(err).any():
        return fit, False
    y = [decimal.Decimal(float(v)) for v in c.y]
    mean = sum(y, decimal.Decimal(0)) / len(y)
    spread = sum(((v - mean) ** 2 for v in y), decimal.Decimal(0)).sqrt()
    norm = _exact_sum_of_squares(err).sqrt()
    hundred_r = 100 * norm / spread
    if _in_range(hundred_r) != "beyond":
        return fit, False
    undefined["fit"] = (
        f"{_beyond('fit', hundred_r, 'beyond', '−', ' %')}: ‖y − ŷ‖ ≈ {_two_digits(norm)} "
        f"against ‖y − mean(y)‖ ≈ {_two_digits(spread)}"
    )
    return -math.inf, True


def _new_rmse(c: _Column) -> float:
    """RMSE now: in any unit; NaN below float64's normal numbers."""
    plain = _mse(c)
    if not c.y.size or np.isinf(c.y_hat).any():
        return math.sqrt(plain) if c.y.size else math.nan
    with np.errstate(over="ignore"):
        err = c.y - c.y_hat
    largest = float(np.max(np.abs(err)))
    if math.isinf(largest):
        return math.nan
    if largest == 0.0 or (largest >= SAFE_LOW and math.isfinite(plain)):
        return math.sqrt(plain)
    exact = (_exact_sum_of_squares(err) / c.y.size).sqrt()
    return float(exact) if _in_range(exact) is None else math.nan


def _vaf(c: _Column) -> float:
    h = c.y_hat
    if np.isinf(h).any():
        return 0.0
    if not h.size or np.all(h == h[0]):
        return np.nan
    with np.errstate(over="ignore", invalid="ignore"):
        ratio = _std_ratio(lambda: c.y - h, h)
        return max(1.0 - ratio * ratio, 0.0) * 100.0


def _fit(c: _Column) -> float:
    y_ok = c.y
    if not y_ok.size or np.all(y_ok == y_ok[0]):
        return np.nan
    with np.errstate(over="ignore", invalid="ignore"):
        error = _norm_ratio(lambda: y_ok - c.y_hat, lambda: y_ok - np.mean(y_ok))
        return (1.0 - error) * 100.0


def _reference_output_metrics(y: npt.ArrayLike, y_hat: npt.ArrayLike) -> list[OutputMetrics]:
    out = []
    for column in _usable(_as_2d(y), _as_2d(y_hat)):
        values = {"vaf": _vaf(column), "fit": _fit(column)}
        n = column.y.size
        undefined: dict[str, str] = {}
        out_of_range: set[str] = set()
        if n == 0:
            why = "no sample has both a measurement and a one-step-ahead prediction"
            undefined = {"mse": why, "vaf": why, "fit": why}
            values["mse"] = np.nan
        else:
            rows = "the only row" if n == 1 else f"all {n:,} rows"
            if np.all(column.y_hat == column.y_hat[0]) and np.isfinite(column.y_hat).all():
                undefined["vaf"] = (
                    f"var(ŷ) = 0: the prediction is the same in {rows} with a prediction, "
                    "so VAF = 1 − var(y − ŷ)/var(ŷ) is undefined"
                )
            if np.all(column.y == column.y[0]):
                undefined["fit"] = (
                    f"‖y − mean(y)‖ = 0: the measurement is the same in {rows} with a "
                    "prediction, so fit = 1 − ‖y − ŷ‖/‖y − mean(y)‖ is undefined"
                )
            with np.errstate(over="ignore"):
                apart = bool(np.isinf(column.y - column.y_hat).any())
            if np.isinf(column.y_hat).any():
                values["mse"] = _mse(column)
                for name in ("mse", "fit"):
                    if np.isinf(values[name]):
                        undefined[name] = (
                            "the prediction diverged (infinite in some rows): its error "
                            "overflows float64"
                        )
            elif apart:
                largest = float(np.max(np.abs(column.y_hat)))
                why = (
                    f"y − ŷ is beyond float64's range in some rows (|ŷ| up to {largest:.3g}, "
                    f"|y| up to {float(np.max(np.abs(column.y))):.3g}), so its metrics cannot "
                    "be computed"
                )
                values["mse"] = np.inf
                for name in ("mse", "vaf", "fit"):
                    if name not in undefined:
                        undefined[name] = why
                        out_of_range.add(name)
                        if name != "mse":
                            values[name] = np.nan
            else:
                values["mse"], beyond = _new_mse(column, undefined)
                if beyond:
                    out_of_range.add("mse")
                values["fit"], beyond = _new_fit(column, values["fit"], undefined)
                if beyond:
                    out_of_range.add("fit")
        out.append(
            OutputMetrics(
                samples=n, **values, undefined=undefined, out_of_range=frozenset(out_of_range)
            )
        )
        del column
    return out


def _reference_state_rmse(state_means: npt.ArrayLike, truth_states: npt.ArrayLike) -> FloatArray:
    columns = _usable(_as_2d(truth_states), _as_2d(state_means))
    return np.array([_new_rmse(c) for c in columns], dtype=np.float64)


# --- comparing bits --------------------------------------------------------------------------


def _same_bits(a: float, b: float) -> bool:
    """Equal as float64 bits (0.0 and -0.0 differ), or both NaN."""
    return (math.isnan(a) and math.isnan(b)) or float(a).hex() == float(b).hex()


def _near(a: float, b: float) -> bool:
    """The same bits, or within 4 ulps: a sum of squares scaled before squaring (errors of
    1e-300 or 1e200), against the exactly rounded value of the reference."""
    return _same_bits(a, b) or (math.isfinite(b) and abs(a - b) <= 4.0 * EPS * abs(b))


def _identical(
    got: Sequence[OutputMetrics], expected: Sequence[OutputMetrics], *, near: bool = False
) -> bool:
    same = _near if near else _same_bits
    return len(got) == len(expected) and all(
        g.samples == e.samples
        and same(g.mse, e.mse)
        and _same_bits(g.vaf, e.vaf)
        and _same_bits(g.fit, e.fit)
        and _same_reasons(g.undefined, e.undefined)
        and g.out_of_range == e.out_of_range
        for g, e in zip(got, expected, strict=True)
    )


def _identical_arrays(got: FloatArray, expected: FloatArray, *, near: bool = False) -> bool:
    same = _near if near else _same_bits
    return got.shape == expected.shape and all(
        same(float(g), float(e)) for g, e in zip(got, expected, strict=True)
    )


def _chunks(rows: int, cuts: Sequence[int]) -> list[slice]:
    """Consecutive slices of ``range(rows)`` ending at ``cuts`` (empty slices included)."""
    ends = sorted(min(max(c, 0), rows) for c in cuts)
    starts = [0, *ends]
    return [slice(a, b) for a, b in zip(starts, [*ends, rows], strict=True)]


def _accumulated(
    y: FloatArray, y_hat: FloatArray, cuts: Sequence[int]
) -> tuple[OutputMetrics, ...]:
    acc = OutputAccumulator(y.shape[1])
    for rows in _chunks(y.shape[0], cuts):
        acc.add(y[rows], y_hat[rows])
    return acc.result()


def _accumulated_rmse(means: FloatArray, truth: FloatArray, cuts: Sequence[int]) -> FloatArray:
    acc = StateAccumulator(means.shape[1])
    for rows in _chunks(means.shape[0], cuts):
        acc.add(means[rows], truth[rows])
    return acc.result()


# Values that reach every branch: NaN rows (skipped), inf (a measurement: skipped; a
# prediction: diverged), zeros and repeats (constant signals), magnitudes whose squares
# underflow or overflow float64, and predictions whose error overflows (|ŷ| 1.79e308
# against |y| up to 1e306, so no sum of y overflows).  No subnormal values (see ``moderate``
# below): the whole-column code's mean of [5e-324, 0] rounds on their coarse grid, so the
# ‖y − mean(y)‖ a null fit's reason quotes is 4.9e-324 where the exact one is 3.5e-324.
special = st.sampled_from([0.0, -0.0, 1.0, -1.0, 2.5, NAN, np.inf, -np.inf])
measured = st.one_of(
    special,
    st.floats(-1e6, 1e6, allow_subnormal=False),
    st.floats(-1e306, 1e306, allow_subnormal=False),
    st.floats(-1e-300, 1e-300, allow_subnormal=False),
)
predicted = st.one_of(measured, st.sampled_from([1.79e308, -1.79e308]))


@st.composite
def output_runs(draw: st.DrawFn, max_rows: int = 60) -> tuple[FloatArray, FloatArray]:
    shape = (draw(st.integers(0, max_rows)), draw(st.integers(1, 3)))
    y = draw(hnp.arrays(np.float64, shape, elements=measured))
    y_hat = draw(hnp.arrays(np.float64, shape, elements=predicted))
    return y, y_hat


# --- a run of at most one block: the bits of the whole-column code ---------------------------


@given(output_runs(), st.lists(st.integers(0, 60), max_size=5))
@settings(max_examples=400, deadline=None)
def test_one_block_has_the_bits_of_the_whole_column_code(
    run: tuple[FloatArray, FloatArray], cuts: list[int]
) -> None:
    y, y_hat = run
    expected = _reference_output_metrics(y, y_hat)
    assert _identical(metrics.output_metrics(y, y_hat), expected, near=True)
    assert _identical(_accumulated(y, y_hat, cuts), expected, near=True)
    for name in ("mse", "vaf", "fit"):
        got = getattr(metrics, name)(y, y_hat)
        assert _identical_arrays(got, np.array([getattr(e, name) for e in expected]), near=True)
    rmse = _reference_state_rmse(y_hat, y)
    assert _identical_arrays(state_error.state_rmse(y_hat, y), rmse, near=True)
    assert _identical_arrays(_accumulated_rmse(y_hat, y, cuts), rmse, near=True)


def test_a_run_of_one_whole_block_keeps_the_bits_in_any_chunks() -> None:
    rng = np.random.default_rng(3)
    y = rng.normal(size=(BLOCK, 3)) * [1.0, 1e-200, 1e200]
    y_hat = y + rng.normal(size=y.shape) * [0.3, 1e-201, 1e199]
    y_hat[0] = NAN
    y[rng.choice(BLOCK, 5_001, replace=False), 1] = np.inf
    expected = _reference_output_metrics(y, y_hat)
    for cuts in ([], [1, 777, BLOCK - 1], [BLOCK // 2] * 3):
        assert _identical(_accumulated(y, y_hat, cuts), expected, near=True)
        assert _identical_arrays(
            _accumulated_rmse(y_hat, y, cuts), _reference_state_rmse(y_hat, y), near=True
        )
    assert _identical(metrics.output_metrics(y, y_hat), expected, near=True)


# --- any split of the rows: the same bits ----------------------------------------------------


@given(
    output_runs(max_rows=120),
    st.sampled_from([1, 2, 3, 8, 33]),
    st.lists(st.lists(st.integers(0, 120), max_size=8), min_size=1, max_size=3),
)
@settings(max_examples=300, deadline=None)
def test_every_split_of_the_rows_gives_the_same_bits(
    run: tuple[FloatArray, FloatArray], block: int, splits: list[list[int]]
) -> None:
    # Small blocks, so that a few rows make many blocks, merged along the tree.
    y, y_hat = run
    with mock.patch.object(row_blocks, "_BLOCK_ROWS", block):
        whole = metrics.output_metrics(y, y_hat)
        rmse = state_error.state_rmse(y_hat, y)
        for cuts in splits:
            assert _identical(_accumulated(y, y_hat, cuts), whole)
            assert _identical_arrays(_accumulated_rmse(y_hat, y, cuts), rmse)


# --- longer runs: the values of the whole-column code, to within roundings ------------------


def _offset(v: FloatArray) -> float:
    """``max|v| / std(v)``: how far ``v`` sits from 0 beside its spread (1/ε at most)."""
    spread = float(np.std(v / np.max(np.abs(v)))) if v.size and np.any(v) else 0.0
    return min(1.0 / spread if spread > 0.0 else math.inf, 1.0 / EPS)


_APPROXIMATE = re.compile(r"≈ −?([0-9.]+)e([+-][0-9]+)")


def _same_reasons(got: Mapping[str, str], expected: Mapping[str, str]) -> bool:
    """The same reasons, their ``≈`` values (two digits of a sum out of float64's range, which
    the order of the additions rounds) within rounding: one unit of the second digit."""
    if got.keys() != expected.keys():
        return False
    for name, reason in got.items():
        other = expected[name]
        if _APPROXIMATE.sub("≈ …", reason) != _APPROXIMATE.sub("≈ …", other):
            return False
        pairs = zip(_APPROXIMATE.findall(reason), _APPROXIMATE.findall(other), strict=True)
        for (mantissa, power), (other_mantissa, other_power) in pairs:
            log = math.log10(float(mantissa)) + int(power)
            other_log = math.log10(float(other_mantissa)) + int(other_power)
            if abs(log - other_log) > math.log10(1.1) + 1e-9:  # 0.1 on a mantissa of 1.0 at least
                return False
    return True


def _assert_same_reasons(got: Mapping[str, str], expected: Mapping[str, str]) -> None:
    assert _same_reasons(got, expected), (got, expected)


def _assert_close(
    got: OutputMetrics, expected: OutputMetrics, y: FloatArray, y_hat: FloatArray
) -> None:
    """Within roundings of the reference, as :class:`OutputAccumulator`'s docstring bounds them.

    MSE to 1e-12 relative; fit's ratio ``r`` (fit = 100 (1 − r)) to 1e-12 plus ``(c ε κ_y)²``
    relative, κ_y the offset of y (:func:`_offset`) and ``c = 2 log2(n + 1)``: the reference's
    mean of y is off by some ``log2(n) ε max|y|`` (pairwise summation), which adds ``n δ²`` to
    ``‖y − ȳ‖²``, ``(δ / std(y))²`` of it (a y of 1e6 whose values differ in their last bit,
    κ_y ≈ 1/ε, has no digit of ``r`` in either code: Hypothesis found one 40 % apart); VAF's
    ``r²`` (VAF = 100 (1 − r²)) to 1e-12 plus ``4 ε κ`` relative, κ the offset of ŷ and of
    the error, the rounding of ``v / max|v|`` that both make.  Plus 1e-13 percentage points:
    the rounding of ``1 − r`` itself.
    """
    assert got.samples == expected.samples
    _assert_same_reasons(dict(got.undefined), dict(expected.undefined))
    ok = np.isfinite(y) & np.isfinite(y_hat)
    with np.errstate(over="ignore", invalid="ignore"):
        kappa = _offset(y_hat[ok]) + _offset(y[ok] - y_hat[ok])
        mean_rounding = (2.0 * math.log2(ok.sum() + 1) * EPS * _offset(y[ok])) ** 2
    for name, value, reference, tolerance in (
        ("mse", got.mse, expected.mse, 1e-12 * abs(expected.mse)),
        (
            "fit",
            got.fit,
            expected.fit,
            100.0 * (1e-12 + mean_rounding) * abs(1.0 - expected.fit / 100.0) + 1e-13,
        ),
        (
            "vaf",
            got.vaf,
            expected.vaf,
            100.0 * (1e-12 + 4.0 * EPS * kappa) * (1.0 - expected.vaf / 100.0) + 1e-13,
        ),
    ):
        if not math.isfinite(reference) or value == reference:
            assert _same_bits(value, reference), (name, value, reference)
        else:
            assert abs(value - reference) <= tolerance, (name, value, reference, tolerance)


def _long_run() -> tuple[FloatArray, FloatArray]:
    """Three blocks and more of the outputs the whole-column code guarded against."""
    n = 3 * BLOCK + 12_345
    rng = np.random.default_rng(11)
    base = rng.normal(size=n)
    noise = rng.normal(size=n)
    ramp = np.linspace(0.0, 1e3, n)
    at = np.arange(n) == 2 * BLOCK + 7
    columns = [
        (base, base + 0.1 * noise),  # an ordinary fit
        (base * 1e-300, (base + 0.2 * noise) * 1e-300),  # squares underflow
        (base * 1e300, (base + 0.2 * noise) * 1e300),  # squares overflow
        (1e6 + 1e-3 * base, 1e6 + 1e-3 * base + 1e-4 * noise),  # 10^9 times its spread
        (base, base + 5.0 + 1e-6 * noise),  # an offset prediction
        (ramp + base, ramp + base + noise),  # a drift: block means far apart
        (base, noise),  # no better than noise: VAF 0, fit < 0
        (base, 1e-3 * noise),  # about the mean: fit near 0
        (base, base * 1e307),  # diverged: MSE inf, fit -inf, VAF 0
        (np.where(at, -1e308, base), np.where(at, 1e308, base + 0.1)),  # e = -inf in one row
        (base, np.full(n, 2.0)),  # constant prediction: VAF undefined
        (np.full(n, 3.0), base),  # constant measurement: fit undefined
        (np.where(np.arange(n) % 3 == 0, np.nan, base), base + 0.1 * noise),  # NaN rows
        (base, np.full(n, np.nan)),  # no usable row
        (np.repeat(rng.normal(size=n // 1_000 + 1) * 100, 1_000)[:n], base * 50),  # steps
    ]
    y = np.column_stack([c[0] for c in columns])
    y_hat = np.column_stack([c[1] for c in columns])
    y_hat[0] = NAN
    return y, y_hat


def test_a_longer_run_agrees_with_the_whole_column_code_whatever_its_chunks() -> None:
    y, y_hat = _long_run()
    expected = _reference_output_metrics(y, y_hat)
    whole = metrics.output_metrics(y, y_hat)
    for j, (got, reference) in enumerate(zip(whole, expected, strict=True)):
        _assert_close(got, reference, y[:, j], y_hat[:, j])
    rng = np.random.default_rng(5)
    for cuts in (
        list(range(BLOCK, y.shape[0], BLOCK)),  # the estimator's chunks
        list(range(0, y.shape[0], 4_099)),
        rng.integers(0, y.shape[0], 40).tolist(),
        [0, 0, y.shape[0]],
    ):
        assert _identical(_accumulated(y, y_hat, cuts), whole)
        assert _identical_arrays(
            _accumulated_rmse(y_hat, y, cuts), state_error.state_rmse(y_hat, y)
        )
    with np.errstate(over="ignore"):
        np.testing.assert_allclose(
            state_error.state_rmse(y_hat, y), _reference_state_rmse(y_hat, y), rtol=1e-12
        )


# No subnormal values: they have fewer significant bits, and the whole-column code's mean
# and deviations of them round on that coarse grid (y = [5e-324, 0] against ŷ = 0: fit 0,
# not -41.4 %), where the merges, in scaled units, do not.
moderate = st.one_of(
    st.sampled_from([0.0, 1.0, -2.0, NAN]),
    st.floats(-1e6, 1e6, allow_subnormal=False),
    st.floats(-1e-200, 1e-200, allow_subnormal=False),
    st.floats(-1e300, 1e300, allow_subnormal=False),
)


@given(
    st.integers(2, 120).flatmap(
        lambda n: st.tuples(
            hnp.arrays(np.float64, (n, 2), elements=moderate),
            hnp.arrays(np.float64, (n, 2), elements=moderate),
        )
    ),
    st.sampled_from([1, 2, 3, 8, 33]),
)
@settings(max_examples=300, deadline=None)
def test_small_blocks_agree_with_the_whole_column_code(
    run: tuple[FloatArray, FloatArray], block: int
) -> None:
    y, y_hat = run
    expected = _reference_output_metrics(y, y_hat)
    with mock.patch.object(row_blocks, "_BLOCK_ROWS", block):
        got = metrics.output_metrics(y, y_hat)
    for j in range(y.shape[1]):
        _assert_close(got[j], expected[j], y[:, j], y_hat[:, j])


# --- the accumulators' contract --------------------------------------------------------------


def test_nothing_added_gives_undefined_metrics_with_their_reason() -> None:
    acc = OutputAccumulator(2)
    acc.add(np.empty((0, 2)), np.empty((0, 2)))
    assert _identical(acc.result(), _reference_output_metrics(np.empty((0, 2)), np.empty((0, 2))))
    assert [m.samples for m in acc.result()] == [0, 0]
    states = StateAccumulator(3)
    assert np.isnan(states.result()).all() and states.result().shape == (3,)
    assert OutputAccumulator(0).result() == ()


def test_one_output_as_1d_arrays_and_shape_errors() -> None:
    y, y_hat = np.array([NAN, 1.0, 2.0, 4.0]), np.array([0.0, 1.5, 2.0, 3.0])
    acc = OutputAccumulator(1)
    acc.add(y[:2], y_hat[:2])
    acc.add(y[2:], y_hat[2:])
    assert _identical(acc.result(), _reference_output_metrics(y, y_hat))
    with pytest.raises(ValueError, match="expected 1 columns; got 2"):
        acc.add(np.zeros((3, 2)), np.zeros((3, 2)))
    with pytest.raises(ValueError, match="shape"):
        acc.add(np.zeros(3), np.zeros(4))
    with pytest.raises(ValueError, match=">= 0"):
        StateAccumulator(-1)


def test_a_result_midway_leaves_the_accumulator_as_it_was() -> None:
    y, y_hat = _long_run()
    half = BLOCK + BLOCK // 3  # a block closed, one open
    acc = OutputAccumulator(y.shape[1])
    acc.add(y[:half], y_hat[:half])
    assert _identical(acc.result(), metrics.output_metrics(y[:half], y_hat[:half]))
    acc.add(y[half:], y_hat[half:])
    assert _identical(acc.result(), metrics.output_metrics(y, y_hat))


def test_measurements_near_the_largest_float_have_the_fit_of_smaller_ones() -> None:
    # Their sum (or deviation from the mean) overflows: the whole-column code divided by an
    # infinite norm and said fit 100, or took the NaN mean for a constant measurement.
    # Scaled by 2^-1000 (exact), nothing overflows.
    rng = np.random.default_rng(2)
    for n, old_fit in ((3, 100.0), (BLOCK + 100, NAN)):
        y = rng.choice([1.7e308, -1.7e308, 1.5e308], size=n)
        y_hat = 0.5 * y + 1e306 * rng.normal(size=n)
        (huge,) = metrics.output_metrics(y, y_hat)
        (plain,) = metrics.output_metrics(np.ldexp(y, -1000), np.ldexp(y_hat, -1000))
        assert huge.fit == pytest.approx(plain.fit, rel=1e-12)
        assert huge.vaf == pytest.approx(plain.vaf, rel=1e-12)
        assert math.isinf(huge.mse) and set(huge.undefined) == {"mse"}
        assert _same_bits(_reference_output_metrics(y, y_hat)[0].fit, old_fit)


# --- memory: temporaries of a block, whatever the rows of one call -------------------------


def _peak(function: Callable[..., object], *args: object) -> int:
    """Peak bytes allocated while ``function(*args)`` ran (NumPy reports to tracemalloc)."""
    tracemalloc.start()
    try:
        function(*args)
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_whole_arrays_are_reduced_with_temporaries_of_a_block() -> None:
    rng = np.random.default_rng(4)
    block = 8 * BLOCK  # bytes of one column's block
    peaks = {}
    for n in (2 * BLOCK + 123, 16 * BLOCK + 123):
        y = rng.normal(size=(n, 3))
        y_hat = y + rng.normal(size=(n, 3))
        y_hat[::5, 1] = NAN
        peaks[n] = (
            _peak(metrics.output_metrics, y, y_hat),
            _peak(state_error.state_rmse, y_hat, y),
        )
        # The scratch of four blocks (2 MiB), whatever the rows: 2.2 MiB each at 10^6 rows
        # and three columns, where the code before streaming took 31 and 24 MiB.
        assert peaks[n][0] < 5 * block and peaks[n][1] < 5 * block
    small, large = peaks.values()
    assert large[0] < small[0] + block // 8 and large[1] < small[1] + block // 8


def test_chunks_of_whole_blocks_leave_no_rows_held_between_calls() -> None:
    # Besides its scratch (four blocks, allocated with it), an accumulator holds summaries
    # and the usable rows of an incomplete block: none after whole blocks.
    rng = np.random.default_rng(6)
    y = rng.normal(size=(BLOCK, 3))
    y_hat = y + rng.normal(size=(BLOCK, 3))
    acc, states = OutputAccumulator(3), StateAccumulator(3)
    tracemalloc.start()
    try:
        for _ in range(4):
            acc.add(y, y_hat)
            states.add(y_hat, y)
        held = tracemalloc.get_traced_memory()[0]
        acc.add(y[:1000], y_hat[:1000])  # an incomplete block: its usable rows are kept
        held_open = tracemalloc.get_traced_memory()[0]
    finally:
        tracemalloc.stop()
    assert held < 64 * 1024  # the summaries only
    assert held_open - held < 3 * 2 * 8 * 1000 + 64 * 1024


def test_a_measurement_that_differs_in_its_last_bit_is_within_the_fit_tolerance() -> None:
    """Hypothesis found y = 1e6 but for an ulp in some rows, ŷ = 0: fit −1.3e18 % in blocks
    of 2 against the reference's −1.6e18 % (the exact value): neither code has a digit of
    ``‖y − ȳ‖`` there, and the tolerance says so rather than fail."""
    y = np.full((7, 1), 1e6)
    y[2, 0], y[5, 0] = np.nextafter(1e6, 2e6), np.nextafter(1e6, 0.0)
    y_hat = np.zeros((7, 1))
    with mock.patch.object(row_blocks, "_BLOCK_ROWS", 2):
        got = metrics.output_metrics(y, y_hat)
    _assert_close(got[0], _reference_output_metrics(y, y_hat)[0], y[:, 0], y_hat[:, 0])
