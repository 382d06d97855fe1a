"""The notes a report gives of how its log was read: samples not used, spans not analysed, repairs.

From the reading record of the signals (``AlignedSignals.reading``: report.json's
``reading`` block) alone: samples faster than the grid, spans left out by ``--split-gaps``
or for non-finite values, gaps bridged, holds, rows put in order, clocks that disagree
(SPEC §5).  Shared by the report (:mod:`hybridlog.report.build`), ``hybridlog cluster``
(:mod:`hybridlog.jobs.cluster`) and the terminal lines of ``analyze``.
"""

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from hybridlog.io.alignment_notes import REGULAR_TOLERANCE
from hybridlog.io.clocks import clocks_disagree
from hybridlog.report.markdown import (
    plural,
)
from hybridlog.times import format_duration, format_time

if TYPE_CHECKING:
    pass


def _faster_notes(faster: Mapping[str, Mapping[str, Any]]) -> list[str]:
    """A note per rate of the inputs and outputs sampled faster than the grid (``faster``).

    The signals of one rate share a note (a 10 Hz log's every column, not one note each).
    """
    rates: dict[tuple[int, int], list[tuple[str, str]]] = {}
    for symbol, count in faster.items():
        rates.setdefault((count["samples"], count["points"]), []).append((count["kind"], symbol))
    notes = []
    for (samples, points), signals in rates.items():
        kinds = {kind for kind, _ in signals}
        named = ", ".join(f"{kind} {symbol}" for kind, symbol in signals)
        taken = " or ".join(
            what
            for kind, what in (
                ("input", "the last at or before it"),
                ("command", "the last at or before it"),
                ("output", "the nearest"),
            )
            if kind in kinds and (kind != "command" or "input" not in kinds)
        )
        notes.append(
            f"NOTE: {named} {'has' if len(signals) == 1 else 'each have'} {samples:,} samples "
            f"over the {points:,} sample times analysed ({samples / points:.3g} a sample "
            f"time): each sample time takes one ({taken}, SPEC §5), so at least "
            f"{samples - points:,}{'' if len(signals) == 1 else ' of each'} "
            f"{'is' if samples - points == 1 else 'are'} not used; is "
            "the model's dt the log's?"
        )
    return notes


def unused_sample_notes(reading: Mapping[str, Any] | None) -> list[str]:
    """The notes of report.md saying that samples of the log are not used.

    Inputs and outputs sampled faster than the grid (``faster``: a log at twice the model's
    rate loses every other sample) and input or command samples the hold never takes
    (``skipped``).  ``analyze`` and ``compare`` print them on the terminal too: a log read
    in half was otherwise said only in report.md.
    """
    reading = reading or {}
    notes = _faster_notes(reading.get("faster") or {})
    notes += [
        f"NOTE: {count['kind']} {symbol}: {count['unused']:,} of its {count['samples']:,} "
        f"samples over the {count['points']:,} sample times analysed "
        f"{'is' if count['unused'] == 1 else 'are'} not used: each sample time takes the last "
        "sample at or before it (SPEC §5), and another sample followed each of these "
        "before the next sample time (a change undone within dt, or a clock jittering by "
        "more than dt/4, whose late samples are then taken a step late)"
        for symbol, count in (reading.get("skipped") or {}).items()
    ]
    return notes


def unanalysed_span_notes(reading: Mapping[str, Any] | None) -> list[str]:
    """The notes of report.md saying that a stretch of the log's time was not analysed.

    A signal that started the analysed span late or ended it early (``span``), the pieces
    ``--split-gaps`` left out (``segments``) and the ends ``--drop-nonfinite`` cut off
    (``nonfinite_span``).  ``analyze`` and ``compare`` print them on the terminal, as
    :func:`unused_sample_notes`: the line ``imm on run.csv: 141 samples ..., mode accuracy
    100.0 %`` of a 301-sample log split at a gap read as the whole log's, the 139 s left out
    said only at the end of report.md.
    """
    reading = reading or {}
    return [
        *_span_notes(reading),
        *_segment_notes(reading),
        *_nonfinite_span_notes(reading),
    ]


