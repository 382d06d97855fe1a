"""What the filter estimators share: noise stacks, output buffers, the runner of their code.

A filter is a generic time loop over the model's compiled functions (mandatory, one
:class:`FilterCode`) and may add an :class:`Accelerator`: straight-line code generated for
the model, which :func:`run_filter` picks for the models it applies to.  Both compute the
same thing (``tests/estimators/test_kernels.py`` checks every accelerator against the plain path).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from hybridlog.errors import ModelError
from hybridlog.estimators.result import EstimationResult
from hybridlog.estimators.unrolled import fits_unrolled, module_source
from hybridlog.jit import compile_for
from hybridlog.model.compiled import ModelFunction, compile_generated, compile_model
from hybridlog.prefault import arrays_in, populated_beside
from hybridlog.signals import AlignedSignals, FloatArray, IntArray

if TYPE_CHECKING:
    from hybridlog.model.hybrid_model import HybridModel


Fn = ModelFunction
"""One of a model's compiled mode functions ``f``, ``F``, ``h``, ``H``: ``fn(mode, x, u, out)``."""


def noise_stacks(model: HybridModel, estimator: str = "") -> tuple[FloatArray, FloatArray]:
    """Per-mode process and measurement covariances, shapes ``(n_modes, n, n)``.

    The filters divide by the innovation covariance, so every ``R_q`` must be positive
    definite; a singular one is a :class:`ModelError` naming the model file, the mode and
    ``estimator``.
    """
    Q = np.ascontiguousarray(np.stack([m.process_noise for m in model.modes]), dtype=float)
    R = np.ascontiguousarray(np.stack([m.measurement_noise for m in model.modes]), dtype=float)
    for mode, r in zip(model.modes, R, strict=True):
        if np.linalg.eigvalsh(r).min() <= 0.0:
            needs = f"the {estimator} filter needs" if estimator else "the filters need"
            raise model.error(
                mode.measurement_noise_key,
                f"the measurement noise covariance of mode '{mode.id}' is singular; "
                f"{needs} it positive definite",
            )
    return Q, R


class FilterRun(NamedTuple):
    """What a filter's time loop reads: one record, the same for both code paths.

    The aligned signals, the per-mode noise stacks of :func:`noise_stacks` (an accelerator
    has them written into its code and does not read them) and the prior of the model.
    """

    inputs: FloatArray
    outputs: FloatArray
    Q: FloatArray
    R: FloatArray
    x0: FloatArray
    P0: FloatArray
    mu0: FloatArray

    @classmethod
    def of(cls, model: HybridModel, signals: AlignedSignals, estimator: str) -> FilterRun:
        """The record of ``model`` over ``signals``, C-contiguous float64 throughout."""
        Q, R = noise_stacks(model, estimator)
        return cls(
            contiguous(signals.inputs),
            contiguous(signals.outputs),
            Q,
            R,
            contiguous(model.initial_state),
            contiguous(model.initial_covariance),
            contiguous(model.initial_mode_probabilities),
        )


class FilterBuffers(NamedTuple):
    """Arrays a compiled filter loop writes its per-sample output into (its ``out`` record)."""

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


def packed_width(n_x: int) -> int:
    """Entries of one mode's :class:`ModeStore` record: mean, upper triangle of covariance."""
    return n_x + n_x * (n_x + 1) // 2


def upper_pairs(n_x: int) -> list[tuple[int, int]]:
    """``(a, b)`` with ``a <= b``, row by row: the order of a packed covariance's entries."""
    return [(a, b) for a in range(n_x) for b in range(a, n_x)]


class ModeStore(NamedTuple):
    """Per-mode quantities a filter keeps for an offline pass after it (issue 12).

    For every mode ``j``: ``log_likelihoods[k, j]`` is ``log N(γ_j(k); 0, S_j(k))`` of the
    measurement ``y(k)`` (row 0: 0).  ``states[k, j]`` is one mode's record, packed: the mean
    (``n_x`` entries) then the upper triangle of the covariance row by row
    (:func:`upper_pairs`, ``n_x(n_x+1)/2`` entries; the covariances are symmetric).  For
    ``k < N−1`` it holds the IMM's mixed prior ``x̂⁰_j(k)``, ``P⁰_j(k)`` of the step
    ``k → k+1`` (the estimate of ``x(k)`` given ``q(k+1) = j``), and in the last row the
    mode-matched filtered ``x̂_j(N−1|N−1)``, ``P_j(N−1|N−1)``.  Arrays nothing after the
    filter needs have no rows (:meth:`allocate`), so the filter's loop writes them only on
    demand: the smoother needs the states (``8 N n_q (n_x + n_x(n_x+1)/2)`` bytes, 206 MiB
    for 10^6 samples, 3 modes, 3 states), the Viterbi path the likelihoods (``8 N n_q``
    bytes).  The filter writes every row, so they are allocated uninitialised.
    """

    states: FloatArray
    log_likelihoods: FloatArray

    @classmethod
    def allocate(
        cls, model: HybridModel, n_samples: int, *, states: bool, likelihoods: bool
    ) -> ModeStore:
        """``n_samples`` rows of the states and of the likelihoods where asked, else none."""
        rows, n_q = (n_samples if states else 0), model.n_modes
        return cls(
            np.empty((rows, n_q, packed_width(model.n_states))),
            np.empty((n_samples if likelihoods else 0, n_q)),
        )

    @property
    def n_states(self) -> int:
        """``n_x``, from the width of the records."""
        width = self.states.shape[2]
        return (math.isqrt(8 * width + 9) - 3) // 2

    @property
    def means(self) -> FloatArray:
        """The means of :attr:`states`, shape ``(rows, n_q, n_x)`` (a view)."""
        return self.states[:, :, : self.n_states]

    @property
    def covariances(self) -> FloatArray:
        """The covariances of :attr:`states` unpacked, shape ``(rows, n_q, n_x, n_x)`` (a copy)."""
        n = self.n_states
        rows, n_q, _ = self.states.shape
        full = np.empty((rows, n_q, n, n))
        for index, (a, b) in enumerate(upper_pairs(n), start=n):
            full[:, :, a, b] = full[:, :, b, a] = self.states[:, :, index]
        return full


