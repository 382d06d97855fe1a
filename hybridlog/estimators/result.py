"""The one result type every estimator returns."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from hybridlog.estimators.capabilities import STEP_FROM_NOTE
from hybridlog.signals import BoolArray, FloatArray, IntArray


class ResultShapeError(ValueError):
    """An estimator built a result whose arrays do not fit together: a defect of the estimator.

    Not a :class:`~hybridlog.errors.HybridlogError`: nothing the user gave can cause it.
    """


@dataclass(frozen=True)
class TimelineColumn:
    """An estimator-specific column of the mode timeline, beside ``mode`` and ``p_<mode>``.

    For example the unthresholded boolean estimates of ``sliding-mode`` (floats) or the mode of
    each component of a ``[components]`` model (labels).

    Attributes
    ----------
    name:
        Column name in timeline.csv (``delta_tilde.d1``, ``mode.regulator2``); it may not
        repeat a standard column's name.
    values:
        Shape ``(N,)``: float64 values, or int64 indices into ``labels`` when labels are given.
    labels:
        When not empty, the column holds these labels (written as text).
    """

    name: str
    values: FloatArray | IntArray
    labels: tuple[str, ...] = ()


FALLBACK_CAUSES = ("prediction", "guard", "rounding", "covariance")
"""Why a smoother's step left the forward estimate standing (docs/smoothing.md "The
algorithms"): the prediction's covariance ``P^-`` not positive definite, the guard
``P^s(k+1) <= P^-``, the rounding probe, the step's covariance not PSD to rounding."""


@dataclass(frozen=True)
class Fallbacks:
    """How often a fixed-interval smoother's estimate is the forward pass's (issue 12).

    Attributes
    ----------
    samples:
        Samples where at least one step that carries weight in the output (a next mode, or
        a pair of modes, of smoothed probability at least ``1e-16``,
        ``rts_steps.NEGLIGIBLE_WEIGHT``) was refused and the forward estimate stood in its
        place.  Negligible next modes, skipped by design, are
        not counted.
    of:
        Samples the backward pass smoothed (all but the last, which is the filter's).
    by_cause:
        Per cause of :data:`FALLBACK_CAUSES`, the samples where a step was refused for it
        (a sample may count under several causes).
    weight:
        The share of the smoothed output the refused steps carry, averaged over the ``of``
        samples (0 to 1): per sample the summed smoothed probability of the next modes (Kim),
        or of the pairs of modes (expectation correction), whose step was refused; 1 per
        refused sample along a ``kbest`` path.  A sample counted in ``samples`` may owe
        little of its estimate to the forward pass: this says how much.
    """

    samples: int
    of: int
    by_cause: dict[str, int]
    weight: float = 0.0

    def weight_text(self) -> str:
        """:attr:`weight` in percent, as :meth:`summary` says it (``99.1 %``, ``0.028 %``)."""
        return _percent(self.weight)

    def summary(self) -> str:
        """One phrase, as ``the smoother fell back to the forward estimate on 12 of 599 ...``.

        The causes that occurred follow in parentheses (``(guard 12)``), then the share of the
        smoothed estimates' weight the refused steps carry (:attr:`weight`).
        """
        causes = ", ".join(f"{c} {n:,}" for c, n in self.by_cause.items() if n)
        return (
            f"the smoother fell back to the forward estimate on {self.samples:,} of {self.of:,} "
            f"samples ({causes}), which carry {self.weight_text()} of the smoothed "
            "estimates' weight"
        )


def _percent(share: float) -> str:
    """``share`` (0 to 1) in percent: one decimal from 1 %, two significant digits below."""
    percent = 100.0 * share
    return f"{percent:.1f} %" if percent >= 1.0 else f"{percent:.2g} %"


