r"""The ``unknown-mode`` estimator: hybrid estimation with unknown modes (paper 002).

For a ``[components]`` model (concurrent probabilistic hybrid automata, Definitions 1–3):

* every tracked hypothesis is a joint mode assignment with one mode per component, where
  ``unknown`` (no equations, §3) is a mode of every component with the prior the model file
  gives (option ``unknown_mode = false`` removes it);
* each assignment is decomposed once (:mod:`~hybridlog.estimators.cpha.structure`, §3.1)
  into a filter cluster, one EKF per cluster (:mod:`~hybridlog.estimators.cpha.cluster_filter`,
  Appendix A); its ``P_O`` is the product of the clusters' (eq. (7)), an upper bound when a
  component is unknown;
* hybrid estimation keeps the ``beam`` most likely trajectories (eqs. (4)–(5),
  :mod:`~hybridlog.estimators.cpha.hypotheses`);
* the transition probabilities into step k are those of the rules that apply under the
  commands at step k−1, ``P_T(m_i | x̂_j, u_d(k-1))`` (eq. (4)): the commands the rules'
  ``when`` name are read from the log like inputs (``AlignedSignals.commands``, held onto
  the grid), and a log without one of them is refused before any estimator runs
  (:func:`~hybridlog.estimators.capabilities.missing_command`).

Result
------
``mode_ids`` are joint assignments labelled ``"<mode of component 1>|<mode of 2>|…"`` in
the model's component order (``m11|m21|unknown``); listed are those that were in the beam at
some step, in order of first appearance.  ``mode_probabilities[k, j]`` is the summed
normalised belief of the kept hypotheses with assignment ``j`` at step k (0 when none is
kept).  ``modes[k]`` is the assignment of the most likely hypothesis (the paper's hybrid
estimate, §2.2), whose ``x̂`` and ``diag P`` are reported; a state in no cluster of it (its
mean held, §3.1) is marked in ``states_not_estimated``, which the report scores, writes and
draws as no estimate.  ``ŷ(k|k-1)`` is made before ``y(k)`` is used (SPEC §8): that of the
most likely hypothesis of step k−1 stepped into its most likely successor assignment (a
component whose targets tie, as out of ``unknown``, held), NaN for an output no cluster of
it predicts (:meth:`Tracker.step <hybridlog.estimators.cpha.hypotheses.Tracker.step>`).  The
most likely hypothesis of step k is chosen by ``y(k)``: its prediction was the kept one
nearest ``y(k)``, and a spike only an unknown component explained left the sample
unpredicted, out of the MSE, VAF and fit.
Timeline columns: ``mode.<component>`` (labels: the component's modes and ``unknown``) of
the most likely hypothesis, and ``p_unknown.<component>``, the summed belief of the kept
hypotheses in which the component is unknown.

Outputs the log did not measure at a sample (``AlignedSignals.unmeasured_outputs``: a gap
bridged, a slower sensor) are read as such, never as the stand-in value the alignment put
there (:meth:`~hybridlog.signals.AlignedSignals.measured_outputs`): each cluster's EKF
updates on its measured outputs only, and where none is measured it predicts and
``P_O = 1`` (no evidence for or against a hypothesis, :mod:`.cluster_filter`); a virtual
input of a cluster's dynamics not measured at k−1 is the parent hypothesis' estimate of it,
and without one the cluster is held (a ``WARNING`` note names the states, which
``states_not_estimated`` marks).  ``ŷ(k|k-1)`` is still given for every output a cluster
predicts.

With ``mode_sequence = "kbest"`` (``--mode-sequence kbest``, offline; issue 12) ``modes``,
the ``mode.<component>`` columns, ``x̂`` and ``diag P`` are those of the most likely
trajectory at the end of the log along its whole history (each step's kept hypotheses and
their parents are recorded, :attr:`Tracker.parents`, and the final winner's ancestors read
back) instead of each step's most likely hypothesis; the probabilities, ``p_unknown`` and
``ŷ(k|k-1)`` stay the causal estimate's, which ``post_processing.filtered`` holds whole.

A sample no filtered successor explains (``rᵀS⁻¹r`` past
:func:`~hybridlog.estimators.vouch.surprise_limit` for each, :attr:`Tracker.surprise`) is
refused as ``imm`` refuses it (:func:`~hybridlog.estimators.vouch.check_surprise`): with the
unknown mode a successor whose component is unknown explains any sample of the outputs it
leaves unchecked, so this is a sample of an output no component can leave unchecked there
(``unknown_mode = false``, ``unknown = 0``).

Notes list the decomposition and filter cache hit rates; when ``candidates`` stopped a
step's search while an unfiltered successor might still have entered the beam, at how many
steps the beam is approximate; when a reported known mode sat in no filter
cluster (an unknown neighbour left its equations undetermined), a warning per component: on
how many samples no output checked it; the rules whose ``when`` never held on the log, with
the command values it held that no rule names (:func:`command_notes`); and, with the unknown
mode, each component whose ``unknown`` no rule leaves (absorbing, a ``WARNING`` where the
estimate sits there on a quarter of the samples or more: :mod:`~.absorbing`), and a
``WARNING`` for one the rules leave too rarely to lose against a fitting mode
(:func:`_sticky_notes`) that the estimate sits in as long.

Modelling the unknown mode
--------------------------
``P_O = exp(-rᵀS⁻¹r/2) ≤ 1`` (eq. (21), unnormalised) and an unknown component drops its
filters, whose ``P_O`` is then the upper bound 1 (§3).  A well-fitting known mode still pays
``E[rᵀS⁻¹r]/2 = 1/2`` per output per step, so a hypothesis that stays unknown gains about
``e^{1/2}`` per dropped output per step.  Unless staying unknown costs more than that — a
``from = "unknown"`` rule leaving it with probability above ``1 − e^{-1/2} ≈ 0.4`` per dropped
output — the unknown mode wins by default after a few dozen steps.  Entering it costs
``log unknown`` once: the smaller ``unknown``, the larger the misfit needed to enter.
"""