def _span_notes(reading: Mapping[str, Any]) -> list[str]:
    notes = []
    for side, bound in (reading.get("span") or {}).items():
        first = side == "start"
        notes.append(
            f"NOTE: the analysed span {side}s at t = {format_time(bound['at'])} s, the "
            f"{'first' if first else 'last'} sample of {bound['signal']}; the inputs and "
            f"outputs {'begin at' if first else 'run on to'} t = {format_time(bound['log'])} s: "
            f"{format_duration(bound['left_out'], bound['at'], bound['log'])} s of the log "
            "not analysed"
        )
    return notes


def _segment_notes(reading: Mapping[str, Any]) -> list[str]:
    segments = reading.get("segments")
    if not segments:
        return []
    # report.json lists the first pieces and gaps only, each counted (io.log_pieces._listed)
    analysed = reading["analysed_segment"]
    kept = reading.get("analysed") or segments[analysed]
    others = [p for i, p in enumerate(segments) if i != analysed]
    pieces = int(reading.get("segment_count", len(segments)))
    gaps = reading.get("gaps") or []
    gap_count = int(reading.get("gap_count", len(gaps)))
    span = f"t = {format_time(kept['start'])} … {format_time(kept['end'])} s"
    return [
        f"NOTE: --split-gaps: {plural(gap_count, 'output gap')} longer than max_gap "
        f"({_spans(gaps, total=gap_count)}) "
        + (
            f"cut the log into {pieces:,} pieces; the longest is analysed, "
            f"{span}; not analysed: {_spans(others, total=pieces - 1)}"
            if pieces > 1  # else the gaps are at the ends: one piece, and they are left out
            else f"left out; analysed: {span}"
        )
    ]


def _nonfinite_span_notes(reading: Mapping[str, Any]) -> list[str]:
    notes = []
    for side, moved in (reading.get("nonfinite_span") or {}).items():
        first = side == "start"
        notes.append(
            f"NOTE: the analysed span {side}s at t = {format_time(moved['at'])} s, the "
            f"{'first' if first else 'last'} sample --drop-nonfinite kept of {moved['signal']}: "
            f"it dropped the {plural(moved['dropped'], 'sample')} "
            f"{'before' if first else 'after'} it ({'from' if first else 'to'} "
            f"t = {format_time(moved['from'])} s)"
        )
    return notes


SLOWER_STEPS = 1.25
"""A bridged output whose median sample step is this many steps of dt or more is published
at a slower rate than the model's (:func:`bridged_cause`)."""
FASTER_STEPS = 0.75
"""One whose median step is at most this many steps of dt is sampled faster than the grid and
has gaps all the same: :func:`bridged_cause` asks whether the model's dt is the log's."""


def bridged_cause(count: Mapping[str, Any]) -> str:
    """Why an output (a true state, a true mode) has gaps, in words, from its median sample step.

    ``count`` is the output's entry in ``reading.bridged`` (a true state's in
    ``reading.truth_bridged``, a true mode's in ``reading.truth_gaps``), with
    :func:`~hybridlog.io.alignment_notes.sampled_every`'s ``every`` and ``steps``.  A topic
    published at a slower rate than the model's (a ROS topic of its own at a third of it) has
    no sample at most grid points by design; one published at the model's rate lacks samples
    there (where it held NaN cells ``--drop-nonfinite`` dropped, say).  The warning asked of
    both whether the model's dt is the log's, as it still does of an entry without ``steps``
    (a report of an earlier version).
    """
    steps = count.get("steps")
    if not isinstance(steps, int | float):
        return "is the model's dt the log's?"
    if steps >= SLOWER_STEPS:
        return f"it is {_sampled_every(count)}"
    if steps > FASTER_STEPS:
        return "it is sampled every dt, with samples missing there"
    return "is the model's dt the log's?"


def _sampled_every(count: Mapping[str, Any]) -> str:
    """``sampled every 0.1 s (median), 10 steps of dt``, of an entry with ``every`` and ``steps``.

    :func:`~hybridlog.io.alignment_notes.sampled_every`'s, of an output or a held input alike.
    """
    steps = count["steps"]
    every = f"sampled every {count['every']:g} s (median)"
    return f"{every}, {steps:g} step{'' if steps == 1 else 's'} of dt"