@dataclass(frozen=True)
class PostProcessing:
    """How an offline pass after the filter changed a result (issue 12).

    Attributes
    ----------
    smoothing:
        Short name of the fixed-interval smoother that produced the states and mode
        probabilities (for example ``"kim-rts"``), or ``None`` when they are the filter's.
    mode_sequence:
        How the per-sample mode was chosen: ``"argmax"`` of the (smoothed) probabilities or
        ``"viterbi"`` (the most likely mode sequence over the filter's likelihoods) or ``"kbest"``
        (the best of the k best mode histories).
    description:
        One line for the report: the algorithm, its paper and equations.
    filtered:
        The causal filter's own result over the same log, for the filtered-vs-smoothed
        comparison.
    explained, filtered_explained:
        The outputs the offline estimate and the filter's explain, ``ŷ(k) = h_q̂(k)(x̂(k),
        u(k))``, shape ``(N, n_y)`` (:mod:`hybridlog.estimators.explained`), computed where
        the estimate was made (the registry's run), so that the process writing the report
        need not load the model's compiled functions; ``None`` where not computed (the
        report then computes them) or where the model's ``h`` does not apply.
    fallbacks:
        Where the smoother that made the states left the forward estimate standing
        (:class:`Fallbacks`; with ``kbest``, the RTS smoother along the path); ``None``
        without a smoother.
    """

    smoothing: str | None
    mode_sequence: str
    description: str
    filtered: EstimationResult
    explained: FloatArray | None = None
    filtered_explained: FloatArray | None = None
    fallbacks: Fallbacks | None = None