from __future__ import annotations

import math
import time
from array import array
from dataclasses import replace

import numpy as np

from hybridlog.cluster.progress import TimedWork, duration_text
from hybridlog.errors import DivergenceError, LogError, ModelError, suffixed
from hybridlog.estimators.capabilities import missing_command
from hybridlog.estimators.cpha.absorbing import (
    ABSORBING_SHARE,
    LEAVING_ADVICE,
    absorbing_components,
    absorbing_notes,
    unknown_stays,
)
from hybridlog.estimators.cpha.cluster_filter import FilterCache
from hybridlog.estimators.cpha.hypotheses import (
    ClusterStepError,
    Hypothesis,
    NoExplanationError,
    Tracker,
)
from hybridlog.estimators.cpha.options import UnknownModeOptions
from hybridlog.estimators.cpha.structure import Assignment, StructureCache
from hybridlog.estimators.options import options_dict
from hybridlog.estimators.result import EstimationResult, PostProcessing, TimelineColumn
from hybridlog.estimators.vouch import check_surprise, surprise_limit
from hybridlog.model.component_structure import ComponentNames, unchecked_note
from hybridlog.model.components import COMMAND_TOLERANCE, UNKNOWN, joint_label
from hybridlog.model.hybrid_model import WEIGHS_OUTPUTS, HybridModel
from hybridlog.signals import AlignedSignals, BoolArray, FloatArray
from hybridlog.times import format_time

__all__ = [
    "NAME",
    "UnknownModeOptions",
    "assignment_label",
    "command_values",
    "run_unknown_mode",
]

NAME = "unknown-mode"


def assignment_label(assignment: Assignment) -> str:
    """``m11|m21|unknown``: its id (:func:`~hybridlog.model.components.joint_label`)."""
    return joint_label(assignment)


_CACHES: dict[tuple[object, ...], tuple[StructureCache, FilterCache]] = {}
_CACHED_MODELS = 4


def caches(model: HybridModel) -> tuple[StructureCache, FilterCache]:
    """Decompositions and compiled cluster filters of ``model``, kept across runs.

    Keyed by the model's text and parameter values; the last :data:`_CACHED_MODELS` models
    are kept, so a batch or a study over many logs of one model compiles once.
    """
    key = (model.name, model.source, tuple(sorted(model.parameters.items())), model.states)
    found = _CACHES.get(key)
    if found is None:
        names = {"states": model.states, "inputs": model.inputs, "outputs": model.outputs}
        structure = StructureCache(model.components, variables=model.variables, **names)
        found = (structure, FilterCache(**names))
        if len(_CACHES) >= _CACHED_MODELS:
            del _CACHES[next(iter(_CACHES))]
        _CACHES[key] = found
    return found


def make_tracker(
    model: HybridModel,
    signals: AlignedSignals,
    options: UnknownModeOptions,
    *,
    fresh: bool = False,
) -> Tracker:
    """The hypothesis tracker over ``signals``; ``fresh``: new caches, else :func:`caches`.

    A model without ``source`` text (built in code) always gets fresh caches.
    """
    if fresh or not model.source:
        names = {"states": model.states, "inputs": model.inputs, "outputs": model.outputs}
        structure = StructureCache(model.components, variables=model.variables, **names)
        filters = FilterCache(**names)
    else:
        structure, filters = caches(model)
    commands, values = command_values(model, signals)
    if values is not None:
        values = _unnamed_as_one(model, commands, values)
    return Tracker(
        model.components,
        structure,
        filters,
        np.ascontiguousarray(signals.inputs, dtype=np.float64),
        # NaN where the log did not measure an output: the stand-in the alignment put
        # there is no measurement, and no filter updates on it (cluster_filter)
        np.ascontiguousarray(signals.measured_outputs(), dtype=np.float64),
        beam=options.beam,
        candidates=options.candidates if options.candidates is not None else 10 * options.beam,
        variance_growth=options.variance_growth,
        unknown_mode=options.unknown_mode,
        commands=values,
        command_names=commands,
    )


