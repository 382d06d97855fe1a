"""The ``analyze`` and ``compare`` jobs: one log through one or several estimators.

This layer joins the others (``io`` → ``model`` → ``estimators`` → ``report``) and is what
the CLI calls; it prints nothing and raises :class:`~hybridlog.errors.HybridlogError`.

Importing it loads no polars: the batch process of ``batch --jobs N`` (and of
``--scheduler``) imports this module to check the model, the options and the outputs but
reads no log and writes no table, and polars' import costs 0.13-0.17 s of a core its
workers need.  The readers (:func:`hybridlog.io.load_signals`) and the report's writer
(:func:`hybridlog.report.write_report`) are imported where a log is read and a report
written (``tests/jobs/test_batch_process.py``).
"""

from __future__ import annotations

import contextlib
import os
import re
import sys
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import partial
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

from hybridlog.background import ESTIMATES, Background, worker
from hybridlog.cluster.progress import current_reporter, current_wait
from hybridlog.errors import (
    DivergenceError,
    HybridlogError,
    LogError,
    OptionError,
    as_text,
    excerpt,
    prefixed,
    set_text,
)
from hybridlog.estimators import (
    ESTIMATORS,
    Estimator,
    Prepared,
    prepare,
    refuse_unrunnable,
    resolve_estimator,
)
from hybridlog.estimators.options import closest
from hybridlog.io import ReadOptions, SignalSpec
from hybridlog.jit import set_up
from hybridlog.jobs import arguments
from hybridlog.jobs.centers import read_centers
from hybridlog.jobs.estimator_calls import reported, warm_up_told
from hybridlog.jobs.origins import given_in_chunks, given_values, run_values
from hybridlog.memory import check_fits, reserved
from hybridlog.model.cache import load_model, load_model_set
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.outputs import (
    PathLike,
    atomic_output_dir,
    check_apart,
    check_dir_target,
)
from hybridlog.outputs.folder_targets import check_outside_batch
from hybridlog.report import (
    Report,
    parse_gates,
    recorded_failures,
    validate_gates,
)
from hybridlog.report.comparison import (
    reach_section,
    sample_counts,
    samples_section,
    unavailable_section,
    unequal_columns,
)
from hybridlog.report.gates import Gate, metric
from hybridlog.report.summary import (
    comparison_markdown,
    gate_cell,
    gated_columns,
    markdown_table,
    state_columns,
    warning_notes,
    write_summary_csv,
)
from hybridlog.report.table_format import check_table_format
from hybridlog.signals import AlignedSignals

if TYPE_CHECKING:
    from hybridlog.estimators.result import EstimationResult


@dataclass(frozen=True)
class Overrides:
    """``--set NAME=VALUE`` values, split into model parameters and estimator options.

    All are read-only mappings: the value is built once by :func:`parse_sets`.
    ``parameter_texts`` holds each parameter's value as typed (``--set A=150`` is ``150``),
    for what a report or an error says of it; ``flags`` the options a flag of their own gave
    (``smooth``: ``--smooth``), as :func:`smoothing_overrides` adds them.
    """

    parameters: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}))
    options: Mapping[str, str] = field(default_factory=lambda: MappingProxyType({}))
    parameter_texts: Mapping[str, str] = field(default_factory=lambda: MappingProxyType({}))
    flags: Mapping[str, str] = field(default_factory=lambda: MappingProxyType({}))


def parse_sets(values: Sequence[str], model_ref: str | Path) -> tuple[HybridModel, Overrides]:
    """Load the model and split ``--set`` values into parameters and estimator options.

    Names of model parameters change the model; all other names are estimator options,
    checked against the chosen estimators by :func:`prepare_estimators` (which refuses a
    parameter's name that is also an option of one of them).
    """
    model = load_model(model_ref)
    texts: dict[str, str] = {}
    options: dict[str, str] = {}
    for text in values:
        name, sep, value = text.partition("=")
        name = name.strip()
        if not sep or not name:
            raise OptionError(f"--set: {excerpt(text)} is not NAME=VALUE")
        if name in texts or name in options:
            raise OptionError(f"--set {excerpt(name)[1:-1]}: given twice")
        if name in model.parameters:
            texts[name] = value.strip()
        else:
            options[name] = value.strip()
    if texts:
        model = load_model_set(model_ref, texts)
        from hybridlog.model.reads import refuse_unread_by_analysis

        refuse_unread_by_analysis(model, texts)
    parameters = {name: model.parameters[name] for name in texts}
    return model, Overrides(
        MappingProxyType(parameters), MappingProxyType(options), MappingProxyType(texts)
    )


SMOOTH_OPTION = "smooth"
"""The estimator option ``--smooth`` sets (``smooth = true`` under ``[estimators.<name>]``)."""

MODE_SEQUENCE_OPTION = "mode_sequence"
"""The estimator option ``--mode-sequence`` sets (``argmax``, ``viterbi`` or ``kbest``)."""

OFFLINE_OPTIONS = (SMOOTH_OPTION, MODE_SEQUENCE_OPTION, "beam", "smoother")
"""The options of the offline passes (``docs/smoothing.md``): ``--set`` of one that no chosen
estimator has is refused as ``--smooth`` is, with the reason (:func:`_not_offered`)."""


def _admits(estimator: Estimator, option: str) -> bool:
    """Whether the estimator has the option (and, for ``smooth``, declares a smoother)."""
    names = {info.name for info in estimator.describe_options()}
    if option == SMOOTH_OPTION:
        return estimator.capabilities.supports_smoothing and option in names
    return option in names


def _choices(estimator: Estimator, option: str) -> list[str]:
    """The values an estimator's option of a ``Literal`` type takes."""
    return next(i.type for i in estimator.describe_options() if i.name == option).split("|")