def _held_note(symbol: str, hold: Mapping[str, Any]) -> str:
    """What ``reading.held`` says of an input (or a command) held over ``max_gap``.

    One sampled regularly (``regular``, :func:`~hybridlog.io.alignment_notes.held_sampling`)
    is said to be so, at its median step: a NOTE where its longest hold is one of those steps
    (within :data:`~hybridlog.io.alignment_notes.REGULAR_TOLERANCE`), a WARNING naming its
    longest hold where a longer one (a dropout) is held too.  Any other is said to be held
    "as an input published only when it changes is", which a 10 Hz input to a model of
    ``dt = 0.01`` was said to be, as if irregular.
    """
    kind = hold.get("kind", "input")
    if hold.get("regular") and isinstance(hold.get("every"), int | float):
        sampled = f"{kind} {symbol} is {_sampled_every(hold)}"
        if hold["seconds"] <= hold["every"] * (1 + REGULAR_TOLERANCE):
            return f"NOTE: {sampled}: held between samples (zero-order hold)"
        return (
            f"WARNING: {sampled}, held between samples (zero-order hold), and its longest "
            f"stretch without a sample is from t = {format_time(hold['start'])} to "
            f"{format_time(hold['end'])} s ({_held_for(hold)} s): held at its last value there"
        )
    return (
        f"WARNING: {kind} {symbol} has no sample {_hold_span(hold)}: held at its last value, "
        f"as {_article(kind)} published only when it changes is (zero-order hold)"
    )


def report_reading_notes(reading: Mapping[str, Any] | None) -> tuple[str, ...]:
    """What report.md must say of how the log was read, beside report.json's ``reading``.

    Warnings about the alignment (outputs and true states bridged across gaps, ``bridged``,
    ``truth_bridged``; input and command samples the hold does not take, ``skipped``), the
    signal that started the analysed span late or ended it early (``span``), and what the user's
    repairs changed: the piece ``--split-gaps`` kept (``segments``), the samples
    ``--drop-nonfinite`` and ``--sort`` dropped, moved, merged or replaced, an MCAP file read by
    ``--recover``; and the ground truth found by default but not used (no samples, or
    unreadable: ``truth_without_samples``, ``truth_unusable``), and ground truth read from an
    input's or output's field (``truth_shared``).
    A report of a tenth of a log, or of one with samples taken out, said only its sample
    count and time span, which read like the whole log's.
    """
    reading = reading or {}
    notes = [
        f"WARNING: output {symbol} has no sample within dt/2 of {count['points']} of "
        f"{count['of']} sample times ({bridged_cause(count)}): the estimator had no "
        f"measurement of it there (a filter updates on the other outputs alone, predicts "
        f"only where none is); MSE, VAF and fit leave them out, and estimates.csv's {symbol} "
        "is empty there"
        for symbol, count in (reading.get("bridged") or {}).items()
    ]
    notes += [
        f"WARNING: true state {symbol} has no sample within dt/2 of {count['points']} of "
        f"{count['of']} sample times ({bridged_cause(count)}): its RMSE leaves them "
        f"out, and estimates.csv's {symbol}_true is empty there"
        for symbol, count in (reading.get("truth_bridged") or {}).items()
    ]
    return (*notes, *log_reading_notes(reading))


def _stamp_clock_notes(offsets: Mapping[str, float]) -> list[str]:
    """A WARNING where ``--time header`` aligned topics stamped by clocks that disagree.

    ``offsets``: each mapped topic's median of ``header.stamp`` minus log time
    (``reading.stamp_offsets``; :func:`~hybridlog.io.clocks.clocks_disagree`).  Their samples
    are aligned as far apart as those clocks are: 1.7e9 s held an input's last sample over
    the whole log, with no word of why.
    """
    disagree = clocks_disagree(offsets)
    if disagree is None:
        return []
    return [
        f"WARNING: --time header: {disagree}, and their samples are aligned that far apart; "
        "--time log aligns them as they were recorded"
    ]


