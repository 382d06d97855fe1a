r"""Regression vectors φ(k) of paper 001 and their generalisation.

Paper 001 (§4.A) clusters

.. math::

    \varphi(k) = [\,y(k),\; y(k-1),\; u(k-1)\,]^T ,

here generalised to several outputs and inputs and any lags:

.. math::

    \varphi(k) = [\,y_1(k-a_1), \dots, y_1(k-a_p), \dots, y_{n_y}(k-a_p),\;
                   u_1(k-b_1), \dots, u_{n_u}(k-b_q)\,]^T

with output lags ``a`` (which must include 0: the decision variables of eq. (3) are the
``y_j(k)`` components of a centre) and input lags ``b``.  Rows ``k`` start at the largest
lag, so ``N − max_lag`` vectors come from ``N`` samples.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from hybridlog.errors import DataShortError, OptionError
from hybridlog.numbers import comma_items, parse_int
from hybridlog.signals import BoolArray, FloatArray

__all__ = [
    "RegressorSpec",
    "check_lags",
    "lag_values",
    "measured_rows",
    "parse_lags",
    "regression_vectors",
]


@dataclass(frozen=True)
class RegressorSpec:
    """Which lags of every output and input make up φ(k); default: paper 001's φ(k).

    Attributes
    ----------
    output_lags:
        Lags ``a`` of each output, in the order they appear in φ(k); must contain 0.
    input_lags:
        Lags ``b`` of each input (may be empty; 0 means ``u(k)``).
    """

    output_lags: tuple[int, ...] = (0, 1)
    input_lags: tuple[int, ...] = (1,)

    def __post_init__(self) -> None:
        for name, lags in (("output_lags", self.output_lags), ("input_lags", self.input_lags)):
            try:
                check_lags(lags, output=name == "output_lags")
            except ValueError as err:
                raise OptionError(f"{name}: {err}") from None

    @property
    def max_lag(self) -> int:
        """The largest lag: the first ``max_lag`` samples give no vector."""
        return max((*self.output_lags, *self.input_lags))

    def dimension(self, n_outputs: int, n_inputs: int) -> int:
        """Length of φ(k)."""
        return n_outputs * len(self.output_lags) + n_inputs * len(self.input_lags)

    def names(self, outputs: Sequence[str], inputs: Sequence[str]) -> list[str]:
        """Component names such as ``y(k)``, ``y(k-1)``, ``u(k-1)``."""

        def lagged(name: str, lag: int) -> str:
            return f"{name}(k)" if lag == 0 else f"{name}(k-{lag})"

        return [lagged(y, a) for y in outputs for a in self.output_lags] + [
            lagged(u, b) for u in inputs for b in self.input_lags
        ]

    def decision_columns(self, n_outputs: int) -> list[int]:
        """Columns of φ(k) holding ``y_j(k)``, one per output (the decision variables)."""
        zero = self.output_lags.index(0)
        return [j * len(self.output_lags) + zero for j in range(n_outputs)]


def check_lags(lags: Sequence[int], *, output: bool) -> None:
    """Refuse lags φ(k) cannot be built from: negative, repeated, or outputs' without 0.

    Raises
    ------
    ValueError
        With the reason alone: the caller names the option and where its value was set.
    """
    if output and 0 not in lags:
        raise ValueError("must contain 0 (y(k) holds the decision variables of eq. (3))")
    if any(lag < 0 for lag in lags):
        raise ValueError(f"lags must be non-negative, got {list(lags)}")
    if len(set(lags)) != len(lags):
        raise ValueError(f"a lag is listed twice in {list(lags)}")


def lag_values(text: str, *, output: bool) -> tuple[int, ...]:
    """The lags of an option's text (``"0,1"``), checked as :class:`RegressorSpec` checks them.

    The options' own check (``output_lags``, ``input_lags``): a value refused here is named
    where it was set (``--output-lags 1``, ``--set output_lags=1``, a model file's key).

    Raises
    ------
    ValueError
        With the reason alone.
    """
    values = _lag_items(text)
    check_lags(values, output=output)
    return values


def _lag_items(text: str) -> tuple[int, ...]:
    """The whole numbers of a comma list (``;`` too); ``ValueError`` naming a bad item."""
    values: list[int] = []
    for part in comma_items(text.replace(";", ","), "lags"):
        try:
            values.append(parse_int(part))
        except ValueError:
            raise ValueError(f"'{part}' is not a whole number") from None
    return tuple(values)


def parse_lags(text: str | Sequence[int], key: str) -> tuple[int, ...]:
    """``"0,1"`` (or a list) → ``(0, 1)``; an empty string is no lag at all.

    An empty item between commas (``"0,,1"``, ``"0,"``) is refused, not skipped: it is a
    lag left out or a typo, which the user must see.
    """
    if not isinstance(text, str):
        values = list(text)
    else:
        try:
            values = list(_lag_items(text))
        except ValueError as err:
            raise OptionError(f"{key}: {err}") from None
    if any(isinstance(v, bool) or not isinstance(v, int | np.integer) for v in values):
        raise OptionError(f"{key}: expected whole numbers, got {values!r}")
    return tuple(int(v) for v in values)


def regression_vectors(outputs: FloatArray, inputs: FloatArray, spec: RegressorSpec) -> FloatArray:
    """φ(k) for ``k = max_lag … N−1``, shape ``(N − max_lag, d)``.

    Parameters
    ----------
    outputs:
        ``y``, shape ``(N, n_y)``.
    inputs:
        ``u``, shape ``(N, n_u)``.
    spec:
        The lags.

    Raises
    ------
    DataShortError
        When there are no more samples than the largest lag (the message names no file: the
        caller knows where the data came from).
    """
    y = np.asarray(outputs, dtype=np.float64)
    u = np.asarray(inputs, dtype=np.float64)
    n = y.shape[0]
    lag = spec.max_lag
    if n <= lag:
        raise DataShortError(
            f"output_lags, input_lags: too few samples for lags up to {lag}: {n}, at least "
            f"{lag + 1} needed"
        )
    columns = [y[lag - a : n - a, j] for j in range(y.shape[1]) for a in spec.output_lags]
    columns += [u[lag - b : n - b, i] for i in range(u.shape[1]) for b in spec.input_lags]
    return np.ascontiguousarray(np.stack(columns, axis=1))


def measured_rows(unmeasured: BoolArray | None, spec: RegressorSpec, n: int) -> BoolArray:
    """Which rows of :func:`regression_vectors` hold only outputs the log measured.

    Row ``i`` is φ(k) with ``k = max_lag + i``; it holds ``y_j(k − a)`` for every output
    ``j`` and lag ``a`` of ``spec.output_lags``.  It is measured when none of them was a value
    the alignment took from the samples around a gap
    (:attr:`~hybridlog.signals.AlignedSignals.unmeasured_outputs`): a log at half the model's
    rate repeats every other output, and φ(k) built on it shows ``y(k) = y(k−1)``, a point
    no measurement gave, which a centre must not be fitted on.  Inputs are held onto the grid
    between their samples, as the model applies them, and count as measured.

    Parameters
    ----------
    unmeasured:
        ``True`` where an output was not measured, shape ``(n, n_y)``; ``None``: all were.
    spec:
        The lags.
    n:
        Number of samples ``N``.

    Returns
    -------
    numpy.ndarray
        Booleans, shape ``(max(N − max_lag, 0),)``.
    """
    lag = spec.max_lag
    rows = max(n - lag, 0)
    kept = np.ones(rows, dtype=np.bool_)
    if unmeasured is None or rows == 0:
        return kept
    if unmeasured.shape[0] != n:
        raise ValueError(f"unmeasured outputs have {unmeasured.shape[0]} rows; expected {n}")
    for a in spec.output_lags:
        kept &= ~np.any(unmeasured[lag - a : n - a], axis=1)
    return kept