def _offers(estimator: Estimator, option: str, value: str) -> bool:
    """Whether the estimator has the option and, for ``mode_sequence``, that value of it."""
    if not _admits(estimator, option):
        return False
    return option != MODE_SEQUENCE_OPTION or value in _choices(estimator, option)


def smoothing_overrides(
    chosen: Sequence[Estimator],
    overrides: Overrides,
    *,
    smooth: bool = False,
    mode_sequence: str | None = None,
    given_by: str = "--estimator",
) -> Overrides:
    """``--smooth`` and ``--mode-sequence`` as the estimator options they stand for.

    ``--smooth`` is ``--set smooth=true`` and ``--mode-sequence X`` is ``--set
    mode_sequence=X``, with one difference: every chosen estimator must have the option
    (``compare --smooth`` smooths every estimator it compares or refuses; ``--set
    smooth=true`` is the way to smooth only the estimators that have a smoother).

    Raises
    ------
    OptionError
        One line naming the flag and the estimator without the option (and the estimators
        that have it), or a flag given together with ``--set`` of its option.
    """
    flags = {SMOOTH_OPTION: ("--smooth", "true" if smooth else None)}
    flags[MODE_SEQUENCE_OPTION] = ("--mode-sequence", mode_sequence)
    options = dict(overrides.options)
    labels = dict(overrides.flags)
    for option, (flag, value) in flags.items():
        if value is None:
            continue
        if option in options:
            raise OptionError(
                f"{flag}: also given as --set {option}={excerpt(options[option])[1:-1]}; "
                "give one of them"
            )
        for estimator in chosen:
            if not _admits(estimator, option):
                hint = ""
                if len(chosen) > 1:
                    hint = f"; --set {option}={value} applies it only to the estimators that do"
                said = flag if option == SMOOTH_OPTION else f"{flag} {value}"
                raise _not_offered(said, estimator, option, value, given_by, hint)
            if not _offers(estimator, option, value):
                raise OptionError(
                    f"{flag} {value}: estimator '{estimator.name}' offers "
                    f"{', '.join(_choices(estimator, option))}"
                    f"{_only_some(chosen, option, value)}"
                )
        options[option] = value
        labels[option] = flag if option == SMOOTH_OPTION else f"{flag} {value}"
    return replace(overrides, options=MappingProxyType(options), flags=MappingProxyType(labels))


def _only_some(chosen: Sequence[Estimator], option: str, value: str) -> str:
    """How to give ``option = value`` to those of several ``chosen`` that offer that value.

    ``--set`` gives it to every estimator with the option, and one that has the option but
    not the value refuses it; a model file's ``[estimators.<name>]`` table gives it to one.
    """
    offering = [e.name for e in chosen if _offers(e, option, value)]
    if len(chosen) < 2 or not offering:
        return ""
    return (
        f'; for {", ".join(offering)} alone, {option} = "{value}" under '
        + ", ".join(f"[estimators.{name}]" for name in offering)
        + " in the model file"
    )


def _not_offered(
    flag: str, estimator: Estimator, option: str, value: object, given_by: str, hint: str = ""
) -> OptionError:
    """One line: ``flag`` sets ``option``, which ``estimator`` lacks; why, and who offers it.

    Those who offer it have the option and, for ``mode_sequence``, ``value`` among its values.
    The reason answers the value: ``mode_sequence = "argmax"`` asks for no offline pass, so
    its refusal says how the estimator decides its modes instead (``Capabilities.mode_rule``,
    hstf's threshold rule), the others why it has no offline pass (``no_smoothing``).
    """
    having = [e.name for e in ESTIMATORS.values() if _offers(e, option, str(value))]
    capabilities = estimator.capabilities
    argmax = option == MODE_SEQUENCE_OPTION and str(value) == "argmax"
    why = capabilities.mode_rule if argmax else capabilities.no_smoothing
    return OptionError(
        f"{flag}: estimator '{estimator.name}' ({given_by}) does not offer it"
        f"{': ' + why if why else ''} (estimators that do: {', '.join(having) or 'none'}){hint}"
    )


def prepare_estimators(
    model: HybridModel,
    names: Sequence[str | None],
    overrides: Overrides,
    *,
    given_by: str = "--estimator",
    smooth: bool = False,
    mode_sequence: str | None = None,
) -> list[Prepared]:
    """Resolve estimators (``None``: the model's default) and their options before any work.

    Each estimator gets the ``--set`` options it declares; a name that is neither a model
    parameter nor an option of any chosen estimator is an :class:`OptionError` listing both
    and suggesting the closest name.  ``smooth`` and ``mode_sequence`` (``--smooth``,
    ``--mode-sequence``) set those options of every chosen estimator, each of which must
    have them (:func:`smoothing_overrides`).
    """
    refuse_unrunnable(model, [name for name in names if name is not None], given_by=given_by)
    chosen = [resolve_estimator(model, name, given_by=given_by) for name in names]
    # what a refusal names as the estimator's origin: the option, or the model's default
    chosen_by = (
        given_by
        if any(name is not None for name in names)
        else f"the default_estimator of {model.origin or model.name}"
    )
    overrides = smoothing_overrides(
        chosen, overrides, smooth=smooth, mode_sequence=mode_sequence, given_by=chosen_by
    )
    declared = {e.name: [i.name for i in e.describe_options()] for e in chosen}
    for name, text in overrides.parameter_texts.items():
        owners = [e for e, known in declared.items() if name in known]
        if owners:  # the parameter took it: hstf's rho stayed 0.95 without a word
            raise OptionError(
                f"{set_text(name, text)}: {name!r} is both a parameter of model "
                f"{model.origin or model.name} and an option of {', '.join(owners)}, and "
                f"--set would change the parameter only; rename the parameter, or set the "
                f"option under [estimators.{owners[0]}] in the model file"
            )
    for name, value in overrides.options.items():
        if not any(name in known for known in declared.values()):
            flag = f"--set {excerpt(name)[1:-1]}={excerpt(value)[1:-1]}"
            if name in OFFLINE_OPTIONS:  # as --smooth and --mode-sequence are refused
                raise _not_offered(flag, chosen[0], name, value, chosen_by)
            if model.scenario is not None and name in model.scenario.parameters:
                # was "neither a parameter ... did you mean 'light_full'?": another name
                raise OptionError(
                    f"{flag}: a scenario parameter of model {model.origin or model.name} "
                    "([simulation.parameters]), which only simulate plays; an estimator "
                    "reads the log, not the scenario"
                )
            options = "; ".join(f"options of {e}: {', '.join(k)}" for e, k in declared.items())
            candidates = [*model.parameters, *(n for k in declared.values() for n in k)]
            raise OptionError(
                f"--set {excerpt(name)[1:-1]}={excerpt(value)[1:-1]}: neither a parameter of "
                f"model {model.origin or model.name} (parameters: "
                f"{', '.join(model.parameters) or 'none'}) nor an estimator option ({options})"
                f"{closest(name, candidates)}"
            )
    prepared = [
        prepare(
            model,
            name,  # None: the default, which a refusal names as default_estimator
            {k: v for k, v in overrides.options.items() if k in declared[e.name]},
            given_by=given_by,
            flags=overrides.flags,
        )
        for name, e in zip(names, chosen, strict=True)
    ]
    _refuse_inert(model, prepared, overrides.options, declared)
    return prepared