def log_reading_notes(reading: Mapping[str, Any] | None) -> tuple[str, ...]:
    """What :func:`report_reading_notes` says of how the log was read but for the bridged signals.

    Samples not used, holds, the true mode's silences and late start, the span, and the
    user's repairs (``--split-gaps``, ``--drop-nonfinite``, ``--sort``, ``--recover``): true
    whatever used the log, so ``hybridlog cluster`` says them too (it said none of them; the
    bridged outputs it words itself: the regression vectors holding them are not clustered).
    """
    reading = reading or {}
    notes = unused_sample_notes(reading)
    notes += [_held_note(symbol, hold) for symbol, hold in (reading.get("held") or {}).items()]
    notes += _stamp_clock_notes(reading.get("stamp_offsets") or {})
    dropped = reading.get("jitter_held") or {}
    notes += [
        f"NOTE: {signal} was recorded once per sample time by a clock that jitters (samples "
        f"up to {jitter * 1e3:.3g} ms from their sample times, some after them): "
        "each sample time takes its own sample, where the zero-order hold would have taken "
        "the one before for every late one, a one-step delay at random"
        + (
            f"; {dropped[signal]['points']:,} of {dropped[signal]['of']:,} sample times "
            f"{'has' if dropped[signal]['points'] == 1 else 'have'} no sample of "
            f"{'its' if dropped[signal]['points'] == 1 else 'their'} own (dropped by the log) "
            f"and {'holds' if dropped[signal]['points'] == 1 else 'hold'} the one before"
            if signal in dropped
            else ""
        )
        for signal, jitter in (reading.get("jitter") or {}).items()
    ]
    notes += [
        f"NOTE: the true {label} has no sample {_hold_span(hold)}: held at its last value, "
        "against which the mode metrics score those samples (it is recorded only at its "
        "switches: no sample repeats the label of the one before, so in between it did not "
        "change)"
        for label, hold in (reading.get("truth_held") or {}).items()
    ]
    gaps = reading.get("truth_gaps") or {}
    notes += [
        f"WARNING: the true {label} has no sample within dt/2 of {gap['points']:,} of "
        f"{gap['of']:,} sample times, {_gap_span(gap)}: it may have switched there unseen, "
        "so those samples have no true mode and are not scored, and no switch is measured "
        "across them (it repeats its label, so it is sampled, not recorded only at its "
        f"switches; {bridged_cause(gap)})"
        for label, gap in gaps.items()
    ]
    notes += [
        f"NOTE: the true {label} starts at t = {format_time(late['at'])} s, after the first "
        f"sample time: the mode metrics score the {late['samples']:,} of {late['of']:,} samples "
        "from it on"
        + (f", less the {gaps[label]['points']:,} without a sample above" if label in gaps else "")
        + " (the samples before have no true mode, as a true state that starts late has no "
        "true value)"
        for label, late in (reading.get("truth_starts") or {}).items()
    ]
    notes += _span_notes(reading)
    notes += _segment_notes(reading)
    for key, what in (
        ("nonfinite_dropped", "--drop-nonfinite dropped NaN or infinite samples"),
        ("out_of_range_dropped", "--drop-nonfinite dropped out-of-range samples"),
        ("sorted", "--sort put samples that went back in time in order"),
        ("duplicates_dropped", "--sort dropped samples of a time already seen, keeping the last"),
    ):
        if key in reading:
            notes.append(f"NOTE: {what}: {_counts(reading[key])}")
    notes += _nonfinite_span_notes(reading)
    # a table's rows (counts; a message log's duplicates are counted per topic, never merged)
    combined, dropped = reading.get("rows_combined", 0), reading.get("duplicates_dropped", 0)
    merged = combined - (dropped if isinstance(dropped, int) else 0)
    if merged > 0:  # rows of one time giving other columns (a row per signal): nothing lost
        notes.append(
            f"NOTE: --sort merged rows of a time already seen into that time's sample, column "
            f"by column: {plural(merged, 'row')}"
        )
    if reading.get("values_superseded"):
        notes.append(
            "NOTE: --sort replaced values by a later row's at the same time: "
            f"{_counts(reading['values_superseded'])}"
        )
    for key, what in (
        ("truth_without_samples", "ground truth fields without samples, not used"),
        ("truth_unusable", "ground truth fields found by default that cannot be read, not used"),
        (
            "truth_shared",
            "ground truth read from the field of an input or output (the measurement itself, "
            "not independent of it)",
        ),
        ("csv_names_stripped", "CSV header names read without the spaces around them"),
    ):
        if reading.get(key):
            notes.append(f"NOTE: {what}: {', '.join(map(str, reading[key]))}")
    if reading.get("time_columns_passed_over"):
        time, *others = reading["time_columns_passed_over"]
        notes.append(
            f"NOTE: the time is column {time!r}; {', '.join(map(repr, others))} beside it is "
            "read as a signal, only where it is mapped (--map)"
        )
    if reading.get("metadata"):
        notes.append(
            "NOTE: metadata.yaml and the bag's storage files disagree (the storage files are "
            f"read): {'; '.join(reading['metadata'])}"
        )
    if reading.get("unlisted_files"):
        notes.append(
            "WARNING: the bag folder holds storage files its metadata.yaml does not list, "
            f"whose messages are not read: {', '.join(reading['unlisted_files'])} (list them "
            "in metadata.yaml, or analyse each file itself)"
        )
    if reading.get("recovered"):
        notes.append(
            f"NOTE: --recover: the MCAP file was read sequentially, "
            f"{plural(reading.get('messages_readable', 0), 'message')} up to "
            f"{reading.get('stopped_at')}"
        )
    return tuple(notes)