@dataclass(frozen=True)
class EstimationResult:
    """Per-sample output of a hybrid estimator over one log.

    The shapes and dtypes below are checked when the result is built
    (:class:`ResultShapeError` names the estimator and the field).

    Row ``k`` describes sample ``k`` of the aligned signals.  Row 0 is the estimator's prior
    (the model's initial state, covariance and mode probabilities): no output was predicted
    for it, so ``output_predictions[0]`` is NaN and metrics are taken over the finite rows.

    Attributes
    ----------
    estimator:
        Registry name of the estimator (``hstf``, ``imm`` ...).
    options:
        The estimator options actually used, defaults filled in.
    time:
        Sample times in seconds, shape ``(N,)``.
    mode_ids:
        The model's mode ids; column ``j`` of ``mode_probabilities`` belongs to ``mode_ids[j]``.
    modes:
        Estimated mode of each sample as an index into ``mode_ids``, shape ``(N,)``.
    mode_probabilities:
        Posterior mode probabilities (or normalised scores), shape ``(N, n_modes)``.
    state_means:
        Estimated continuous state ``x̂(k|k)``, shape ``(N, n_x)``.
    state_variances:
        Diagonal of the estimation error covariance ``P(k|k)``, shape ``(N, n_x)``;
        NaN where the estimator defines none.
    output_predictions:
        One-step-ahead output prediction ``ŷ(k|k-1)`` made before ``y(k)`` was used,
        shape ``(N, n_y)``.
    runtime_s:
        Wall time of the estimation itself, excluding one-time compilation.
    compile_s:
        Wall time spent compiling (close to 0 when the compiled code came from the cache).
    notes:
        Remarks for the report (for example which variant of an algorithm ran).
    covariances:
        Full ``P(k|k)``, shape ``(N, n_x, n_x)``, only when the caller asked for it.
    timeline_columns:
        Estimator-specific timeline columns (:class:`TimelineColumn`), written after the
        standard ones.
    post_processing:
        Set when the estimates above are not the causal filter's own (``--smooth``,
        ``--mode-sequence viterbi``): how they were made, and the filter's result beside them.
        ``output_predictions`` stay the filter's one-step-ahead predictions either way.
    whitened_innovations:
        ``L⁻¹ γ(k)`` per sample (``S = L Lᵀ``, the innovation and its covariance of the mode
        nearest to ``y(k)``), shape ``(N, n_y)``, NaN where none was computed; ``None`` for
        an estimator that keeps none (:mod:`hybridlog.estimators.consistency` tests them).
    modes_given:
        Why ``modes`` are not an estimate, where they are read from the log (``switching-
        observer``'s switching signal, which is the log's true mode); empty for an estimate.
        The report then scores none of the mode metrics: they would compare the log's true
        mode with itself, and a gate would pass on a number that measures nothing.
    states_not_estimated:
        Shape ``(N, n_x)``, ``True`` where the estimator did not estimate the state at that
        sample but carried a value it cannot vouch for (``unknown-mode``'s states in no
        filter cluster, paper 002 §3.1: the mean held where it was); ``None`` where every
        state was estimated on every sample.  The report reads
        :meth:`estimated_state_means`: the state RMSE is over the estimated samples only,
        estimates.csv leaves ``<x>_hat`` empty and the plots draw no estimate there.
    """

    estimator: str
    options: dict[str, Any]
    time: FloatArray
    mode_ids: tuple[str, ...]
    state_names: tuple[str, ...]
    output_names: tuple[str, ...]
    modes: IntArray
    mode_probabilities: FloatArray
    state_means: FloatArray
    state_variances: FloatArray
    output_predictions: FloatArray
    runtime_s: float = 0.0
    compile_s: float = 0.0
    notes: tuple[str, ...] = field(default=())
    covariances: FloatArray | None = None
    timeline_columns: tuple[TimelineColumn, ...] = ()
    post_processing: PostProcessing | None = None
    whitened_innovations: FloatArray | None = None
    modes_given: str = ""
    states_not_estimated: BoolArray | None = None

    def __post_init__(self) -> None:
        self._check_names()
        if not isinstance(self.time, np.ndarray) or self.time.ndim != 1:
            got = getattr(self.time, "shape", type(self.time).__name__)
            raise ResultShapeError(
                f"{self.estimator}: result field 'time' has shape {got}; expected (N,)"
            )
        n = self.time.shape[0]
        n_modes, n_x, n_y = len(self.mode_ids), len(self.state_names), len(self.output_names)
        expected: dict[str, tuple[tuple[int, ...], type[np.generic]]] = {
            "time": ((n,), np.float64),
            "modes": ((n,), np.int64),
            "mode_probabilities": ((n, n_modes), np.float64),
            "state_means": ((n, n_x), np.float64),
            "state_variances": ((n, n_x), np.float64),
            "output_predictions": ((n, n_y), np.float64),
        }
        if self.covariances is not None:
            expected["covariances"] = ((n, n_x, n_x), np.float64)
        if self.whitened_innovations is not None:
            expected["whitened_innovations"] = ((n, n_y), np.float64)
        if self.states_not_estimated is not None:
            expected["states_not_estimated"] = ((n, n_x), np.bool_)
        for name, (shape, dtype) in expected.items():
            array = getattr(self, name)
            if not isinstance(array, np.ndarray) or array.shape != shape:
                got = array.shape if isinstance(array, np.ndarray) else type(array).__name__
                raise ResultShapeError(
                    f"{self.estimator}: result field '{name}' has shape {got}; expected "
                    f"{shape} (N samples, {n_modes} modes, {n_x} states, {n_y} outputs)"
                )
            if array.dtype != dtype:
                raise ResultShapeError(
                    f"{self.estimator}: result field '{name}' has dtype {array.dtype}; "
                    f"expected {np.dtype(dtype)}"
                )
        if n and not (self.modes.min() >= 0 and self.modes.max() < n_modes):
            raise ResultShapeError(
                f"{self.estimator}: result field 'modes' holds mode indices outside "
                f"[0, {n_modes}) ({self.modes.min()} .. {self.modes.max()})"
            )

        standard = {"t", "mode", "truth_mode", *(f"p_{m}" for m in self.mode_ids)}
        seen: set[str] = set()
        for column in self.timeline_columns:
            labelled = bool(column.labels)
            dtype = np.int64 if labelled else np.float64
            values = column.values
            if (
                column.name in standard
                or column.name in seen
                or not isinstance(values, np.ndarray)
                or values.shape != (n,)
                or values.dtype != dtype
                or (
                    labelled and n and not (values.min() >= 0 and values.max() < len(column.labels))
                )
            ):
                raise ResultShapeError(
                    f"{self.estimator}: timeline column {column.name!r} must have a new name "
                    f"and shape ({n},) of {np.dtype(dtype)}"
                    + (f" indices into its {len(column.labels)} labels" if labelled else "")
                )
            seen.add(column.name)

    def _check_names(self) -> None:
        """Refuse names, notes and options of the wrong type (:class:`ResultShapeError`).

        A string where a tuple of strings belongs passed, as a sequence of its characters:
        ``notes=("one remark")`` (no comma) wrote ``"notes": ["o", "n", "e", ...]`` into
        report.json, and ``mode_ids="12"`` fitted two modes.
        """
        for name in ("mode_ids", "state_names", "output_names", "notes"):
            value = getattr(self, name)
            if isinstance(value, str) or not all(isinstance(item, str) for item in value):
                raise ResultShapeError(
                    f"{self.estimator}: result field '{name}' must be a tuple of strings, "
                    f"not {type(value).__name__}"
                    + (f" {value[:40]!r}" if isinstance(value, str) else "")
                )
        if not isinstance(self.options, dict):
            raise ResultShapeError(
                f"{self.estimator}: result field 'options' must be a dict, not "
                f"{type(self.options).__name__}"
            )

    @property
    def n_samples(self) -> int:
        """Number of samples estimated."""
        return int(self.time.shape[0])

    def estimated_state_means(self) -> FloatArray:
        """``state_means`` with NaN where the state was not estimated (``states_not_estimated``).

        What the state RMSE scores, estimates.csv writes and the plots draw: a value the
        estimator held rather than estimated is no estimate to score against the true state.
        ``state_means`` itself (no copy) where every state was estimated.
        """
        if self.states_not_estimated is None:
            return self.state_means
        return np.where(self.states_not_estimated, np.nan, self.state_means)

    def rows(self, start: int, stop: int) -> EstimationResult:
        """Rows ``start:stop`` of every per-sample array, as views (nothing is copied).

        The timeline columns and :attr:`post_processing` (the filter's result and the outputs
        explained) are cut alike; ``runtime_s`` and ``compile_s`` stay the whole run's.

        Raises
        ------
        ValueError
            For rows outside the result (a slice would silently shorten it).
        """
        if not 0 <= start <= stop <= self.n_samples:
            raise ValueError(f"rows {start}:{stop} of {self.n_samples} samples")
        post = self.post_processing
        if post is not None:
            post = replace(
                post,
                filtered=post.filtered.rows(start, stop),
                explained=None if post.explained is None else post.explained[start:stop],
                filtered_explained=(
                    None if post.filtered_explained is None else post.filtered_explained[start:stop]
                ),
            )
        return replace(
            self,
            time=self.time[start:stop],
            modes=self.modes[start:stop],
            mode_probabilities=self.mode_probabilities[start:stop],
            state_means=self.state_means[start:stop],
            state_variances=self.state_variances[start:stop],
            output_predictions=self.output_predictions[start:stop],
            covariances=None if self.covariances is None else self.covariances[start:stop],
            whitened_innovations=(
                None if self.whitened_innovations is None else self.whitened_innovations[start:stop]
            ),
            states_not_estimated=(
                None if self.states_not_estimated is None else self.states_not_estimated[start:stop]
            ),
            timeline_columns=tuple(
                replace(column, values=column.values[start:stop])
                for column in self.timeline_columns
            ),
            post_processing=post,
        )

    def with_modes_of_the_step_from(self) -> EstimationResult:
        """The result with each sample's mode that of the step *from* it, not *into* it.

        A Markov-jump filter's mode of sample k is the one under which ``x(k)`` came from
        ``x(k-1)`` (paper 000 eq. (2)); a state-driven model's mode of sample k is the one
        under which ``x(k+1)`` comes from ``x(k)`` (paper 001 eq. (1), the log's true mode).
        So sample k takes the modes and mode probabilities the estimator gave sample k+1,
        the offline estimate that has seen the step it governs; the last sample, whose step
        the log does not hold, keeps its own.  States, variances and output predictions are
        the estimator's.  The filter's own result (:attr:`post_processing`) is moved alike.
        """
        post = self.post_processing
        if post is not None:  # the outputs explained depend on the modes: computed afresh
            post = replace(
                post,
                filtered=post.filtered.with_modes_of_the_step_from(),
                explained=None,
                filtered_explained=None,
            )
        return replace(
            self,
            modes=_one_earlier(self.modes),
            mode_probabilities=_one_earlier(self.mode_probabilities),
            notes=(*self.notes, STEP_FROM_NOTE),
            post_processing=post,
        )


def _one_earlier(values: np.ndarray[Any, Any]) -> np.ndarray[Any, Any]:
    """``values`` moved one row earlier, the last row kept (a copy)."""
    moved = values.copy()
    moved[:-1] = values[1:]
    return moved