def _inert(options: object, model: HybridModel) -> Mapping[str, str]:
    """The options an options dataclass says are inert on ``model`` (name → why)."""
    inert: Callable[[HybridModel], Mapping[str, str]] | None = getattr(options, "inert", None)
    return {} if inert is None else inert(model)


def _refuse_inert(
    model: HybridModel,
    prepared: Sequence[Prepared],
    options: Mapping[str, str],
    declared: Mapping[str, list[str]],
) -> None:
    """Refuse a ``--set`` option that no chosen estimator having it would read.

    An options dataclass may say which of its options the others' values, or the model,
    make inert (``inert(model) -> {name: why}``, e.g. ``imm``'s ``beam`` without
    ``mode_sequence = kbest``, its ``transition_stay`` on a one-mode model);
    ``--set`` of one is refused when every chosen estimator that has it says so (``compare
    --estimators imm,unknown-mode --set beam=50`` sets unknown-mode's beam, and runs).
    """
    for name, value in options.items():
        having = [p for p in prepared if name in declared[p.name]]
        why = [_inert(p.options, model).get(name) for p in having]
        if having and all(why):
            raise OptionError(
                f"--set {excerpt(name)[1:-1]}={excerpt(value)[1:-1]}: has no effect on "
                f"estimator '{having[0].name}': {why[0]}"
            )


def set_reach(model: HybridModel, prepared: Sequence[Prepared], overrides: Overrides) -> list[str]:
    """What each ``--set`` of an estimator option left out of the estimators compared.

    ``--set NAME=VALUE`` goes to every chosen estimator that has the option and is refused
    only when none would read it (:func:`prepare_estimators`, :func:`_refuse_inert`):
    ``compare --estimators hstf,imm --set rho=0.9`` tunes hstf alone (imm has no ``rho``),
    and the comparison then set a tuned hstf beside a default imm without a word.  One
    phrase per option that does not reach every estimator: those it reaches, then each
    left out and why (``--set rho=0.9 reaches hstf alone: imm has no option rho``; an
    option it has but does not read there: ``on imm it has no effect: ...``).  The flags
    (``--smooth``, ``--mode-sequence``) reach every estimator or are refused.
    """
    phrases: list[str] = []
    for name, value in overrides.options.items():
        if name in overrides.flags:
            continue
        reached: list[str] = []
        lacking: list[str] = []
        unread: list[str] = []
        for p in prepared:
            why = _inert(p.options, model).get(name)
            if name not in {info.name for info in p.estimator.describe_options()}:
                lacking.append(p.name)
            elif why:
                unread.append(f"on {p.name} it has no effect: {why}")
            else:
                reached.append(p.name)
        if not (lacking or unread):
            continue
        shown = f"--set {excerpt(name)[1:-1]}={excerpt(value)[1:-1]}"
        if lacking:
            have = "has" if len(lacking) == 1 else "have"
            unread.insert(0, f"{', '.join(lacking)} {have} no option {excerpt(name)[1:-1]}")
        phrases.append(f"{shown} reaches {', '.join(reached)} alone: {'; '.join(unread)}")
    return phrases


FILE_OPTIONS: Mapping[str, tuple[str, Callable[[str], object]]] = MappingProxyType(
    {"centers": ("centres file", read_centers)}
)
"""Estimator options that name an input file: option → (what the file is, its reader).

The job reads the file (estimators read none) and passes the parsed content to the
estimator's run function as the keyword argument of the same name (:func:`estimator_inputs`);
no output may touch the file (:func:`input_paths`)."""


def input_paths(
    logs: Sequence[PathLike],
    model_ref: PathLike,
    prepared: Sequence[Prepared],
    read: ReadOptions,
) -> list[tuple[str, PathLike]]:
    """Every file and folder a run reads, named for error messages: no output may touch them.

    The logs, the model file (unless a built-in name), the files estimator options name
    (:data:`FILE_OPTIONS`: a centres file, from ``--set`` or the model file) and every
    ``--msg-dir``.
    """
    paths: list[tuple[str, PathLike]] = [("log", log) for log in logs]
    if os.path.isfile(model_ref):  # a folder named like a built-in is not the model
        paths.append(("model file", model_ref))
    for estimator in prepared:
        for name, (what, _) in FILE_OPTIONS.items():
            value = getattr(estimator.options, name, None)
            if value:
                paths.append((what, value))
    paths += [("--msg-dir folder", folder) for folder in read.msg_dirs]
    return paths


