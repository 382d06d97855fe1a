"""The numbers an estimator's result must hold before they leave the estimators (SPEC §9).

A hostile plant model or log (``sqrt`` of a state that noise drives negative, ``1/x`` across
zero, ``exp`` overflow, covariances of ``1e300``, an unobservable unstable state) makes a
filter compute numbers it cannot vouch for: a state or variance that is not finite, a
negative variance, mode probabilities that are not a distribution, an output prediction
that is not finite.  The report would take them over the finite rows, or print them.
:func:`check_result` refuses such a result with one line naming the model file, the
estimator, the time and sample, what is wrong and, where it can tell, why: the expression of
the model (mode, key and text) that is not finite at the estimate of the sample before
(:func:`_why`; for the HSTF also each mode's output Jacobian at the modes' mean prediction,
:func:`_combined_not_finite`), a covariance grown past what double precision holds, or a
derivative so steep there that the covariance it propagates rounds by more than the
variances (:func:`_precision_lost`).

It is one pass over the finished arrays (no cost inside the compiled loops), made where a
result leaves the estimators (:meth:`hybridlog.estimators.Prepared.run`, each chunk of
:meth:`~hybridlog.estimators.Prepared.stream`) and by the filters' chunk runner before an
offline pass reads the forward pass (:func:`hybridlog.estimators.common.run_filter_chunks`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from hybridlog.errors import DivergenceError, ModelError, excerpt
from hybridlog.jit import jit
from hybridlog.times import format_time

if TYPE_CHECKING:
    from hybridlog.estimators.result import EstimationResult
    from hybridlog.model.compiled import CompiledModel
    from hybridlog.model.hybrid_model import HybridModel
    from hybridlog.signals import AlignedSignals, FloatArray

__all__ = [
    "Flaw",
    "check_explained",
    "check_result",
    "check_surprise",
    "first_flaw",
    "surprise_limit",
]

PROBABILITY_TOLERANCE = 1e-6
"""How far a row of mode probabilities may sum from 1 (or an entry leave [0, 1])."""

NEGATIVE_VARIANCE_TOLERANCE = 1e-9
"""A variance below ``-tolerance × (the row's largest |variance|)`` is refused (rounding of
a covariance's update leaves a state known exactly at about ``-1e-17`` of the others), or
below ``-SUBNORMAL`` where every variance of the row is that small: a covariance shrunk into
the subnormal numbers (a plant without process noise, thousands of samples) rounds there to
``-1e-323`` with no normal number left to be relative to."""

SUBNORMAL = float(np.finfo(np.float64).tiny)
"""The smallest normal float64 (2.2e-308): a negative variance smaller in magnitude is rounding."""

MAX_SHOWN = 6
"""Most states and inputs a message shows of the point where an expression is not finite."""

OVERFLOWING = 1e150
"""A Jacobian entry times the largest standard deviation past this: its square, which the
predicted covariance holds, leaves double precision."""

HUGE_VARIANCE = 1e100
"""A variance above this at the sample before a failure is named as its cause: its square,
as the filters' products form it, leaves double precision."""

ROUNDING = 2.0**-52
"""Double precision's relative rounding: a covariance ``F P Fᵀ`` rounds by this times its
size, which the update then subtracts down to variances it can no longer resolve."""


@dataclass(frozen=True)
class Flaw:
    """The first row of a result holding a number nobody can vouch for, and what it is."""

    row: int
    what: str


def _first_row(bad: Any) -> int:
    """The first row where a per-row flag is set."""
    return int(np.argmax(bad))


def first_flaw(
    result: EstimationResult,
    *,
    variances: bool = True,
    unpredicted: bool = False,
    first: int = 0,
) -> Flaw | None:
    """The earliest row of ``result`` (and of the filter's result inside it) with a flaw.

    Parameters
    ----------
    result:
        An estimator's result, or a chunk of one whose row 0 is row ``first`` of the log.
    variances:
        Whether the estimator defines state variances (else they are NaN and not read).
    unpredicted:
        Whether the estimator may leave an output without prediction (NaN; never infinite).
    first:
        The log's row of the result's row 0: the log's row 0 is the prior and predicts
        nothing.
    """
    flaws = [
        flaw
        for flaw in (
            _own_flaw(result, variances=variances, unpredicted=unpredicted, first=first),
            _filtered_flaw(result, variances=variances, unpredicted=unpredicted, first=first),
        )
        if flaw is not None
    ]
    return min(flaws, key=lambda flaw: flaw.row) if flaws else None


def _filtered_flaw(
    result: EstimationResult, *, variances: bool, unpredicted: bool, first: int
) -> Flaw | None:
    post = result.post_processing
    if post is None:
        return None
    flaw = _own_flaw(post.filtered, variances=variances, unpredicted=unpredicted, first=first)
    return None if flaw is None else Flaw(flaw.row, f"{flaw.what} (the filter's own estimate)")


def _own_flaw(
    result: EstimationResult, *, variances: bool, unpredicted: bool, first: int
) -> Flaw | None:
    found: list[Flaw] = []
    row = _first_not_finite(result.state_means)
    if row >= 0:
        found.append(Flaw(row, "the state estimate is not finite"))
    if variances:
        found.extend(_variance_flaws(result.state_variances, result.state_names))
    found.extend(_probability_flaws(result.mode_probabilities))
    found.extend(_prediction_flaws(result, unpredicted=unpredicted, first=first))
    return min(found, key=lambda flaw: flaw.row) if found else None


def _variance_flaws(values: FloatArray, names: tuple[str, ...]) -> list[Flaw]:
    found = []
    row = _first_not_finite(values)
    if row >= 0:
        column = int(np.argmin(np.isfinite(values[row])))
        found.append(Flaw(row, f"the variance of {names[column]} is {values[row, column]:g}"))
    row = _first_negative(values, NEGATIVE_VARIANCE_TOLERANCE)
    if row >= 0:
        column = int(np.argmin(values[row]))
        found.append(
            Flaw(
                row,
                f"the variance of {names[column]} is negative ({values[row, column]:.3g}), "
                "its covariance no longer positive semi-definite",
            )
        )
    return found


def _probability_flaws(p: FloatArray) -> list[Flaw]:
    not_finite = _first_not_finite(p)
    row = _first_no_distribution(p if not_finite < 0 else p[:not_finite], PROBABILITY_TOLERANCE)
    if row >= 0:
        return [
            Flaw(
                row,
                f"the mode probabilities are no distribution (sum {p[row].sum():.6g}, "
                f"smallest {p[row].min():.3g})",
            )
        ]
    if not_finite >= 0:
        return [Flaw(not_finite, "the mode probabilities are not finite")]
    return []


def _prediction_flaws(result: EstimationResult, *, unpredicted: bool, first: int) -> list[Flaw]:
    y = result.output_predictions
    # the log's row 0 is the prior: it predicts nothing
    row = _first_unpredicted(y, 1 if first == 0 else 0, unpredicted)
    if row < 0:
        return []
    bad = np.isinf(y[row]) if unpredicted else ~np.isfinite(y[row])
    column = int(np.argmax(bad))
    return [
        Flaw(row, f"the output prediction of {result.output_names[column]} is {y[row, column]:g}")
    ]


def _bounds(values: FloatArray) -> tuple[float, float]:
    """The smallest and largest value (NaN when one is): two vectorised passes, no copy."""
    if not values.size:
        return 0.0, 0.0
    return float(values.min()), float(values.max())


def _first_not_finite(values: FloatArray) -> int:
    """The first row holding a value that is not finite; -1 when there is none."""
    low, high = _bounds(values)
    if math.isfinite(low) and math.isfinite(high):
        return -1
    return _first_not_finite_row(values)


@jit
def _first_not_finite_row(values: FloatArray) -> int:
    for row in range(values.shape[0]):
        for column in range(values.shape[1]):
            if not math.isfinite(values[row, column]):
                return row
    return -1


def _first_negative(values: FloatArray, tolerance: float) -> int:
    """The first row with a value below ``-tolerance`` times its largest finite magnitude."""
    if not values.size or values.min() >= 0.0:  # NaN compares false: searched
        return -1
    return _first_negative_row(values, tolerance)


@jit
def _first_negative_row(values: FloatArray, tolerance: float) -> int:
    for row in range(values.shape[0]):
        smallest = 0.0
        largest = 0.0
        for column in range(values.shape[1]):
            value = values[row, column]
            if value < smallest:
                smallest = value
            if math.isfinite(value) and abs(value) > largest:
                largest = abs(value)
        if smallest < -max(tolerance * largest, SUBNORMAL):
            return row
    return -1


def _first_no_distribution(p: FloatArray, tolerance: float) -> int:
    """The first row of finite ``p`` leaving [0, 1] or not summing to 1 (within ``tolerance``)."""
    low, high = _bounds(p)
    if low >= -tolerance and high <= 1.0 + tolerance and _worst_sum(p) <= tolerance:
        return -1
    return _first_no_distribution_row(p, tolerance)


@jit
def _worst_sum(p: FloatArray) -> float:
    """``max_k |Σ_j p[k, j] − 1|`` (one pass, no branch to leave it)."""
    worst = 0.0
    for row in range(p.shape[0]):
        total = 0.0
        for column in range(p.shape[1]):
            total += p[row, column]
        worst = max(worst, abs(total - 1.0))
    return worst


@jit
def _first_no_distribution_row(p: FloatArray, tolerance: float) -> int:
    for row in range(p.shape[0]):
        total = 0.0
        for column in range(p.shape[1]):
            value = p[row, column]
            if value < -tolerance or value > 1.0 + tolerance:
                return row
            total += value
        if abs(total - 1.0) > tolerance:
            return row
    return -1


def _first_unpredicted(y: FloatArray, start: int, nan_allowed: bool) -> int:
    """The first row from ``start`` with an infinite prediction (or NaN, unless allowed)."""
    low, high = _bounds(y[start:])
    if math.isfinite(low) and math.isfinite(high):
        return -1
    return _first_unpredicted_row(y, start, nan_allowed)


@jit
def _first_unpredicted_row(y: FloatArray, start: int, nan_allowed: bool) -> int:
    for row in range(start, y.shape[0]):
        for column in range(y.shape[1]):
            value = y[row, column]
            if math.isinf(value) or (not nan_allowed and math.isnan(value)):
                return row
    return -1


def check_result(
    model: HybridModel,
    signals: AlignedSignals,
    result: EstimationResult,
    *,
    variances: bool = True,
    unpredicted: bool = False,
    first: int = 0,
    before: FloatArray | None = None,
    surprise: FloatArray | None = None,
    paired: bool = False,
) -> None:
    """Refuse ``result`` when it holds a number nobody can vouch for (:func:`first_flaw`).

    ``first`` is the log's row of the result's row 0 (a chunk of a streamed run) and
    ``before`` the state estimate of the row before it, for the diagnosis.  A filter's
    ``surprise`` (:class:`~hybridlog.estimators.common.FilterBuffers`) also refuses a
    sample no mode explains (:func:`check_surprise`), the first refusal said when it is at
    or before the others (a measurement too far from every mode's prediction for double
    precision made the HSTF's state estimate infinite there), and a measured sample that no
    mode could weigh (:func:`_first_unweighed`) before any flaw (a flaw of the same sample
    is said with its cause, :func:`_why`, which names an expression that is not finite
    there or the innovation covariance that is singular).  ``paired``: the estimator ran on
    the model's mode pairs (:mod:`~hybridlog.estimators.mode_pairs`), so the cause is
    looked for in every mode's ``h`` after every mode's ``f`` (:func:`_measuring`).

    Raises
    ------
    DivergenceError
        ``<model file>: <estimator> diverged at t = <t> s (sample <k>): <what>[; <why>]``,
        ``... cannot explain the log at ...`` or ``... cannot weigh the measurement at t =
        <t> s (sample <k>): ...``.
    """
    flaw = first_flaw(result, variances=variances, unpredicted=unpredicted, first=first)
    unweighed = -1 if surprise is None else _first_unweighed(signals, surprise, first)
    if surprise is not None:  # a sample no mode explains, before what the filter made of it
        rows = (unweighed, -1 if flaw is None else flaw.row)
        last = min((row for row in rows if row >= 0), default=surprise.shape[0] - 1)
        check_surprise(model, signals, result, surprise[: last + 1], first=first)
    if unweighed >= 0 and (flaw is None or unweighed < flaw.row):
        at, what = (
            unweighed,
            (
                "no mode's innovation covariance H P Hᵀ + R is finite and positive definite in "
                "double precision, so no mode probability or update exists there"
            ),
        )
        verb = "cannot weigh the measurement at"
    elif flaw is not None:
        at, what, verb = flaw.row, flaw.what, "diverged at"
    else:
        return
    row = first + at
    if at > 0:
        before = result.state_means[at - 1]
        variance = result.state_variances[at - 1] if variances else None
    else:
        variance = None
    why = (
        _why(
            model,
            signals,
            row,
            before,
            variance,
            combined=result.estimator == "hstf",
            paired=paired,
        )
        if row > 0 and before is not None
        else ""
    )
    raise DivergenceError(
        f"{model.origin or model.name}: {result.estimator} {verb} t = "
        f"{format_time(result.time[at])} s (sample {row}): {what}" + (f"; {why}" if why else "")
    )


def _first_unweighed(signals: AlignedSignals, surprise: FloatArray, first: int) -> int:
    """The first row measuring an output where no mode's likelihood weighed it (-1: none).

    There every mode's innovation covariance ``S = H P Hᵀ + R`` (paper 000 eq. (9)) was not
    positive definite, or overflowed to infinity, as computed in double precision (or, in
    the IMM, the modes where it was not are those its transitions rule out, ``c̄_j = 0``):
    no mode's likelihood, and so no mode probability and no update, exists.  The filters' loops kept
    the modes' predictions and the predicted mode probabilities (``h = 1e200*x``: every
    sample; the IMM's generic loop, past 8 modes, where every ``S`` was singular), which
    nobody can vouch for as an estimate of the log.  Such a row's ``surprise`` is NaN though
    an output was measured (the prior's row 0 and the rows measuring nothing have none).
    ``first`` is the log's row of ``surprise``'s row 0.
    """
    rows = np.flatnonzero(np.isnan(surprise))
    if first == 0:
        rows = rows[rows > 0]
    if rows.size == 0:
        return -1
    outputs = signals.outputs[first + rows]
    if signals.unmeasured_outputs is not None:  # a stand-in value is not a measurement
        outputs = np.where(signals.unmeasured_outputs[first + rows], np.nan, outputs)
    measured = ~np.isnan(outputs).all(axis=1)
    return int(rows[int(np.argmax(measured))]) if bool(measured.any()) else -1


def surprise_limit(n_outputs: int) -> float:
    """The ``γᵀ S⁻¹ γ`` past which no mode explains a sample: ``1500 + 50 m`` for ``m`` outputs.

    For Gaussian noise ``γᵀ S⁻¹ γ`` is χ² with ``m`` degrees of freedom, and Chernoff's bound
    ``P(χ²_m ≥ T) ≤ (T/m)^(m/2) e^((m − T)/2)`` puts every ``T`` past this limit below
    ``1e-300`` for every ``m``: such a sample is not noise the model describes (an outlier, a
    stuck or offset sensor, another plant), and the filter's answer to it (a mode decided by
    which of the impossible likelihoods is least so, a state pulled to the outlier with the
    variance of a good measurement) is not one anybody can vouch for.
    """
    return 1500.0 + 50.0 * n_outputs


def check_surprise(
    model: HybridModel,
    signals: AlignedSignals,
    result: EstimationResult,
    surprise: FloatArray,
    *,
    first: int = 0,
) -> None:
    """Refuse ``result`` at its first sample that no mode can explain (:func:`surprise_limit`).

    ``surprise`` holds the rows' smallest ``γᵀ S⁻¹ γ`` over the modes the filter weighs
    there (the IMM's: those its transitions leave possible, ``c̄_j > 0``; ``∞`` where it
    overflowed; NaN where none was computed;
    :class:`~hybridlog.estimators.common.FilterBuffers`), ``first`` the log's row of the
    result's row 0.  :func:`check_result` calls it.

    Raises
    ------
    DivergenceError
        ``<model file>: <estimator> cannot explain the log at t = <t> s (sample <k>): ...``,
        each output's value and prediction there.
    """
    if surprise.shape[0] == 0:
        return
    limit = surprise_limit(model.n_outputs)
    beyond = surprise > limit  # NaN compares False: rows without a value pass
    if not bool(beyond.any()):
        return
    at = _first_row(beyond)
    row = first + at
    measured = signals.rows(row, row + 1).measured_outputs()[0]  # NaN: a stand-in, not scored
    predicted = result.output_predictions[at]
    shown = ", ".join(
        (f"{name} = {measured[b]:.4g}" if measured[b] == measured[b] else f"{name} not measured")
        + f" (predicted {predicted[b]:.4g})"
        for b, name in enumerate(model.outputs[:MAX_SHOWN])
    )
    more = f", {model.n_outputs - MAX_SHOWN} more" if model.n_outputs > MAX_SHOWN else ""
    lost = _lost_before(signals, result, at, first)
    raise DivergenceError(
        f"{model.origin or model.name}: {result.estimator} cannot explain the log at t = "
        f"{format_time(result.time[at])} s (sample {row}): {shown}{more}: "
        f"{_deviations(float(surprise[at]))} from every possible mode's prediction "
        f"(over {math.sqrt(limit):.3g}: P < 1e-300 for Gaussian noise); "
        + (
            lost
            or "an outlier, a stuck or offset sensor, another plant's log, or an estimate that "
            "had lost the plant before it (a wrong mode whose outputs another state matched)?"
        )
    )


def _deviations(distance: float) -> str:
    """``12.3 standard deviations`` for ``γᵀ S⁻¹ γ = distance``, which may have overflowed."""
    if math.isinf(distance):
        return f"over {math.sqrt(np.finfo(np.float64).max):.3g} standard deviations"
    return f"{math.sqrt(distance):.3g} standard deviations"


def _lost_before(signals: AlignedSignals, result: EstimationResult, at: int, first: int) -> str:
    """What the log's true mode says of the estimate before the unexplained row ``at``.

    A filter can follow the plant in a wrong mode whose outputs another state matches (the
    three-tank's ``h_i = i·x``: mode 1 at three times the levels of mode 3), with variances
    as small as if it were right; the plant's next switch is then one no mode explains from
    that state, though the log is sound (10^7 samples simulated from the model: the IMM held
    mode 1 for the 100 samples of mode 3 before t = 1844101 s and was refused there as an
    outlier or another plant's log).  Where the log's true mode at the row before differs from
    the estimate's, this says so (how many samples back, within the result, sample 0's prior
    not counted); else empty.
    """
    truth = signals.truth_modes
    if truth is None or at < 1:
        return ""
    ids = result.mode_ids  # the model's, which the true codes index too

    def wrong(row: int) -> bool:
        # sample 0's mode is the prior's, not an estimate: a log no mode explains at
        # sample 1 (every output 1e6) was said to be one the estimate "had lost" there
        code = int(truth[first + row])
        return first + row >= 1 and code >= 0 and code != int(result.modes[row])

    if not wrong(at - 1):
        return ""
    held, true_id = ids[int(result.modes[at - 1])], ids[int(truth[first + at - 1])]
    count = 1
    while count < at and wrong(at - 1 - count):
        count += 1
    return (
        f"the estimate had lost the plant before it: it held mode {excerpt(held)} over the "
        f"{count:,} sample{'s' if count > 1 else ''} before, where the log's true mode was "
        f"{excerpt(true_id)} (a wrong mode whose outputs another state matched); the log may "
        "be sound, and another estimator or its options may follow it"
    )


def _why(
    model: HybridModel,
    signals: AlignedSignals,
    row: int,
    before: FloatArray,
    variance: FloatArray | None,
    *,
    combined: bool = False,
    paired: bool = False,
) -> str:
    """Why the step into sample ``row`` from the estimate ``before`` of the sample before broke.

    The first expression of the model's modes (``f``, its Jacobian, then ``h`` and its
    Jacobian at the predicted state) that is not finite there, a variance past
    :data:`HUGE_VARIANCE` at the sample before, a derivative that swamps the variances
    (:func:`_precision_lost`), or every mode's innovation covariance singular in double
    precision (:func:`_innovation_singular`); empty when none explains it.  With
    ``combined`` (the HSTF, whose eq. (12) takes every mode's ``∂h/∂x`` at the mean of the
    modes' predictions) also ``∂h/∂x`` there (:func:`_combined_not_finite`).  ``paired``:
    the modes as a run on the mode pairs steps and measures them (:func:`_measuring`).
    """
    if not np.isfinite(before).all():
        return ""
    found = _expression_not_finite(model, signals, row, before, variance, paired)
    if not found and combined:
        found = _combined_not_finite(model, signals, row, before)
    if found:
        return found
    if variance is not None and np.isfinite(variance).all() and variance.size:
        column = int(np.argmax(variance))
        if variance[column] > HUGE_VARIANCE:
            return (
                f"the variance of {model.states[column]} was {variance[column]:.3g} at the "
                "sample before, too large for double precision (the model's noise or initial "
                "covariance, or the estimator's options)"
            )
    found = _precision_lost(model, signals, row, before, variance, paired)
    if found:
        return found
    found = _innovation_singular(model, signals, row, before, variance, paired)
    if found:
        return found
    if _evaluable(model, signals, row):
        return (
            f"every expression of the model is finite at the estimate of sample {row - 1} "
            f"({_point(model, before, signals.inputs[row - 1])})"
        )
    return ""


def _evaluable(model: HybridModel, signals: AlignedSignals, row: int) -> bool:
    """Whether :func:`_expression_not_finite` evaluates the model's discrete-time modes."""
    return not (model.is_continuous or model.has_components) and signals.inputs.shape[0] > row


@dataclass(frozen=True)
class _Step:
    """The step into sample ``row`` from the estimate ``x`` of the sample before, evaluable."""

    compiled: CompiledModel
    n_outputs: int
    x: FloatArray
    u_before: FloatArray
    u_now: FloatArray

    def mode(
        self, index: int, measured: int | None = None
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """Mode ``index``'s ``f``, ``∂f/∂x`` at ``x``, and ``h``, ``∂h/∂x`` at its prediction.

        ``h`` and ``∂h/∂x`` those of mode ``measured`` when given (a mode pair,
        :func:`_measuring`); they stay zero where the prediction is not finite.
        """
        measured = index if measured is None else measured
        n, m = self.x.shape[0], self.n_outputs
        x_next, F = np.zeros(n), np.zeros((n, n))
        y, H = np.zeros(m), np.zeros((m, n))
        with np.errstate(all="ignore"):
            self.compiled.f(index, self.x, self.u_before, x_next)
            self.compiled.F(index, self.x, self.u_before, F)
            if np.isfinite(x_next).all():
                self.compiled.h(measured, x_next, self.u_now, y)
                self.compiled.H(measured, x_next, self.u_now, H)
        return x_next, F, y, H


def _step(
    model: HybridModel, signals: AlignedSignals, row: int, before: FloatArray
) -> _Step | None:
    """The model's compiled modes on the step into ``row``; ``None`` where not evaluable."""
    if not _evaluable(model, signals, row):
        return None
    from hybridlog.model.compiled import compile_model

    try:
        compiled = compile_model(model)
    except ModelError:
        return None
    return _Step(
        compiled,
        model.n_outputs,
        np.ascontiguousarray(before, dtype=np.float64),
        np.ascontiguousarray(signals.inputs[row - 1], dtype=np.float64),
        np.ascontiguousarray(signals.inputs[row], dtype=np.float64),
    )


def _expression_not_finite(
    model: HybridModel,
    signals: AlignedSignals,
    row: int,
    before: FloatArray,
    variance: FloatArray | None,
    paired: bool = False,
) -> str:
    """The first mode expression not finite on the step from ``before`` into ``row``.

    Or, with the ``variance`` of the sample before, the first Jacobian entry so large that
    the covariance it propagates (``F P Fᵀ``, ``H P Hᵀ``) overflows.
    """
    step = _step(model, signals, row, before)
    if step is None:
        return ""
    x, u_before, u_now = step.x, step.u_before, step.u_now
    with np.errstate(all="ignore"):
        for index, measured in _measuring(model, paired):
            x_next, F, y, H = step.mode(index, measured)
            for name, values, at, inputs, of in (
                ("f", x_next, x, u_before, index),
                ("F", F, x, u_before, index),
                ("h", y, x_next, u_now, measured),
                ("H", H, x_next, u_now, measured),
            ):
                finite = np.isfinite(values)
                if not finite.all():
                    flat = int(np.argmin(finite.reshape(-1)))
                    value = float(values.reshape(-1)[flat])
                    return _expression(model, of, name, flat, value, at, inputs)
            if variance is None or not np.isfinite(variance).all():
                continue
            spread = float(np.sqrt(max(float(variance.max()), 1.0)))
            for name, values, at, inputs, of in (
                ("F", F, x, u_before, index),
                ("H", H, x_next, u_now, measured),
            ):
                flat = int(np.argmax(np.abs(values)))
                value = float(values.reshape(-1)[flat])
                if abs(value) * spread > OVERFLOWING:
                    found = _expression(model, of, name, flat, value, at, inputs)
                    return f"{found}: the covariance it propagates overflows"
    return ""


def _measuring(model: HybridModel, paired: bool) -> list[tuple[int, int]]:
    """The modes whose ``f`` steps into a sample and whose ``h`` measures it, as filters pair them.

    Each mode with itself; for a run on the mode pairs (``paired``, the IMM on a model
    :func:`~hybridlog.estimators.capabilities.runs_on_pairs` holds) every mode's ``h`` after
    every mode's ``f``: its refusal is checked in the model's own modes
    (:class:`~hybridlog.estimators.common.CheckedAs`), whose keys it names.  Told by the
    caller, not by the model: the HSTF on the same model evaluates no ``h`` after another
    mode's ``f``, and its refusal named one it never evaluated (``modes.a.h[0] = 'sqrt(x1)'
    is nan at x1 = -0.1``, mode b's prediction, where its eq. (12) had met ``∂h/∂x`` at the
    modes' mean prediction).
    """
    from hybridlog.estimators.capabilities import runs_on_pairs

    n = model.n_modes
    if paired and runs_on_pairs(model):
        return [(index, measured) for index in range(n) for measured in range(n)]
    return [(index, index) for index in range(n)]


def _combined_not_finite(
    model: HybridModel, signals: AlignedSignals, row: int, before: FloatArray
) -> str:
    """A mode's ``∂h/∂x`` not finite at the mean of the modes' predictions from ``before``.

    The HSTF's eq. (12) takes every mode's output Jacobian at the combined prediction
    ``x̂(k+1|k) = Σ f_i(x̂(k|k), u(k)) / n_q``, a point none of the modes predicts: ``sqrt``
    of a level that only the mean of the modes takes below zero.
    """
    step = _step(model, signals, row, before)
    if step is None:
        return ""
    compiled, u_now = step.compiled, step.u_now
    n, m = model.n_states, model.n_outputs
    with np.errstate(all="ignore"):
        predictions = np.zeros((model.n_modes, n))
        for index in range(model.n_modes):
            compiled.f(index, step.x, step.u_before, predictions[index])
        mean = np.ascontiguousarray(predictions.mean(axis=0))
        if not np.isfinite(mean).all():
            return ""
        for index in range(model.n_modes):
            H = np.zeros((m, n))
            compiled.H(index, mean, u_now, H)
            finite = np.isfinite(H)
            if not finite.all():
                flat = int(np.argmin(finite.reshape(-1)))
                value = float(H.reshape(-1)[flat])
                found = _expression(model, index, "H", flat, value, mean, u_now)
                return f"{found}, the modes' mean prediction (eq. (12))"
    return ""


def _precision_lost(
    model: HybridModel,
    signals: AlignedSignals,
    row: int,
    before: FloatArray,
    variance: FloatArray | None,
    paired: bool = False,
) -> str:
    """The Jacobian entry whose propagated covariance rounds by more than the variances.

    A finite but steep derivative (``sqrt`` of a difference of levels that are nearly
    equal: ``1e9``) makes ``F P Fᵀ`` so large that its rounding (:data:`ROUNDING` times its
    size) exceeds the smallest variance of the sample before, which the update must then
    recover by cancellation: the covariance comes out negative or not finite.  The largest
    ``|∂f/∂x_j| σ_j`` (or ``∂h/∂x_j``) of any mode at the estimate of the sample before,
    when it is that large; empty otherwise.  ``paired``: as :func:`_measuring`.
    """
    if variance is None or not np.isfinite(variance).all() or not (variance > 0.0).all():
        return ""
    step = _step(model, signals, row, before)
    if step is None:
        return ""
    x, u_before, u_now = step.x, step.u_before, step.u_now
    sigma = np.sqrt(variance)
    worst: tuple[float, int, str, int, float, FloatArray, FloatArray] | None = None
    with np.errstate(all="ignore"):
        for index, measured in _measuring(model, paired):
            x_next, F, _, H = step.mode(index, measured)
            for name, values, at, inputs, of in (
                ("F", F, x, u_before, index),
                ("H", H, x_next, u_now, measured),
            ):
                scaled = np.abs(values) * sigma
                if not np.isfinite(scaled).all():
                    continue
                flat = int(np.argmax(scaled))
                size = float(scaled.reshape(-1)[flat]) ** 2
                if worst is None or size > worst[0]:
                    value = float(values.reshape(-1)[flat])
                    worst = (size, of, name, flat, value, at, inputs)
    smallest = float(variance.min())
    if worst is None or worst[0] * ROUNDING <= smallest:
        return ""
    size, index, name, flat, value, at, inputs = worst
    expression = _expression(model, index, name, flat, value, at, inputs)
    product = "F P Fᵀ" if name == "F" else "H P Hᵀ"
    return f"{expression}: {product} = {size:.3g} swamps variances of {smallest:.3g}"


def _innovation_singular(
    model: HybridModel,
    signals: AlignedSignals,
    row: int,
    before: FloatArray,
    variance: FloatArray | None,
    paired: bool = False,
) -> str:
    """Every mode's innovation covariance singular in double precision on the step into ``row``.

    The EKF update (paper 000 eqs. (9)-(11)) factorises ``S = H P⁻ Hᵀ + R`` with
    ``P⁻ = F P Fᵀ + Q``; where ``H P⁻ Hᵀ`` is more than ``1/ε`` times ``R`` and has a null
    direction (two outputs measuring one state: a prior variance of ``1e20`` beside a
    measurement noise of ``1e-10``), ``R`` is lost in its rounding and ``S`` is singular
    as computed: no mode's update, and so no mode probability, exists.  ``P`` is taken as
    the variances of the sample before (its diagonal).  The mode whose ``S`` is nearest to
    singular, when every mode's is singular at :data:`ROUNDING`; empty otherwise.
    ``paired``: every pair of :func:`_measuring`, ``Q`` of the mode that steps and ``R`` of
    the mode that measures, named as :func:`~hybridlog.estimators.mode_pairs.pair_named`.
    """
    if variance is None or not np.isfinite(variance).all():
        return ""
    step = _step(model, signals, row, before)
    if step is None:
        return ""
    P = np.diag(variance)
    worst: tuple[float, tuple[int, int], float, float] | None = None
    with np.errstate(all="ignore"):
        for index, measured in _measuring(model, paired):
            _, F, _, H = step.mode(index, measured)
            S = H @ (F @ P @ F.T + model.modes[index].process_noise) @ H.T
            R = model.modes[measured].measurement_noise
            values = np.linalg.eigvalsh(S + R) if np.isfinite(S).all() else None
            if values is None:
                return ""
            largest = float(np.abs(values).max())
            ratio = float(values.min()) / largest if largest > 0.0 else 1.0
            if ratio > S.shape[0] * ROUNDING:
                return ""
            if worst is None or ratio < worst[0]:
                worst = (ratio, (index, measured), float(np.linalg.eigvalsh(R).min()), largest)
    if worst is None:
        return ""
    _, (index, measured), smallest_r, largest = worst
    if index == measured:
        named = excerpt(model.modes[index].id)
    else:
        from hybridlog.estimators.mode_pairs import pair_named

        named = pair_named(index * model.n_modes + measured, model)
    return (
        f"every mode's innovation covariance H P Hᵀ + R is singular in float64 (mode "
        f"{named}: {largest:.3g} rounds away R's {smallest_r:.3g}), "
        f"from variances {_point_variances(model, variance)} at the sample before: the "
        "model's [initial] covariance and [noise] are too far apart for double precision"
    )


def _point_variances(model: HybridModel, variance: FloatArray) -> str:
    """``x1 1e+20, ...``: the variances of the first :data:`MAX_SHOWN` states."""
    return ", ".join(
        f"{name} {value:.3g}"
        for name, value in zip(model.states[:MAX_SHOWN], variance[:MAX_SHOWN], strict=False)
    )


def _expression(
    model: HybridModel,
    mode_index: int,
    name: str,
    flat: int,
    value: float,
    at: FloatArray,
    inputs: FloatArray,
) -> str:
    """``modes.<id>.h[0] = 'sqrt(x1)' is nan at x1 = -0.3, u = 0`` (or its derivative)."""
    mode = model.modes[mode_index]
    n = model.n_states
    function = name.lower()
    component, by = (flat // n, model.states[flat % n]) if name in "FH" else (flat, "")
    expressions = mode.f if function == "f" else mode.h
    text = excerpt(expressions[component])
    key = (
        f"dynamics.{function}[{component}] of mode '{mode.id}'"
        if model.has_booleans
        else f"modes.{mode.id}.{function}[{component}]"
    )
    what = f"the derivative by {by} of {key} = {text}" if by else f"{key} = {text}"
    shown = "nan" if math.isnan(value) else f"{value:g}"
    return f"{what} is {shown} at {_point(model, at, inputs)}"


def _point(model: HybridModel, at: FloatArray, inputs: FloatArray) -> str:
    """``x1 = -0.3, u = 0``: the states and inputs, the first :data:`MAX_SHOWN` of them."""
    values = [
        f"{symbol} = {number:.6g}"
        for symbol, number in (
            *zip(model.states, at.tolist(), strict=True),
            *zip(model.inputs, inputs.tolist(), strict=True),
        )
    ]
    return ", ".join(values[:MAX_SHOWN]) + (", …" if len(values) > MAX_SHOWN else "")


def check_explained(
    model: HybridModel, signals: AlignedSignals, result: EstimationResult, *, first: int = 0
) -> None:
    """Refuse outputs an offline estimate explains that are not finite (``h`` out of its domain).

    :attr:`~hybridlog.estimators.result.PostProcessing.explained` (and the filter's), which
    the report's ``smoothing`` block scores: ``h`` of the estimated mode at a smoothed state
    that left its domain (``sqrt`` of a negative level) would drop the sample from the scores.
    ``signals`` are the rows of ``result`` (a chunk's, whose row 0 is the log's ``first``).

    Raises
    ------
    DivergenceError
        Naming the estimator, the time and sample, the mode, the expression and the state.
    """
    post = result.post_processing
    if post is None:
        return
    for outputs, estimate, whose in (
        (post.explained, result, "the offline estimate"),
        (post.filtered_explained, post.filtered, "the filter's estimate"),
    ):
        if outputs is None or np.isfinite(outputs).all():
            continue
        finite = np.isfinite(outputs)
        row = _first_row(~finite.all(axis=1))
        column = int(np.argmin(finite[row]))
        mode = int(estimate.modes[row])
        expression = _expression(
            model,
            mode,
            "h",
            column,
            float(outputs[row, column]),
            estimate.state_means[row],
            signals.inputs[row],
        )
        raise DivergenceError(
            f"{model.origin or model.name}: {result.estimator} diverged at t = "
            f"{format_time(result.time[row])} s (sample {first + row}): {expression}, the state "
            f"and mode {whose} holds there (h is not defined at that state)"
        )