def command_values(
    model: HybridModel, signals: AlignedSignals
) -> tuple[tuple[str, ...], FloatArray | None]:
    """The commands the model's transition rules name and their values in the log.

    Returns
    -------
    tuple
        The names, in the model's order, and their values, shape ``(N, n_c)`` (``None`` when
        no rule has ``when``).

    Raises
    ------
    LogError
        For a command a rule names that the log lacks, naming the command, the rule's
        component and the rule (:func:`~hybridlog.estimators.capabilities.missing_command`,
        which the commands check before any estimator runs, with this message).
    """
    missing = missing_command(model, signals)
    if missing is not None:
        raise LogError(f"{signals.source}: estimator '{NAME}' {missing}")
    needed = {command for c in model.components for rule in c.rules for command in rule.when}
    if not needed:
        return (), None
    names = tuple(c for c in model.commands if c in needed)
    have = signals.command_names
    columns = [have.index(c) for c in names]
    assert signals.commands is not None
    values = np.array(signals.commands[:, columns], dtype=np.float64)
    for j, command in enumerate(names):
        _snap(values[:, j], _settings(model, command))
    return names, values


def _settings(model: HybridModel, command: str) -> set[float]:
    """The values of ``command`` some rule's ``when`` names."""
    return {
        rule.when[command] for c in model.components for rule in c.rules if command in rule.when
    }


OTHER_VALUE = float("inf")
"""A command's value where no ``when`` names it: no rule's ``when`` holds there.

Rules name finite values only (the loader refuses others), so ``inf`` matches none.
"""


def _unnamed_as_one(model: HybridModel, names: tuple[str, ...], values: FloatArray) -> FloatArray:
    """``values`` with each value no ``when`` names replaced by :data:`OTHER_VALUE`.

    Every such value selects the same rules (those without that condition), and the tracker
    builds and keeps a transition table per source mode and command values: a command logged
    with noise or as a set point (0.37, 0.38, ...) made one per sample, so that a long log's
    run grew by a table a step (4x the memory on 20,000 samples) for nothing.
    """
    out = values.copy()
    for j, command in enumerate(names):
        named = np.isin(out[:, j], sorted(_settings(model, command)))
        out[~named, j] = OTHER_VALUE
    return out


def command_notes(model: HybridModel, signals: AlignedSignals) -> tuple[str, ...]:
    """A note on the log's commands where some rule's ``when`` never held on it.

    The values a command took that no ``when`` names are listed with it: a log that gives
    a command in other units or codes than the model (0/100 for 0/1, -1/1) had every rule
    with ``when`` quietly never apply, leaving only the rules without it.  Only the steps
    whose commands select a transition count (rows 0 … N−2, eq. (4)).
    """
    names, values = command_values(model, signals)
    if values is None or len(values) < 2:
        return ()
    used = values[:-1]
    column = {name: used[:, j] for j, name in enumerate(names)}
    never = [
        rule
        for c in model.components
        for rule in c.rules
        if rule.when
        and not np.logical_and.reduce(
            [column[name] == value for name, value in rule.when.items()]
        ).any()
    ]
    if not never:
        return ()
    listed = "; ".join(
        f"{rule.key} ({', '.join(f'{n} = {v:.15g}' for n, v in rule.when.items())})"
        for rule in never
    )
    others = []
    for name in names:
        unnamed = used[~np.isin(column[name], sorted(_settings(model, name))), names.index(name)]
        if unnamed.size:
            found, counts = np.unique(unnamed, return_counts=True)
            order = np.argsort(-counts, kind="stable")[:3]
            shown = ", ".join(f"{found[i]:.15g} on {counts[i]:,}" for i in order)
            more = f" and {found.size - 3:,} more values" if found.size > 3 else ""
            others.append(
                f"{name} took values no rule names on {unnamed.size:,} of {len(used):,} "
                f"steps ({shown}{more})"
            )
    tail = f"; {'; '.join(others)}" if others else ""
    return (
        f"transition rules whose 'when' never held on this log (the commands of no step "
        f"matched): {listed}{tail}; while no 'when' held, the rules without one applied",
    )


def _snap(column: FloatArray, settings: set[float]) -> None:
    """Put the values of ``column`` within :data:`COMMAND_TOLERANCE` of a setting on it."""
    for setting in settings:
        near = np.abs(column - setting) <= COMMAND_TOLERANCE * max(1.0, abs(setting))
        column[near] = setting


