"""The command line's ``--set``, ``--smooth`` and ``--mode-sequence``, given to the estimators.

``--set NAME=VALUE`` values split into the model's parameters and the estimators' options
(:class:`Overrides`, :func:`parse_sets`); ``--smooth`` and ``--mode-sequence`` as the options
they stand for (:func:`smoothing_overrides`); the chosen estimators resolved and prepared
with the options each declares, every name checked before any work
(:func:`prepare_estimators`); and what each ``--set`` left out of several estimators
(:func:`set_reach`).  Shared by ``analyze``, ``compare`` and ``batch``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from types import MappingProxyType

from hybridlog.errors import OptionError, UnusedParameterError, excerpt, set_text
from hybridlog.estimators import (
    ESTIMATORS,
    Estimator,
    Prepared,
    prepare,
    refuse_unrunnable,
    resolve_estimator,
)
from hybridlog.estimators.offline_options import (
    MODE_SEQUENCE_OPTION,
    OFFLINE_OPTIONS,
    SMOOTH_OPTION,
    admits,
    choices,
    lacks,
    not_offered,
    offers,
)
from hybridlog.estimators.options import closest
from hybridlog.jobs.arguments import set_texts
from hybridlog.model.cache import load_model, load_model_set
from hybridlog.model.hybrid_model import HybridModel


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
    for name, value in set_texts(values).items():
        (texts if name in model.parameters else options)[name] = value.strip()
    if texts:
        try:
            model = load_model_set(model_ref, texts)
        except UnusedParameterError as err:
            raise _also_an_option(err) from None
        from hybridlog.model.reads import refuse_unread_by_analysis

        refuse_unread_by_analysis(model, texts)
    parameters = {name: model.parameters[name] for name in texts}
    return model, Overrides(
        MappingProxyType(parameters), MappingProxyType(options), MappingProxyType(texts)
    )


def _also_an_option(err: UnusedParameterError) -> UnusedParameterError:
    """``err`` saying so where the unused parameter's name is also an estimator option.

    ``--set stay_probability=0.9`` on a model with a leftover parameter of that name was
    refused as changing nothing, though the user meant ``imm``'s option, which it would.
    """
    for name in sorted(err.named):
        owners = [e.name for e in ESTIMATORS.values() if name in _option_names(e)]
        if owners:
            return UnusedParameterError(
                f"{err}; {name!r} is also an option of {', '.join(owners)}, which --set "
                "cannot reach while the model has a parameter of that name: remove or rename "
                f"the parameter, or set the option under [estimators.{owners[0]}]",
                named=err.named,
            )
    return err


def _option_names(estimator: Estimator) -> set[str]:
    """The names of ``estimator``'s options."""
    return {option.name for option in estimator.describe_options()}


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
            if not admits(estimator, option):
                hint = ""
                if len(chosen) > 1:
                    hint = f"; --set {option}={value} applies it only to the estimators that do"
                said = flag if option == SMOOTH_OPTION else f"{flag} {value}"
                raise _not_offered(said, estimator, option, value, given_by, hint)
            if not offers(estimator, option, value):
                raise OptionError(
                    f"{flag} {value}: estimator '{estimator.name}' offers "
                    f"{', '.join(choices(estimator, option))}"
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
    offering = [e.name for e in chosen if offers(e, option, value)]
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
    """One line: ``flag`` sets ``option``, which ``estimator`` lacks; why, and who offers it."""
    why = not_offered(estimator, option, value, ESTIMATORS.values())
    return OptionError(f"{flag}: estimator '{estimator.name}' ({given_by}) {why}{hint}")


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
            owner, dot, option = name.partition(".")
            if dot and owner in ESTIMATORS:  # --set imm.beam=4: "did you mean 'beam'?" at best
                raise OptionError(
                    f"{flag}: --set takes an estimator's option by its name alone (--set "
                    f"{excerpt(option)[1:-1]}={excerpt(value)[1:-1]}), for every estimator run "
                    f"that has it; for {owner} alone, set it under [estimators.{owner}] in the "
                    "model file"
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
    _refuse_inert(model, prepared, overrides.options, declared, overrides.flags)
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
    flags: Mapping[str, str],
) -> None:
    """Refuse a ``--set`` option (or flag) that no chosen estimator having it would read.

    An options dataclass may say which of its options the others' values, or the model,
    make inert (``inert(model) -> {name: why}``, e.g. ``imm``'s ``beam`` without
    ``mode_sequence = kbest``, its ``transition_stay`` and ``mode_sequence`` on a one-mode
    model); ``--set`` of one is refused when every chosen estimator that has it says so
    (``compare --estimators imm,unknown-mode --set beam=50`` sets unknown-mode's beam, and
    runs).  ``flags`` (option → the flag as given, ``--mode-sequence viterbi``): an option a
    flag gave is named by its flag.
    """
    for name, value in options.items():
        having = [p for p in prepared if name in declared[p.name]]
        why = [_inert(p.options, model).get(name) for p in having]
        if having and all(why):
            given = flags.get(name) or f"--set {excerpt(name)[1:-1]}={excerpt(value)[1:-1]}"
            raise OptionError(f"{given}: has no effect on estimator '{having[0].name}': {why[0]}")


def set_reach(model: HybridModel, prepared: Sequence[Prepared], overrides: Overrides) -> list[str]:
    """What each ``--set`` of an estimator option left out of the estimators compared.

    ``--set NAME=VALUE`` goes to every chosen estimator that has the option and is refused
    only when none would read it (:func:`prepare_estimators`, :func:`_refuse_inert`):
    ``compare --estimators hstf,imm --set rho=0.9`` tunes hstf alone (imm has no ``rho``),
    and the comparison then set a tuned hstf beside a default imm without a word.  One
    phrase per option that does not reach every estimator: those it reaches, then each
    left out and why (``--set rho=0.9 reaches hstf alone: imm has no option rho``; an
    offline pass's option says why the estimator has none, as its refusal does:
    ``hstf does not offer it: ...``; an option it has but does not read there: ``on imm it
    has no effect: ...``).  The flags
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
            if name in OFFLINE_OPTIONS and not offers(p.estimator, name, str(value)):
                unread.append(f"{p.name} {lacks(p.estimator, name, value)}")
            elif name not in {info.name for info in p.estimator.describe_options()}:
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
