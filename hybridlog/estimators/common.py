"""What the filter estimators share: noise stacks, output buffers, the runner of their code.

A filter is a generic time loop over the model's compiled functions (mandatory, one
:class:`FilterCode`) and may add an :class:`Accelerator`: straight-line code generated for
the model, which :func:`run_filter` picks for the models it applies to.  Both compute the
same thing (``tests/estimators/test_kernels.py`` checks every accelerator against the plain path).
Both compute any run of consecutive rows from the state the rows before left (a
:class:`Chunk`): :func:`run_filter_chunks` yields a log's result chunk after chunk in buffers
of one chunk, and :func:`run_filter` is its one chunk (``tests/estimators/test_filter_chunks.py``
checks that the chunks put end to end are the whole result, bit for bit).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from functools import partial
from typing import TYPE_CHECKING, Any, Generic, NamedTuple, TypeVar

import numpy as np

from hybridlog.background import Background
from hybridlog.estimators.result import EstimationResult
from hybridlog.estimators.unrolled import fits_unrolled, module_source
from hybridlog.estimators.vouch import check_result
from hybridlog.jit import compile_for
from hybridlog.model.compiled import ModelFunction, compile_generated, compile_model
from hybridlog.model.hybrid_model import WEIGHS_OUTPUTS
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
    ``estimator``; so is a covariance the file does not give
    (:meth:`~hybridlog.model.hybrid_model.HybridModel.require_measurement_noise`).
    """
    who = f"estimator '{estimator}'" if estimator else "the filter"
    model.require_measurement_noise(f"{who}{WEIGHS_OUTPUTS}")
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
            contiguous(signals.measured_outputs()),  # NaN: not measured (kernels.left_out)
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
    surprise: FloatArray
    """Per row, the smallest over the modes of ``γᵀ S⁻¹ γ``, the squared length of the
    measurement's innovation in its predicted standard deviations (NaN: not computed, as at
    the prior's row or by a filter that keeps none; no rows: not kept).  A value past
    :func:`~hybridlog.estimators.vouch.surprise_limit` is a sample no mode can explain."""
    whitened: FloatArray
    """Per row, ``L⁻¹ γ`` (``S = L Lᵀ``) of the mode whose ``γᵀ S⁻¹ γ`` is :attr:`surprise`,
    shape ``(N, n_y)`` (NaN: not computed; no rows: the filter keeps none), which
    :mod:`hybridlog.estimators.consistency` tests over the whole log."""

    @classmethod
    def allocate(
        cls,
        model: HybridModel,
        n_samples: int,
        *,
        store_covariances: bool = False,
        whitened: bool = False,
    ) -> FilterBuffers:
        """Buffers for ``n_samples`` rows; full covariances and whitened innovations when asked."""
        n_x = model.n_states
        return cls(
            modes=np.zeros(n_samples, dtype=np.int64),
            mode_probabilities=np.zeros((n_samples, model.n_modes)),
            state_means=np.zeros((n_samples, n_x)),
            state_variances=np.zeros((n_samples, n_x)),
            output_predictions=np.full((n_samples, model.n_outputs), np.nan),
            covariances=np.zeros((n_samples if store_covariances else 0, n_x, n_x)),
            surprise=np.full(n_samples, np.nan),
            whitened=np.full((n_samples if whitened else 0, model.n_outputs), np.nan),
        )

    def head(self, rows: int) -> FilterBuffers:
        """The first ``rows`` rows (views), or the buffers themselves when they have as many."""
        if rows == self.modes.shape[0]:
            return self
        return FilterBuffers(
            self.modes[:rows],
            self.mode_probabilities[:rows],
            self.state_means[:rows],
            self.state_variances[:rows],
            self.output_predictions[:rows],
            self.covariances[:rows],
            self.surprise[:rows],
            self.whitened[:rows],
        )

    def result(
        self,
        name: str,
        options: dict[str, Any],
        model: HybridModel,
        time: FloatArray,
        *,
        runtime_s: float,
        compile_s: float,
        notes: tuple[str, ...] = (),
    ) -> EstimationResult:
        """Package the filled buffers, the rows at ``time``, as the common result type."""
        return EstimationResult(
            estimator=name,
            options=options,
            time=time,
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
            whitened_innovations=self.whitened if self.whitened.shape[0] else None,
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
    ``k → k+1`` (the estimate of ``x(k)`` given ``q(k+1) = j``; Kim's smoother), or, when the
    IMM's ``ImmSettings.filtered_store`` asks for it (expectation correction, ``smoother =
    "ec"``), the mode-matched filtered ``x̂_j(k|k)``, ``P_j(k|k)`` in the same records; in
    the last row the mode-matched filtered ``x̂_j(N−1|N−1)``, ``P_j(N−1|N−1)``.  Arrays
    nothing after the filter needs have no rows (:meth:`allocate`), so the filter's loop
    writes them only on demand: either smoother needs the states (``8 N n_q (n_x +
    n_x(n_x+1)/2)`` bytes, 206 MiB for 10^6 samples, 3 modes, 3 states), the Viterbi path
    the likelihoods (``8 N n_q`` bytes).  The filter writes every row, so they are allocated
    uninitialised.
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


State = TypeVar("State", bound=tuple[Any, ...])
"""A filter's loop-carried state: a named tuple of arrays (:attr:`FilterCode.prior`)."""


class Chunk(NamedTuple, Generic[State]):
    """The rows one call of a filter's loop computes, and the state it resumes from.

    The loop computes rows ``first … stop−1`` of the log (row 0 is the prior, row ``k+1``
    the step from sample ``k``) into rows ``0 … stop−first−1`` of its
    :class:`FilterBuffers`.  ``state`` is the filter's loop-carried state, a named tuple of
    arrays (:attr:`FilterCode.prior`): on entry the state after row ``first−1`` (the prior
    when ``first`` is 0), on return the state after row ``stop−1``, which the next chunk
    resumes from.  Nothing else crosses a step, so the chunks of a log compute, operation
    for operation, what one call over the whole log computes (:func:`run_filter_chunks`).
    """

    first: int
    stop: int
    state: State


@dataclass(frozen=True)
class Accelerator:
    """Straight-line code a filter generates for a model: optional, faster, the same result.

    ``generate(model)`` returns the source of one function named ``function`` taking the
    frame of the generic loop without the model functions, ``(run, settings, chunk, out)``
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
    masked: Callable[[HybridModel], str] | None = None
    """The source of the same function for a log with an output not measured at some row
    (:attr:`~hybridlog.signals.AlignedSignals.measures_every_output` false: NaN in
    ``run.outputs``), updating on the measured outputs alone as the generic loop does
    (:func:`~hybridlog.estimators.kernels.leave_out_unmeasured`); cached apart.  ``None``:
    ``generate``'s code updates on every output, and such a log runs the generic loop."""


@dataclass(frozen=True)
class FilterCode:
    """The code of one filter (see ``docs/architecture.md``, "Compiled code").

    ``loop`` is the generic time loop, plain Python that numba compiles on first use (its
    signature derived from the arguments): ``(f, F, h, H, run, settings, chunk, out)``, the
    model's mode functions (first-class functions: one machine code for every model), the
    :class:`FilterRun`, the filter's own settings (a named tuple), the :class:`Chunk` of rows
    to compute with the state it resumes from, and the :class:`FilterBuffers`.
    ``accelerator`` is optional and takes the same frame.  The mode functions stay four
    arguments: numba types a tuple of first-class functions only through its experimental
    unification of function types (it warns, and a named tuple of them does not match the
    compiled signature at the call).
    """

    name: str
    loop: Callable[..., None]
    prior: Callable[[FilterRun], tuple[Any, ...]]
    """The loop-carried state before the first step (:class:`Chunk`): the run's prior."""
    accelerator: Accelerator | None = None
    whitened: bool = False
    """Whether the loop writes :attr:`FilterBuffers.whitened` (else it has no rows)."""


def _masked(code: FilterCode) -> bool:
    """Whether ``code``'s accelerator has code for a log with outputs not measured."""
    return code.accelerator is not None and code.accelerator.masked is not None


def _compiled_loop(
    code: FilterCode,
    model: HybridModel,
    frame: tuple[Any, ...],
    *,
    jit: bool,
    kernel: str,
    every_output: bool,
) -> tuple[Callable[..., None], tuple[Fn, ...], float]:
    """The loop of the code path ``kernel`` and ``jit`` pick, compiled for ``frame``.

    ``every_output``: whether every output was measured at every row (else the
    accelerator's ``masked`` code, or without one the generic loop).
    Returns the loop, the model functions it takes before the frame (none for an
    accelerator) and the seconds spent generating, compiling or loading them.
    """
    accelerator = code.accelerator
    generate = None
    if accelerator is not None:
        generate = accelerator.generate if every_output else accelerator.masked
    if (
        jit
        and accelerator is not None
        and generate is not None
        and (kernel == "unrolled" or (kernel == "auto" and accelerator.applies(model)))
    ):
        modules = (accelerator.generate.__module__, *accelerator.modules)
        loop, compile_s = compile_generated(
            model,
            code.name if every_output else f"{code.name}_masked",
            lambda: module_source(model, generate(model)),
            modules,
            accelerator.function,
            frame,
        )
        return loop, (), compile_s
    start = time.perf_counter()
    compiled = compile_model(model, jit=jit)
    functions = (compiled.f, compiled.F, compiled.h, compiled.H)
    loop = compile_for(code.loop, (*functions, *frame)) if jit else code.loop
    return loop, functions, time.perf_counter() - start


class CheckedAs(NamedTuple):
    """The model a filter's results are checked in, when it ran on another one.

    A run on a model's mode pairs (:mod:`~hybridlog.estimators.mode_pairs`) is checked
    (:func:`~hybridlog.estimators.vouch.check_result`) in the model's own modes, so that a
    refusal names the keys of the file and the modes the log's truth is written in, not
    the pairs ``up->down`` the user never wrote.
    """

    model: HybridModel
    """The model whose modes and keys the checks name."""
    read: Callable[[EstimationResult], EstimationResult]
    """A result of the model the filter ran on, read in :attr:`model`'s modes."""


def run_filter_chunks(
    code: FilterCode,
    model: HybridModel,
    signals: AlignedSignals,
    settings: tuple[Any, ...],
    options: dict[str, Any],
    *,
    jit: bool,
    kernel: str,
    store_covariances: bool,
    rows: int,
    checked_as: CheckedAs | None = None,
) -> Iterator[EstimationResult]:
    """Run a filter over the aligned signals in consecutive chunks of at most ``rows`` rows.

    Yields results covering rows ``[0, N)`` in order, each ``rows`` long but the last (an
    empty log: one empty result), so that a consumer holds one chunk, not the whole result.
    Each call of the loop resumes from the state the one before left (:class:`Chunk`), so
    the chunks put end to end are, bit for bit, :func:`run_filter`'s result, which is this
    run in one chunk.  Row 0 of the first chunk is the prior.

    The chunks' arrays are views of buffers of ``min(rows, N)`` rows allocated once, which
    a later chunk overwrites: a consumer copies what it keeps before asking for the next.
    While the consumer takes a chunk, the next one is computed in a thread (the compiled
    loop releases the GIL) into a second set of buffers, so a streamed run costs the time
    of the longer of the filter and its consumer, not their sum; the chunk after it waits
    until the consumer asks for the next, whose buffers are then free again.
    Each chunk's ``time`` is its slice of ``signals.time``; its ``runtime_s`` is the loop's
    time so far and its ``compile_s`` the set-up's, so the last chunk carries the run's
    totals.  The checks (``kernel``, the noise covariances) and the compilation happen at
    the call, the loop as the chunks are asked for.  ``kernel``, ``jit``: as for
    :func:`run_filter`.  ``checked_as``: the model the chunks are checked in
    (:class:`CheckedAs`; the chunks yielded are the run's own).

    Raises
    ------
    ModelError
        When a chunk holds a number nobody can vouch for (a state or variance not finite, a
        negative variance, ...: :func:`~hybridlog.estimators.vouch.check_result`), naming
        the sample by its index in the log and the model's expression that broke where it
        can tell; no chunk follows.
    """
    if rows < 1:
        raise ValueError(f"rows must be at least 1, got {rows}")
    # the discrete-time filters (paper 000 eqs. (1)-(2)): a continuous model has no f, and
    # a library caller's run_imm on one ended in a bare IndexError of the straight-line code
    model.check_supported(f"estimator '{code.name}'", components=True)
    if kernel not in KERNELS:
        raise ValueError(f"unknown kernel {kernel!r}")
    if kernel == "unrolled" and code.accelerator is None:
        raise ValueError(f"{code.name} has no accelerator")
    if kernel == "unrolled" and not signals.measures_every_output and not _masked(code):
        raise ValueError(
            f"{code.name}'s accelerator updates on every output: not for a log with outputs "
            "not measured at some rows (kernel 'loops' or 'auto')"
        )
    n = signals.n_samples
    run = FilterRun.of(model, signals, code.name)
    size = min(rows, n)
    allocate = partial(
        FilterBuffers.allocate,
        model,
        size,
        store_covariances=store_covariances,
        whitened=code.whitened,
    )
    buffers = [allocate()]
    if n > rows:  # a second set: the next chunk is computed while the caller takes this one
        buffers.append(allocate())
    opening: Chunk[tuple[Any, ...]] = Chunk(0, size, code.prior(run))
    loop, functions, compile_s = _compiled_loop(
        code,
        model,
        (run, settings, opening, buffers[0]),
        jit=jit,
        kernel=kernel,
        every_output=signals.measures_every_output,
    )

    def compute(chunk: Chunk[tuple[Any, ...]], into: FilterBuffers) -> float:
        start = time.perf_counter()
        with populated_beside([*into, *arrays_in(settings)]):
            loop(*functions, run, settings, chunk, into)
        return time.perf_counter() - start

    def chunks() -> Iterator[EstimationResult]:
        chunk, which, runtime = opening, 0, 0.0
        before: FloatArray | None = None
        pending: Background[float] | None = None
        try:
            spent = compute(chunk, buffers[which])
            while True:
                runtime += spent
                filled = buffers[which].head(chunk.stop - chunk.first)
                result = filled.result(
                    code.name,
                    options,
                    model,
                    signals.time[chunk.first : chunk.stop],
                    runtime_s=runtime,
                    compile_s=compile_s,
                )
                check_result(
                    model if checked_as is None else checked_as.model,
                    signals,
                    result if checked_as is None else checked_as.read(result),
                    first=chunk.first,
                    before=before,
                    surprise=filled.surprise,
                    paired=checked_as is not None,
                )
                if chunk.stop > chunk.first:  # the next chunk's diagnosis starts from here
                    before = filled.state_means[-1].copy()
                if chunk.stop < n:  # the compiled loop releases the GIL: it runs beside
                    following = chunk._replace(first=chunk.stop, stop=min(chunk.stop + rows, n))
                    into = buffers[1 - which]
                    pending = Background(
                        partial(compute, following, into), f"hybridlog-{code.name}-chunk"
                    )
                yield result
                if pending is None:
                    return
                spent = pending.result()
                pending = None
                chunk, which = following, 1 - which
        finally:
            if pending is not None:  # the caller stopped early: the loop still writes
                pending.wait()

    return chunks()


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
    checked_as: CheckedAs | None = None,
) -> EstimationResult:
    """Run a filter over the aligned signals with the chosen code path: the whole result.

    ``kernel``: ``unrolled`` (the filter's accelerator), ``loops`` (the generic compiled
    loop) or ``auto`` (the accelerator where it applies, see :class:`Accelerator`);
    ``jit=False`` runs the generic loop as plain Python on plain-Python mode functions, the
    tests' reference.  The one chunk of :func:`run_filter_chunks`.
    """
    (whole,) = run_filter_chunks(
        code,
        model,
        signals,
        settings,
        options,
        jit=jit,
        kernel=kernel,
        store_covariances=store_covariances,
        rows=max(signals.n_samples, 1),
        checked_as=checked_as,
    )
    return whole