def run_unknown_mode(
    model: HybridModel, signals: AlignedSignals, options: UnknownModeOptions
) -> EstimationResult:
    """Run hybrid estimation with unknown modes over the aligned log (module docstring).

    Raises
    ------
    ModelError
        Naming the model file and key: what the structural analysis of a mode assignment
        the run reaches refuses (an equation that determines nothing, one that cannot be
        solved), a cluster's EKF that cannot step, or a step no successor explains (every
        one's ``P_O`` is 0, or none exists: :class:`~.hypotheses.NoExplanationError`).
    """
    model.require_measurement_noise(f"estimator 'unknown-mode'{WEIGHS_OUTPUTS}")
    try:
        return _run(model, signals, options)
    except ModelError as err:  # the analysis of a later assignment names only its key
        origin = f"{model.origin or model.name}: "
        if str(err).startswith(origin):
            raise
        raise ModelError(f"{origin}{err}") from err


def _run(
    model: HybridModel, signals: AlignedSignals, options: UnknownModeOptions
) -> EstimationResult:
    tracker = make_tracker(model, signals, options)
    n = signals.n_samples
    n_x, n_y = model.n_states, model.n_outputs
    components = model.components
    structure, filters = tracker.structure, tracker.filters
    counts = (structure.hits, structure.misses, filters.hits, filters.misses)
    compiling = structure.seconds + filters.seconds
    start = time.perf_counter()
    hypotheses = tracker.start(
        np.array(model.initial_state, dtype=np.float64),
        np.array(model.initial_covariance, dtype=np.float64),
    )
    labels: dict[Assignment, int] = {}
    # per assignment: its label index and its components in the unknown mode
    known: dict[Assignment, tuple[int, tuple[int, ...]]] = {}
    # per step, the summed belief of each assignment kept: flat (step, label, belief)
    beliefs_of = _StepBeliefs()
    # the most likely hypothesis' estimate per step, written as the run goes: the
    # hypotheses themselves (each with its full P, y_pred and cluster steps) were kept to
    # the end, about 2 KB a sample for one state, which no memory check counted
    best_label = np.empty(n, dtype=np.int64)
    means = np.empty((n, n_x), dtype=np.float64)
    variances = np.empty((n, n_x), dtype=np.float64)
    predictions = np.empty((n, n_y), dtype=np.float64)
    offline = options.mode_sequence == "kbest"
    histories = _Histories(n_x) if offline else None
    p_unknown = np.zeros((n, len(components)))
    # per step, the states the reported hypothesis held for want of a virtual input
    undetermined = np.zeros((n, n_x), dtype=np.bool_)
    # per step, the smallest rᵀS⁻¹r over the successors filtered (Tracker.surprise)
    surprise = np.full(n, np.nan)
    cut = np.zeros(n, dtype=np.bool_)  # per step, whether candidates stopped the search
    what = f"{NAME} over {n:,} samples, beam {options.beam:,}"
    # a large beam takes minutes: timed on the steps after the first, compilation excluded
    long_run = TimedWork(
        n - 1,
        f"{NAME} steps",
        lambda left, seconds: (
            f"{what}: about {duration_text(seconds)} more on this machine ({left:,} of "
            f"{n - 1:,} steps left, timed on the steps after the first, compilation "
            "excluded; a smaller beam or candidates takes less)"
        ),
        clock=lambda: time.perf_counter() - structure.seconds - filters.seconds,
    )
    truncated = tracker.truncated
    bound = options.candidates if options.candidates is not None else 10 * options.beam
    with long_run:
        for k in range(n):
            if k > 0:
                try:
                    hypotheses = tracker.step(hypotheses, k)
                except (ClusterStepError, NoExplanationError) as err:
                    raise model.error(
                        "components", f"at t = {format_time(signals.time[k])} s {err}"
                    ) from err
            row: dict[int, float] = {}
            beliefs = np.exp([h.log_belief for h in hypotheses]).tolist()
            p_row = p_unknown[k].tolist()
            for h, belief in zip(hypotheses, beliefs, strict=True):
                found = known.get(h.assignment)
                if found is None:
                    unknown = tuple(c for c, mode in enumerate(h.assignment) if mode == UNKNOWN)
                    found = known[h.assignment] = (
                        labels.setdefault(h.assignment, len(labels)),
                        unknown,
                    )
                j, unknown = found
                row[j] = row.get(j, 0.0) + belief
                for c in unknown:
                    p_row[c] += belief
            p_unknown[k] = p_row
            beliefs_of.add(k, row)
            if histories is not None:
                kept = [known[h.assignment][0] for h in hypotheses]
                histories.keep(hypotheses, kept, tracker.parents if k > 0 else [])
            top = max(hypotheses, key=lambda h: h.log_belief)
            undetermined[k] = _undetermined_states(top, n_x)
            best_label[k] = labels[top.assignment]
            means[k] = top.x
            variances[k] = np.diag(top.P)
            predictions[k] = tracker.prediction
            if k > 0:
                surprise[k] = tracker.surprise
                cut[k] = tracker.truncated > truncated
                truncated = tracker.truncated
                long_run.reached(k)
    compile_s = structure.seconds + filters.seconds - compiling
    runtime = time.perf_counter() - start - compile_s
    mode_ids = tuple(assignment_label(a) for a in labels)
    probabilities = beliefs_of.matrix(n, len(mode_ids))
    totals = probabilities.sum(axis=1, keepdims=True)
    probabilities /= np.where(totals > 0, totals, 1.0)
    assignment_of = list(labels)
    best_assignments = [assignment_of[j] for j in best_label.tolist()]
    modes = best_label
    predictions[:1] = np.nan  # no prediction before the first sample (of a log of none)
    p_columns = [
        TimelineColumn(f"p_unknown.{component.name}", np.clip(p_unknown[:, c], 0.0, 1.0))
        for c, component in enumerate(components)
    ]
    columns = [*_component_columns(model, best_assignments), *p_columns]
    s_hits, s_misses = structure.hits - counts[0], structure.misses - counts[1]
    f_hits, f_misses = filters.hits - counts[2], filters.misses - counts[3]
    notes: tuple[str, ...] = (
        f"decompositions: {s_misses} computed, {s_hits} cache hits "
        f"({_rate(s_hits, s_misses)}); cluster filters: {f_misses} compiled, {f_hits} cache "
        f"hits ({_rate(f_hits, f_misses)}); {tracker.filtered} cluster EKF steps",
    )
    if tracker.truncated:
        notes += (
            f"the beam is approximate at {tracker.truncated} of {n - 1} steps: the bound of "
            f"{bound} candidates was reached while a successor not filtered might still have "
            "entered it; a larger candidates searches further",
        )
    notes += command_notes(model, signals)
    unchecked = unchecked_note(
        components, ComponentNames(model.states, model.inputs, model.outputs, model.variables)
    )
    notes += () if unchecked is None else (unchecked,)
    absorbing = (
        absorbing_components(components, tracker.transitions.commands, tracker.commands)
        if options.unknown_mode
        else {}
    )
    stays = (
        unknown_stays(components, tracker.transitions.commands, tracker.commands)
        if options.unknown_mode
        else {}
    )
    filtered_notes = (
        notes
        + absorbing_notes(components, absorbing, best_assignments, signals.time)
        + _sticky_notes(model, structure, best_assignments, signals.time, stays)
        + _unchecked_notes(model, structure, best_assignments, signals.time)
        + _held_notes(model, structure, best_assignments, signals.time)
        + _undetermined_notes(model, undetermined, signals.time)
    )
    filtered = EstimationResult(
        estimator=NAME,
        options=options_dict(options),
        time=np.asarray(signals.time, dtype=np.float64),
        mode_ids=mode_ids,
        state_names=model.states,
        output_names=model.outputs,
        modes=modes,
        mode_probabilities=probabilities,
        state_means=means,
        state_variances=variances,
        output_predictions=predictions,
        runtime_s=runtime,
        compile_s=compile_s,
        notes=filtered_notes,
        timeline_columns=tuple(columns),
        states_not_estimated=_not_estimated(model, structure, best_assignments, undetermined),
    )
    # a sample no successor explains (the unknown mode off, or a component without it):
    # the beam's estimate of it is no more vouched for than imm's (vouch.check_surprise)
    try:
        check_surprise(model, signals, filtered, surprise)
    except DivergenceError as err:
        beyond = np.flatnonzero(surprise > surprise_limit(model.n_outputs))
        if beyond.size and cut[beyond[0]]:  # an unfiltered successor may explain it
            raise suffixed(
                err,
                f" (at that step the bound of {bound} candidates stopped the search before "
                "every successor was filtered: a larger candidates may find one that explains "
                "the sample, a component in the unknown mode)",
            ) from err
        raise
    if histories is None:
        return filtered
    offline_start = time.perf_counter()
    path = histories.best_path([h.log_belief for h in hypotheses])
    assignments = [assignment_of[j] for j in histories.path_labels(path)]
    path_means, path_variances, path_undetermined = histories.states(path)
    result = replace(
        filtered,
        modes=np.array([labels[a] for a in assignments], dtype=np.int64),
        state_means=path_means,
        state_variances=path_variances,
        timeline_columns=(*_component_columns(model, assignments), *p_columns),
        states_not_estimated=_not_estimated(model, structure, assignments, path_undetermined),
        notes=(
            notes
            + absorbing_notes(components, absorbing, assignments, signals.time)
            + _sticky_notes(model, structure, assignments, signals.time, stays)
            + _unchecked_notes(model, structure, assignments, signals.time)
            + _held_notes(model, structure, assignments, signals.time)
            + _undetermined_notes(model, path_undetermined, signals.time)
        ),
        runtime_s=runtime + time.perf_counter() - offline_start,
        post_processing=PostProcessing(
            smoothing=None,
            mode_sequence="kbest",
            description=KBEST_DESCRIPTION.format(beam=options.beam),
            filtered=filtered,
        ),
    )
    return result