def estimator_inputs(prepared: Prepared, model: HybridModel) -> dict[str, Any]:
    """The files the estimator's options name (:data:`FILE_OPTIONS`), read, parsed and checked.

    The keyword arguments of :meth:`Prepared.run <hybridlog.estimators.Prepared.run>` (and
    ``stream``), checked against ``model`` and the options before any log is read
    (:meth:`Prepared.check_inputs <hybridlog.estimators.Prepared.check_inputs>`); errors
    name the file and the key at fault, and a file a model file names is named by its key
    (``m.toml: estimators.chiu.centers: ...``), a relative path there being relative to the
    model file's folder.
    """
    inputs: dict[str, Any] = {}
    for name, (_, read) in FILE_OPTIONS.items():
        value = getattr(prepared.options, name, None)
        if value:
            origin = prepared.origins.get(name, "")
            try:
                inputs[name] = read(value)
            except OptionError as err:
                if origin.startswith("--set"):
                    raise
                raise OptionError(f"{origin}: {err}") from err
    prepared.check_inputs(model, **inputs)
    return inputs


def read_log(
    log: str | Path,
    model: HybridModel,
    read: ReadOptions,
    notes: dict[str, Any] | None = None,
) -> AlignedSignals:
    """The log's signals for ``model`` on its grid; ``notes`` gets what reading did."""
    from hybridlog.io import load_signals  # polars: see the module's docstring

    return load_signals(log, SignalSpec.of(model), read, notes=notes)


def _memory_needs(
    log: str | Path, model: HybridModel, prepared: Sequence[Prepared], signals: AlignedSignals
) -> tuple[list[tuple[str, int]], str, str]:
    """What the estimators need of memory: ``(parts, what, remedy)`` for :func:`check_fits`.

    ``compare`` runs them one after the other, so the largest counts.
    """
    n = signals.n_samples

    def needs(estimator: Prepared) -> list[tuple[str, int]]:
        name = f" of {estimator.name}" if len(prepared) > 1 else ""
        return [(f"{what}{name}", size) for what, size in estimator.memory_needed(model, n)]

    parts = max(map(needs, prepared), key=lambda need: sum(size for _, size in need), default=[])
    offline = any(p.offline for p in prepared)
    remedy = "analyse a shorter log" + (
        ", or without --smooth and --mode-sequence" if offline else ""
    )
    beams: list[int] = sorted(
        {
            int(p.options.beam)
            for p in prepared
            if getattr(p.options, "mode_sequence", None) == "kbest" and hasattr(p.options, "beam")
        }
    )
    if beams:  # the k-best histories grow with the beam as with the log
        remedy += f", or a smaller beam (--set beam=N, now {', '.join(map(str, beams))})"
    names = ", ".join(p.name for p in prepared)
    return parts, f"{log}: {n:,} samples through {names}", remedy


def check_memory(
    log: str | Path, model: HybridModel, prepared: Sequence[Prepared], signals: AlignedSignals
) -> None:
    """Refuse, before any estimator allocates, a run whose results cannot fit in memory.

    The estimators' needs (:meth:`Prepared.memory_needed
    <hybridlog.estimators.Prepared.memory_needed>`; ``compare`` runs them one after the
    other, so the largest counts) against what the machine can still give
    (:func:`hybridlog.memory.check_fits`).

    Raises
    ------
    LogError
        One line naming the log, its samples, the estimators, the largest parts, the memory
        available and what to change.
    """
    parts, what, remedy = _memory_needs(log, model, prepared, signals)
    check_fits(parts, what=what, remedy=remedy, error=LogError)


def memory_reserved(
    log: str | Path, model: HybridModel, prepared: Sequence[Prepared], signals: AlignedSignals
) -> contextlib.AbstractContextManager[float]:
    """:func:`check_memory` for a ``with`` block that counts a pool's other workers too.

    In a worker of a local ``batch --jobs N`` the needs are held in the pool's ledger for the
    block, and a log that fits alone but not beside the logs the other workers run waits for
    them (:func:`hybridlog.memory.reserved`); on a Dask worker with a ``memory_limit``, the
    needs are checked against that limit and held beside the worker's other logs
    (:func:`hybridlog.jobs.dask_backend.worker_reserved`); elsewhere it is
    :func:`check_memory`.  The context gives the seconds waited.
    """
    from hybridlog.jobs.dask_backend import worker_memory, worker_reserved

    parts, what, remedy = _memory_needs(log, model, prepared, signals)
    on_dask = worker_memory()
    if on_dask is not None:
        return worker_reserved(parts, on_dask, what=what, remedy=remedy, error=LogError)
    return reserved(parts, what=what, remedy=remedy, error=LogError)


def read_for_estimation(
    log: str | Path, model: HybridModel, read: ReadOptions, notes: dict[str, Any]
) -> AlignedSignals:
    """The log's signals, with numba set up meanwhile for the estimators.

    Where the process has a worker (the console script's ``analyze`` and ``compare``,
    :func:`hybridlog.background.start_worker`), the estimators run there and the worker set
    numba up from its start: the log is simply read.  Elsewhere the log is read in a thread
    while this one sets up numba (:func:`hybridlog.jit.set_up`): polars' readers release
    the GIL, numba's set-up holds it, and on two cores the pair costs the time of the
    longer.  ``notes`` gets what reading did.  polars, if that thread imported it first,
    leaves ``SIGINT`` to Python from then on (:mod:`hybridlog.polars_import`).
    """
    if worker(ESTIMATES) is not None:
        return read_log(log, model, read, notes)
    reading = Background(lambda: read_log(log, model, read, notes), "hybridlog-read")
    try:
        set_up()
    finally:
        reading.wait()
        if "hybridlog.polars_import" in sys.modules:  # first imported by the thread
            sys.modules["hybridlog.polars_import"].take_back_sigint()
    return reading.result()


