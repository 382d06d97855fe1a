"""What an estimator needs of the model and the log, checked before it runs.

An estimator declares its needs as :class:`Capabilities` (typed flags in its registry
entry); :class:`ModelTraits` says what a loaded model offers.  :meth:`Capabilities.mismatch`
compares the two and returns the first reason the estimator cannot run, so the run layer can
refuse with one line naming the model file and the estimator instead of failing deep inside
an algorithm.  This module imports nothing heavy at import time (sympy only when a model's
state measurement is asked for): the registry, and through it ``--help``, import it.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from hybridlog.model.hybrid_model import HybridModel
    from hybridlog.signals import AlignedSignals, IntArray

__all__ = [
    "MAX_JOINT_MODES",
    "Capabilities",
    "ModelTraits",
    "missing_command",
    "unmeasured_state",
]

MAX_JOINT_MODES = 256
"""The most joint modes a ``[components]`` model is enumerated into
(:func:`~hybridlog.estimators.cpha.joint.joint_mode_model`)."""


STEP_FROM_NOTE = (
    "state-driven model: the mode of sample k governs the step from x(k) to x(k+1) (paper 001 "
    "eq. (1)), so sample k shows the mode this estimator found for that step, at sample k+1 "
    "(one sample of look-ahead); the last sample, whose step the log does not hold, keeps its "
    "own"
)
"""What an estimator with :attr:`Capabilities.modes_of_the_step_into` does on a state-driven
model: its report's note and its line in ``docs/estimators.md``."""

STEP_INTO_OUTPUTS_WARNING = (
    "WARNING: state-driven model whose output equations differ by mode: y(k) follows the mode "
    "of the step from x(k) (paper 001 eq. (1)), this estimator weighs it with that of the step "
    "into x(k) (paper 000 eq. (2)): switches found late or missed, large innovations there"
)
"""Said with :data:`STEP_FROM_NOTE` where the modes' ``h`` differ (a mode-dependent sensor
map): the moved modes do not make up for the output equation the filter applied."""


def runs_on_pairs(model: HybridModel) -> bool:
    """Whether an estimator that can runs ``model`` on its mode pairs.

    :attr:`Capabilities.runs_on_mode_pairs`, :mod:`hybridlog.estimators.mode_pairs`: a
    state-driven model whose output equations differ by mode
    (:attr:`~hybridlog.model.hybrid_model.HybridModel.outputs_differ_by_mode`).
    """
    return model.state_driven and model.outputs_differ_by_mode