class _StepBeliefs:
    """Per step, the summed belief of each joint assignment kept, in flat typed arrays.

    At most ``beam`` entries a step of 8 + 8 + 8 bytes (step, label, belief): a Python list
    of tuples a step took about five times that.
    """

    def __init__(self) -> None:
        self.steps = array("q")
        self.labels = array("q")
        self.beliefs = array("d")

    def add(self, k: int, row: dict[int, float]) -> None:
        """Step k's summed beliefs by label index."""
        self.steps.extend([k] * len(row))
        self.labels.extend(row.keys())
        self.beliefs.extend(row.values())

    def matrix(self, n: int, n_labels: int) -> FloatArray:
        """The beliefs as an ``(n, n_labels)`` array, 0 where an assignment was not kept."""
        out = np.zeros((n, n_labels), dtype=np.float64)
        steps = np.frombuffer(self.steps, dtype=np.int64)
        labels = np.frombuffer(self.labels, dtype=np.int64)
        out[steps, labels] = np.frombuffer(self.beliefs, dtype=np.float64)
        return out


KBEST_DESCRIPTION = (
    "modes: the history of the most likely of the {beam} trajectories kept at the end of the "
    "log (paper 002 eqs. (4)-(5), read offline); states: that trajectory's cluster filters; "
    "mode probabilities and output predictions: the causal estimate's"
)


