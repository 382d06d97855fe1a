"""``hybridlog models FILE``: check a model file as ``analyze`` would, and say what it holds.

A user writing a model file had no way to check it short of analysing or simulating a log:
``hybridlog models`` printed built-ins only.  :func:`check_and_describe` loads the file
(every key validated, SPEC §6), prepares every estimator whose needs the model meets (so each
``[estimators.<name>]`` table of the file is read as that estimator reads it: a bad value is
the same one-line error ``analyze`` gives), and returns a short description: the time base,
the symbols, the modes (or components and their modes), each ``[estimators.<name>]`` table as
the estimator applies it, which estimators can run it, and, last, what the model's equations
say of its estimability (:func:`~hybridlog.model.diagnosis.model_diagnoses`, nonlinear modes
linearised: outputs that see no state, states the outputs do not determine, undamped
components without process noise, an integration step too long for a mode), a ``WARNING:``
or ``NOTE:`` line each.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path

from hybridlog.estimators.capabilities import ModelTraits
from hybridlog.estimators.options import OptionSource, parse_options, shown
from hybridlog.estimators.registry import ESTIMATORS, Prepared, prepare, unsuited, unsuited_text
from hybridlog.jobs.estimation import estimator_inputs
from hybridlog.model.cache import load_model
from hybridlog.model.diagnosis import model_diagnoses
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.model.reads import unread_parameters

__all__ = ["check_and_describe"]


def check_and_describe(path: Path) -> str:
    """The description of the model file at ``path``, once it loads and its tables read.

    Raises
    ------
    ModelError
        Whatever ``analyze`` would refuse in the file (one line naming the file and key),
        including a bad option value of any estimator that can run the model, and a
        ``default_estimator`` that cannot run it (``analyze`` without ``--estimator``
        refused the file that ``models`` called valid).  A file that writes no
        ``default_estimator`` is valid whichever estimators can run it: the description
        then says when ``analyze`` needs ``--estimator``.
    OptionError
        An ``[estimators.<name>]`` table naming no estimator, or a file one names (a
        ``centers`` file) that is missing or does not suit the model, as ``analyze`` reads it.
    """
    model = load_model(path)
    traits = ModelTraits(model)
    suited = [e.name for e in ESTIMATORS.values() if e.capabilities.mismatch(traits) is None]
    if model.has_components and "imm" in suited:
        # imm runs the joint modes, each solved as it is built (the loader checked that each
        # determines its variables): one sympy cannot solve is refused here as imm would
        from hybridlog.estimators.cpha.joint import joint_mode_model

        joint_mode_model(model)
    default = model.estimator_by_default
    # as analyze without --estimator: a default_estimator the file writes must run the model;
    # where it writes none and the default cannot run it, analyze needs --estimator
    unwritten_and_unsuited = model.default_estimator is None and default not in suited
    # complete=False: a value the options still lack (sliding-mode's v_max) --set may give
    prepared = [] if unwritten_and_unsuited else [prepare(model, None, complete=False)]
    for name in suited:  # reads its [estimators.<name>] table as analyze would
        if name != default:
            prepared.append(prepare(model, name, complete=False))
    for each in prepared:  # the files a table names (centers = "c.json"), read and checked
        estimator_inputs(each, model)
    if unwritten_and_unsuited:
        problem = ESTIMATORS[default].capabilities.mismatch(traits)
        default_line = (
            f"default_estimator: not written, and the default '{default}' {problem}: "
            "analyze needs --estimator"
        )
    else:
        default_line = f"default_estimator: {default}"
    return "\n".join(
        [
            f"{path}: a valid model file",
            *_lines(model),
            *_table_lines(model, {each.name: each for each in prepared}),
            f"estimators for it: {', '.join(suited) or _none_suits(model)}",
            *_switching_lines(model, suited),
            default_line,
            *model_diagnoses(model),
            *unread_parameters(model),
        ]
    )


def _switching_lines(model: HybridModel, suited: list[str]) -> list[str]:
    """How the filters among ``suited`` read a state-driven model's modes (or no line).

    Its mode of sample k governs the step from ``x(k)`` (paper 001 eq. (1)), a Markov-jump
    filter's the step into it; where the output equations differ by mode, ``imm`` runs on the
    mode pairs and ``hstf`` warns (:mod:`hybridlog.estimators.mode_pairs`): said before any
    log is read, so a user knows why one runs slower and the other warns.
    """
    filters = [n for n in suited if ESTIMATORS[n].capabilities.modes_of_the_step_into]
    if not (model.state_driven and filters):
        return []
    if not model.outputs_differ_by_mode:
        return [
            "switching: by guards; the mode of sample k governs the step from x(k), so "
            f"{' and '.join(filters)} {'show' if len(filters) > 1 else 'shows'} at sample k "
            "the mode found for that step, at k+1"
        ]
    pairs = (
        f"runs on the {model.n_modes**2} mode pairs (the modes of the step into x(k) and from it)"
    )
    warns = (
        "moves its modes a sample earlier and warns: it weighs y(k) with the mode of the step "
        "into x(k)"
    )
    said = [
        f"{n} {pairs if ESTIMATORS[n].capabilities.runs_on_mode_pairs else warns}" for n in filters
    ]
    return [
        "switching: by guards; the mode of sample k governs the step from x(k) and y(k), whose "
        f"equations differ by mode: {'; '.join(said)}"
    ]


def _none_suits(model: HybridModel) -> str:
    """``none: 'imm', 'hstf' (needs a discrete-time model), ...``: why each cannot run it."""
    return f"none: {unsuited_text(unsuited(model, list(ESTIMATORS)))}"


def _table_lines(model: HybridModel, prepared: Mapping[str, Prepared]) -> list[str]:
    """Each ``[estimators.<name>]`` table as ``analyze`` applies it, one line per table.

    The values as the estimator reads them (``rho = 1`` is 1.0, a relative ``centers`` path
    from the model file's folder), each one the table's other values leave unread said so
    (``smoother = "ec"`` under ``[estimators.imm]`` waits for ``--smooth``), and a table of
    an estimator that cannot run the model named as such: ``models`` said nothing of the
    tables it had checked.
    """
    lines = []
    for name, table in model.estimator_options.items():
        if not table:
            continue
        if name in prepared:
            options, note = prepared[name].options, ""
        else:
            origin = model.origin or model.name
            sources = {k: OptionSource.model_file(origin, name, k) for k in table}
            options = parse_options(
                ESTIMATORS[name].options_type, table, estimator=name, sources=sources
            )
            note = f" ({name} cannot run this model)"
        inert_on: Callable[[HybridModel], Mapping[str, str]] | None = getattr(
            options, "inert", None
        )
        unread = {} if inert_on is None else inert_on(model)
        values = [
            f"{key} = {shown(getattr(options, key))}"
            + (f" (no effect as written: {unread[key]})" if key in unread else "")
            for key in table
        ]
        lines.append(f"[estimators.{name}]{note}: {', '.join(values)}")
    return lines


def _lines(model: HybridModel) -> list[str]:
    timebase = model.timebase
    # as written, to the digits that read back (`:g` wrote dt = 1.23456789 as 1.23457)
    time = f"{timebase.kind} time, dt {shown(timebase.dt)} s"
    if timebase.method is not None:
        time += f", integration {timebase.method} with step {shown(timebase.step)} s"
    lines = [
        f"name: {model.name}" + (f" ({model.reference})" if model.reference else ""),
        time,
        f"states: {_names(model.states)}",
        f"inputs: {_names(model.inputs)}",
        f"outputs: {_names(model.outputs)}",
    ]
    if model.commands:
        lines.append(f"commands: {_names(model.commands)}")
    if model.components:
        lines.append(f"components: {len(model.components)}")
        lines.extend(
            f"  {c.name}: {_names(tuple(c.initial_mode_probabilities))}" for c in model.components
        )
    else:
        lines.append(f"modes: {len(model.modes)} ({_names(tuple(m.id for m in model.modes))})")
    if model.jumps:
        lines.append(f"jump maps: {len(model.jumps)}")
    return lines


def _names(names: tuple[str, ...], shown: int = 12) -> str:
    """``x1, x2, x3``; past ``shown`` names the first ones and how many more."""
    if not names:
        return "none"
    if len(names) <= shown:
        return ", ".join(names)
    return f"{', '.join(names[:shown])}, … ({len(names) - shown} more)"