def contiguous(array: FloatArray) -> FloatArray:
    """C-contiguous float64 copy-if-needed, as the compiled kernels require."""
    return np.ascontiguousarray(array, dtype=np.float64)


KERNELS = ("auto", "unrolled", "loops")
"""Code paths of a filter: ``unrolled`` is its accelerator, ``loops`` the generic loop,
``auto`` the accelerator where it applies."""


@dataclass(frozen=True)
class Accelerator:
    """Straight-line code a filter generates for a model: optional, faster, the same result.

    ``generate(model)`` returns the source of one function named ``function`` taking the
    frame of the generic loop without the model functions, ``(run, settings, out)``
    (:class:`FilterCode`), written by :meth:`~hybridlog.estimators.unrolled.Program.function`;
    it runs in a module with ``math`` and ``LOG_2PI``
    (:func:`~hybridlog.estimators.unrolled.module_source`).  The generated module is cached by
    model (:func:`hybridlog.model.compiled.load_generated`); ``modules`` names the modules
    whose code shapes the source besides ``generate``'s own (their text is part of the key).
    """

    generate: Callable[[HybridModel], str]
    function: str
    applies: Callable[[HybridModel], bool] = fits_unrolled
    """Whether ``auto`` takes the accelerator for a model."""
    modules: tuple[str, ...] = ("hybridlog.estimators.unrolled",)


@dataclass(frozen=True)
class FilterCode:
    """The code of one filter (see ``docs/architecture.md``, "Compiled code").

    ``loop`` is the generic time loop, plain Python that numba compiles on first use (its
    signature derived from the arguments): ``(f, F, h, H, run, settings, out)``, the model's
    mode functions (first-class functions: one machine code for every model), the
    :class:`FilterRun`, the filter's own settings (a named tuple) and the
    :class:`FilterBuffers`.  ``accelerator`` is optional and takes the same frame.  The mode
    functions stay four arguments: numba types a tuple of first-class functions only through
    its experimental unification of function types (it warns, and a named tuple of them does
    not match the compiled signature at the call).
    """

    name: str
    loop: Callable[..., None]
    accelerator: Accelerator | None = None


def _diverged(
    code: FilterCode, model: HybridModel, signals: AlignedSignals, row: int
) -> ModelError:
    return ModelError(
        f"{model.origin or model.name}: {code.name} diverged at t = {signals.time[row]:g} s "
        f"(sample {row}): the state estimate is not finite; a Jacobian of the model may be "
        "infinite there"
    )


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

    ``kernel``: ``unrolled`` (the filter's accelerator), ``loops`` (the generic compiled
    loop) or ``auto`` (the accelerator where it applies, see :class:`Accelerator`);
    ``jit=False`` runs the generic loop as plain Python on plain-Python mode functions, the
    tests' reference.
    """
    if kernel not in KERNELS:
        raise ValueError(f"unknown kernel {kernel!r}")
    accelerator = code.accelerator
    if kernel == "unrolled" and accelerator is None:
        raise ValueError(f"{code.name} has no accelerator")
    buffers = FilterBuffers.allocate(model, signals.n_samples, store_covariances=store_covariances)
    frame = (FilterRun.of(model, signals, code.name), settings, buffers)
    loop: Callable[..., None]
    arguments: tuple[Any, ...]
    if (
        jit
        and accelerator is not None
        and (kernel == "unrolled" or (kernel == "auto" and accelerator.applies(model)))
    ):
        arguments = frame
        modules = (accelerator.generate.__module__, *accelerator.modules)
        loop, compile_s = compile_generated(
            model,
            code.name,
            lambda: module_source(model, accelerator.generate(model)),
            modules,
            accelerator.function,
            arguments,
        )
    else:
        start = time.perf_counter()
        compiled = compile_model(model, jit=jit)
        arguments = (compiled.f, compiled.F, compiled.h, compiled.H, *frame)
        loop = compile_for(code.loop, arguments) if jit else code.loop
        compile_s = time.perf_counter() - start
    start = time.perf_counter()
    with populated_beside([*buffers, *arrays_in(settings)]):
        loop(*arguments)
    runtime = time.perf_counter() - start
    finite = np.isfinite(buffers.state_means).all(axis=1)
    if not finite.all():
        raise _diverged(code, model, signals, int(np.argmin(finite)))
    return buffers.result(
        code.name, options, model, signals, runtime_s=runtime, compile_s=compile_s
    )