class _Histories:
    """The kept hypotheses of every step, reduced to what their histories need.

    Per step: each hypothesis' assignment (its label index), mean and variances, and its
    parent's index in the step before (:attr:`Tracker.parents`), in flat typed arrays:
    ``8 · (2 n_x + 2)`` bytes per hypothesis kept (:func:`~.options.unknown_mode_memory`
    counts them).  Lists of tuples and one array per step took about twice that, more
    than the memory check was told.  A hypothesis that held states for want of a virtual
    input (:func:`_undetermined_states`, rare) has them listed by its position.
    """

    def __init__(self, n_x: int) -> None:
        self.n_x = n_x
        self.undetermined: dict[int, BoolArray] = {}
        self.starts = array("q")  # per step, its first hypothesis' position
        self.labels = array("q")
        self.parents = array("q")
        self.means = array("d")
        self.variances = array("d")

    def keep(self, hypotheses: list[Hypothesis], labels: list[int], parents: list[int]) -> None:
        """Record step k's hypotheses.

        ``labels``: their assignments' label indices; ``parents``: their parents' indices
        at k-1 (empty at step 0).
        """
        self.starts.append(len(self.labels))
        for position, h in enumerate(hypotheses, start=len(self.labels)):
            held = _undetermined_states(h, self.n_x)
            if held.any():
                self.undetermined[position] = held
        self.labels.extend(labels)
        self.parents.extend(parents if parents else [-1] * len(hypotheses))
        for h in hypotheses:
            self.means.extend(h.x.tolist())
            self.variances.extend(np.diag(h.P).tolist())

    def best_path(self, final_beliefs: list[float]) -> list[int]:
        """Per step, the position of the most likely final hypothesis' ancestor (back-tracking)."""
        starts = self.starts
        index = int(np.argmax(final_beliefs))
        path = [starts[-1] + index]
        for k in range(len(starts) - 1, 0, -1):
            index = self.parents[starts[k] + index]
            path.append(starts[k - 1] + index)
        return path[::-1]

    def path_labels(self, path: list[int]) -> list[int]:
        """The label index of each hypothesis on ``path``."""
        return [self.labels[i] for i in path]

    def states(self, path: list[int]) -> tuple[FloatArray, FloatArray, BoolArray]:
        """The means, variances and undetermined states along ``path``, ``(N, n_x)`` each."""
        n_x = self.n_x
        rows = np.asarray(path, dtype=np.int64)
        means = np.frombuffer(self.means, dtype=np.float64).reshape(-1, n_x)[rows]
        variances = np.frombuffer(self.variances, dtype=np.float64).reshape(-1, n_x)[rows]
        undetermined = np.zeros((len(path), n_x), dtype=np.bool_)
        for k, position in enumerate(path):
            held = self.undetermined.get(position)
            if held is not None:
                undetermined[k] = held
        return (
            means.reshape(len(path), n_x),
            variances.reshape(len(path), n_x),
            undetermined,
        )


def _component_columns(model: HybridModel, assignments: list[Assignment]) -> list[TimelineColumn]:
    """The timeline's ``mode.<component>`` columns of a sequence of joint assignments."""
    columns = []
    for c, component in enumerate(model.components):
        mode_labels = (*component.mode_ids, UNKNOWN)
        values = np.array([mode_labels.index(a[c]) for a in assignments], dtype=np.int64)
        columns.append(TimelineColumn(f"mode.{component.name}", values, mode_labels))
    return columns


