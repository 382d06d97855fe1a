"""The one result type every estimator returns."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from hybridlog.signals import FloatArray, IntArray


@dataclass(frozen=True)
class EstimationResult:
    """Per-sample output of a hybrid estimator over one log.

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

    @property
    def n_samples(self) -> int:
        """Number of samples estimated."""
        return int(self.time.shape[0])
