"""``--split-gaps``: a log cut at its output gaps longer than ``max_gap``, its longest piece.

The log is cut where the reading would refuse it, and only there
(:func:`split_at_refused_gaps`); each output keeps the samples the piece's grid reads
(:func:`_piece_of`), and the pieces and gaps are listed for report.json, the first
:data:`~hybridlog.io.summary.MAX_LISTED_GAPS` of each, counted (:func:`_listed`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from hybridlog.errors import LogError
from hybridlog.io.alignment_notes import seconds_between
from hybridlog.io.output_gaps import slower_than_max_gap
from hybridlog.io.resampling import Resampled
from hybridlog.io.source import NS_PER_S, Series, format_ns
from hybridlog.io.summary import MAX_LISTED_GAPS
from hybridlog.io.time_grid import clock_tolerance_ns, longer_than_max_gap
from hybridlog.signals import IntArray


def split_at_refused_gaps(
    named: tuple[str, str],
    held: Mapping[str, Series],
    outputs: Mapping[str, Series],
    steps: tuple[int, int],
    notes: dict[str, Any],
    build: tuple[
        Callable[[str, Mapping[str, Series]], IntArray],
        Callable[[Mapping[str, Series], IntArray], list[Resampled]],
    ],
) -> tuple[dict[str, Series], str, IntArray, list[Resampled]]:
    """``--split-gaps``: the longest piece whose grid refuses no gap, with that grid.

    ``named``: the log's path and what it calls a series; ``steps``: ``dt`` and ``max_gap``
    (ns); ``build``: the grid of a piece's outputs (named by the piece) and the outputs
    resampled onto it.  A step between two samples that is longer than ``max_gap`` but
    shorter than about ``2*dt`` leaves a grid point more than ``dt/2`` from both, which the
    reading refuses, or not, by where the grid lies: cut at every step longer than
    ``max(max_gap, dt)``, a log on a clock jittering by 20 % of ``dt`` read whole with
    ``--max-gap`` equal to ``dt`` came in 105 pieces with ``--split-gaps``, which analysed
    5 of its 301 samples.  So the log is cut at the gaps refused wherever the grid lies
    (:func:`_longest_piece`), then at those the piece's own grid refuses, until it refuses
    none: ``--split-gaps`` cuts where the reading alone would refuse the log, and only there.
    Returns the piece's outputs, its description (empty when nothing was cut), its grid and
    its outputs resampled.
    """
    source, field_word = named
    grid_of, resampled = build
    refused: frozenset[tuple[int, int]] = frozenset()
    while True:
        cut, piece = _longest_piece(source, field_word, held, outputs, steps, notes, refused)
        grid = grid_of(f"{source} ({piece})" if piece else source, cut)
        on_grid_outputs = resampled(cut, grid)
        more = set(refused)
        for series, (_, too_long, _) in zip(cut.values(), on_grid_outputs, strict=True):
            hi = np.searchsorted(series.time_ns, grid[too_long], side="right")
            inside = (hi >= 1) & (hi < series.time_ns.size)  # points outside: refused later
            for k in hi[inside].tolist():
                more.add((int(series.time_ns[k - 1]), int(series.time_ns[k])))
        if len(more) == len(refused):
            return cut, piece, grid, on_grid_outputs
        refused = frozenset(more)


def _gap_anywhere(steps: IntArray, max_gap_ns: int, dt_ns: int) -> npt.NDArray[np.bool_]:
    """Which steps between two samples (ns) the reading refuses wherever the grid lies.

    Longer than ``max_gap`` (:func:`~hybridlog.io.time_grid.longer_than_max_gap`), and long enough
    that the stretch more than ``dt/2`` from both samples
    (:func:`~hybridlog.io.time_grid.past_half_step`) is longer than a grid step: it holds a grid
    point, as :func:`~hybridlog.io.output_gaps.gap_on_the_grid` reasons.  A shorter step is refused
    or not by the phase of the grid (:func:`split_at_refused_gaps`).
    """
    half = dt_ns // 2 + clock_tolerance_ns(dt_ns) + 1
    anywhere: npt.NDArray[np.bool_] = longer_than_max_gap(steps, max_gap_ns, dt_ns) & (
        steps - 2 * half > dt_ns + 1
    )
    return anywhere


def _piece(start_ns: int, end_ns: int) -> dict[str, float]:
    """A piece of a log cut by ``--split-gaps``, as report.json lists it."""
    return {
        "start": start_ns / NS_PER_S,
        "end": end_ns / NS_PER_S,
        "duration": seconds_between(start_ns, end_ns),
    }


def _listed(key: str, noun: str, items: list[dict[str, float]]) -> dict[str, Any]:
    """``items`` under ``key``, the first :data:`MAX_LISTED_GAPS` of them, counted and flagged.

    ``{key: [...], f"{noun}_count": n, f"{key}_truncated": bool}``: a reader of report.json
    knows from the flag, never from a guess, that the list is not whole.
    """
    return {
        key: items[:MAX_LISTED_GAPS],
        f"{noun}_count": len(items),
        f"{key}_truncated": len(items) > MAX_LISTED_GAPS,
    }


def _longest_piece(
    source: str,
    field_word: str,
    inputs: Mapping[str, Series],
    outputs: Mapping[str, Series],
    steps: tuple[int, int],
    notes: dict[str, Any],
    refused: frozenset[tuple[int, int]] = frozenset(),
) -> tuple[dict[str, Series], str]:
    """The outputs (none empty) cut to the longest stretch without a gap longer than ``max_gap``.

    ``steps``: ``dt`` and ``max_gap`` (ns).  The log is cut at every step between two
    samples of an output that the reading refuses wherever its grid lies
    (:func:`_gap_anywhere`), and at the steps in ``refused`` (``(start, end)`` times, ns),
    which the grid of a piece cut before refused (:func:`split_at_refused_gaps`).  A
    sample alone between two gaps is a piece of its own, wherever it lies.  With it, the
    piece kept when the log was cut, for messages (``--split-gaps piece 2 of 3, t = 20 … 23
    s, the longest``; its number counts the pieces in time order from 1, as report.json's
    ``reading.segments`` lists them); empty when no gap cut it.
    """
    dt_ns, max_gap_ns = steps
    for symbol, series in outputs.items():
        # every step a gap: no piece longer than one sample (counted, not judged from the
        # median step: a log mostly sampled slowly can still hold a piece sampled at dt)
        diffs = np.diff(series.time_ns)
        if diffs.size and bool(np.all(_gap_anywhere(diffs, max_gap_ns, dt_ns))):
            hint = slower_than_max_gap(series, max_gap_ns, dt_ns)
            raise LogError(
                f"{source}: --split-gaps: output {symbol!r} ({field_word} {series.name!r}) "
                f"leaves no piece of more than one sample{hint}"
            )
    start = max(int(s.time_ns[0]) for s in (*inputs.values(), *outputs.values()))
    end = min(int(s.time_ns[-1]) for s in outputs.values())
    if start > end:  # nothing to cut: the grid refuses it, naming the signals
        return dict(outputs), ""
    found: set[tuple[int, int]] = set(refused)
    for series in outputs.values():
        diffs = np.diff(series.time_ns)
        for i in np.flatnonzero(_gap_anywhere(diffs, max_gap_ns, dt_ns)).tolist():
            found.add((int(series.time_ns[i]), int(series.time_ns[i + 1])))
    if not found:
        return dict(outputs), ""
    gaps = sorted(found)
    pieces: list[tuple[int, int]] = []
    cursor = start
    for gap_start, gap_end in gaps:
        if gap_start >= cursor:  # a sample between two gaps (gap_start == cursor) too
            pieces.append((cursor, min(gap_start, end)))
        cursor = max(cursor, gap_end)
    if cursor <= end:
        pieces.append((cursor, end))
    pieces = [(a, b) for a, b in pieces if a <= b]
    if not pieces:
        raise _no_piece(source, field_word, outputs, (start, end), gaps)
    best = max(range(len(pieces)), key=lambda i: (pieces[i][1] - pieces[i][0], -i))
    lo, hi = pieces[best]
    notes.update(_listed("segments", "segment", [_piece(a, b) for a, b in pieces]))
    notes["analysed_segment"] = best
    notes["analysed"] = _piece(lo, hi)
    gap_list = [{"start": a / NS_PER_S, "end": b / NS_PER_S} for a, b in gaps]
    notes.update(_listed("gaps", "gap", gap_list))
    cut = {symbol: _piece_of(series, (lo, hi), found) for symbol, series in outputs.items()}
    longest = "the only one" if len(pieces) == 1 else "the longest"
    piece = (
        f"--split-gaps piece {best + 1:,} of {len(pieces):,}, t = {format_ns(lo)} … "
        f"{format_ns(hi)} s, {longest}"
    )
    return cut, piece


def _piece_of(series: Series, piece: tuple[int, int], cuts: set[tuple[int, int]]) -> Series:
    """The samples of an output that a piece ``(lo, hi)`` (ns) of the log reads.

    Those inside it, and the one on either side of it unless a cut (``cuts``, ``(start,
    end)`` of two samples, ns) lies between: the piece's grid takes the nearest sample, or
    bridges a short gap, as the log read whole would.  Cut to the piece alone, a point at
    its start took another output's sample a step away where one lay 2 ms before the
    start, and the grid started a whole step late (the piece said ``t = 22.41 …``, the grid
    23.17 s), and an output with no sample inside a short piece had "no samples".  A
    longer gap between such a sample and the piece is refused on the piece's grid, and cut
    (:func:`split_at_refused_gaps`).
    """
    time_ns = series.time_ns
    lo, hi = piece
    first = int(np.searchsorted(time_ns, lo, side="left"))
    stop = int(np.searchsorted(time_ns, hi, side="right"))
    if first > 0 and (int(time_ns[first - 1]), int(time_ns[first])) not in cuts:
        first -= 1
    if stop < time_ns.size and (int(time_ns[stop - 1]), int(time_ns[stop])) not in cuts:
        stop += 1
    return Series(series.name, time_ns[first:stop], series.values[first:stop])


def _no_piece(
    source: str,
    field_word: str,
    outputs: Mapping[str, Series],
    overlap: tuple[int, int],
    gaps: Sequence[tuple[int, int]],
) -> LogError:
    """The error of ``--split-gaps`` when the signals overlap only inside output gaps.

    ``overlap``: the latest first sample and the earliest last one (ns); ``gaps``: the cuts,
    ``(start, end)`` in time order.  Names the first gap over the overlap and its output:
    "no stretch of the outputs is free of gaps" named neither, nor when.
    """
    start, end = overlap
    first = next(g for g in gaps if g[1] > start)
    owner = next(
        (
            f"output {symbol!r} ({field_word} {series.name!r})"
            for symbol, series in outputs.items()
            if bool(np.any((series.time_ns[:-1] == first[0]) & (series.time_ns[1:] == first[1])))
        ),
        "an output",
    )
    return LogError(
        f"{source}: --split-gaps: no piece: the signals overlap from t={format_ns(start)} s to "
        f"t={format_ns(end)} s, where {owner} has no sample from t={format_ns(first[0])} s "
        f"to t={format_ns(first[1])} s, a gap longer than max_gap"
    )