def _sticky_notes(
    model: HybridModel,
    structure: StructureCache,
    assignments: list[Assignment],
    times: FloatArray,
    stays: dict[str, float],
) -> tuple[str, ...]:
    """A warning per component reported ``unknown`` on many samples whose rules keep it there.

    Staying in ``unknown`` costs ``-ln P(stay)`` a step against about 1/2 per output a
    well-fitting known mode checks (the outputs its unknown mode leaves unchecked: a tank
    whose level feeds a valve's flow unchecks the other tank's output too).  Where
    ``P(stay) > e^(-n/2)`` the unknown mode outscores a mode that fits: two tanks and a valve,
    each leaving ``unknown`` with probability 0.5 or 0.6, were reported ``unknown`` on most of
    a fault-free log without a word on why (:mod:`~.absorbing` names those no rule leaves).
    """
    n = len(assignments)
    notes = []
    for c, component in enumerate(model.components):
        stay = stays.get(component.name, 0.0)
        where = [a for a in assignments if a[c] == UNKNOWN]
        if not 0.0 < stay < 1.0 or not n or len(where) < ABSORBING_SHARE * n:
            continue
        typical = max(set(where), key=where.count)
        unchecked = max(
            len(_checked_outputs(structure, (*typical[:c], mode, *typical[c + 1 :])))
            - len(_checked_outputs(structure, typical))
            for mode in component.mode_ids
        )
        threshold = math.exp(-unchecked / 2)
        if unchecked == 0 or stay <= threshold:
            continue
        first = next(k for k, a in enumerate(assignments) if a[c] == UNKNOWN)
        notes.append(
            f"WARNING: component {component.name} is reported in its unknown mode on "
            f"{len(where):,} of {n:,} samples (first at t = {format_time(times[first])} s), "
            f"and stays there with probability {stay:.3g} a step, above e^(-n/2) = "
            f"{threshold:.2f} for the n = {unchecked} outputs its unknown mode leaves "
            f"unchecked: staying costs {-math.log(stay):.2f} a step, a mode that fits about "
            f"{unchecked / 2:g} (1/2 per output it checks), so the unknown mode, whose dropped "
            "filters score the upper bound P_O = 1 (paper 002 §3), outscores even a "
            "well-fitting mode; unless the component truly behaved as no mode describes there, "
            f'let its [[components.{component.name}.transitions]] rule from = "unknown" leave '
            f"more readily ({LEAVING_ADVICE})"
        )
    return tuple(notes)


def _checked_outputs(structure: StructureCache, assignment: Assignment) -> frozenset[str]:
    """The outputs the kept filter clusters of ``assignment`` check."""
    return frozenset(o for cluster in structure.get(assignment).clusters for o in cluster.outputs)


def _unchecked_notes(
    model: HybridModel,
    structure: StructureCache,
    assignments: list[Assignment],
    times: FloatArray,
) -> tuple[str, ...]:
    """A warning naming the components whose reported known mode no output checked.

    A component in ``unknown`` leaves the variables its equations determined undetermined;
    a known mode whose equations then sit in no kept filter cluster (§3.1: the cluster is
    dropped) is tested by no measurement, and the hypothesis keeps it only through its
    transition probabilities.  On a log the model cannot explain (another plant, a dead
    sensor) the timeline then reported such a component, the chamber of ``bioplex_pgc``
    say, in its nominal mode on every sample, and the mode metrics scored that guess as an
    estimate, without a word.
    """
    checked: dict[Assignment, frozenset[str]] = {}
    counts: dict[str, dict[str, int]] = {}
    first: dict[str, int] = {}
    for k, assignment in enumerate(assignments):
        inside = checked.get(assignment)
        if inside is None:
            clusters = structure.get(assignment).clusters
            inside = checked[assignment] = frozenset(c for cl in clusters for c in cl.components)
        for component, mode in zip(model.components, assignment, strict=True):
            if mode != UNKNOWN and component.name not in inside:
                modes = counts.setdefault(component.name, {})
                modes[mode] = modes.get(mode, 0) + 1
                first.setdefault(component.name, k)
    if not counts:
        return ()
    n = len(assignments)
    order = {component.name: c for c, component in enumerate(model.components)}
    parts = []
    for name, modes in sorted(counts.items(), key=lambda item: order[item[0]]):
        total = sum(modes.values())
        listed = ", ".join(f"{mode} {count:,}" for mode, count in modes.items())
        parts.append(
            f"{name} on {total:,} of {n:,} samples ({listed}; first at t = "
            f"{format_time(times[first[name]])} s)"
        )
    return (
        "WARNING: a reported mode no output checked: "
        + "; ".join(parts)
        + ". A component in `unknown` left the variables these modes' equations use "
        "undetermined, so no filter cluster held them (paper 002 §3.1): there the mode is "
        "carried over by the transition probabilities, not estimated, and the mode metrics "
        "score that carry-over",
    )


