"""The estimator registry: one entry per estimator, and the one way to run any of them.

An entry names the estimator, says in one line what it is and which paper and equations it
implements, points to its options dataclass and run function, and declares its
:class:`~hybridlog.estimators.capabilities.Capabilities`.  The module is named by a string
and imported on first use, so importing the registry (``--help``, batch workers) loads no
numba, sympy, scipy, cvxpy or matplotlib.

Adding an estimator is one module (an options dataclass made with
:func:`~hybridlog.estimators.options.option` and ``run(model, signals, options) ->
EstimationResult``) and one entry in :data:`ESTIMATORS`; an estimator that can give its result
in chunks (the filters) names its ``stream`` function too (:meth:`Prepared.stream`).

:func:`prepare` resolves the estimator and its options against a model before any log is
read: the model's ``default_estimator`` when none is named, its capabilities against the
model, the options of the model file's ``[estimators.<name>]`` table and then the overrides,
each error naming the file and key or the command-line option the user must change.
"""

from __future__ import annotations

import contextlib
import importlib
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any, cast

from hybridlog.errors import (
    DivergenceError,
    LogError,
    ModelError,
    OptionError,
    excerpt,
    suffixed,
)
from hybridlog.estimators.capabilities import (
    STEP_FROM_NOTE,
    STEP_INTO_OUTPUTS_WARNING,
    Capabilities,
    ModelTraits,
    runs_on_pairs,
)
from hybridlog.estimators.footprint import MODE_BYTES, REPORT_FACTOR, Parts, result_bytes
from hybridlog.estimators.offline_options import OFFLINE_OPTIONS, admits, not_offered
from hybridlog.estimators.options import (
    OptionInfo,
    OptionSource,
    check_table,
    closest,
    describe_options,
    format_options,
    options_dict,
    parse_options,
    refuse_invalid,
    shown,
)

if TYPE_CHECKING:
    from hybridlog.estimators.result import EstimationResult
    from hybridlog.model.hybrid_model import HybridModel
    from hybridlog.signals import AlignedSignals

__all__ = [
    "CHUNK_ROWS",
    "ESTIMATORS",
    "Estimator",
    "Prepared",
    "get_estimator",
    "prepare",
    "reference_markdown",
    "refuse_unrunnable",
    "resolve_estimator",
    "unsuited",
    "unsuited_text",
]

Runner = Callable[..., "EstimationResult"]
"""``run(model, signals, options, **inputs) -> EstimationResult``."""

Streamer = Callable[..., Iterator["EstimationResult"]]
"""``stream(model, signals, options, *, rows, **inputs) -> Iterator[EstimationResult]``."""

CHUNK_ROWS = 1 << 16
"""Rows per chunk of a streamed run (:meth:`Prepared.stream`).

The filters' buffers of one chunk take about 104 bytes a row on the three-tank model (mode,
three probabilities, means, variances and output predictions): 6.8 MB for 65,536 rows, next
to the 10^8 bytes of a 10^6-row whole result.  A 10^6-row log is then 16 calls of the
compiled loop, each about 0.04 s of steps beside a set-up (dispatch, scratch arrays, loading
and storing the carried state) of tens of microseconds for the generated code and half a
millisecond for the generic loop: smaller chunks would cost calls, larger ones memory.
"""


