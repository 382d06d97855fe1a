"""A simulation's mode schedule: the mode of every row, and what a run did not play of it.

A schedule ``"1:100,2:100"`` becomes the mode of every row (:func:`mode_sequence`); after
the run, the modes and switches of the schedule that the run never had (:func:`unreached_modes`,
:func:`unmade_switches`, from the switches it made, :func:`switches_made`), the note of the
scheduled modes ``--steps`` cut off (:func:`cut_schedule`) and the notes of scheduled switches
the model's ``[transitions]`` give probability 0 (:func:`impossible_switches`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from hybridlog.errors import OptionError
from hybridlog.model.schedule import parse_schedule
from hybridlog.signals import FloatArray, IntArray
from hybridlog.simulation_inputs import model_origin
from hybridlog.times import format_time

if TYPE_CHECKING:
    from hybridlog.model.hybrid_model import HybridModel


def mode_sequence(schedule: list[tuple[int, int]], steps: int | None) -> IntArray:
    """Mode of every row (``steps + 1`` rows); the schedule repeats when ``steps`` is longer.

    Only the rows run are built: ``--steps 5`` of a schedule ``1:10000000000,2:5`` takes
    5 rows of memory, not the schedule's 10^10 (which ran out of memory).
    """
    period = sum(count for _, count in schedule)
    total = period if steps is None else steps
    if total <= 0:
        raise OptionError("--steps: must be positive")
    rows = np.empty(total + 1, dtype=np.int64)
    filled = 0
    for mode, count in schedule:
        take = min(count, total - filled)
        if take <= 0:
            break
        rows[1 + filled : 1 + filled + take] = mode
        filled += take
    if filled < total:  # the schedule repeats
        rows[1:] = np.resize(rows[1 : 1 + filled], total)
    rows[0] = rows[1]
    return rows


def unreached_modes(model: HybridModel, modes: IntArray, schedule: str | None) -> dict[str, int]:
    """Mode id → the step the schedule first plays it, for each mode of it the run never had.

    ``modes``: the run's (:attr:`~hybridlog.simulate.SimulatedLog.modes`); ``schedule``: the
    ``--schedule`` given, else the model's ``[simulation] schedule`` (none: the first mode
    throughout, which every run has).  Only a ``--steps`` shorter than the schedule leaves one
    out; row 0 carries the first scheduled mode (:func:`mode_sequence`), an entry after it
    starts one row after the steps before it.  Empty for a state-driven model (its guards
    decide).
    """
    parsed = _run_schedule(model, schedule)
    if parsed is None:
        return {}
    starts: dict[str, int] = {}
    before = 0
    for mode, count in parsed:
        if not np.any(modes == mode):
            starts.setdefault(model.mode_ids[mode], before + 1 if before else 0)
        before += count
    return starts


def _run_schedule(model: HybridModel, schedule: str | None) -> list[tuple[int, int]] | None:
    """The schedule a run followed, parsed.

    ``--schedule`` if given, else the model's ``[simulation] schedule``; ``None`` for a
    state-driven model (its guards decide) or one without a schedule (its first mode
    throughout).
    """
    if model.state_driven:
        return None
    if schedule is not None:
        return parse_schedule(schedule, model.mode_ids)
    if model.simulation_schedule:
        where = f"{model_origin(model)}: simulation.schedule"
        return parse_schedule(model.simulation_schedule, model.mode_ids, where=where)
    return None


def switches_made(model: HybridModel, modes: IntArray) -> set[tuple[str, str]]:
    """The switches ``(from id, to id)`` between consecutive rows of a run's ``modes``."""
    changed = np.flatnonzero(modes[1:] != modes[:-1])
    pairs = np.unique(np.stack([modes[changed], modes[changed + 1]], axis=1), axis=0)
    ids = model.mode_ids
    return {(ids[int(a)], ids[int(b)]) for a, b in pairs}


def unmade_switches(
    model: HybridModel, modes: IntArray, schedule: str | None
) -> dict[tuple[str, str], int]:
    """Switch ``(from id, to id)`` → the step the schedule first makes it, the run not having.

    As :func:`unreached_modes`: ``schedule`` is the ``--schedule`` given, else the model's;
    an entry after the first starts one row after the steps before it, and the schedule
    repeats, so its last mode switches to its first one row after its total.  Empty for a
    state-driven model (its guards decide) and a model without a schedule (one mode).
    """
    parsed = _run_schedule(model, schedule)
    if parsed is None:
        return {}
    made = switches_made(model, modes)
    steps: dict[tuple[str, str], int] = {}
    before = 0
    previous = parsed[-1][0]  # the repeat's switch into the first entry
    for i, (mode, count) in enumerate(parsed):
        if mode != previous:
            switch = (model.mode_ids[previous], model.mode_ids[mode])
            at = before + 1 if i else sum(c for _, c in parsed) + 1
            if switch not in made:
                steps[switch] = min(at, steps.get(switch, at))
        previous = mode
        before += count
    return steps


