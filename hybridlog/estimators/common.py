"""What the filter estimators share: noise stacks, output buffers, the result assembly."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from hybridlog.errors import ModelError
from hybridlog.estimators.result import EstimationResult
from hybridlog.estimators.unrolled import module_source, use_unrolled
from hybridlog.model.compiled import compile_generated, compile_model
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.signals import AlignedSignals, FloatArray, IntArray


def noise_stacks(model: HybridModel) -> tuple[FloatArray, FloatArray]:
    """Per-mode process and measurement covariances, shapes ``(n_modes, n, n)``.

    The filters divide by the innovation covariance, so every ``R_q`` must be positive
    definite; a singular one is a :class:`ModelError` naming the mode.
    """
    Q = np.ascontiguousarray(np.stack([m.process_noise for m in model.modes]), dtype=float)
    R = np.ascontiguousarray(np.stack([m.measurement_noise for m in model.modes]), dtype=float)
    for mode, r in zip(model.modes, R, strict=True):
        if np.linalg.eigvalsh(r).min() <= 0.0:
            raise model.error(
                mode.measurement_noise_key,
                f"the measurement noise covariance of mode '{mode.id}' is singular; "
                "the filters need it positive definite",
            )
    return Q, R


@dataclass(frozen=True)
class FilterBuffers:
    """Arrays a compiled filter loop writes its per-sample output into."""

    modes: IntArray
    mode_probabilities: FloatArray
    state_means: FloatArray
    state_variances: FloatArray
    output_predictions: FloatArray
    covariances: FloatArray

    @classmethod
    def allocate(
        cls, model: HybridModel, n_samples: int, *, store_covariances: bool = False
    ) -> FilterBuffers:
        """Buffers for ``n_samples`` rows; full covariances only when asked for."""
        n_x = model.n_states
        return cls(
            modes=np.zeros(n_samples, dtype=np.int64),
            mode_probabilities=np.zeros((n_samples, model.n_modes)),
            state_means=np.zeros((n_samples, n_x)),
            state_variances=np.zeros((n_samples, n_x)),
            output_predictions=np.full((n_samples, model.n_outputs), np.nan),
            covariances=np.zeros((n_samples if store_covariances else 0, n_x, n_x)),
        )

    def arrays(self) -> tuple[IntArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
        """The buffers in the order the compiled loops take them."""
        return (
            self.modes,
            self.mode_probabilities,
            self.state_means,
            self.state_variances,
            self.output_predictions,
            self.covariances,
        )

    def result(
        self,
        name: str,
        options: dict[str, Any],
        model: HybridModel,
        signals: AlignedSignals,
        *,
        runtime_s: float,
        compile_s: float,
        notes: tuple[str, ...] = (),
    ) -> EstimationResult:
        """Package the filled buffers as the common result type."""
        return EstimationResult(
            estimator=name,
            options=options,
            time=signals.time,
            mode_ids=model.mode_ids,
            state_names=model.states,
            output_names=model.outputs,
            modes=self.modes,
            mode_probabilities=self.mode_probabilities,
            state_means=self.state_means,
            state_variances=self.state_variances,
            output_predictions=self.output_predictions,
            runtime_s=runtime_s,
            compile_s=compile_s,
            notes=notes,
            covariances=self.covariances if self.covariances.shape[0] else None,
        )


def contiguous(array: FloatArray) -> FloatArray:
    """C-contiguous float64 copy-if-needed, as the compiled kernels require."""
    return np.ascontiguousarray(array, dtype=np.float64)


@dataclass(frozen=True)
class FilterCode:
    """The code paths of one filter (see ``docs/architecture.md``, "Compiled code").

    Both loops take ``(inputs, outputs, x0, P0, mu0, *settings, *buffers)``; the generic ones
    take the model functions ``f, F, h, H`` first and ``Q, R`` after the outputs.
    """

    name: str
    generate: Callable[[HybridModel], str]
    """Straight-line source of the whole loop for a model, defining ``<name>_run``."""
    compiled_loops: Callable[[], Callable[..., None]]
    """The generic loops, compiled."""
    plain_loops: Callable[..., None]
    """The generic loops as plain Python."""


def run_filter(
    code: FilterCode,
    model: HybridModel,
    signals: AlignedSignals,
    settings: tuple[Any, ...],
    options: dict[str, Any],
    *,
    jit: bool,
    kernel: str,
    store_covariances: bool,
) -> EstimationResult:
    """Run a filter over the aligned signals with the chosen code path.

    ``kernel``: ``unrolled`` (straight-line code generated for the model), ``loops`` (the
    generic compiled loops) or ``auto`` (unrolled for small models); ``jit=False`` runs the
    generic loops as plain Python on plain-Python mode functions, the tests' reference.
    """
    Q, R = noise_stacks(model)
    buffers = FilterBuffers.allocate(model, signals.n_samples, store_covariances=store_covariances)
    common = (
        contiguous(signals.inputs),
        contiguous(signals.outputs),
        contiguous(model.initial_state),
        contiguous(model.initial_covariance),
        contiguous(model.initial_mode_probabilities),
        *settings,
        *buffers.arrays(),
    )
    loop: Callable[..., None]
    arguments: tuple[Any, ...]
    if jit and use_unrolled(model, kernel):
        arguments = common
        source = module_source(model, code.generate(model))
        loop, compile_s = compile_generated(source, f"{code.name}_run", arguments)
    else:
        compiled = compile_model(model, jit=jit)
        arguments = (compiled.f, compiled.F, compiled.h, compiled.H, *common[:2], Q, R, *common[2:])
        loop = code.compiled_loops() if jit else code.plain_loops
        compile_s = compiled.compile_s
    start = time.perf_counter()
    loop(*arguments)
    runtime = time.perf_counter() - start
    finite = np.isfinite(buffers.state_means).all(axis=1)
    if not finite.all():
        row = int(np.argmin(finite))
        raise ModelError(
            f"{model.name}: {code.name} diverged at t = {signals.time[row]:g} s (sample {row}): "
            "the state estimate is not finite; a Jacobian of the model may be infinite there"
        )
    return buffers.result(
        code.name, options, model, signals, runtime_s=runtime, compile_s=compile_s
    )