@dataclass(frozen=True)
class Estimator:
    """A registered estimator.

    Attributes
    ----------
    name:
        Registry name (``--estimator NAME``).
    summary:
        One line: what the estimator is.
    source:
        The paper (file under ``papers/``) and equations it implements, or the classic
        reference.
    module:
        The module that holds it, imported on first use.
    options:
        Name of its options dataclass, in ``options_module`` or else in ``module``.
    run:
        Name of ``run(model, signals, options) -> EstimationResult`` in ``module``.
    capabilities:
        What it needs of the model and the log.
    options_module:
        A light module holding the options dataclass (no numba, scipy, cvxpy), so that
        ``--help`` and the checks made before any log is read do not load the compiler;
        empty: ``module``.
    memory:
        Name of ``memory(model, options, n) -> [(what, bytes), ...]`` in ``options_module``:
        the arrays a run over ``n`` samples allocates beyond its result
        (:mod:`hybridlog.estimators.footprint`); empty: none worth counting.
    stream:
        Name of ``stream(model, signals, options, *, rows) -> Iterator[EstimationResult]``
        in ``module``: the run's result in consecutive chunks of at most ``rows`` rows, each
        a view the next one overwrites (:meth:`Prepared.stream`); empty: the estimator
        gives its result whole.
    inputs_check:
        Name of ``check(model, options, *, origins, **inputs)`` in ``options_module``
        (``origins``: :attr:`Prepared.origins`, for messages): checks the parsed
        files the options name (``centers=``) against the model and the options, before
        any log is read (:meth:`Prepared.check_inputs`); empty: nothing to check.
    """

    name: str
    summary: str
    source: str
    module: str
    options: str
    run: str
    capabilities: Capabilities = field(default_factory=Capabilities)
    options_module: str = ""
    memory: str = ""
    stream: str = ""
    inputs_check: str = ""

    def _attribute(self, name: str, module: str = "") -> Any:
        return getattr(importlib.import_module(module or self.module), name)

    @property
    def options_type(self) -> type[Any]:
        """The options dataclass (imports ``options_module``)."""
        return cast(type[Any], self._attribute(self.options, self.options_module))

    @property
    def run_function(self) -> Runner:
        """The run function (imports the estimator's module)."""
        return cast(Runner, self._attribute(self.run))

    @property
    def stream_function(self) -> Streamer:
        """The stream function (imports the estimator's module); only where ``stream`` is set."""
        return cast(Streamer, self._attribute(self.stream))

    def describe_options(self) -> tuple[OptionInfo, ...]:
        """Every option: name, type, default, range or choices, one-line help."""
        return describe_options(self.options_type)

    def help_text(self) -> str:
        """The estimator and its options as plain text for ``--help`` and the docs."""
        lines = [
            f"{self.name}: {self.summary} ({self.source})",
            f"needs: {', '.join(self.capabilities.needs())}",
            format_options(self.describe_options()),
        ]
        return "\n".join(lines)

    def markdown(self) -> str:
        """The estimator and a table of its options, for ``docs/estimators.md``."""

        def cell(value: object) -> str:
            return str(value).replace("|", "\\|")

        rows = [
            f"| `{i.name}` | {cell(i.type)} | `{shown(i.default)}` | "
            f"{cell(i.constraint.removeprefix('in '))} | {cell(i.help)} |"
            for i in self.describe_options()
        ]
        return "\n".join(
            [
                f"## {self.name}",
                "",
                f"{self.summary}. Source: {self.source}. Needs: "
                f"{', '.join(self.capabilities.needs())}." + self._step_from_text(),
                "",
                "| option | type | default | range | help |",
                "|---|---|---|---|---|",
                *rows,
            ]
        )

    def _step_from_text(self) -> str:
        """What the estimator does on a state-driven model, for :meth:`markdown` (or "")."""
        if not self.capabilities.modes_of_the_step_into:
            return ""
        differ = (
            "it runs instead on the mode pairs (mode of the step into x(k), mode of the step "
            "from it), so that y(k) is weighed with the output equations of its own mode and "
            "sample k shows the mode of the step from x(k) without look-ahead"
            if self.capabilities.runs_on_mode_pairs
            else "the report warns that the filter applied those of the step into x(k)"
        )
        return f" On a {STEP_FROM_NOTE}; where its modes' output equations differ, {differ}."

    def parse_options(
        self, values: Mapping[str, Any], sources: Mapping[str, OptionSource] | None = None
    ) -> Any:
        """The options dataclass from ``values``; errors name ``sources[name]``."""
        return parse_options(self.options_type, values, estimator=self.name, sources=sources)


_PER_SAMPLE_CLASSIFIER = Capabilities(
    needs_linear_model=True,
    needs_detectable=True,
    state_variances=False,
    no_smoothing="it classifies each sample from its own regressor (paper 001 eqs. (2)-(3)): "
    "no mode chain and no likelihoods to smooth",
    mode_rule="it classifies each sample from its own regressor (paper 001 eqs. (2)-(3)): "
    "its mode is a class, with no mode probabilities to take the most probable of",
)
"""What paper 001's estimators (``chiu``, ``kmeans``) need and why they have no smoother."""