def warm_up(prepared: Sequence[Prepared], model: HybridModel) -> None:
    """Send the estimators' warm-up to the estimators' worker, where there is one.

    :meth:`Prepared.warm_up <hybridlog.estimators.Prepared.warm_up>`: numba's cached
    machine code of the model's filters is loaded there while this process reads the log.
    On a model's first run with those options there is none: the warm-up compiles it (up to
    a minute, expectation correction's straight-line code), and the command's reporter, if
    any, is told (:func:`warm_up_told`: ``analyze`` and ``compare`` say so on a terminal
    once it outlasts a moment).
    """
    running = worker(ESTIMATES)
    if running is None:
        return
    wait = current_wait()
    for estimator in prepared:
        running.submit(partial(warm_up_told, estimator, wait=wait), model)


def estimates(
    prepared: Prepared,
    model: HybridModel,
    signals: AlignedSignals,
    inputs: Mapping[str, Any],
    *,
    last: bool = True,
) -> Iterator[EstimationResult]:
    """The estimator's result over the signals, as its chunks come (:meth:`Prepared.stream`).

    Computed in the process's worker where there is one (the model and the signals but the
    true states, which no estimator reads, are sent to it pickled, the arrays out of band;
    the chunks come back as they are made, the worker making the next while this process
    takes one), else here; sent when the first chunk is asked for (the report first sends
    the plots' worker its preparation).  So the process that writes the report never
    loads numba's compiler (its machine code and the loaded libraries, about 110 MiB, stay
    in the worker), and the estimator's loop never shares an interpreter with the report.
    ``last``: no estimator runs after this one, so the worker is let go with the last chunk
    (:meth:`~hybridlog.background.Worker.release`: its exit overlaps the drawing, not the
    command's end).
    """
    running = worker(ESTIMATES)
    if running is None:
        yield from prepared.stream(model, signals, **inputs)
        return
    sent = replace(signals, truth_states=None)  # what no estimator reads stays here
    stream: Callable[..., Iterator[EstimationResult]] = partial(prepared.stream, **inputs)
    reporter = current_reporter()
    if reporter is not None:  # the worker's long work (chiu's clustering) says how long
        stream = partial(reported, reporter, stream)
    try:
        yield from running.stream(stream, model, sent)
    finally:  # also after the run's error: compare reports a failed last estimator and goes on
        if last:
            running.release()


@dataclass(frozen=True)
class Outcome:
    """What ``analyze`` produced: the report, where it went, and the missed CI gates."""

    report: Report
    out_dir: Path
    gate_failures: list[str]


def gates_for(
    model: HybridModel,
    prepared: Sequence[Prepared],
    fail_under: Sequence[str],
    fail_over: Sequence[str],
) -> list[Gate]:
    """Parse the CI gates and check that every report of the run can be read for them.

    The outputs, states and components they name must exist, a gate on the smoother's
    fallbacks needs a smoother on every estimator of ``prepared`` (:func:`without_smoother`),
    and a gate on a mode metric needs every estimator of ``prepared`` to estimate its modes
    (:func:`modes_given`: ``compare --estimators sliding-mode,switching-observer
    --fail-under mode_accuracy=0.9`` failed switching-observer's gate after every run, as
    its report scores no mode metric).
    """
    gates = parse_gates(fail_under, fail_over)
    validate_gates(
        gates,
        output_names=model.outputs,
        state_names=model.states,
        component_names=[c.name for c in model.components],
        without_smoother=without_smoother(prepared),
        modes_given=modes_given(prepared, model),
    )
    return gates


def modes_given(prepared: Sequence[Prepared], model: HybridModel | None = None) -> dict[str, str]:
    """The estimators of ``prepared`` that read their modes from the log, each with why.

    An estimator that needs the switching signal takes it as its modes, and the log's true
    mode is that signal: its report scores no mode metric (``EstimationResult.modes_given``,
    paper 004), which comparison.md says of it too.  On a one-mode ``model`` its sigma is
    that mode, with or without the signal in the log.
    """
    why = "it reads its modes from the log's switching signal, the log's true mode"
    if model is not None and model.n_modes == 1:
        why = "its model has one mode, which is sigma at every sample"
    return {p.name: why for p in prepared if p.estimator.capabilities.needs_switching_signal}


def without_smoother(prepared: Sequence[Prepared]) -> dict[str, str]:
    """The estimators of ``prepared`` that run no smoother, each with why, in order.

    A smoother runs where the estimator has one and its option ``smooth`` is true
    (``--smooth``, ``--set smooth=true`` or the model file); only then does report.json have
    ``smoothing.fallbacks``.
    """
    missing: dict[str, str] = {}
    for p in prepared:
        capabilities = p.estimator.capabilities
        if not capabilities.supports_smoothing:
            missing[p.name] = "it has none"
        elif not getattr(p.options, SMOOTH_OPTION, False):
            sequence = getattr(p.options, MODE_SEQUENCE_OPTION, "argmax")
            alone = "" if sequence == "argmax" else f", --mode-sequence {sequence} alone"
            missing[p.name] = f"smooth = false{alone}; add --smooth"
    return missing


