"""Aligned signals: what every log reader produces and every estimator consumes."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]

SHORTEST_DT_S = 1e-9
"""The shortest sample time: the grid counts whole nanoseconds."""
LONGEST_DT_S = 1e7
"""The longest sample time or gap (about 116 days): the grid counts nanoseconds in int64
(up to 9.2e9 s), and a gap of several sample times must fit."""
MAX_SUBSTEPS = 100_000
"""The most integration steps per sample of a continuous-time model (``dt / step``); more
would take hours on any log, with no gain in accuracy a log's sample time could show."""

MAX_MAGNITUDE = 2.0**480
"""Largest magnitude (≈ 3.1e144) of a signal value hybridlog accepts from a log.

Metrics square differences of values and sum them over the log: with ``|v| < 2**480`` a
difference is below ``2**481`` and its square below ``2**962``, so a sum over up to
``2**61`` samples (more than any log holds) stays below float64's ``2**1024``.  A larger
value cannot be a measurement; it is what corrupt bytes decode to (``-1e271``).
"""

NO_TRUE_MODE = -1
"""The true-mode code of a sample without truth: before the log's first true-mode sample, or
where a sampled true mode has no sample within ``dt/2`` (a gap of any length).

A true mode (or a component's) that starts after the first sample time leaves the samples
before it without truth, as a true state that starts late does; one that repeats its label
(sampled, not recorded only at its switches) leaves those of its silences, where it may
have switched unseen (:mod:`hybridlog.io.align`).  The mode metrics score the other samples.
Every reader of true-mode codes masks it: as an index it would pick the last mode without a
word.
"""


def covered_from(codes: IntArray) -> int:
    """Index of the first sample with a true mode (``codes.size`` when none has one)."""
    covered = np.flatnonzero(codes != NO_TRUE_MODE)
    return int(covered[0]) if covered.size else int(codes.size)


def first_uncovered(codes: IntArray) -> int | None:
    """Index of the first sample without a true mode after the first with one, else ``None``.

    A sampled true mode's gap (or its end before the log's) leaves such samples.
    """
    start = covered_from(codes)
    missing = np.flatnonzero(codes[start:] == NO_TRUE_MODE)
    return start + int(missing[0]) if missing.size else None


@dataclass(frozen=True)
class ComponentTruth:
    """The true mode of one component of a ``[components]`` model, sample by sample.

    Attributes
    ----------
    labels:
        The component's mode ids.
    codes:
        Index into ``labels`` of each sample's true mode, shape ``(N,)``;
        :data:`NO_TRUE_MODE` before the component's first true-mode sample and in its
        gaps (no sample within ``dt/2``) when it is sampled.
    """

    labels: tuple[str, ...]
    codes: IntArray


def _no_components() -> Mapping[str, ComponentTruth]:
    return MappingProxyType({})