ESTIMATORS: dict[str, Estimator] = {
    e.name: e
    for e in (
        Estimator(
            name="hstf",
            summary="hybrid strong tracking filter (unknown mode transitions)",
            source="paper 000, eqs. (5)-(40)",
            module="hybridlog.estimators.hstf",
            options="HstfOptions",
            options_module="hybridlog.estimators.filter_options",
            run="run_hstf",
            stream="stream_hstf",
            capabilities=Capabilities(
                needs_measurement_noise=True,
                no_smoothing="under paper 000's uniform mode prediction (1/n_q, eq. (20)) "
                "Kim's smoother returns the filtered probabilities and Viterbi the per-sample "
                "argmax; kbest would drop eq. (24)'s fading",
                mode_rule="its mode is the threshold rule of paper 000 eq. (40), not an argmax: "
                "the most probable mode once its probability reaches θ (option theta), "
                "else the previous sample's mode",
                modes_of_the_step_into=True,
            ),
        ),
        Estimator(
            name="imm",
            summary="interacting multiple model with an EKF per mode",
            source="Blom and Bar-Shalom 1988; Bar-Shalom, Li, Kirubarajan 2001, 11.6.6",
            module="hybridlog.estimators.imm",
            options="ImmOptions",
            options_module="hybridlog.estimators.filter_options",
            run="run_imm",
            stream="stream_imm",
            capabilities=Capabilities(
                needs_measurement_noise=True,
                uses_markov_matrix=True,
                supports_smoothing=True,
                modes_of_the_step_into=True,
                runs_on_mode_pairs=True,
                enumerates_components=True,
            ),
            memory="imm_memory",
        ),
        Estimator(
            name="chiu",
            summary="Chiu subtractive clustering + switched Luenberger observer",
            source="paper 001, eqs. (2)-(8), LMI (15)",
            module="hybridlog.estimators.chiu",
            options="ChiuOptions",
            options_module="hybridlog.estimators.observer_options",
            run="run_chiu",
            capabilities=_PER_SAMPLE_CLASSIFIER,
            inputs_check="check_centers",
        ),
        Estimator(
            name="kmeans",
            summary="k-means clustering + switched Luenberger observer (paper 001's baseline)",
            source="paper 001, eqs. (2)-(3), (8), LMI (15)",
            module="hybridlog.estimators.kmeans",
            options="KMeansOptions",
            options_module="hybridlog.estimators.observer_options",
            run="run_kmeans",
            capabilities=_PER_SAMPLE_CLASSIFIER,
            inputs_check="check_centers",
        ),
        Estimator(
            name="switching-observer",
            summary="switching observer of nonlinear hybrid automata with jumps (known sigma)",
            source="paper 004, eqs. (7), (20)-(21), sec. 5",
            module="hybridlog.estimators.hybrid_observer",
            options="SwitchingObserverOptions",
            options_module="hybridlog.estimators.hybrid_observer_options",
            run="run_switching_observer",
            capabilities=Capabilities(
                needs_switching_signal=True,
                applies_jump_maps=True,
                continuous_time=True,
                needs_single_output=True,
                needs_drift_observable=True,
                state_variances=False,
                no_smoothing="it takes the modes from the log's switching signal and its "
                "observer keeps no covariance (paper 004): no mode to decide, no RTS step",
                mode_rule="it takes the modes from the log's switching signal (paper 004): "
                "no mode to decide",
            ),
        ),
        Estimator(
            name="unknown-mode",
            summary="hybrid estimation with unknown modes: filter clusters per joint mode, "
            "k best trajectories",
            source="paper 002, eqs. (4)-(8), (12)-(21), §3.1",
            module="hybridlog.estimators.cpha.unknown_mode",
            options="UnknownModeOptions",
            options_module="hybridlog.estimators.cpha.options",
            run="run_unknown_mode",
            memory="unknown_mode_memory",
            capabilities=Capabilities(
                needs_components=True,
                needs_measurement_noise=True,
                applies_commands=True,
                unpredicted_outputs=True,
                no_smoothing="its cluster filters keep nothing for a backward pass; "
                "--mode-sequence kbest gives its offline mode sequence",
            ),
        ),
        Estimator(
            name="sliding-mode",
            summary="discrete-state reconstruction by a second-order sliding-mode observer",
            source="paper 003, eqs. (10)-(21), (30), (32), (48)",
            module="hybridlog.estimators.sliding_mode",
            options="SlidingModeOptions",
            options_module="hybridlog.estimators.sliding_mode_options",
            run="run_sliding_mode",
            capabilities=Capabilities(
                continuous_time=True,
                needs_boolean_affine=True,
                needs_measured_state=True,
                state_variances=False,
                no_smoothing="its modes are read from a sliding-mode observer's equivalent "
                "output injection (paper 003), with no likelihoods or covariances to smooth",
                mode_rule="its modes are read from a sliding-mode observer's equivalent "
                "output injection (paper 003), with no mode probabilities to take the most "
                "probable of",
            ),
        ),
    )
}
"""Every estimator this version provides, by name."""


def _unknown(name: str, known: Mapping[str, Estimator]) -> str:
    available = ", ".join(known)
    return f"unknown estimator {excerpt(name)} (available: {available}){closest(name, known)}"


def get_estimator(name: str, *, given_by: str = "--estimator") -> Estimator:
    """The registered estimator called ``name``.

    Raises
    ------
    OptionError
        ``<given_by>: unknown estimator ...`` listing the available ones.
    """
    if name in ESTIMATORS:
        return ESTIMATORS[name]
    raise OptionError(f"{given_by}: {_unknown(name, ESTIMATORS)}")


def unsuited(model: HybridModel, names: Sequence[str]) -> dict[str, list[str]]:
    """The names of ``names`` that are unknown or cannot run ``model``, by reason.

    The reason is what the estimator needs, the first clause of
    :meth:`~hybridlog.estimators.capabilities.Capabilities.mismatch`; an unknown name's is
    ``unknown`` with the closest known one.
    """
    traits = ModelTraits(model)
    refused: dict[str, list[str]] = {}  # reason -> names
    for name in names:
        if name not in ESTIMATORS:
            refused.setdefault(f"unknown{closest(name, ESTIMATORS)}", []).append(name)
        elif (mismatch := ESTIMATORS[name].capabilities.mismatch(traits)) is not None:
            refused.setdefault(mismatch.split("; ")[0], []).append(name)
    return refused