def analyze(
    log: str | Path,
    model_ref: str | Path,
    *,
    out_dir: str | os.PathLike[str] | None = None,
    estimator: str | None = None,
    sets: Sequence[str] = (),
    read: ReadOptions | None = None,
    fail_under: Sequence[str] = (),
    fail_over: Sequence[str] = (),
    table_format: str = "csv",
    force: bool = False,
    smooth: bool = False,
    mode_sequence: str | None = None,
) -> Outcome:
    """Run one estimator over one log and write the outputs of SPEC §8 into ``out_dir``.

    ``out_dir`` defaults to ``<log name>_<estimator>`` in the working directory.  Everything
    the user gave is validated before anything is written; the output directory appears
    complete or not at all.  ``smooth`` and ``mode_sequence`` are ``--smooth`` and
    ``--mode-sequence`` (:func:`smoothing_overrides`).  An argument of the wrong type (a
    single string for ``sets``) is an ``OptionError`` (:mod:`hybridlog.jobs.arguments`).
    """
    arguments.path(log, "log")
    read = arguments.common(
        model_ref,
        sets=sets,
        read=read,
        fail_under=fail_under,
        fail_over=fail_over,
        table_format=table_format,
        force=force,
        smooth=smooth,
        mode_sequence=mode_sequence,
    )
    arguments.path(out_dir, "out_dir", optional=True)
    arguments.text(estimator, "estimator", optional=True)
    model, overrides = parse_sets(sets, model_ref)
    (prepared,) = prepare_estimators(
        model, [estimator], overrides, smooth=smooth, mode_sequence=mode_sequence
    )
    estimator = prepared.name
    out_dir = Path(out_dir) if out_dir is not None else Path(f"{Path(log).stem}_{estimator}")
    check_apart([("--out", out_dir)], input_paths([log], model_ref, [prepared], read))
    check_dir_target(out_dir, force=force)
    check_outside_batch(out_dir)
    check_table_format(table_format)
    gates = gates_for(model, [prepared], fail_under, fail_over)
    inputs = estimator_inputs(prepared, model)
    warm_up([prepared], model)
    reading: dict[str, Any] = {}
    signals = read_for_estimation(log, model, read, reading)
    check_signals([prepared], model, signals)
    check_memory(log, model, [prepared], signals)
    from hybridlog.report import write_report  # polars: see the module's docstring

    given = given_values(overrides.parameter_texts, prepared)
    report = write_report(
        out_dir,
        given_in_chunks(partial(estimates, prepared, model, signals, inputs), given),
        signals,
        log=as_text(log),
        model_name=model.name,
        dt=model.dt,
        table_format=table_format,
        force=force,
        reading=reading,
        extra=run_values(model, prepared, overrides.parameter_texts),
        model=model,
        gates=gates,
    )
    return Outcome(report=report, out_dir=out_dir, gate_failures=recorded_failures(report))


@dataclass(frozen=True)
class Comparison:
    """What ``compare`` produced: one report per estimator and the side-by-side table.

    ``failures``: the estimators whose run failed on the log (it diverged, or could not be
    computed on this log), each with its one-line reason; they have no report.
    ``unlike``: what is not like for like between the estimators, a phrase each (``vaf,
    fit and mse are not over the same samples for every estimator``; the mode metrics of
    an estimator that reads the switching signal, or of offline estimates beside others'
    own), which comparison.md's "What the numbers are over" details.
    ``reach``: each ``--set`` that did not reach every estimator, what it reached and why
    not the others (:func:`set_reach`), which comparison.md's "Given to some estimators
    only" lists.
    """

    reports: dict[str, Report]
    table: str
    gate_failures: list[str]
    failures: dict[str, str] = field(default_factory=dict)
    unlike: list[str] = field(default_factory=list)
    reach: list[str] = field(default_factory=list)

    @property
    def warned(self) -> list[str]:
        """The estimators whose report has a note that warns (:func:`warning_notes`)."""
        return [name for name, report in self.reports.items() if warning_notes(report)]


_COLUMNS = (
    "vaf",
    "fit",
    "mse",
    "mode_accuracy",
    "missed_switches",
    "detection_delay_s",
    "samples_per_s",
)


def _filtered_state_rmse(report: Report, column: str) -> float | None:
    """The filter's own RMSE of a ``state_rmse.<x>`` column: the smoothed run's filter's."""
    state = column.removeprefix("state_rmse.")
    states = report.states if report.smoothing is None else report.smoothing.filtered.states
    own = states.get(state)
    return None if own is None else own.rmse


_SMOOTHING_COLUMNS = ("smoothing", "filtered_mode_accuracy", "smoothing_fallback_weight")
"""Columns added to the comparison when an estimator's estimates were smoothed: the
smoother and mode sequence (``kim-rts, viterbi``; ``none`` for a filter's own estimates), the
filter's own mode accuracy, beside the smoothed one in ``mode_accuracy``, and the share of the
smoothed estimates' weight carried by the steps where the smoother left the forward estimate
standing (report.json's ``smoothing.fallbacks.weight``, 0 to 1, as batch's summary.csv; ``n/a``
where no smoother ran).  For an estimator not smoothed the filter's own mode accuracy is its
``mode_accuracy``: its estimates are its own (it was ``n/a``, so that the filters' own
estimates, like for like, were in two columns)."""


def _smoothing_columns(state_columns: Sequence[str]) -> tuple[str, ...]:
    """:data:`_SMOOTHING_COLUMNS`, a ``filtered_state_rmse.<x>`` per state shown among them.

    After ``filtered_mode_accuracy``, named as batch's summary.csv names them.
    """
    smoother, filtered, fallbacks = _SMOOTHING_COLUMNS
    return (smoother, filtered, *(f"filtered_{c}" for c in state_columns), fallbacks)