@dataclass(frozen=True)
class AlignedSignals:
    """Input/output samples on the model's grid ``t0 + k*dt``.

    Row ``k`` holds the input ``u(k)`` applied from ``t_k`` to ``t_{k+1}`` and the output
    ``y(k)`` measured at ``t_k``.  Ground truth, when the log has it, uses the same rows.

    Attributes
    ----------
    source:
        Path (or name) of the log the samples came from, for reports and errors.
    time:
        Sample times in seconds, shape ``(N,)``.
    inputs:
        ``u``, shape ``(N, n_u)``, columns in the order of ``input_names``.
    outputs:
        ``y``, shape ``(N, n_y)``, columns in the order of ``output_names``.
    truth_modes:
        True mode of each sample as an index into ``mode_ids`` of the model, shape ``(N,)``,
        or ``None`` when the log has no ground-truth mode; :data:`NO_TRUE_MODE` for the
        samples before a true mode that starts late (:func:`covered_from`) and in a sampled
        true mode's gaps (no sample within ``dt/2``).
    truth_states:
        True states, shape ``(N, n_x)`` with NaN in columns the log does not have, or ``None``.
    truth_components:
        For a ``[components]`` model, the true mode of each component the log has (its
        ``mode.<component>`` column or ``/truth/mode/<component>`` topic), in the model's
        component order; empty otherwise.
    command_names, commands:
        For a ``[components]`` model, the commands its transition rules' ``when`` name that
        the log has, and their values, shape ``(N, len(command_names))``, held onto the grid
        as inputs are (row ``k`` holds ``u_d(k)``, paper 002 eq. (4)); ``None`` without any.
    unmeasured_outputs:
        ``True`` where the log has no sample of the output within ``dt/2`` of the row's time
        and ``outputs`` holds a value taken from the samples around (a gap up to
        ``max_gap`` bridged, SPEC §5), shape ``(N, n_y)``; ``None`` where every row was
        measured.  What the estimators update on, what is reported as measured and what is
        scored is :meth:`measured_outputs`, NaN there: no estimator takes the stand-in for
        a measurement (an update on the measured outputs alone, prediction only where none
        is).
    piece:
        The part of the log the signals hold when ``--split-gaps`` cut it (``--split-gaps
        piece 1 of 3, t = 0 … 1 s, the longest``); empty: the whole log.  ``source`` then
        names it too (``log.csv (--split-gaps piece 1 of 3, ...)``), so that every message
        about the signals says which piece of the log it is about.
    """

    source: str
    time: FloatArray
    input_names: tuple[str, ...]
    output_names: tuple[str, ...]
    inputs: FloatArray
    outputs: FloatArray
    truth_modes: IntArray | None = None
    state_names: tuple[str, ...] = ()
    truth_states: FloatArray | None = None
    truth_components: Mapping[str, ComponentTruth] = field(default_factory=_no_components)
    command_names: tuple[str, ...] = ()
    commands: FloatArray | None = None
    unmeasured_outputs: BoolArray | None = None
    piece: str = ""

    @property
    def n_samples(self) -> int:
        """Number of rows on the grid."""
        return int(self.time.shape[0])

    def rows(self, start: int, stop: int) -> AlignedSignals:
        """Rows ``start:stop`` of every per-sample array, as views (nothing is copied).

        For the tables of a chunk of a run's result: the chunk's rows of the signals, whose
        arrays stay those of the whole run.

        Parameters
        ----------
        start, stop:
            The rows, ``0 <= start <= stop <= n_samples``.

        Returns
        -------
        AlignedSignals
            The same names and source; ``stop - start`` samples.

        Raises
        ------
        ValueError
            For rows outside the signals (a slice would silently shorten them).

        """
        if not 0 <= start <= stop <= self.n_samples:
            raise ValueError(f"rows {start}:{stop} of {self.n_samples} samples")
        return replace(
            self,
            time=self.time[start:stop],
            inputs=self.inputs[start:stop],
            outputs=self.outputs[start:stop],
            truth_modes=None if self.truth_modes is None else self.truth_modes[start:stop],
            truth_states=None if self.truth_states is None else self.truth_states[start:stop],
            truth_components={
                name: ComponentTruth(truth.labels, truth.codes[start:stop])
                for name, truth in self.truth_components.items()
            },
            commands=None if self.commands is None else self.commands[start:stop],
            unmeasured_outputs=(
                None if self.unmeasured_outputs is None else self.unmeasured_outputs[start:stop]
            ),
        )

    def checked(self) -> AlignedSignals:
        """The signals as the estimators take them, or a one-line refusal.

        ``time``, ``inputs`` and ``outputs`` as float64, C-contiguous and writable arrays of
        consistent shapes, the inputs and outputs finite: what
        :func:`hybridlog.io.load_signals` and :meth:`SimulatedLog.signals
        <hybridlog.simulate.SimulatedLog.signals>` give already (returned as they are, no
        copy).  Signals built by hand from lists, frames, float32, integer, strided or
        read-only arrays are converted (copied where needed): a read-only array had raised
        numba's ``TypeError`` from a compiled estimator, a list an ``AttributeError``, a NaN
        SciPy's ``ValueError``.  An output the log did not measure is marked in
        ``unmeasured_outputs``, with a stand-in value in ``outputs``, never a NaN there.

        Raises
        ------
        LogError
            An array that is not numbers or of the wrong shape, or an input or output that
            is not finite (naming ``source``, the symbol, the row and its time).
        """
        from hybridlog.errors import LogError

        time, inputs, outputs = (
            _float_rows(self.source, name, getattr(self, name))
            for name in ("time", "inputs", "outputs")
        )
        if time.ndim != 1:
            raise LogError(f"{self.source}: time: shape {time.shape}, not (N,)")
        for name, values, names in (
            ("inputs", inputs, self.input_names),
            ("outputs", outputs, self.output_names),
            ("unmeasured_outputs", self.unmeasured_outputs, self.output_names),
        ):
            if values is not None and np.shape(values) != (time.size, len(names)):
                raise LogError(
                    f"{self.source}: {name}: shape {np.shape(values)}, not "
                    f"({time.size}, {len(names)}) for {time.size} samples of {len(names)} symbols"
                )
        _refuse_non_finite(self.source, "inputs", inputs, self.input_names, time)
        _refuse_non_finite(self.source, "outputs", outputs, self.output_names, time)
        if time is self.time and inputs is self.inputs and outputs is self.outputs:
            return self
        return replace(self, time=time, inputs=inputs, outputs=outputs)

    @property
    def measures_every_output(self) -> bool:
        """Whether the log measured every output at every row (no stand-in value)."""
        return self.unmeasured_outputs is None or not bool(self.unmeasured_outputs.any())

    def measured_outputs(self) -> FloatArray:
        """``outputs`` with NaN where the log did not measure them (``unmeasured_outputs``).

        What MSE, VAF and fit score, estimates.csv writes and the plots draw: a value the
        alignment took from the samples around a gap is the estimators' stand-in, not a
        measurement to score a prediction against.  ``outputs`` itself (no copy) when every
        row was measured.
        """
        if self.unmeasured_outputs is None:
            return self.outputs
        return np.where(self.unmeasured_outputs, np.nan, self.outputs)


def _float_rows(source: str, name: str, given: npt.ArrayLike) -> FloatArray:
    """``given`` as a float64, C-contiguous and writable array (itself where it is one)."""
    from hybridlog.errors import LogError

    try:
        return np.require(np.asarray(given), np.float64, ("C", "W"))
    except (TypeError, ValueError) as err:
        raise LogError(f"{source}: {name}: not an array of numbers ({err})") from err


def _refuse_non_finite(
    source: str, name: str, values: FloatArray, names: tuple[str, ...], time: FloatArray
) -> None:
    """Refuse the first value of ``values`` that is not finite, naming its symbol and time."""
    if np.isfinite(values.sum()):  # no temporary: values below MAX_MAGNITUDE sum finite
        return
    rows, columns = np.nonzero(~np.isfinite(values))
    if rows.size:
        from hybridlog.errors import LogError
        from hybridlog.times import format_time

        row, column = int(rows[0]), int(columns[0])
        raise LogError(
            f"{source}: {name}: {names[column]} = {values[row, column]} at "
            f"t = {format_time(float(time[row]))} s (row {row}) is not finite"
        )