def unsuited_text(refused: Mapping[str, Sequence[str]]) -> str:
    """``'chiu', 'kmeans' (needs a linear switched model), ...`` of :func:`unsuited`."""
    return ", ".join(f"{', '.join(map(excerpt, group))} ({why})" for why, group in refused.items())


def refuse_unrunnable(model: HybridModel, names: Sequence[str], *, given_by: str) -> None:
    """Refuse the estimators of ``names`` that cannot run ``model``, all in one message.

    Named one at a time (:func:`get_estimator`, :func:`prepare`), the seven estimators on the
    double cart were refused for ``switching-observer``, then, it taken out, for
    ``unknown-mode``, then ``sliding-mode``, and two typos took two runs.  With two or more
    names unknown or unsuited each is named, those of one reason together, the reason as
    what the estimator needs (the first clause of
    :meth:`~hybridlog.estimators.capabilities.Capabilities.mismatch`: the message stays one
    line the CLI prints whole); one alone is left to those, which say it in full as before.

    Raises
    ------
    OptionError
        A name is unknown (``unknown; did you mean 'imm'?``).
    ModelError
        Every refused name is an estimator the model does not suit.
    """
    refused = unsuited(model, names)
    count = sum(map(len, refused.values()))
    if count < 2:
        return
    traits = ModelTraits(model)
    suited = [e.name for e in ESTIMATORS.values() if e.capabilities.mismatch(traits) is None]
    items = unsuited_text(refused)
    message = (
        f"{model.origin or model.name}: {given_by}: {count} of the {len(names)} estimators "
        f"cannot run this model: {items}; estimators for this model: "
        f"{', '.join(suited) or 'none'}"
    )
    if any(name not in ESTIMATORS for group in refused.values() for name in group):
        raise OptionError(message)
    raise ModelError(message)


def resolve_estimator(
    model: HybridModel, name: str | None, *, given_by: str = "--estimator"
) -> Estimator:
    """The estimator ``name``, or the model's ``default_estimator`` when ``name`` is None.

    Raises
    ------
    ModelError
        The model file names an unknown estimator in ``default_estimator`` (also when
        ``name`` is given: a typo there is an error of the file whichever estimator runs)
        or in an ``[estimators.<x>]`` table, or such a table has an option ``x`` does not
        have, a value that is not one of its option, or an option the model leaves unread
        (:func:`~hybridlog.estimators.options.check_table`): every table, not only the chosen
        estimator's (``smooth = true`` under ``[estimators.hstf]``, ``transition_stay = 7``
        under ``[estimators.imm]``, are errors of the file whichever estimator runs).
        Each table is checked whole, with the defaults of the options it leaves out (a
        combination its options refuse, a value the model cannot take); when its estimator
        is prepared, again with the ``--set`` values (:func:`prepare`).
    OptionError
        ``name`` is unknown (``<given_by>: unknown estimator ...``).
    """
    origin = model.origin or model.name
    if model.default_estimator is not None and model.default_estimator not in ESTIMATORS:
        raise ModelError(
            f"{origin}: default_estimator: {_unknown(model.default_estimator, ESTIMATORS)}"
        )
    for table, values in model.estimator_options.items():
        if table not in ESTIMATORS:
            raise ModelError(f"{origin}: estimators.{table}: {_unknown(table, ESTIMATORS)}")
        sources = {k: OptionSource.model_file(origin, table, k) for k in values}
        for key, value in values.items():
            if key in OFFLINE_OPTIONS and not admits(ESTIMATORS[table], key):
                why = not_offered(ESTIMATORS[table], key, value, ESTIMATORS.values())
                raise ModelError(f"{sources[key].label}: estimator '{table}' {why}")
        check_table(
            ESTIMATORS[table].options_type, values, estimator=table, sources=sources, model=model
        )
    return get_estimator(model.estimator_by_default if name is None else name, given_by=given_by)


