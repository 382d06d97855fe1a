"""The state RMSE of one estimation run: root mean square error against the true states.

Taken by :class:`StateAccumulator` over chunks of rows, or :func:`state_rmse` at once, with
the errors scaled before they are squared where their squares would leave float64's range
(:class:`~hybridlog.report.error_power.ErrorPower`), as the output metrics of
:mod:`hybridlog.report.metrics` are.

"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from hybridlog.report.error_power import ErrorPower
from hybridlog.report.row_blocks import Columns, paired
from hybridlog.signals import FloatArray

__all__ = ["StateAccumulator", "state_rmse"]


def _rmse(part: ErrorPower) -> tuple[float, str | None]:
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
        self._columns = Columns(n_states, ErrorPower.between)

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
    truth, means = paired(truth_states, state_means)
    accumulator = StateAccumulator(truth.shape[1])
    accumulator.add(means, truth)
    return accumulator.result()
