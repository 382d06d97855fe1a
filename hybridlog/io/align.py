"""Alignment of sample series onto the model's grid ``t0 + k*dt`` (SPEC §5).

Format-independent: works on :class:`~hybridlog.io.source.Series` in integer nanoseconds.

- The grid starts at ``t0``, the first instant where every input and output has a value (the
  latest first sample among them), and ends at the last grid point where every output still
  has a sample within half a step.  When the inputs and commands share one clock (every
  sample within the clock tolerance of a tick, :func:`~hybridlog.io.time_grid.held_clock`) and every
  output is
  sampled around its ticks (median distance at most ``dt/8``), the grid is on that clock:
  ``t0`` is its first tick where every held signal has a sample at or before it and every
  output one within half a step.  The latest first sample could be a jittered output
  message that came early (56 ms of 1 s): the grid then sat just before the ticks, and the
  held inputs and true mode came out one step behind the outputs.  A log on one clock keeps
  ``t0`` to the nanosecond; outputs on a clock of their own (half a step off) keep theirs.
  Held signals each recorded once per step around a common phase (a jittering clock, every
  sample within ``dt/4`` of it) put ``t0`` on that phase, the first tick where every held
  signal has a sample within ``dt/4`` and every output one within half a step, unless the
  latest first sample's grid already gives every held sample a point within ``dt/4``: topics
  each jittering by 20 % of ``dt`` started the grid at the latest first message, 0.106 s
  after a tick, and the hold took 57 of 300 input samples a step late (below).
  ``t_k = t0 + round(k * dt)`` in nanoseconds, so ``dt`` is not rounded once and the error
  multiplied by ``k``.
- Inputs: zero-order hold, the last sample at or before ``t_k``; but a series recorded once
  per step on a jittering clock (every sample within ``dt/4`` of a grid point of its own,
  more than half the points with one, some late, some not) takes each point's own sample,
  where the hold would delay about half of them by a step at random
  (:func:`~hybridlog.io.resampling.jittered_index`, ``notes["jitter"]``); a point whose sample was
  dropped holds the one before, counted (``notes["jitter_held"]``).  The true mode likewise, but a
  sampled one's point whose sample was dropped has none (below).  Samples no grid point takes
  (another followed within the step) are counted, ``notes["skipped"]``.  Commands (of a
  ``[components]`` model) are held as inputs are.
- Outputs: the nearest sample, if it is within ``dt/2`` (``resample="nearest"``; ties go to
  the earlier sample), or linear interpolation between the samples around ``t_k``
  (``resample="linear"``).  A grid point without a sample within ``dt/2`` is a gap; a gap
  between two samples more than ``max_gap`` apart is an error, shorter gaps are bridged by the
  same rule (nearest or linear) from the samples around them; no line is drawn across a
  longer one (:func:`~hybridlog.io.resampling._nearest_beside_gaps`): the points within ``dt/2`` of
  its ends take those samples, as the points past a series' last sample take the last.  A sample
  half a step between two grid points is within ``dt/2`` of both; when both take it (no other sample
  beside it: a log sampled every ``1.5*dt``), the later point is bridged, for the log
  measured once (:func:`~hybridlog.io.resampling._taken_twice`).
- True mode: zero-order hold; grid points before its first sample take that sample if it is
  within ``dt/2``, and have no true mode (``NO_TRUE_MODE``, not scored) if not: a true mode
  that starts late is scored over the samples from its first on, as a true state that starts
  late is (``notes["truth_starts"]``).  A true mode recorded only at its switches (no sample
  repeats the label of the one before, :func:`~hybridlog.io.true_modes.records_switches`) is held
  however long it is silent: its silence says the mode did not change (``notes["truth_held"]``).
  One that repeats its label is *sampled*: its silence says nothing, and a stretch without a sample
  longer than ``dt`` (a gap of any length, bridged or not: the hold of an output's short gap
  is not the truth's; or past its last sample, to the grid's end) may hide a switch; its
  grid points more than ``dt/2`` from every sample have no true mode (those within ``dt/2``
  of the sample after take it, the nearer one, as before the first), are not scored, and
  are recorded (``notes["truth_gaps"]``, :func:`~hybridlog.io.true_modes._blank_gaps`), as a true
  state's bridged points are left out of its RMSE.  A jittered true mode's dropped samples likewise.
  A sampled true mode around the grid's points (median distance at most ``dt/8``,
  :func:`~hybridlog.io.time_grid.sampled_around`, as the grid's start reads the outputs) gives each
  point its nearest sample, as the outputs and true states are read: logged in their rows 10 ms
  after the inputs' ticks (the grid on the ticks), the hold took each point the row before's mode,
  a step behind the outputs and states of its own row.
- True states: like outputs, but NaN instead of an error where no sample is usable.
- The signal that starts the grid more than ``max_gap`` after the log's first input or output
  sample, or ends it that long before the last one, is recorded (``notes["span"]``): the
  report's span alone would not say that part of the log was left out.
- ``split_gaps``: instead of refusing a log with an output gap longer than ``max_gap``, cut it
  at every such gap and align the longest piece (the earliest of equally long ones): at the
  gaps the piece's grid refuses, and only there
  (:func:`~hybridlog.io.log_pieces.split_at_refused_gaps`); a sample alone between two gaps is a
  piece of its own.  Each output keeps its samples inside the
  piece and the one beside it on either side that no cut separates
  (:func:`~hybridlog.io.log_pieces._piece_of`): the piece's grid reads them as the whole log's
  would.  The estimators need one continuous grid, and a filter carried across a gap would start the
  next piece from a stale state; analysing each piece separately would need one report per piece.
  The pieces and the one analysed are recorded (``notes["segments"]``,
  ``notes["analysed_segment"]``, ``notes["analysed"]``) and end up in ``report.json``: the
  first :data:`~hybridlog.io.summary.MAX_LISTED_GAPS` pieces and gaps in time order, as
  ``inspect`` lists gaps, each list with its count and whether it was cut
  (``segment_count``, ``segments_truncated``, ``gap_count``, ``gaps_truncated``): a log cut
  into 20,000 pieces had them all listed, 2 MB of report.json, in every report of a batch.

A sample up to ``dt/1000`` (at least 1 µs, at most ``dt/4``) away from a grid point counts as
*at* it: float seconds at Unix-epoch magnitudes carry ~0.2 µs of rounding, and a log sampled
at ``dt`` must come out unchanged.  For the same reason a gap is longer than ``max_gap`` only
when it exceeds it by more than that tolerance
(:func:`~hybridlog.io.time_grid.longer_than_max_gap`): a gap of exactly ``5*dt`` is accepted whether
the log's clock starts at 0 or at 1.7e9 s.  And a sample is more than ``dt/2`` from a grid point
only beyond that tolerance (:func:`~hybridlog.io.time_grid.past_half_step`): an output sampled half
a step off the grid is within ``dt/2`` of every point wherever it lies. With that, a log already on
the grid is reproduced bit for bit: every value is one of the log's samples, never recomputed.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from hybridlog.errors import LogError
from hybridlog.io.alignment_notes import (
    faster_than_the_grid,
    held_sampling,
    longest_hold,
    record_span_bounds,
    sampled_every,
    skipped_by_the_hold,
)
from hybridlog.io.log_pieces import split_at_refused_gaps
from hybridlog.io.options import Resample, check_max_gap, check_resample
from hybridlog.io.output_gaps import gap_error, gap_on_the_grid
from hybridlog.io.resampling import (
    Jittered,
    Resampled,
    hold_index,
    jittered_index,
    on_grid_values,
    resample_series,
)
from hybridlog.io.source import NS_PER_S, LabelSeries, Series, ns_to_seconds
from hybridlog.io.time_grid import (
    clock_tolerance_ns,
    grid_between,
    on_whole_ns,
    span_end,
    step_ns,
    t0_and_last,
)
from hybridlog.io.true_modes import hold_modes, records_switches, truth_start
from hybridlog.signals import AlignedSignals, ComponentTruth, FloatArray, IntArray

DEFAULT_MAX_GAP_STEPS = 5


def _output_grid(
    source: str,
    dt: float,
    signals: tuple[Mapping[str, Series], Mapping[str, Series], Mapping[str, Series]],
    field_word: str,
    max_gap_ns: int,
    dropped: Mapping[str, IntArray],
) -> IntArray:
    """The grid ``t0 + k*dt`` (ns) of the inputs, commands and outputs ``signals``.

    A gap of an output that the grid is sure to refuse is refused before the grid is made
    (:func:`~hybridlog.io.output_gaps.gap_on_the_grid`): times not in seconds would ask for GiBs.
    """
    inputs, commands, outputs = signals
    dt_ns = step_ns(dt)
    output_list = list(outputs.values())
    held_signals = [*inputs.values(), *commands.values()]
    starts, ends = [*held_signals, *output_list], output_list or held_signals
    # the grid's first and last times, found once (the held signals' clock is a pass over
    # their samples): the span the output gaps are judged over, then the grid
    t0, t_last = t0_and_last(starts, ends, source, dt_ns, on_whole_ns(held_signals, dt))
    span = t0, span_end(dt_ns, t_last, bool(ends))
    for symbol, series in outputs.items():
        gap = gap_on_the_grid(series, span, dt_ns, max_gap_ns)
        if gap is not None:
            raise gap_error(
                source,
                f"output {symbol!r}",
                field_word,
                series,
                gap,
                0,
                max_gap_ns,
                dt_ns,
                dropped=dropped.get(symbol),
            )
    return grid_between(dt, t0, t_last, bool(ends))


def check_alignment_options(
    dt: float, resample: str, max_gap: float | None
) -> tuple[int, Resample, int]:
    """Validate the alignment options before any log is read.

    Returns
    -------
    tuple
        ``dt`` in nanoseconds, the resampling method, and ``max_gap`` in nanoseconds.

    Raises
    ------
    OptionError
        For an unusable ``dt``, an unknown ``resample`` or a negative ``max_gap``.
    """
    dt_ns = step_ns(dt)
    method = check_resample(resample)
    check_max_gap(max_gap)
    if max_gap is None:
        return dt_ns, method, DEFAULT_MAX_GAP_STEPS * dt_ns
    return dt_ns, method, round(max_gap * NS_PER_S)


def align_signals(
    *,
    source: str,
    dt: float,
    inputs: Mapping[str, Series],
    outputs: Mapping[str, Series],
    commands: Mapping[str, Series] | None = None,
    truth_mode: LabelSeries | None = None,
    truth_components: Mapping[str, LabelSeries] | None = None,
    states: Sequence[str] = (),
    truth_states: Mapping[str, Series] | None = None,
    resample: str = "nearest",
    max_gap: float | None = None,
    split_gaps: bool = False,
    notes: dict[str, Any] | None = None,
    field_word: str = "column",
    dropped: Mapping[str, IntArray] | None = None,
) -> AlignedSignals:
    """Put mapped series onto the grid ``t0 + k*dt`` (rules in the module docstring).

    Parameters
    ----------
    source:
        The log's path, stored in the result and used in messages.
    dt:
        The model's sample time in seconds.
    inputs, outputs:
        ``{symbol: series}`` in the model's order.
    commands:
        ``{command: series}`` of a ``[components]`` model's commands, held onto the grid
        as inputs are (and, like them, bounding its start), into
        ``AlignedSignals.commands``; named as commands in messages and notes (``held``
        entries of commands carry ``"kind": "command"``).
    truth_mode:
        True-mode samples whose ``codes`` are indices into the model's mode ids
        (:func:`~hybridlog.io.source.labels_to_codes`), or ``None``.
    truth_components:
        ``{component: true-mode samples}`` whose ``codes`` index the component's mode ids,
        held onto the grid like ``truth_mode``.
    states:
        The model's state names (order of ``truth_states`` columns).
    truth_states:
        ``{state: series}`` for the states the log has.
    resample:
        ``"nearest"`` or ``"linear"`` (outputs and true states).
    max_gap:
        Longest tolerated time in seconds between two output samples around a gap;
        default ``5*dt``.
    split_gaps:
        Align the longest piece between longer gaps instead of refusing the log.
    notes:
        Filled with the signals that start the grid late or end it early by more than
        ``max_gap`` (``span``), the pieces (``segments``) and the one analysed when
        ``split_gaps`` cut the log, and per output the grid points bridged across short
        gaps (``bridged``: ``{symbol: {points, of, every, steps}}``, the last two of
        :func:`~hybridlog.io.alignment_notes.sampled_every`), per true state the same
        (``truth_bridged``), per input and output sampled faster than the grid its
        samples on the grid's span and the grid's points (``faster``: ``{symbol: {kind,
        samples, points}}``), per input its longest hold over ``max_gap`` (``held``:
        ``{symbol: {start, end, seconds, holds, every, steps, regular}}``, the last three of
        :func:`~hybridlog.io.alignment_notes.held_sampling`), and the same for the true mode
        and each component's (``truth_held``: ``{"mode" | "mode.<component>": {start, end,
        seconds}}``),
        and for a true mode that starts more than half a step after the first sample time
        where it starts and how many samples it covers (``truth_starts``: ``{"mode" |
        "mode.<component>": {at, samples, of}}``).  ``truth_held`` is of a true mode recorded
        only at its switches (:func:`~hybridlog.io.true_modes.records_switches`); a sampled one's
        stretches without a sample (longer than ``dt``, whatever ``max_gap``) leave their grid
        points more than
        ``dt/2`` from every sample without a true mode, recorded as ``truth_gaps``:
        ``{"mode" | "mode.<component>": {start, end, seconds, gaps, points, of, every,
        steps}}`` (the longest stretch, how many there are, the grid points left without a
        true mode, all grid points, and how often it is sampled, as ``bridged``).
    field_word:
        What the log calls a series in messages: ``"column"`` (tables) or ``"field"``
        (message paths; :attr:`~hybridlog.io.source.SourceInfo.field_word`).
    dropped:
        ``{output: times (ns)}`` of the samples ``--drop-nonfinite`` dropped, for the error
        of a gap they made.

    Returns
    -------
    AlignedSignals

    Raises
    ------
    OptionError
        For an unknown ``resample``, a negative ``max_gap`` or an unusable ``dt``.
    LogError
        For an input or output without samples, an output gap longer than ``max_gap``
        (naming the time span), or signals that do not overlap.
    """
    dt_ns, method, max_gap_ns = check_alignment_options(dt, resample, max_gap)
    tolerance = clock_tolerance_ns(dt_ns)
    commands = commands or {}
    for kind, signals in (("input", inputs), ("output", outputs), ("command", commands)):
        for symbol, series in signals.items():
            if series.time_ns.size == 0:
                raise LogError(
                    f"{source}: {kind} {symbol!r} ({field_word} {series.name!r}) has no samples"
                )
    if notes is not None:
        record_span_bounds(inputs, outputs, commands, field_word, dt_ns, max_gap_ns, notes)
    piece = ""
    held_series = {**inputs, **commands}

    def grid_of(named: str, cut: Mapping[str, Series]) -> IntArray:
        return _output_grid(
            named, dt, (inputs, commands, cut), field_word, max_gap_ns, dropped or {}
        )

    def resampled(cut: Mapping[str, Series], grid: IntArray) -> list[Resampled]:
        return [resample_series(s, grid, dt_ns, max_gap_ns, method) for s in cut.values()]

    if split_gaps and outputs:
        outputs, piece, grid, on_grid_outputs = split_at_refused_gaps(
            (source, field_word),
            held_series,
            outputs,
            (dt_ns, max_gap_ns),
            notes if notes is not None else {},
            (grid_of, resampled),
        )
        if piece:  # every message from here on is about that piece
            source = f"{source} ({piece})"
    else:
        grid = grid_of(source, outputs)
        on_grid_outputs = resampled(outputs, grid)
    n = grid.size

    u = _held_onto(grid, inputs, "input", dt_ns, max_gap_ns, notes)
    held_commands = _held_onto(grid, commands, "command", dt_ns, max_gap_ns, notes)

    y = np.empty((n, len(outputs)), dtype=np.float64)
    unmeasured: npt.NDArray[np.bool_] | None = None
    for j, (symbol, series) in enumerate(outputs.items()):
        values, too_long, bridged = on_grid_outputs[j]
        if too_long.size:
            raise gap_error(
                source,
                f"output {symbol!r}",
                field_word,
                series,
                grid,
                int(too_long[0]),
                max_gap_ns,
                dt_ns,
                dropped=(dropped or {}).get(symbol),
            )
        if bridged.size:
            if unmeasured is None:
                unmeasured = np.zeros((n, len(outputs)), dtype=np.bool_)
            unmeasured[bridged, j] = True
            if notes is not None:
                notes.setdefault("bridged", {})[symbol] = {
                    "points": int(bridged.size),
                    "of": n,
                    **sampled_every(series.time_ns, grid, dt_ns),
                }
        faster = faster_than_the_grid(series.time_ns, grid, dt_ns, "output")
        if faster is not None and notes is not None:
            notes.setdefault("faster", {})[symbol] = faster
        y[:, j] = values

    jittered: dict[str, Any] = {}
    labelled = {"mode": truth_mode} if truth_mode is not None else {}
    labelled |= {f"mode.{name}": series for name, series in (truth_components or {}).items()}
    codes_of: dict[str, IntArray] = {}
    for label, label_series in labelled.items():
        codes, gaps = hold_modes(
            f"{source}: truth.{label}",
            field_word,
            label_series,
            grid,
            (dt_ns, tolerance),
            jittered,
            label,
        )
        codes_of[label] = codes
        if notes is None:
            continue
        if gaps is not None:  # with how often it was sampled: the gaps' cause, as an output's
            notes.setdefault("truth_gaps", {})[label] = {
                **gaps,
                **sampled_every(label_series.time_ns, grid, dt_ns),
            }
        held = (  # a record of the switches: held however long, and the metrics score the hold
            longest_hold(label_series.time_ns, grid, dt_ns, max_gap_ns)
            if records_switches(label_series.codes)
            else None
        )
        if held is not None:
            notes.setdefault("truth_held", {})[label] = held
        late = truth_start(label_series, codes, grid)
        if late is not None:
            notes.setdefault("truth_starts", {})[label] = late
    modes = codes_of.get("mode")
    components = {
        name: ComponentTruth(series.categories, codes_of[f"mode.{name}"])
        for name, series in (truth_components or {}).items()
    }
    for signal, found in jittered.items():
        _note_jitter(notes, signal, found, n)

    x_true: FloatArray | None = None
    if truth_states:
        x_true = np.full((n, len(states)), np.nan)
        for j, state in enumerate(states):
            truth_series = truth_states.get(state)
            if truth_series is None or truth_series.time_ns.size == 0:
                continue
            values, too_long, bridged = resample_series(
                truth_series, grid, dt_ns, max_gap_ns, method
            )
            if bridged.size and notes is not None:
                notes.setdefault("truth_bridged", {})[state] = {
                    "points": int(bridged.size),
                    "of": n,
                    **sampled_every(truth_series.time_ns, grid, dt_ns),
                }
            x_true[:, j] = values
            x_true[too_long, j] = np.nan
            x_true[bridged, j] = np.nan  # not the truth there: no state error is scored

    return AlignedSignals(
        source=source,
        time=ns_to_seconds(grid),
        input_names=tuple(inputs),
        output_names=tuple(outputs),
        inputs=u,
        outputs=y,
        truth_modes=modes,
        state_names=tuple(states),
        truth_states=x_true,
        truth_components=components,
        command_names=tuple(commands or {}),
        commands=held_commands if commands else None,
        unmeasured_outputs=unmeasured,
        piece=piece,
    )


def _held_onto(
    grid: IntArray,
    signals: Mapping[str, Series],
    kind: str,
    dt_ns: int,
    max_gap_ns: int,
    notes: dict[str, Any] | None,
) -> FloatArray:
    """Inputs (or commands: ``kind``) on the grid by the hold, ``(N, len(signals))``.

    Each column is the series' sample at each grid point (on the grid), its own sample
    (a jittering clock, :func:`~hybridlog.io.resampling.jittered_index`), or the last at or before
    it.  Recorded in ``notes`` under the signal's own kind: a command is held as an input is, but
    the model has no input of its name, and a note of "input cmd" sent the user looking for one.
    """
    tolerance = clock_tolerance_ns(dt_ns)
    n = grid.size
    held = np.empty((n, len(signals)), dtype=np.float64)
    for j, (symbol, series) in enumerate(signals.items()):
        on = on_grid_values(series, grid, tolerance)
        index: IntArray | None = None
        if on is None:
            found = jittered_index(series.time_ns, grid, tolerance, dt_ns)
            if found is not None:
                _note_jitter(notes, f"{kind} {symbol}", found, n)
            index = (
                found.taken if found is not None else _hold_from_first(series.time_ns, grid, dt_ns)
            )
            on = series.values[index]
        held[:, j] = on
        if notes is None:
            continue
        faster = faster_than_the_grid(series.time_ns, grid, dt_ns, kind)
        if faster is not None:
            notes.setdefault("faster", {})[symbol] = faster
        elif index is not None:
            skipped = skipped_by_the_hold(index, kind)
            if skipped is not None:
                notes.setdefault("skipped", {})[symbol] = {**skipped, "points": n}
        hold = longest_hold(series.time_ns, grid, dt_ns, max_gap_ns)
        if hold is not None:  # with how often it was sampled: regularly, or when it changed
            hold |= held_sampling(series.time_ns, grid, dt_ns)
            notes.setdefault("held", {})[symbol] = (
                hold if kind == "input" else {**hold, "kind": kind}
            )
    return held


def _hold_from_first(time_ns: IntArray, grid_ns: IntArray, dt_ns: int) -> IntArray:
    """:func:`.hold_index` of a held series, whose first sample the points before it take.

    Only a grid on a jittering clock (:func:`~hybridlog.io.time_grid._grid_start`) starts before a
    held series' first sample, by at most ``dt/4``; :func:`~hybridlog.io.resampling.jittered_index`
    gives that point its sample, but a series it does not take (half its samples dropped over a
    short grid) was held from index -1: the series' last sample, 299 at the first point of a log
    from 0 to 299.
    """
    index = hold_index(time_ns, grid_ns, clock_tolerance_ns(dt_ns))
    np.maximum(index, 0, out=index)
    return index


def _note_jitter(notes: dict[str, Any] | None, signal: str, found: Jittered, n: int) -> None:
    """Record a jittered series: its jitter (s), and the grid points it held, if any."""
    if notes is None:
        return
    notes.setdefault("jitter", {})[signal] = found.jitter
    if found.held:
        notes.setdefault("jitter_held", {})[signal] = {"points": found.held, "of": n}