def _smoothing_cells(report: Report, state_columns: Sequence[str]) -> list[Any]:
    smoothing = report.smoothing
    filtered_states = [_filtered_state_rmse(report, column) for column in state_columns]
    if smoothing is None:
        return ["none", report.modes.accuracy, *filtered_states, None]
    name = ", ".join(n for n in (smoothing.method, smoothing.mode_sequence) if n)
    fallbacks = smoothing.fallbacks
    weight = None if fallbacks is None else fallbacks.weight
    return [name, smoothing.filtered.mode_accuracy, *filtered_states, weight]


RUN_FAILURES: tuple[type[HybridlogError], ...] = (DivergenceError,)
"""What an estimator's run raises when it fails on a log every check accepted: it diverged, its
model left its domain at an estimate, or it met numerical trouble.  In ``compare`` that is the
estimator's result, its row saying why.  Every other error of a run stays bad input (exit 2,
nothing written): a singular covariance (``ModelError``), a log without the switching signal
the estimator needs (``LogError``), ``cluster_modes`` naming fewer modes than chiu finds
clusters (``OptionError``)."""


class _RunFailedError(Exception):
    """An estimator's run failed on the log (:data:`RUN_FAILURES`).

    Raised under ``write_report``, which removes the estimator's half-written folder and lets
    it through to :func:`compare`.
    """

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


def _watched(
    name: str, chunks: Iterator[EstimationResult], *, named: bool
) -> Iterator[EstimationResult]:
    """The chunks of one of the compared estimators, its failure on the log told apart.

    A run failure becomes :class:`_RunFailedError`; another error of its run is raised naming the
    estimator when several are compared (``named``): ``cluster_modes: 2 mode ids for 3
    clusters`` did not say which of ``chiu,kmeans`` failed (the option reaches both); it
    becomes ``--estimators chiu: cluster_modes: ...``.
    """
    try:
        yield from chunks
    except RUN_FAILURES as err:
        raise _RunFailedError(str(err)) from err
    except HybridlogError as err:
        if not named:
            raise
        raise prefixed(err, f"--estimators {name}: ") from err


def _check_separators(estimators: Sequence[str]) -> None:
    """Refuse a name that is several estimators joined by another separator than a comma.

    ``--estimators imm;hstf`` was an unknown estimator ``'imm;hstf'`` with "did you mean
    'hstf'?", as if the user had meant hstf alone.
    """
    for name in estimators:
        parts = [part for part in re.split(r"[;:|/\s]+", name) if part]
        if name not in ESTIMATORS and len(parts) > 1 and all(p in ESTIMATORS for p in parts):
            raise OptionError(
                f"--estimators: {excerpt(name)} is {len(parts)} estimators; separate them with "
                f"commas: {','.join(parts)}"
            )


def check_signals(
    prepared: Sequence[Prepared], model: HybridModel, signals: AlignedSignals
) -> None:
    """Refuse the log for any of ``prepared`` that lacks a signal it needs, before any runs.

    :meth:`Prepared.check_signals <hybridlog.estimators.Prepared.check_signals>`: the
    switching signal, the commands the transition rules name.  Found as the estimator
    started, a log without the switching signal or a command of the last one named was
    refused after the others had run, their work lost.  Named as :func:`_watched` names a
    run's error when several are compared.
    """
    for estimator in prepared:
        try:
            estimator.check_signals(model, signals)
        except HybridlogError as err:
            if len(prepared) == 1:
                raise
            raise prefixed(err, f"--estimators {estimator.name}: ") from err