@dataclass(frozen=True)
class Capabilities:
    """What an estimator needs (checked before it runs) and what it offers.

    Attributes
    ----------
    needs_linear_model:
        Every mode's ``f`` and ``h`` must be affine in the states and inputs.
    needs_markov_matrix:
        The model must have a ``[transitions]`` Markov matrix.
    uses_markov_matrix:
        The model's ``[transitions]`` matrix is used when present (a default otherwise).
    needs_switching_signal:
        The log must carry the switching signal (the true mode, ``--map truth.mode=PATH``).
    applies_commands:
        The estimator applies a ``[components]`` model's transition rules with ``when`` by
        the logged commands (paper 002 eq. (4)): the log must hold every command a rule's
        ``when`` names (:func:`missing_command`).
    needs_measurement_noise:
        The estimator weighs the outputs by their measurement noise covariance ``R`` (its
        likelihoods and gains): the model file must give it (``[noise] measurement`` or a
        mode's own), never a guessed one.
    needs_measured_state:
        The continuous state must be measured: the outputs are the states in every mode.
    needs_components:
        The model must describe ``[components]`` (concurrent probabilistic automata).
    enumerates_components:
        A ``[components]`` model is run on its enumerated joint known modes (at most
        :data:`MAX_JOINT_MODES`); without it, and without ``needs_components``, such a
        model is refused.
    needs_boolean_affine:
        The model must be boolean-affine (``booleans = [...]``, paper 003 eq. (48)).
    applies_jump_maps:
        The estimator applies the model's ``[jumps]`` state resets at switches; without it a
        model with jump maps is refused (they would be silently ignored).
    continuous_time:
        The estimator works on continuous-time models (and only on them); ``False``: on
        discrete-time models only.
    supports_smoothing:
        A fixed-interval smoother can run after the filter (``--smooth``).
    no_smoothing:
        Why the method admits no offline pass, when it does not: the reason the one-line
        refusal of ``--smooth``, ``--mode-sequence viterbi|kbest`` (and ``--set`` of the
        offline options) gives (issue 12).
    mode_rule:
        How the estimator decides each sample's mode when its options have no
        ``mode_sequence`` (so no argmax to choose): the reason the refusal of
        ``--mode-sequence argmax`` gives, which the smoother's reason does not answer.
    needs_single_output:
        The model must have exactly one output (paper 004's observer, ``h`` maps to R).
    needs_detectable:
        Every mode of a linear discrete-time model must be detectable at every decay rate the
        observer design takes (at most 1): no eigenvalue of ``A`` with ``|λ| ≥ 1`` that the
        outputs do not see, for which paper 001's LMI (15) has no solution whatever the log
        (:attr:`ModelTraits.undetectable`).
    needs_drift_observable:
        Every mode's ``Φ = [h, L_f h, …]`` must reach every state (paper 004, eq. (7)): a
        state that neither ``h`` nor, through the drift's ``dx``, any derivative of it
        reads leaves ``Q = ∂Φ/∂x`` singular at every state
        (:attr:`ModelTraits.drift_blind`).
    modes_of_the_step_into:
        The estimator's mode of sample k is the one under which ``x(k)`` came from
        ``x(k-1)``, as a Markov-jump filter's (paper 000 eq. (2)).  On a state-driven model,
        whose mode of sample k governs the step from ``x(k)`` (paper 001 eq. (1)), its
        modes are moved one sample earlier
        (:meth:`~hybridlog.estimators.result.EstimationResult.with_modes_of_the_step_from`).
    runs_on_mode_pairs:
        With :attr:`modes_of_the_step_into`: on a state-driven model whose output equations
        differ by mode the estimator runs on the mode pairs
        (:mod:`hybridlog.estimators.mode_pairs`) and gives the modes of the step from each
        sample itself; nothing is moved.
    state_variances:
        The estimator computes state variances (``False``: its result holds NaN for them,
        which are then not read); a defined one must be finite and not negative
        (:mod:`hybridlog.estimators.vouch`).
    unpredicted_outputs:
        The estimator may leave an output without a one-step-ahead prediction (NaN: an
        output no hypothesis predicts); otherwise every sample after the first has one.
    """

    needs_linear_model: bool = False
    needs_markov_matrix: bool = False
    uses_markov_matrix: bool = False
    needs_switching_signal: bool = False
    applies_commands: bool = False
    needs_measured_state: bool = False
    needs_measurement_noise: bool = False
    needs_components: bool = False
    enumerates_components: bool = False
    needs_boolean_affine: bool = False
    applies_jump_maps: bool = False
    continuous_time: bool = False
    supports_smoothing: bool = False
    needs_single_output: bool = False
    needs_drift_observable: bool = False
    needs_detectable: bool = False
    no_smoothing: str = ""
    mode_rule: str = ""
    modes_of_the_step_into: bool = False
    runs_on_mode_pairs: bool = False
    state_variances: bool = True
    unpredicted_outputs: bool = False

    def needs(self) -> tuple[str, ...]:
        """The needs in words, for ``--help`` and the docs."""
        words = ["continuous-time model" if self.continuous_time else "discrete-time model"]
        if self.needs_linear_model:
            words.append("linear modes")
        if self.needs_detectable:
            words.append("every mode detectable (no unobserved eigenvalue with |λ| ≥ 1)")
        if self.needs_markov_matrix:
            words.append("Markov matrix")
        elif self.uses_markov_matrix:
            words.append("Markov matrix (optional)")
        if self.needs_components:
            words.append("[components]")
        elif self.enumerates_components:
            words.append(f"[components] as joint modes (optional, at most {MAX_JOINT_MODES})")
        if self.needs_boolean_affine:
            words.append("boolean-affine model")
        if self.applies_jump_maps:
            words.append("jump maps (optional)")
        if self.needs_measurement_noise:
            words.append("measurement noise covariance ([noise] measurement)")
        if self.needs_measured_state:
            words.append("measured state")
        if self.needs_single_output:
            words.append("one output")
        if self.needs_drift_observable:
            words.append("every state read by the output or its drift derivatives")
        if self.needs_switching_signal:
            words.append("switching signal in the log (a one-mode model: none)")
        if self.applies_commands:
            words.append("each command a transition rule's when names, in the log")
        return tuple(words)

    def mismatch(self, traits: ModelTraits) -> str | None:
        """The first reason the model cannot be used, as ``needs X; the model ...``, or None."""
        if self.continuous_time != traits.continuous:
            wanted = "continuous-time" if self.continuous_time else "discrete-time"
            has = "continuous" if traits.continuous else "discrete"
            return f"needs a {wanted} model; the model's time is {has}"
        if self.needs_components and not traits.components:
            return "needs a model with [components]; the model has none"
        if traits.components and not self.needs_components:
            if not self.enumerates_components:
                return (
                    "needs a model with enumerated [modes]; the model describes concurrent "
                    "[components] (paper 002)"
                )
            if traits.joint_modes > MAX_JOINT_MODES:
                return (
                    f"runs a [components] model on its joint modes, at most {MAX_JOINT_MODES}; "
                    f"the model has {traits.joint_modes:,}"
                )
        if self.needs_boolean_affine and not traits.booleans:
            return "needs a boolean-affine model (booleans = [...]); the model is not one"
        if self.needs_boolean_affine and traits.surplus_booleans is not None:
            return (
                "needs at most as many booleans as states (paper 003, eq. (2)); "
                f"{traits.surplus_booleans}"
            )
        if self.needs_boolean_affine and traits.singular_d is not None:
            return f"needs D(x, u) of full column rank (paper 003, eq. (47)); {traits.singular_d}"
        if traits.jumps and not self.applies_jump_maps:
            return "does not apply jump maps; the model has [jumps] state resets"
        if self.needs_markov_matrix and not traits.markov_matrix:
            return "needs a Markov matrix; the model has no [transitions] table"
        if self.needs_linear_model and traits.nonlinear is not None:
            return f"needs a linear model; the modes are nonlinear: {traits.nonlinear}"
        if self.needs_detectable and traits.undetectable is not None:
            return f"needs every mode detectable from its outputs; {traits.undetectable}"
        if self.needs_measurement_noise and traits.unstated_measurement_noise is not None:
            from hybridlog.model.hybrid_model import WEIGHS_OUTPUTS

            return f"{WEIGHS_OUTPUTS.strip()}; {traits.unstated_measurement_noise}"
        if self.needs_measured_state and traits.unmeasured_state is not None:
            return f"needs the state measured; {traits.unmeasured_state}"
        if self.needs_single_output and traits.outputs != 1:
            return (
                f"needs a single-output model; the model has {traits.outputs} outputs "
                f"({', '.join(traits.model.outputs)})"
            )
        if self.needs_drift_observable and traits.drift_blind is not None:
            return f"needs every mode drift-observable from its output; {traits.drift_blind}"
        return None

    def signals_mismatch(self, model: HybridModel, signals: AlignedSignals) -> str | None:
        """The first reason the aligned log cannot be used with ``model``, or None.

        Checked by every command before any estimator runs
        (:meth:`~hybridlog.estimators.registry.Prepared.check_signals`): found as the
        estimator started, a log ``compare`` could not give the last estimator named was
        refused after the others had run, their work lost.  An estimator that applies the
        commands (:attr:`applies_commands`) needs each one a transition rule names
        (:func:`missing_command`).

        An estimator that needs the state measured (:attr:`needs_measured_state`) needs
        it at every sample (:func:`unmeasured_state`).

        An estimator that takes every sample's mode from the switching signal
        (:attr:`needs_switching_signal`) needs one that covers the log: a true mode that
        starts late leaves the samples before it without one
        (:data:`~hybridlog.signals.NO_TRUE_MODE`), and a sampled one its gaps (the samples
        without one within ``dt/2``, whatever the gap's length), which the mode metrics leave
        out but such an estimator would read as a mode.  A one-mode model needs none: its
        sigma is that mode (a log without the signal was refused, for a signal of one value),
        and a signal the log has, late or with gaps, is not read.
        """
        if self.applies_commands:
            missing = missing_command(model, signals)
            if missing is not None:
                return missing
        if self.needs_measured_state:
            unmeasured = unmeasured_state(model, signals)
            if unmeasured is not None:
                return unmeasured
        if not self.needs_switching_signal or model.n_modes == 1:
            # a one-mode model's sigma is that mode: the signal, or a gap in it, tells nothing
            # (a log's sampled mode column with gaps was refused, the same log without it ran)
            return None
        if signals.truth_modes is None:
            return (
                "needs the switching signal in the log; map it with --map truth.mode=PATH "
                "(or a 'mode' column)"
            )
        import numpy as np

        from hybridlog.signals import NO_TRUE_MODE, covered_from, first_uncovered  # on a log only
        from hybridlog.times import format_time

        first = covered_from(signals.truth_modes)
        if first > 0:
            return (
                "needs the switching signal at every sample; the true mode starts at "
                f"t={format_time(float(signals.time[first]))} s (sample {first}), after the "
                f"first sample time t={format_time(float(signals.time[0]))} s (map a switching "
                "signal that covers the log with --map truth.mode=PATH)"
            )
        gap = first_uncovered(signals.truth_modes)
        if gap is None:
            return None
        at = f"t={format_time(float(signals.time[gap]))} s (sample {gap})"
        slower = _sampled_every(signals.truth_modes)
        if slower is not None:  # the log's sample time, not a gap
            uncovered = int(np.count_nonzero(signals.truth_modes == NO_TRUE_MODE))
            return (
                "needs the switching signal at every sample; the true mode has none within "
                f"dt/2 of {uncovered:,} of {signals.n_samples:,} sample times, the first at {at}: "
                f"it is sampled every {slower:g} steps of dt = {model.timebase.dt:g} s "
                "(median), so a switch between its samples would go unseen: use a model whose "
                "dt is the log's sample time (or map a switching signal sampled every dt with "
                "--map truth.mode=PATH)"
            )
        return (
            f"needs the switching signal at every sample; the true mode has none within dt/2 "
            f"of {at}: it repeats its label, so it is sampled, and a gap in it may hide a "
            "switch (map a switching signal that covers the log with --map truth.mode=PATH)"
        )