@dataclass(frozen=True)
class Prepared:
    """An estimator with validated options, checked against a model, ready to run.

    Attributes
    ----------
    estimator:
        The registry entry.
    options:
        Its options dataclass, defaults filled in.
    origins:
        Where each option given came from, as errors name it (``--set centers=c.json``,
        ``m.toml: estimators.chiu.centers``); an option left at its default has none.
    """

    estimator: Estimator
    options: Any
    origins: Mapping[str, str] = field(default_factory=dict, compare=False)

    @property
    def name(self) -> str:
        """The estimator's registry name."""
        return self.estimator.name

    def check_inputs(self, model: HybridModel, **inputs: Any) -> None:
        """Check the parsed files the options name against ``model`` (``Estimator.inputs_check``).

        Run by the jobs before any log is read, so that a centres file fitted for another
        model fails at once, not after a long log was read (or, in a batch, on every log).
        """
        if self.estimator.inputs_check:
            check = self.estimator._attribute(
                self.estimator.inputs_check, self.estimator.options_module
            )
            check(model, self.options, origins=self.origins, **inputs)

    def run(self, model: HybridModel, signals: AlignedSignals, **inputs: Any) -> EstimationResult:
        """Run over the aligned log (checked first for what the estimator needs of a log).

        The signals are taken through :meth:`AlignedSignals.checked
        <hybridlog.signals.AlignedSignals.checked>` (lists and read-only arrays converted,
        an input or output that is not finite a ``LogError``), by :meth:`stream` too.

        ``inputs`` are the parsed files the options name (``centers=``), read by the job:
        estimators read no file.  A result with an offline pass carries the outputs its
        estimates explain (:func:`~hybridlog.estimators.explained.with_explained_outputs`).
        """
        from hybridlog.estimators.explained import with_explained_outputs  # numpy: not at start-up
        from hybridlog.estimators.vouch import check_explained

        signals = signals.checked()
        result = with_explained_outputs(model, self._whole(model, signals, inputs), signals)
        check_explained(model, signals, result)
        return result

    def _whole(
        self, model: HybridModel, signals: AlignedSignals, inputs: Mapping[str, Any]
    ) -> EstimationResult:
        """The estimator's whole result, its modes moved where :meth:`moves_modes` says."""
        self.check_signals(model, signals)
        with self._rules_left_out(model):
            with self._numerical_trouble(model), self._option_keys():
                result: EstimationResult = self._stamped(
                    self.estimator.run_function(model, signals, self.options, **inputs)
                )
            self._vouch(model, signals, result)
        if self.moves_modes(model):
            result = result.with_modes_of_the_step_from()
            if model.outputs_differ_by_mode:
                result = replace(result, notes=(*result.notes, STEP_INTO_OUTPUTS_WARNING))
        return self._with_component_modes(model, result)

    def _stamped(self, result: EstimationResult) -> EstimationResult:
        """``result`` named after this entry and holding its options, as the report writes them.

        The registry knows both: an estimator that left ``options`` empty (or named itself
        otherwise) wrote ``"options": {}`` into report.json, its ``--set`` values lost,
        though the recipe asks of its module only ``run(model, signals, options)``.  The
        options the estimator wrote itself stay, after the declared ones it left out
        (``chiu``'s fitted centres and gains).
        """
        declared = options_dict(self.options)
        if result.estimator == self.name and declared.keys() <= result.options.keys():
            return result
        return replace(result, estimator=self.name, options={**declared, **result.options})

    def _with_component_modes(
        self, model: HybridModel, result: EstimationResult
    ) -> EstimationResult:
        """Run on a ``[components]`` model's joint modes: add each component's modes.

        As timeline columns ``mode.<component>``
        (:func:`~hybridlog.estimators.cpha.joint.component_mode_columns`), which the report
        scores against the log's per-component truth.
        """
        if not (model.has_components and self.estimator.capabilities.enumerates_components):
            return result
        from hybridlog.estimators.cpha.joint import component_mode_columns, unapplied_rules_note

        note = unapplied_rules_note(model, self.estimator.name)
        notes = () if note is None else (note,)
        columns = component_mode_columns(model, result.modes)
        post = result.post_processing
        if post is not None:  # the filter's own modes, which the report compares with these
            filtered = post.filtered
            own = component_mode_columns(model, filtered.modes)
            post = replace(
                post,
                filtered=replace(
                    filtered,
                    timeline_columns=(*filtered.timeline_columns, *own),
                    notes=(*filtered.notes, *notes),
                ),
            )
        return replace(
            result,
            timeline_columns=(*result.timeline_columns, *columns),
            post_processing=post,
            notes=(*result.notes, *notes),
        )

    def _vouch(
        self,
        model: HybridModel,
        signals: AlignedSignals,
        result: EstimationResult,
        *,
        first: int = 0,
        before: Any = None,
    ) -> None:
        """Refuse a result holding a number nobody can vouch for (:mod:`.vouch`).

        A state or a defined variance that is not finite, a negative variance, mode
        probabilities that are no distribution, an output prediction that is not finite (NaN
        only where the estimator may leave an output unpredicted): no metric of such a run
        can be vouched for.  ``first`` is the log's row of the result's row 0 (a chunk),
        ``before`` the state estimate of the row before it.
        """
        from hybridlog.estimators.vouch import check_result

        capabilities = self.estimator.capabilities
        check_result(
            model,
            signals,
            result,
            variances=capabilities.state_variances,
            unpredicted=capabilities.unpredicted_outputs,
            first=first,
            before=before,
            paired=capabilities.runs_on_mode_pairs and runs_on_pairs(model),
        )

    @contextlib.contextmanager
    def _numerical_trouble(self, model: HybridModel) -> Iterator[None]:
        """A numerical warning raised as an error (as the commands do) names the estimator."""
        try:
            yield
        except RuntimeWarning as err:
            raise DivergenceError(
                f"{model.origin or model.name}: {self.name} stopped on numerical trouble "
                f"({err}): the model or the log drive it past double precision"
            ) from err

    @contextlib.contextmanager
    def _rules_left_out(self, model: HybridModel) -> Iterator[None]:
        """A run on a ``[components]`` model's joint modes that fails names the rules it left out.

        ``imm`` applies no rule with ``when`` (:func:`~hybridlog.estimators.cpha.joint.
        unapplied_rules_note`); a report says so in its notes, but a run that failed wrote
        none: a commanded valve's closing, which those rules alone allow, ended ``imm`` with
        "cannot explain the log ... an outlier, a stuck or offset sensor, another plant's
        log ...?", and the one cause that was the estimator's own went unsaid.
        """
        try:
            yield
        except ModelError as err:
            if not (model.has_components and self.estimator.capabilities.enumerates_components):
                raise
            from hybridlog.estimators.cpha.joint import unapplied_rules_note

            note = unapplied_rules_note(model, self.estimator.name)
            if note is None:
                raise
            raise suffixed(err, f" ({note})") from err

    @contextlib.contextmanager
    def _option_keys(self) -> Iterator[None]:
        """An error of the run about an option the model file gave names the file's key.

        An estimator names the option it refuses as the run finds out (chiu's
        ``cluster_modes: 2 mode ids for 3 clusters``: the clusters are fitted on the log);
        given by ``--set``, the option is named after the message
        (:func:`~hybridlog.errors.after_given`), but written in the model file it was named
        by neither the file nor the key.  Now the message starts with the key, as the
        file's other errors do: ``m.toml: estimators.chiu.cluster_modes: 2 mode ids ...``.
        """
        try:
            yield
        except OptionError as err:
            name, sep, rest = str(err).partition(": ")
            origin = self.origins.get(name, "") if sep else ""
            if not origin or origin.startswith("--"):  # a default, or the command line's
                raise
            raise ModelError(f"{origin}: {rest}", named=err.named) from err

    def moves_modes(self, model: HybridModel) -> bool:
        """Whether the modes are moved one sample earlier for this model.

        For an estimator whose modes are those of the step into each sample
        (:attr:`~hybridlog.estimators.capabilities.Capabilities.modes_of_the_step_into`) on
        a state-driven model, unless it runs on the mode pairs there
        (:attr:`~hybridlog.estimators.capabilities.Capabilities.runs_on_mode_pairs`, where
        the output equations differ by mode).  The result is then computed whole: a sample's
        mode is known only with the next sample's.
        """
        capabilities = self.estimator.capabilities
        if not (capabilities.modes_of_the_step_into and model.state_driven):
            return False
        return not (capabilities.runs_on_mode_pairs and runs_on_pairs(model))

    def check_signals(self, model: HybridModel, signals: AlignedSignals) -> None:
        """Refuse a log that lacks what the estimator needs of one (one line, ``LogError``).

        :meth:`Capabilities.signals_mismatch
        <hybridlog.estimators.capabilities.Capabilities.signals_mismatch>`: the switching
        signal, the commands the transition rules name.  Run as the estimator starts, and by
        ``analyze``, ``compare`` (for every estimator) and each log of a batch once the log
        is read, before any estimator runs: a log without the switching signal or a command
        of the last estimator named was refused after the others had run, their work lost.
        Signals aligned for another model (other inputs or outputs, or in another order) are
        refused too: the compiled loops index the model's columns without bounds checks,
        and gave a result read from the wrong columns or past the arrays.
        """
        for kind, held, named in (
            ("inputs", signals.input_names, model.inputs),
            ("outputs", signals.output_names, model.outputs),
        ):
            if tuple(held) != tuple(named):
                raise LogError(
                    f"{signals.source}: the signals hold the {kind} {', '.join(held) or 'none'}, "
                    f"where model {model.origin or model.name} has {', '.join(named) or 'none'} "
                    "(signals aligned for another model: load_signals(path, SignalSpec.of(model)))"
                )
        problem = self.estimator.capabilities.signals_mismatch(model, signals)
        if problem is not None:
            raise LogError(f"{signals.source}: estimator '{self.name}' {problem}")

    def stream(
        self,
        model: HybridModel,
        signals: AlignedSignals,
        *,
        rows: int = CHUNK_ROWS,
        **inputs: Any,
    ) -> Iterator[EstimationResult]:
        """The run's result in consecutive chunks of at most ``rows`` rows, in order.

        Checked first as :meth:`run` is.  For an entry with ``stream``, its chunks: each
        chunk's arrays are views of buffers the next chunk overwrites, so a consumer copies
        what it keeps before asking for the next one; ``runtime_s`` and ``compile_s`` are
        the run's so far.  For the others, and for a run with an offline pass
        (:attr:`offline`) or whose modes are moved (:meth:`moves_modes`), the whole result
        is computed first (here, before the first chunk is asked for) and given in chunks of
        ``rows`` rows (:meth:`~hybridlog.estimators.result.EstimationResult.rows`, views),
        each with the outputs its estimates explain as :meth:`run` gives them, computed as
        the chunk is asked for: from the estimators' worker of a command the chunks cross
        while the report takes the one before.  :meth:`streamed` says whether the
        estimator itself streams (its memory is then a chunk's).
        """
        signals = signals.checked()
        if not self.estimator.stream or self.offline or self.moves_modes(model):
            return self._in_chunks(model, signals, self._whole(model, signals, inputs), rows)
        self.check_signals(model, signals)
        with self._rules_left_out(model), self._numerical_trouble(model), self._option_keys():
            chunks = self.estimator.stream_function(
                model, signals, self.options, rows=rows, **inputs
            )
        return self._vouched_chunks(model, signals, chunks)

    def _vouched_chunks(
        self, model: HybridModel, signals: AlignedSignals, chunks: Iterator[EstimationResult]
    ) -> Iterator[EstimationResult]:
        """The estimator's own chunks, each checked (:meth:`_vouch`) before it is given."""
        first, before = 0, None
        while True:
            with self._rules_left_out(model):
                with self._numerical_trouble(model), self._option_keys():
                    chunk = next(chunks, None)
                if chunk is None:
                    return
                chunk = self._stamped(chunk)
                self._vouch(model, signals, chunk, first=first, before=before)
            if chunk.n_samples:
                first, before = first + chunk.n_samples, chunk.state_means[-1].copy()
            yield self._with_component_modes(model, chunk)

    @staticmethod
    def _in_chunks(
        model: HybridModel, signals: AlignedSignals, result: EstimationResult, rows: int
    ) -> Iterator[EstimationResult]:
        """``result`` in consecutive chunks of at most ``rows`` rows (one for an empty log)."""
        from hybridlog.estimators.explained import with_explained_outputs
        from hybridlog.estimators.vouch import check_explained

        if rows < 1:
            raise ValueError(f"rows must be at least 1, got {rows}")
        n = result.n_samples
        for start in range(0, max(n, 1), rows):
            stop = min(start + rows, n)
            rows_of_log = signals.rows(start, stop)
            chunk = with_explained_outputs(model, result.rows(start, stop), rows_of_log)
            check_explained(model, rows_of_log, chunk, first=start)
            yield chunk

    def warm_up(self, model: HybridModel, rows: int = 3) -> None:
        """Load what a run needs for this model: a stream over a few rows of zeros.

        Numba's cached machine code, for an entry with ``stream`` (the filters, whose
        compiled loops take about 0.5 s to load), its chunks discarded: the console script
        sends it to the estimators' worker as soon as the options are checked, so that the
        loading happens while the command reads the log (``hybridlog.jobs.estimation``).
        Other entries have nothing to load ahead.  What it raises is raised again by the run
        itself.
        """
        if not self.estimator.stream:
            return
        import numpy as np

        from hybridlog.signals import AlignedSignals

        zeros = AlignedSignals(
            source="warm-up",
            time=np.arange(rows, dtype=np.float64) * np.float64(model.dt),
            input_names=tuple(model.inputs),
            output_names=tuple(model.outputs),
            inputs=np.zeros((rows, len(model.inputs))),
            outputs=np.zeros((rows, len(model.outputs))),
            state_names=tuple(model.states),
        )
        for _ in self.stream(model, zeros):
            pass

    @property
    def offline(self) -> bool:
        """Whether the options ask for an offline pass after the filter.

        ``smooth``, or a ``mode_sequence`` other than ``argmax``: a pass that reads the whole
        forward pass.
        """
        options = self.options_dict()
        return options.get("smooth") is True or options.get("mode_sequence", "argmax") != "argmax"

    def streamed(self, model: HybridModel, n_samples: int, rows: int = CHUNK_ROWS) -> bool:
        """Whether the estimator computes a log of ``n_samples`` rows a chunk at a time.

        Only an entry with ``stream`` does, for a log longer than ``rows``, and only when
        its options ask for no offline pass (:attr:`offline`): such a pass reads the whole
        forward pass, so the result is computed whole; so is one whose modes are moved
        (:meth:`moves_modes`).  (:meth:`stream` gives a whole result in chunks too, but
        it is all in memory first.)
        """
        if rows < 1:
            raise ValueError(f"rows must be at least 1, got {rows}")
        return (
            bool(self.estimator.stream)
            and not self.offline
            and not self.moves_modes(model)
            and n_samples > rows
        )

    def memory_needed(self, model: HybridModel, n_samples: int) -> Parts:
        """What a run over ``n_samples`` needs at its peak: (what, bytes) of each part.

        A run whose result is computed whole (:meth:`run`, or not :meth:`streamed`): the
        result times :data:`~hybridlog.estimators.footprint.REPORT_FACTOR` (the report's
        temporaries beside it), the estimator's own arrays, and with an offline pass
        (:attr:`offline`) the outputs its estimate and the filter's explain (:meth:`run`).
        A streamed run (:meth:`streamed`): one chunk of the result times the same factor, and
        the estimated mode of every sample, which the report keeps for its mode metrics.
        """
        if self.streamed(model, n_samples):
            return [
                (
                    "one chunk of the estimates",
                    int(result_bytes(model, CHUNK_ROWS) * REPORT_FACTOR),
                ),
                ("the estimated modes", MODE_BYTES * n_samples),
            ]
        parts = [("the estimates", int(result_bytes(model, n_samples) * REPORT_FACTOR))]
        if self.estimator.memory:
            own = self.estimator._attribute(self.estimator.memory, self.estimator.options_module)
            parts += own(model, self.options, n_samples)
        if self.offline:
            parts.append(("the outputs each side explains", 2 * 8 * n_samples * model.n_outputs))
        return parts

    def options_dict(self) -> dict[str, Any]:
        """The options as the report's ``options`` (read back by :func:`prepare`)."""
        return options_dict(self.options)