def compare(
    log: str | Path,
    model_ref: str | Path,
    estimators: Sequence[str],
    *,
    out_dir: str | os.PathLike[str],
    sets: Sequence[str] = (),
    read: ReadOptions | None = None,
    fail_under: Sequence[str] = (),
    fail_over: Sequence[str] = (),
    table_format: str = "csv",
    force: bool = False,
    smooth: bool = False,
    mode_sequence: str | None = None,
) -> Comparison:
    """Run several estimators on one log: ``<out>/<estimator>/`` reports and a table.

    The table (``comparison.md`` and ``comparison.csv``) has one row per estimator; CI gates
    apply to every estimator, and with gates the table gets a ``gates`` column (``pass (2)``
    or the gates the estimator missed) and a column per gated metric it does not show
    already (``state_rmse.x1``: each estimator's value).  ``smooth`` (``--smooth``) and
    ``mode_sequence`` apply to every estimator, each of which must offer them
    (:func:`smoothing_overrides`); when any estimator's estimates were smoothed, the table
    gets a ``smoothing`` column and the filter's own mode accuracy beside the smoothed one.

    Everything the user gave is checked before any estimator runs.  An estimator whose run
    then fails on the log (:data:`RUN_FAILURES`: it diverged) gets no folder, and its row
    empty metrics and, in an ``error`` column, the one-line reason; the others' reports are
    written (:attr:`Comparison.failures`; the command exits 1, as for a batch's failed log).
    """
    arguments.path(log, "log")
    read = arguments.common(
        model_ref,
        sets=sets,
        read=read,
        fail_under=fail_under,
        fail_over=fail_over,
        table_format=table_format,
        force=force,
        smooth=smooth,
        mode_sequence=mode_sequence,
    )
    arguments.texts(estimators, "estimators")
    arguments.path(out_dir, "out_dir")
    if not estimators:
        raise OptionError("--estimators: name at least one estimator")
    _check_separators(estimators)
    twice = sorted({name for name in estimators if list(estimators).count(name) > 1})
    if twice:  # two reports under one folder name
        raise OptionError(f"--estimators: {', '.join(map(excerpt, twice))} named twice")
    model, overrides = parse_sets(sets, model_ref)
    prepared = prepare_estimators(
        model,
        estimators,
        overrides,
        given_by="--estimators",
        smooth=smooth,
        mode_sequence=mode_sequence,
    )
    reach = set_reach(model, prepared, overrides)
    check_apart([("--out", out_dir)], input_paths([log], model_ref, prepared, read))
    check_dir_target(out_dir, force=force)
    check_outside_batch(out_dir)
    check_table_format(table_format)
    gates = gates_for(model, prepared, fail_under, fail_over)
    inputs = {p.name: estimator_inputs(p, model) for p in prepared}
    warm_up(prepared, model)
    reading: dict[str, Any] = {}
    signals = read_for_estimation(log, model, read, reading)
    check_signals(prepared, model, signals)
    check_memory(log, model, prepared, signals)
    reports: dict[str, Report] = {}
    failures: dict[str, str] = {}
    from hybridlog.report import write_report  # polars: see the module's docstring

    with atomic_output_dir(out_dir, force=force) as folder:
        for i, estimator in enumerate(prepared):  # one after the other: one's chunks at a time
            run = partial(
                estimates,
                estimator,
                model,
                signals,
                inputs[estimator.name],
                last=i == len(prepared) - 1,
            )
            chunks = given_in_chunks(run, given_values(overrides.parameter_texts, estimator))
            try:
                reports[estimator.name] = write_report(
                    folder / estimator.name,
                    _watched(estimator.name, chunks, named=len(prepared) > 1),
                    signals,
                    log=as_text(log),
                    model_name=model.name,
                    dt=model.dt,
                    table_format=table_format,
                    reading=reading,
                    extra=run_values(model, estimator, overrides.parameter_texts),
                    model=model,
                    gates=gates,
                )
            except _RunFailedError as failed:  # a result: the others are still compared
                failures[estimator.name] = failed.reason
        missed = {name: recorded_failures(report) for name, report in reports.items()}
        names = [p.name for p in prepared]
        columns, rows = _comparison_rows(names, reports, failures, gates, missed)
        table = markdown_table(columns, rows, distinct=True)  # estimators side by side
        given = list(modes_given(prepared))
        scored, unlike = samples_section(reports, _rmse_states(columns), given)
        shown = [
            c for c in columns if c in _COLUMNS or c in _gated(gates) or c.startswith("state_rmse.")
        ]
        sections = [
            *reach_section(reach),
            *scored,
            *unavailable_section(columns, rows, reports, shown),
        ]
        (folder / "comparison.md").write_text(
            comparison_markdown(
                f"{model.name} on {as_text(log)}",
                table,
                reports,
                failures,
                sections=sections,
                gates=[f"{g.option} {g.spec}" for g in gates],
            ),
            encoding="utf-8",
        )
        write_summary_csv(folder / "comparison.csv", columns, rows)
    failing = [f"{name}: {failure}" for name, missing in missed.items() for failure in missing]
    return Comparison(
        reports=reports,
        table=table,
        gate_failures=failing,
        failures=failures,
        unlike=unlike,
        reach=reach,
    )


def _gated(gates: Sequence[Gate]) -> set[str]:
    return {gate.metric for gate in gates}


def _rmse_states(columns: Sequence[str]) -> list[str]:
    """The states whose RMSE the table shows (``state_rmse.x1``: ``x1``)."""
    prefix = "state_rmse."
    return [c.removeprefix(prefix) for c in columns if c.startswith(prefix)]


def _comparison_rows(
    names: Sequence[str],
    reports: Mapping[str, Report],
    failures: Mapping[str, str],
    gates: Sequence[Gate],
    missed: Mapping[str, Sequence[str]],
) -> tuple[tuple[str, ...], list[list[Any]]]:
    """The comparison's columns and its rows, one per estimator in the order given.

    A failed estimator's cells are empty (``n/a``) but its gates (``not analysed``) and the
    ``error`` column, added when any estimator failed, which holds its reason.  ``warnings``:
    the number of the report's notes that warn (:func:`warning_notes`), listed in
    comparison.md.  Where the estimators' numbers are not over the same samples, a column
    per count that differs (``output_samples.y1``, ``mode_samples``, ``state_samples.x1``:
    :func:`~hybridlog.report.comparison.unequal_columns`), after the metrics.
    """
    states = state_columns(reports.values())
    *scores, speed = _COLUMNS
    metrics = (*scores, *states, speed)  # the states' RMSEs beside the other scores
    columns: tuple[str, ...] = ("estimator", *metrics)
    smoothed = any(report.smoothing is not None for report in reports.values())
    smoothing_columns = _smoothing_columns(states) if smoothed else ()
    # each estimator's value of a gated metric not shown yet (state_rmse.x1), as batch's
    # summaries show it: 'pass (1)' alone did not say by how much (a gated
    # smoothing_fallback_weight is shown once, among the smoothing columns)
    extra = gated_columns([gate.metric for gate in gates], (*columns, *smoothing_columns))
    # a VAF over 170 samples beside one over 179 read as like for like: the counts that
    # differ get a column
    counts = unequal_columns(reports, _rmse_states((*states, *extra)))
    columns += counts
    columns += smoothing_columns
    columns += extra
    rows: list[list[Any]] = []
    for name in names:
        report = reports.get(name)
        if report is None:
            width = len(columns) - 1
            row: list[Any] = [name, *[None] * width]
        else:
            row = [name, *(metric(report, column) for column in metrics)]
            own = sample_counts(report, _rmse_states((*states, *extra)))
            row += [own.get(column) for column in counts]
            if smoothed:
                row += _smoothing_cells(report, states)
            row += [metric(report, column) for column in extra]
        if gates:  # which estimator missed which gate, as a batch's summary shows per log
            row.append("not analysed" if report is None else gate_cell(len(gates), missed[name]))
        row.append(None if report is None else len(warning_notes(report)))  # as summary.csv's
        if failures:
            row.append(failures.get(name, ""))
        rows.append(row)
    if gates:
        columns += ("gates",)
    columns += ("warnings",)
    if failures:
        columns += ("error",)
    return columns, rows