def _sampled_every(codes: IntArray) -> float | None:
    """The median step, in samples, between the samples with a true mode, where 1.5 or more.

    A log sampled at twice the model's ``dt`` was told of "a gap" at its second sample and
    to map another switching signal, when its sample time is not the model's.
    """
    import numpy as np

    from hybridlog.signals import NO_TRUE_MODE

    covered = np.flatnonzero(codes != NO_TRUE_MODE)
    if covered.size < 2:
        return None
    steps = float(np.median(np.diff(covered)))
    return steps if steps >= 1.5 else None


def unmeasured_state(model: HybridModel, signals: AlignedSignals) -> str | None:
    """Why the log does not measure the state at every sample, or None.

    ``sliding-mode`` (paper 003) integrates observer (10), ``ż = G(x, u) + w``, at the
    measured state ``x`` and slides on ``e = x − z``: at a sample the log did not measure
    (``AlignedSignals.unmeasured_outputs``: a gap bridged, or an output slower than the
    model's ``dt``) it has neither, and the value the alignment took from the samples
    around would be read as a measured state.  The paper measures the state continuously
    and says nothing of running without it: the log is refused, naming the first such
    output (in the log's order; the others too), how many samples and the first.
    """
    if signals.unmeasured_outputs is None or not signals.unmeasured_outputs.any():
        return None
    from hybridlog.times import format_time

    unmeasured = signals.unmeasured_outputs
    columns = [j for j in range(unmeasured.shape[1]) if unmeasured[:, j].any()]
    rows = unmeasured[:, columns[0]].nonzero()[0]
    others = [signals.output_names[j] for j in columns[1:]]
    also = f" ({', '.join(others)} too)" if others else ""
    return (
        "needs the state measured at every sample (paper 003, observer (10)); "
        f"{signals.output_names[columns[0]]} has no sample within dt/2 of {rows.size:,} of "
        f"{signals.n_samples:,} sample times, the first at t = "
        f"{format_time(float(signals.time[rows[0]]))} s{also}: use a log that "
        f"measures every output each dt = {model.timebase.dt:g} s, "
        "or a model whose dt is the log's sample time"
    )