def _kind(value: object) -> str:
    """``value``'s type and an excerpt of it, for a refusal of an argument's type."""
    return f"{type(value).__name__} {excerpt(value)}"


def prepare(
    model: HybridModel,
    name: str | None,
    overrides: Mapping[str, Any] | None = None,
    *,
    given_by: str = "--estimator",
    overrides_by: str = "--set",
    flags: Mapping[str, str] | None = None,
    complete: bool = True,
) -> Prepared:
    """Resolve an estimator and its options for ``model`` before any log is read.

    Parameters
    ----------
    model:
        The loaded model (``model.origin`` names its file in errors).
    name:
        The estimator's name, or ``None`` for the model's ``default_estimator``.
    overrides:
        Option values that replace the model file's ``[estimators.<name>]`` values.
    given_by, overrides_by:
        The command-line options ``name`` and ``overrides`` came from, for messages.
    flags:
        The overrides a flag of their own gave (``smooth``: ``--smooth``), as messages and
        :attr:`Prepared.origins` name them instead of ``overrides_by``.
    complete:
        Refuse options that leave the estimator without something it needs (their
        ``missing()``: ``sliding-mode`` without ``v_max`` or ``drift_bound``), as a run
        would; ``False`` where a command line may still give it (``hybridlog models FILE``,
        which reads no log).

    Raises
    ------
    ModelError
        The model file names an unknown estimator (``default_estimator``, an
        ``[estimators.<x>]`` table), gives a bad option value, the model lacks what the
        estimator needs, or (with ``complete``) the options leave it without a value it
        needs (one line naming the file, the key and the estimator).
    OptionError
        An unknown estimator name or a bad override (naming ``given_by``/``overrides_by``);
        a ``name`` that is not a ``str``, or ``overrides`` not a mapping of option names
        (``["smooth=true"]``: ``{"smooth": "true"}``), named by type.
    """
    if name is not None and not isinstance(name, str):
        raise OptionError(f"{given_by}: expected an estimator's name, got the {_kind(name)}")
    if overrides is not None and not (
        isinstance(overrides, Mapping) and all(isinstance(k, str) for k in overrides)
    ):
        raise OptionError(
            f"{overrides_by}: expected a mapping of option names to values, "
            f"got the {_kind(overrides)}"
        )
    estimator = resolve_estimator(model, name, given_by=given_by)
    unwritten = name is None and model.default_estimator is None
    what = (
        "estimator"
        if name is not None
        else "no default_estimator is written, and the default estimator"
        if unwritten
        else "default_estimator"
    )
    name = estimator.name
    origin = model.origin or model.name
    traits = ModelTraits(model)
    problem = estimator.capabilities.mismatch(traits)
    if problem is not None:
        suited = [e.name for e in ESTIMATORS.values() if e.capabilities.mismatch(traits) is None]
        hint = f" (estimators for this model: {', '.join(suited)})" if suited else ""
        if unwritten:
            hint = f"; give --estimator{hint}"
        raise ModelError(f"{origin}: {what} '{name}' {problem}{hint}")
    from_file = model.estimator_options.get(name, {})
    sources = {k: OptionSource.model_file(origin, name, k) for k in from_file}
    overrides = overrides or {}
    for k, v in overrides.items():
        flag = (flags or {}).get(k)  # --smooth, not --set smooth=true
        sources[k] = OptionSource(flag) if flag else OptionSource.command_line(overrides_by, k, v)
    options = estimator.parse_options({**from_file, **overrides}, sources)
    refuse_invalid(options, model, name, sources, overrides)  # the file's: check_table
    missing = getattr(options, "missing", None) if complete else None
    if missing is not None and (why := missing()) is not None:
        raise model.error(f"estimators.{name}", why)
    return Prepared(estimator, options, {k: source.label for k, source in sources.items()})


def reference_markdown() -> str:
    """``docs/estimators.md``: every estimator and its options, from the registry alone."""
    sections = [e.markdown() for e in ESTIMATORS.values()]
    return "\n\n".join([_REFERENCE_HEADER, *sections]) + "\n"


_REFERENCE_HEADER = """# Estimators and their options

Generated from the registry (`hybridlog/estimators/registry.py`) with
`python -m hybridlog.estimators > docs/estimators.md`; a test checks it is current.
Options are set in a model file's `[estimators.<name>]` table or with `--set NAME=VALUE`
(which wins)."""