def _not_estimated(
    model: HybridModel,
    structure: StructureCache,
    assignments: list[Assignment],
    undetermined: BoolArray,
) -> BoolArray | None:
    """Per sample and state, whether the reported hypothesis held the state there.

    A state in no filter cluster of the reported assignment, or in a cluster that could not
    step for want of a virtual input (``undetermined``, :func:`_undetermined_states`).
    ``EstimationResult.states_not_estimated``: there the mean was held, not estimated
    (:func:`_held_notes`, :func:`_undetermined_notes` name the states); ``None`` where
    every state was estimated.
    """
    rows: dict[Assignment, list[bool]] = {}
    for assignment in dict.fromkeys(assignments):
        held = structure.get(assignment).held_states
        rows[assignment] = [state in held for state in model.states]
    if not any(any(row) for row in rows.values()) and not undetermined.any():
        return None
    table = np.array(list(rows.values()), dtype=np.bool_).reshape(len(rows), model.n_states)
    index = {assignment: i for i, assignment in enumerate(rows)}
    return table[np.array([index[a] for a in assignments], dtype=np.int64)] | undetermined


def _undetermined_states(hypothesis: Hypothesis, n_x: int) -> BoolArray:
    """The states of ``hypothesis``'s clusters that were held at its step (``StepResult.held``).

    A cluster whose ``f`` uses a virtual input the log did not measure at k−1, of which the
    hypothesis had no estimate (:meth:`~.hypotheses.Tracker._virtual_before`).
    """
    held = np.zeros(n_x, dtype=np.bool_)
    for states, step in hypothesis.sources.items():
        if step.held:
            held[list(states)] = True
    return held


def _undetermined_notes(
    model: HybridModel, undetermined: BoolArray, times: FloatArray
) -> tuple[str, ...]:
    """A warning naming the states held because an output another cluster uses was not measured.

    Paper 002 §3.1 keeps a cluster only when everything upstream of it is determined; an
    output the log did not measure at k−1 that a cluster's dynamics use as a virtual input,
    and that the hypothesis could not estimate (no cluster of it determines that output),
    leaves the cluster undetermined at k: its states are held, not estimated.
    """
    counts = undetermined.sum(axis=0)
    if not counts.any():
        return ()
    n = len(times)
    parts = [
        f"{state} on {int(count):,} of {n:,} samples (first at t = "
        f"{format_time(times[int(np.argmax(undetermined[:, s]))])} s)"
        for s, (state, count) in enumerate(zip(model.states, counts.tolist(), strict=True))
        if count
    ]
    return (
        "WARNING: a reported state held for want of a measurement: "
        + "; ".join(parts)
        + ". Its cluster's dynamics use an output the log did not measure at the sample "
        "before, which no filter of the reported modes estimated either, so the cluster was "
        "not determined there (paper 002 §3.1): its mean is held and only its variance grows, "
        "and the state RMSE, estimates.csv and the plots leave those samples out",
    )


def _held_notes(
    model: HybridModel,
    structure: StructureCache,
    assignments: list[Assignment],
    times: FloatArray,
) -> tuple[str, ...]:
    """A warning naming the states the reported hypothesis held instead of estimating.

    A state in no filter cluster of the reported assignment (unobservable, or undetermined
    while a component is unknown, §3.1) keeps the mean it had, the initial state if no
    cluster ever held it, and only its variance grows.  The report scored that held value
    against the log's true state as if it were an estimate: a model whose output equation
    left x1 unobservable on every sample had "x1 RMSE 1.06 over 400 samples", without a word
    (now those samples are no estimate, :func:`_not_estimated`).
    """
    held: dict[Assignment, tuple[str, ...]] = {}
    counts: dict[str, int] = {}
    first: dict[str, int] = {}
    for k, assignment in enumerate(assignments):
        states = held.get(assignment)
        if states is None:
            states = held[assignment] = structure.get(assignment).held_states
        for state in states:
            counts[state] = counts.get(state, 0) + 1
            first.setdefault(state, k)
    if not counts:
        return ()
    n = len(assignments)
    parts = [
        f"{state} on {counts[state]:,} of {n:,} samples (first at t = "
        f"{format_time(times[first[state]])} s)"
        for state in model.states
        if state in counts
    ]
    return (
        "WARNING: a reported state no filter estimated: "
        + "; ".join(parts)
        + ". In no filter cluster of the reported modes (unobservable there, or undetermined "
        "while a component is `unknown`, paper 002 §3.1), its mean is held where it was (the "
        "initial state if no cluster held it before) and only its variance grows: there the "
        "state is not estimated, and the state RMSE, estimates.csv and the plots leave those "
        "samples out",
    )


def _rate(hits: int, misses: int) -> str:
    total = hits + misses
    return f"{100.0 * hits / total:.1f} % hit rate" if total else "no look-ups"