def missing_command(model: HybridModel, signals: AlignedSignals) -> str | None:
    """Why the log lacks a command a transition rule's ``when`` names, or None.

    ``needs the command 'cmd' in the log, which a transition rule of component 'valve'
    reads (m.toml: components.valve.transitions[0].when); map it ...``: the first such
    command in the model's order, with the first rule that names it.  Without its values
    the rule cannot be applied, and leaving it out would analyse another model (a
    commanded switch seen as a fault).
    """
    needed: dict[str, tuple[str, str]] = {}
    for component in model.components:
        for rule in component.rules:
            for command in rule.when:
                needed.setdefault(command, (component.name, rule.key))
    have = signals.command_names if signals.commands is not None else ()
    for command in (c for c in model.commands if c in needed and c not in have):
        owner, rule_key = needed[command]
        return (
            f"needs the command {command!r} in the log, which a transition rule of component "
            f"{owner!r} reads ({model.origin or model.name}: {rule_key}.when): the rules are "
            f"applied by the logged commands; map it with --map {command}=FIELD or [signals]"
        )
    return None


RANK_POINTS = 24
"""Random points at which :attr:`ModelTraits.singular_d` evaluates ``D(x, u)``."""


class ModelTraits:
    """What a loaded model offers, as :meth:`Capabilities.mismatch` asks for it.

    Each trait is read off the loaded model; the costly ones are worked out once.
    """

    def __init__(self, model: HybridModel) -> None:
        self.model = model

    @property
    def continuous(self) -> bool:
        """True for a continuous-time model (``time = "continuous"``)."""
        return self.model.is_continuous

    @property
    def components(self) -> bool:
        """True when the model has ``[components]``."""
        return self.model.has_components

    @property
    def joint_modes(self) -> int:
        """How many joint assignments of known modes the ``[components]`` have (1 if none)."""
        return math.prod(len(c.modes) for c in self.model.components)

    @property
    def booleans(self) -> bool:
        """True for a boolean-affine model (``booleans = [...]``)."""
        return self.model.has_booleans

    @property
    def surplus_booleans(self) -> str | None:
        """Why a boolean-affine model has more booleans than states, or None.

        ``D(x, u)`` is n × L: with L > n it is never of full column rank, so eq. (30) cannot
        recover δ from the sliding observer's ``w``; found only once a log had been read, the
        refusal came after ``compare``'s other estimators had run, their work lost, and
        ``hybridlog models FILE`` listed ``sliding-mode`` among the model's estimators.
        """
        affine = self.model.boolean_affine
        if affine is None or len(affine.booleans) <= self.model.n_states:
            return None
        return (
            f"the model has {len(affine.booleans)} booleans ({', '.join(affine.booleans)}) and "
            f"{self.model.n_states} state{'s' if self.model.n_states != 1 else ''}"
        )

    @functools.cached_property
    def singular_d(self) -> str | None:
        """Why ``D(x, u)`` of a boolean-affine model is singular at every state, or None.

        A boolean read only by ``h``, or two booleans that add the same term (``U + 2*V``
        with ``L = 2``, one state affected), make every ``D(x, u)`` singular: eq. (30) can
        never tell the modes apart, which the run said only after a log had been read, and
        ``hybridlog models`` listed ``sliding-mode`` among the model's estimators.  ``D`` is
        evaluated at :data:`RANK_POINTS` random points around ``[initial] state``, within 0.5,
        5 and 50 times its size (at least 1) of it (inputs in [0.5, 1.5]; a point where it is
        not finite is skipped): where none has rank ``L``, no
        state does but a set of measure 0 (its rank as expressions, by sympy, took minutes on
        eight dense booleans).  A model ``D`` is finite at no such point of is not judged: the
        run still refuses a ``D`` singular at every sample of the log.
        """
        affine = self.model.boolean_affine
        if affine is None or len(affine.booleans) > self.model.n_states:
            return None
        import numpy as np
        import sympy

        from hybridlog.model.codegen import lambdify
        from hybridlog.model.derivatives import boolean_affine_split

        try:
            _, columns = boolean_affine_split(affine.dynamics, affine.symbols())
        except ValueError:  # the loader refuses it first
            return None
        xs, us = self.model.symbols()
        evaluate = lambdify([*xs, *us], sympy.Matrix(columns), "numpy")
        draws = np.random.default_rng(0)
        centre = np.asarray(self.model.initial_state, dtype=float)
        scale = np.maximum(np.abs(centre), 1.0)
        ranks = []
        with np.errstate(all="ignore"):
            for point in range(RANK_POINTS):
                spread = 0.5 * 10.0 ** (point % 3)  # near the start, and 10, 100 times wider
                x = centre + scale * draws.uniform(-spread, spread, centre.size)
                if point % 2:  # half of them where every state is positive (a tank's sqrt)
                    x = np.abs(x)
                u = draws.uniform(0.5, 1.5, len(us))
                try:
                    D = np.asarray(evaluate(*x, *u), dtype=float)
                except (ArithmeticError, ValueError, TypeError):
                    continue
                if np.isfinite(D).all():  # columns scaled alike: C1 = 4.7e295 is no rank loss
                    size = np.abs(D).max(axis=0)
                    ranks.append(int(np.linalg.matrix_rank(D / np.where(size > 0, size, 1.0))))
        if not ranks or max(ranks) >= len(affine.booleans):
            return None
        return (
            f"its column j, the derivative of {affine.key}.dx by boolean j, gives a matrix of "
            f"rank {max(ranks)} for the {len(affine.booleans)} booleans "
            f"({', '.join(affine.booleans)}) at each of the {len(ranks)} states and inputs "
            "drawn around [initial] state (up to 50 times its size away), so eq. (30) could "
            "not tell its modes apart there"
        )

    @property
    def jumps(self) -> bool:
        """True when the model has ``[jumps]`` state resets."""
        return self.model.has_jumps

    @property
    def outputs(self) -> int:
        """Number of outputs."""
        return self.model.n_outputs

    @property
    def markov_matrix(self) -> bool:
        """True when the model file gives a ``[transitions]`` matrix."""
        return self.model.transitions is not None

    @functools.cached_property
    def nonlinear(self) -> str | None:
        """The first mode equation that is not affine in the states and inputs, or None.

        ``"modes.1.f[0] is not affine in x1, x3"``.  The loader has already worked out which
        modes are affine (:attr:`~hybridlog.model.hybrid_model.Mode.linear_form`); only the
        first nonlinear mode is differentiated again, to name the variables at fault.
        """
        mode = next((m for m in self.model.modes if m.linear_form is None), None)
        if mode is None:
            return None
        import sympy

        xs, us = self.model.symbols()
        variables = {*xs, *us}
        for key, expressions in (("dx" if mode.dx else "f", mode.dynamics), ("h", mode.h)):
            for i, expression in enumerate(expressions):
                bent = sorted(
                    str(v) for v in variables if sympy.diff(expression, v).free_symbols & variables
                )
                if bent:
                    return f"modes.{mode.id}.{key}[{i}] is not affine in {', '.join(bent)}"
        return f"{mode.nonlinear_key} is not affine in the states and inputs"

    @functools.cached_property
    def undetectable(self) -> str | None:
        """The first linear mode with an unobserved eigenvalue ``|λ| ≥ 1``, or None.

        Paper 001's LMI (15) asks for a decay rate of at most 1, which no gain ``L_i`` gives
        ``A_i − L_i C_i`` along an eigenvalue ``C_i`` does not see: ``chiu`` and ``kmeans``
        read and clustered the whole log before refusing such a model, and ``hybridlog
        models FILE`` listed them among its estimators in the line above its own warning
        that they refuse the mode.  Judged as that warning judges it
        (:mod:`hybridlog.model.observability`: the eigenvalues of ``A`` on the null space of
        the observability matrix), from the matrices alone: no sympy, which a warm run's
        model has not loaded; ``None`` also for a model with a mode that is not linear
        (refused for that first).
        """
        forms = [mode.linear_form for mode in self.model.modes]
        if self.model.is_continuous or not forms or any(form is None for form in forms):
            return None
        from hybridlog.model.observability import unobservable_basis, unseen_eigenvalues

        for mode, form in zip(self.model.modes, forms, strict=True):
            assert form is not None  # for mypy: checked above
            seen = unseen_eigenvalues(form.A, unobservable_basis(form.A, form.C))
            slow = [v for v in seen if abs(v) >= 1.0]
            if slow:
                worst = max(slow, key=abs)
                shown = f"{worst.real:.4g}" if worst.imag == 0.0 else f"{worst:.4g}"
                return (
                    f"mode '{mode.id}' has the eigenvalue {shown} (|λ| = {abs(worst):.4g}), "
                    "which its outputs do not see, so the observer LMI (15) of paper 001 has "
                    "no gain for it at any decay rate"
                )
        return None

    @functools.cached_property
    def unstated_measurement_noise(self) -> str | None:
        """Where the model file gives no measurement noise covariance, or None."""
        return self.model.unstated_measurement_noise()

    @functools.cached_property
    def drift_blind(self) -> str | None:
        """The first mode whose ``Φ`` (paper 004, eq. (7)) cannot read some state, or None.

        ``L_f^k h`` reads only states within ``k`` steps of ``h``'s through the drift (``dx``
        with the inputs at zero: ``x_i`` leads to the states ``dx_i`` reads); a state no
        path reaches enters no entry of ``Φ``, so ``Q = ∂Φ/∂x`` has a zero column at every
        state.  Read off the expressions' symbols, no derivative taken: such a model ran
        (``hybridlog models`` passed it) and was refused as diverged at its first sample.
        A state reached whose terms cancel is still found by the run's diagnosis.
        """
        import sympy

        xs, us = self.model.symbols()
        zero = {u: sympy.S.Zero for u in us}  # the drift, as drift_observability takes it
        for mode in self.model.modes:
            reads = [sympy.sympify(e).xreplace(zero).free_symbols for e in mode.dx]
            reached: set[object] = set()
            for e in mode.h:
                reached |= e.free_symbols
            frontier = set(reached)
            while frontier:
                found: set[object] = set()
                for j, x in enumerate(xs):
                    if x in frontier:
                        found |= reads[j]
                frontier = found - reached
                reached |= found
            blind = [
                name for name, x in zip(self.model.states, xs, strict=True) if x not in reached
            ]
            if blind:
                return (
                    f"{', '.join(blind)} enter(s) neither modes.{mode.id}.h nor, through its "
                    "dx, any time derivative of it: Q = dPhi/dx (eq. (21)) of mode "
                    f"'{mode.id}' is singular at every state"
                )
        return None

    @functools.cached_property
    def unmeasured_state(self) -> str | None:
        """Why the outputs are not the states (``h = x``) in every mode, or None.

        The key named is the one the file has: a model of booleans (``[dynamics]``, paper
        003) writes its outputs once, as ``dynamics.h``; its modes are not tables of the
        file, and ``modes.0.h`` sent the user looking for a ``[modes.0]`` it does not have.
        """
        xs, _ = self.model.symbols()
        states = ", ".join(self.model.states)
        for mode in self.model.modes:
            if list(mode.h) != xs:
                if self.model.boolean_affine is not None:
                    return f"dynamics.h is not the state ({states}) in mode '{mode.id}'"
                return f"modes.{mode.id}.h is not the state ({states})"
        return None
