"""The ``hybridlog simulate`` job: a simulated run of a model, written as a log.

The simulation itself is the pure algorithm :func:`hybridlog.simulate.simulate`; this job
loads the model, checks the output before simulating (it must not replace, contain or sit
inside the model file; an existing target needs ``force``), and writes the log with ground
truth (:func:`hybridlog.io.bag_writers.write_log`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from hybridlog.cluster.progress import TimedWork, duration_text
from hybridlog.errors import (
    ModelError,
    OptionError,
    as_text,
    excerpt,
    given_in_errors,
    set_text,
)
from hybridlog.estimators.options import closest
from hybridlog.io.bag_writers import (
    check_log_target,
    check_topic_names,
    write_log,
)
from hybridlog.jobs import arguments
from hybridlog.model.cache import load_model, load_model_set
from hybridlog.model.reads import refuse_unread_by_simulation
from hybridlog.model.schedule import parse_schedule
from hybridlog.numbers import parse_float
from hybridlog.outputs import PathLike
from hybridlog.simulate import simulate as simulate_model
from hybridlog.simulation_inputs import parse_disturbance
from hybridlog.simulation_schedule import (
    cut_schedule,
    switches_made,
    unmade_switches,
    unreached_modes,
)

if TYPE_CHECKING:
    from hybridlog.model.hybrid_model import HybridModel

__all__ = ["SimulationOutcome", "log_columns", "simulate_log"]


@dataclass(frozen=True)
class SimulationOutcome:
    """What ``hybridlog simulate`` wrote: the log, its number of samples (rows), and notes.

    ``notes``: scheduled modes ``--steps`` cut off
    (:func:`hybridlog.simulation_schedule.cut_schedule`) and what the run did that the model
    gives probability 0 (:func:`hybridlog.simulation_schedule.impossible_switches`), which the
    CLI prints on stderr.
    """

    path: Path
    samples: int
    notes: tuple[str, ...] = ()


def simulate_log(
    model_ref: str | Path,
    out: PathLike,
    *,
    log_format: str | None = None,
    encoding: str | None = None,
    schedule: str | None = None,
    steps: int | None = None,
    seed: int = 0,
    noise: bool = True,
    disturbance: str | None = None,
    force: bool = False,
    sets: Sequence[str] = (),
) -> SimulationOutcome:
    """Simulate ``model_ref`` and write the run to ``out`` with its true modes and states.

    Parameters
    ----------
    model_ref:
        Built-in model name or model file.
    out:
        The log: ``.csv``, ``.parquet``, ``.mcap``, ``.bag``, or a ROS 2 bag folder.
    log_format, encoding:
        As for :func:`hybridlog.io.bag_writers.write_log` (format from the suffix when
        ``None``; the message encoding of an MCAP file).
    schedule, steps, seed, noise:
        As for :func:`hybridlog.simulate.simulate`.
    disturbance:
        ``"A,OMEGA"``: the :class:`~hybridlog.simulation_inputs.Disturbance` of paper 003 eq. (49).
    force:
        Replace an existing file, or a ROS 2 bag folder hybridlog wrote (never the model).
    sets:
        ``NAME=VALUE`` texts (``--set``, named as ``analyze``, ``compare`` and ``batch``
        name it): the model's ``[parameters]`` (the plant simulated with other values: a
        model run beside the log then meets the mismatch), and the scenario parameters of a
        components model (:mod:`hybridlog.model.scenario`), e.g. a fault time or a drift rate.

    Raises
    ------
    HybridlogError
        A bad model, option or output, each found before anything is simulated or written.
    """
    arguments.path(model_ref, "model_ref")
    arguments.path(out, "out")
    arguments.texts(sets, "sets")
    arguments.text(log_format, "log_format", optional=True)
    arguments.text(schedule, "schedule", optional=True)
    arguments.text(disturbance, "disturbance", optional=True)
    arguments.text(encoding, "encoding", optional=True)
    steps = arguments.integer(steps, "steps", optional=True)
    seed = arguments.integer(seed, "seed")
    arguments.flag(noise, "noise")
    arguments.flag(force, "force")
    parsed = parse_disturbance(disturbance) if disturbance is not None else None
    model = load_model(model_ref)
    inputs: list[tuple[str, PathLike]] = (
        [("model file", model_ref)] if Path(model_ref).is_file() else []
    )
    texts = arguments.set_texts(sets)
    moved = {name: text for name, text in texts.items() if name in model.parameters}
    if moved:  # the plant simulated with other [parameters] values
        model = load_model_set(model_ref, moved)
    values = _scenario_values({k: v for k, v in texts.items() if k not in moved})
    # a simulation's error names the --set values (all of them: the run uses each) and
    # the disturbance, which drove the plant there (ice_clutch's "integration.step: 0.001 s
    # is too long", where the model's step suits its own dynamics)
    given = {name: set_text(name, text) for name, text in texts.items()}
    if disturbance is not None:
        given[_DISTURBANCE] = f"--disturbance {excerpt(disturbance.strip())[1:-1]}"
    with given_in_errors(given, (ModelError,)):  # as the simulation's own errors
        _refuse_options_unread(model, schedule, parsed is not None, noise, values)
    # Every check of the output runs before the simulation, after those of what it reads:
    # a bad --set was told only once the output, refused first, was out of the way
    chosen = check_log_target(out, format=log_format, encoding=encoding, force=force, inputs=inputs)
    if chosen not in ("csv", "parquet"):  # every name a ROS name, no two one topic
        check_topic_names(out, *log_columns(model))
    if model.has_components:
        from hybridlog.simulate_components import simulate_components

        with given_in_errors(given, (ModelError,)):  # its OptionErrors: --steps, --seed, --set
            played = simulate_components(
                model, steps=steps, seed=seed, settings=values, log_format=chosen
            )
        refuse_unread_by_simulation(
            model,
            moved,
            {name: set(modes) for name, modes in played.modes.items()},
            played.unreached,
            unstarted=played.unstarted,
        )
        columns, truth = played.columns(model), played.truth_columns(model)
        samples = int(played.time.shape[0])
        notes: tuple[str, ...] = played.notes
    else:
        with given_in_errors(given, (ModelError,)):
            log = simulate_model(
                model,
                schedule=schedule,
                steps=steps,
                seed=seed,
                noise=noise,
                disturbance=parsed,
                log_format=chosen,  # a ROS 1 bag's seconds are 32-bit
            )
        ids = {model.modes[int(q)].id for q in set(log.modes.tolist())}
        unreached = unreached_modes(model, log.modes, schedule)
        refuse_unread_by_simulation(
            model,
            moved,
            {"": ids},
            {"": unreached},
            switches_made(model, log.modes),
            unmade_switches(model, log.modes, schedule),
        )
        columns, truth = log.columns(model), ("mode", *model.states)
        samples = int(log.time.shape[0])
        notes = (*cut_schedule(model, log.modes, steps, schedule), *log.notes)
    # a bag or MCAP file is written a message at a time: a minute for 10^6 rows
    messages = len(columns) - 1
    writing = TimedWork(
        samples,
        "rows written",
        lambda left, seconds: (
            f"writing {as_text(out)}: about {duration_text(seconds)} more on this machine "
            f"({left:,} of {samples:,} rows left, {messages} messages a row)"
        ),
    )
    with writing:
        path = write_log(
            out,
            columns,
            truth=truth,
            format=log_format,
            encoding=encoding,
            force=force,
            inputs=inputs,
            progress=writing.reached,
        )
    from hybridlog.report.build import MIN_SAMPLES  # the report's modules: not imported ahead

    if samples < MIN_SAMPLES:  # written as asked, but no command reads it into a report
        from hybridlog.report.markdown import plural

        notes = (
            *notes,
            f"{plural(samples, 'sample')}: analyze, compare and batch need at least "
            f"{MIN_SAMPLES} (the first sample is the prior); give --steps {MIN_SAMPLES - 1} "
            "or more",
        )
    return SimulationOutcome(path=path, samples=samples, notes=notes)


_DISTURBANCE = "--disturbance"
"""The disturbance's entry among the values a simulation's errors name (no parameter's name)."""


def _refuse_options_unread(
    model: HybridModel,
    schedule: str | None,
    disturbance: bool,
    noise: bool,
    values: Mapping[str, float],
) -> None:
    """Refuse the options ``model``'s simulation would not read, before any output is checked.

    A components model schedules its components' modes and sets its noise and unmodelled
    behaviours in its ``[simulation]`` table (no ``--schedule``, ``--disturbance`` or
    ``--no-noise``); only it has scenario parameters (``values``, the ``--set`` names that
    are not the model's parameters), which must be its scenario's.  Another model's
    ``--schedule`` must name its modes.  (``simulate bioplex_pgc --out old.csv --set nosuch=1``
    and ``--schedule garbage`` said "already exists", and the bad option only after --force.)
    """
    name = model.origin or model.name
    if model.has_components and model.scenario is not None and values:
        from hybridlog.simulate_components import scenario_settings

        scenario_settings(model, model.scenario, values)
    if not model.has_components and schedule is not None and not model.state_driven:
        parse_schedule(schedule, model.mode_ids)  # a state-driven model's is refused as such
    if model.has_components:
        if schedule is not None:
            raise OptionError(
                f"--schedule: {name} is a components model; its components' modes are "
                "scheduled in simulation.modes"
            )
        if disturbance:
            raise OptionError(
                f"--disturbance: {name} is a components model; what its modes do not describe "
                "is set in its [[simulation.unmodelled]] behaviours"
            )
        if not noise:
            raise OptionError(
                f"--no-noise: {name} is a components model, simulated with the noise of its "
                "modes ([noise], or a mode's process_noise and measurement_noise); for a run "
                "without noise set those variances to 0 in a copy of the file"
            )
    elif values:
        given = next(iter(values))
        known = ", ".join(model.parameters) or "none"
        raise OptionError(
            f"--set {excerpt(given)[1:-1]}: neither a parameter of model {name} (parameters: "
            f"{known}) nor a scenario parameter (only a components model has them, in "
            f"[simulation.parameters]){closest(given, model.parameters)}"
        )


def log_columns(model: HybridModel) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The columns of the log ``simulate`` writes of ``model`` but ``t``, and those that are truth.

    As :meth:`hybridlog.simulate.SimulatedLog.columns` (and ``truth_columns`` of a
    components model's run) name them, known before the run.
    """
    if model.has_components:
        truth = (*(f"mode.{c.name}" for c in model.components), *model.states)
        return (*model.inputs, *model.outputs, *model.commands, *truth), truth
    truth = ("mode", *model.states)
    return (*model.inputs, *model.outputs, *truth), truth


def _scenario_values(texts: Mapping[str, str]) -> dict[str, float]:
    """The scenario parameters' ``--set`` texts as numbers, each named in its error."""
    values: dict[str, float] = {}
    for name, value in texts.items():
        try:
            values[name] = parse_float(value)
        except ValueError as err:
            raise OptionError(f"{set_text(name, value)}: {err}, got {excerpt(value)}") from None
    return values