def _article(kind: str) -> str:
    """``an input``, ``a command``: what ``reading.held`` says of a signal of ``kind``."""
    return f"{'an' if kind[0] in 'aeiou' else 'a'} {kind}"


def _gap_span(gap: Mapping[str, Any]) -> str:
    """Where a true mode of ``reading.truth_gaps`` has no sample, and how often.

    ``from t = 19 to 23 s (4 s)``; ``in 30 stretches, the longest from t = 290 to 300 s
    (10 s)`` where there are several.  Any stretch longer than ``dt`` counts, not only those
    longer than ``max_gap``: a sampled true mode is not held across a gap.
    """
    span = f"from t = {format_time(gap['start'])} to {format_time(gap['end'])} s"
    span += f" ({_held_for(gap)} s)"
    count = int(gap["gaps"])
    return f"in {count:,} stretches, the longest {span}" if count > 1 else span


def _hold_span(hold: Mapping[str, float]) -> str:
    """Where a signal of ``reading.held`` or ``truth_held`` has no sample, and how often.

    ``from t = 10 to 40 s (30 s, longer than max_gap)``; ``in 30 stretches longer than
    max_gap, the longest from t = 290 to 300 s (10 s)`` where there are several.
    """
    span = f"from t = {format_time(hold['start'])} to {format_time(hold['end'])} s"
    count = int(hold.get("holds", 1))
    if count > 1:
        return (
            f"in {count:,} stretches longer than max_gap, the longest {span} ({_held_for(hold)} s)"
        )
    return f"{span} ({_held_for(hold)} s, longer than max_gap)"


def _held_for(hold: Mapping[str, float]) -> str:
    """How long a hold of ``reading.held`` or ``truth_held`` lasts, to the digits its times hold."""
    return format_duration(hold["seconds"], hold["start"], hold["end"])


def _spans(spans: list[Mapping[str, float]], most: int = 5, total: int | None = None) -> str:
    """``t = a … b s, ...`` for at most ``most`` spans, then how many more of ``total``.

    ``total``: how many there are, when ``spans`` lists only the first (report.json's).
    """
    total = len(spans) if total is None else total
    shown = spans[: min(most, total)]
    text = ", ".join(f"t = {format_time(p['start'])} … {format_time(p['end'])} s" for p in shown)
    return text + (f" and {total - len(shown):,} more" if total > len(shown) else "")


def _counts(value: object) -> str:
    """A count of rows, or per signal (topic, column) its count: ``y1 556, /odom 3``."""
    if isinstance(value, Mapping) and set(value) == {"rows_out_of_order"}:  # a table's rows
        value = value["rows_out_of_order"]
    if isinstance(value, Mapping):
        return ", ".join(f"{name} {count}" for name, count in value.items())
    return plural(int(value), "row") if isinstance(value, int) else str(value)