def cut_schedule(
    model: HybridModel, modes: IntArray, steps: int | None, schedule: str | None
) -> tuple[str, ...]:
    """A note when ``steps`` stops a scheduled run before one of its modes is reached.

    ``--schedule 1:100,2:100 --steps 50`` wrote a log of mode 1 alone without a word, which a
    user who asked for both modes took for a run through both.  ``modes``: the run's
    (:attr:`~hybridlog.simulate.SimulatedLog.modes`); ``schedule``: the ``--schedule`` given,
    else the model's ``[simulation] schedule`` is meant (none: nothing was scheduled, nothing to
    note).
    """
    if steps is None or model.state_driven:
        return ()
    if schedule is not None:
        where = "--schedule"
        parsed = parse_schedule(schedule, model.mode_ids)
    elif model.simulation_schedule:
        where = f"{model_origin(model)}: simulation.schedule"
        parsed = parse_schedule(model.simulation_schedule, model.mode_ids, where=where)
    else:
        return ()
    missing = [m for m in dict.fromkeys(m for m, _ in parsed) if not np.any(modes == m)]
    if not missing:
        return ()
    total = sum(count for _, count in parsed)
    named = ", ".join(f"'{model.mode_ids[m]}'" for m in missing)
    return (
        f"--steps {steps:,} ends the run within the schedule's {total:,} steps ({where}): "
        f"{'mode' if len(missing) == 1 else 'modes'} {named} never run",
    )


def impossible_switches(
    model: HybridModel, modes: IntArray, time: FloatArray, schedule: str | None
) -> tuple[str, ...]:
    """What a scheduled run does that the model gives probability 0, one note per kind.

    A switch ``a → b`` whose ``[transitions]`` entry is 0 (the first time, and how many
    more): the log is valid, but an estimator that weighs the model's Markov matrix
    (``imm``, its Viterbi and k-best passes) cannot follow the run there, which its mode
    metrics then count as errors.  ``schedule``: the ``--schedule`` given, if any (else the
    model's ``[simulation] schedule`` or its first mode throughout was followed), named in
    the notes.  A first mode that ``[initial]`` gives probability 0 is not noted: it costs
    one sample (the Markov matrix lets the estimate leave the prior's mode at the next),
    and the paper's own three-tank scenario starts so on purpose (a prior of mode 2 for a
    run in mode 1), where a note on every ``simulate`` would be noise.
    """
    if schedule is not None:
        where = "--schedule"
    elif model.simulation_schedule:
        where = f"{model_origin(model)}: simulation.schedule"
    else:
        where = f"{model_origin(model)}: the first mode throughout (no schedule)"
    notes: list[str] = []
    ids = model.mode_ids
    markov = model.transitions
    if markov is None or modes.size < 2:
        return ()
    rows = np.flatnonzero(modes[1:] != modes[:-1]) + 1  # the first row of each new mode
    impossible = rows[markov[modes[rows - 1], modes[rows]] == 0.0]
    # one note per switch a -> b, at its first row (a repeated schedule makes millions)
    pairs = modes[impossible - 1] * model.n_modes + modes[impossible]
    _, first, counts = np.unique(pairs, return_index=True, return_counts=True)
    for index, count in sorted(zip(first.tolist(), counts.tolist(), strict=True)):
        row = int(impossible[index])
        source, target = int(modes[row - 1]), int(modes[row])
        more = count - 1
        notes.append(
            f"{where}: switches from mode '{ids[source]}' to '{ids[target]}' at "
            f"t = {format_time(time[row])} s (row {row})"
            + (f" and {more} more time{'s' if more > 1 else ''}" if more else "")
            # the switch named by its modes: the file may write [transitions] as stay = 1,
            # a matrix keyed by mode id or one in the modes' order
            + ", which [transitions] gives probability 0: the model rules it out, so imm "
            "weighs it as impossible and its Viterbi and k-best mode sequences cannot take it"
        )
    return tuple(notes)
