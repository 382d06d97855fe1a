"""A true mode's silence: a gap when it is sampled, a hold when it is recorded only at its
switches.

It was held at its last value either way (``truth_held``, a NOTE), and the mode metrics
scored the estimate against the held label: a log with 80 s of its sampled true mode blanked
read a mode accuracy of 0.72 against 0.99 for the same log whole, the true switch inside the
blank counted as detected or missed at a guessed time.  Then a sampled true mode was still
held across a gap up to max_gap, without a word, where its true states were left out of
their RMSE: three rows missing around a switch scored three mode errors and placed the
switch at the gap's end, missed.  Now any grid point more than dt/2 from every sample of a
sampled true mode has none, whatever the gap's length.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from hybridlog.io.align import align_signals
from hybridlog.io.source import LabelSeries, Series, seconds_to_ns
from hybridlog.io.true_modes import records_switches
from hybridlog.report.reading_notes import report_reading_notes
from hybridlog.signals import NO_TRUE_MODE, first_uncovered

GRID = np.arange(0.0, 41.0)  # dt = 1 s, max_gap 5 s by default


def _series(name: str, seconds: np.ndarray) -> Series:
    return Series(name, seconds_to_ns(seconds), np.cos(seconds))


def _labels(seconds: list[float], codes: list[int]) -> LabelSeries:
    return LabelSeries("mode", seconds_to_ns(np.array(seconds)), np.array(codes), ("a", "b"))


def _align(mode: LabelSeries, notes: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    aligned = align_signals(
        source="log", dt=1.0, inputs={"u": _series("u", GRID)}, outputs={"y": _series("y", GRID)},
        truth_mode=mode, truth_components={"valve": mode}, notes=notes,
    )  # fmt: skip
    assert aligned.truth_modes is not None
    return aligned.truth_modes, aligned.truth_components["valve"].codes


def test_a_sampled_true_mode_has_no_true_mode_over_a_gap_longer_than_max_gap() -> None:
    # sampled every second but from 10.2 to 19.6 s (9.4 s > 5 s), where it switched unseen
    seconds = [s + 0.2 for s in range(11)] + [19.6, *np.arange(20.0, 41.0).tolist()]
    codes = [0] * 11 + [1] * 22
    notes: dict[str, Any] = {}
    modes, valve = _align(_labels(seconds, codes), notes)
    # 10 s holds 9.2 s; 11 s is 0.8 s after 10.2 s, 19 s 0.6 s before 19.6 s: over half a step
    want = np.array([0] * 11 + [NO_TRUE_MODE] * 9 + [1] * 21)
    np.testing.assert_array_equal(modes, want)
    np.testing.assert_array_equal(valve, want)
    gap = {"start": 10.2, "end": 19.6, "seconds": 9.4, "gaps": 1, "points": 9, "of": 41}
    gap |= {"every": 1.0, "steps": 1.0}  # how often it is sampled: the gap's cause
    assert notes["truth_gaps"] == {"mode": gap, "mode.valve": gap}
    assert "truth_held" not in notes
    assert first_uncovered(modes) == 11
    # a point within half a step of the sample after the gap takes it, as the nearest sample
    near = _labels([s - 0.2 if s == 19.6 else s for s in seconds], codes)
    modes, _ = _align(near, {})
    assert modes[19] == 1 and (modes[11:19] == NO_TRUE_MODE).all()
    said = [n for n in report_reading_notes(notes) if "the true mode " in n]
    assert said == [
        "WARNING: the true mode has no sample within dt/2 of 9 of 41 sample times, from "
        "t = 10.2 to 19.6 s (9.4 s): it may have switched there unseen, so those samples "
        "have no true mode and are not scored, and no switch is measured across them (it "
        "repeats its label, so it is sampled, not recorded only at its switches; it is "
        "sampled every dt, with samples missing there)"  # was "is the model's dt the log's?"
    ]


def test_the_same_label_on_both_sides_of_a_gap_is_no_proof_that_it_did_not_switch() -> None:
    seconds = [*range(0, 11), *range(30, 41)]
    notes: dict[str, Any] = {}
    modes, _ = _align(_labels([float(s) for s in seconds], [0] * len(seconds)), notes)
    assert (modes[11:30] == NO_TRUE_MODE).all() and (modes[:11] == 0).all()
    assert (modes[30:] == 0).all()
    assert notes["truth_gaps"]["mode"]["points"] == 19


def test_a_sampled_true_mode_that_ends_early_has_none_after_its_last_sample() -> None:
    seconds = np.arange(0.0, 21.0)
    notes: dict[str, Any] = {}
    modes, _ = _align(_labels(seconds.tolist(), [0] * 10 + [1] * 11), notes)
    assert (modes[:21] != NO_TRUE_MODE).all() and (modes[21:] == NO_TRUE_MODE).all()
    assert notes["truth_gaps"]["mode"] == {
        "start": 20.0, "end": 40.0, "seconds": 20.0, "gaps": 1, "points": 20, "of": 41,
        "every": 1.0, "steps": 1.0,
    }  # fmt: skip
    # ending within max_gap of the log's end: none after its last sample either
    notes = {}
    modes, _ = _align(_labels(np.arange(0.0, 36.0).tolist(), [0] * 36), notes)
    assert (modes[:36] == 0).all() and (modes[36:] == NO_TRUE_MODE).all()
    assert notes["truth_gaps"]["mode"]["points"] == 5
    # half a step past its last sample: the last point takes it, as the nearest sample
    notes = {}
    modes, _ = _align(_labels([*np.arange(0.0, 40.0).tolist(), 39.5], [0] * 41), notes)
    assert (modes == 0).all() and "truth_gaps" not in notes


def test_several_gaps_are_counted() -> None:
    seconds = [0.0, 1.0, 10.0, 11.0, 20.0, 21.0, 30.0, 31.0, 40.0]
    notes: dict[str, Any] = {}
    modes, _ = _align(_labels(seconds, [0, 0, 1, 1, 0, 0, 1, 1, 0]), notes)
    assert int(np.count_nonzero(modes == NO_TRUE_MODE)) == 4 * 8
    assert notes["truth_gaps"]["mode"] == {
        "start": 1.0, "end": 10.0, "seconds": 9.0, "gaps": 4, "points": 32, "of": 41,
        "every": 5.0, "steps": 5.0,
    }  # fmt: skip


def test_a_true_mode_recorded_only_at_its_switches_is_held_however_long() -> None:
    """Its silence says the mode did not change: held, and scored, as before."""
    switches = _labels([0.0, 12.5, 30.0], [0, 1, 0])
    assert records_switches(switches.codes)
    notes: dict[str, Any] = {}
    modes, valve = _align(switches, notes)
    want = np.array([0] * 13 + [1] * 17 + [0] * 11)
    np.testing.assert_array_equal(modes, want)
    np.testing.assert_array_equal(valve, want)
    assert "truth_gaps" not in notes
    assert notes["truth_held"]["mode"]["holds"] == 3
    (said, *_) = (n for n in report_reading_notes(notes) if "the true mode " in n)
    assert said.startswith("NOTE: the true mode has no sample in 3 stretches longer than")
    assert said.endswith(
        "held at its last value, against which the mode metrics score those samples (it is "
        "recorded only at its switches: no sample repeats the label of the one before, so in "
        "between it did not change)"
    )


def test_a_gap_and_a_late_start_are_said_together() -> None:
    seconds = [float(s) for s in (*range(5, 11), *range(25, 41))]
    notes: dict[str, Any] = {}
    modes, _ = _align(_labels(seconds, [0] * len(seconds)), notes)
    assert int(np.count_nonzero(modes != NO_TRUE_MODE)) == 6 + 16
    said = [n for n in report_reading_notes(notes) if "the true mode starts" in n]
    assert said == [
        "NOTE: the true mode starts at t = 5 s, after the first sample time: the mode metrics "
        "score the 36 of 41 samples from it on, less the 14 without a sample above (the "
        "samples before have no true mode, as a true state that starts late has no true value)"
    ]


def test_a_short_gap_of_a_sampled_true_mode_is_not_held() -> None:
    """Rows 20..22 missing (3 s < max_gap); true mode a at 19 s, b from 21 s on."""
    seconds = [float(s) for s in (*range(0, 20), *range(23, 41))]
    codes = [0] * 20 + [1] * 18
    notes: dict[str, Any] = {}
    modes, valve = _align(_labels(seconds, codes), notes)
    want = np.array([0] * 20 + [NO_TRUE_MODE] * 3 + [1] * 18)
    np.testing.assert_array_equal(modes, want)  # was a at 20..22 s, the switch at 23 s
    np.testing.assert_array_equal(valve, want)  # a component's true mode by the same rule
    gap = {"start": 19.0, "end": 23.0, "seconds": 4.0, "gaps": 1, "points": 3, "of": 41}
    gap |= {"every": 1.0, "steps": 1.0}
    assert notes["truth_gaps"] == {"mode": gap, "mode.valve": gap}
    assert first_uncovered(modes) == 20
    said = [n for n in report_reading_notes(notes) if "the true mode " in n]
    assert said[0].startswith(
        "WARNING: the true mode has no sample within dt/2 of 3 of 41 sample times, from "
        "t = 19 to 23 s (4 s): it may have switched there unseen"
    )
    # one row missing: the point between its neighbours, a step from both, has none
    notes = {}
    modes, _ = _align(_labels([s for s in GRID.tolist() if s != 7.0], [0] * 40), notes)
    assert modes[7] == NO_TRUE_MODE and int(np.count_nonzero(modes == NO_TRUE_MODE)) == 1
    assert notes["truth_gaps"]["mode"]["points"] == 1


def test_a_true_mode_sampled_every_other_step_has_none_between_its_samples() -> None:
    """Sampled (it repeats its label) at 2 dt: the points between say nothing of it."""
    seconds = np.arange(0.0, 41.0, 2.0)
    codes = [0] * 10 + [1] * 11
    notes: dict[str, Any] = {}
    modes, _ = _align(_labels(seconds.tolist(), codes), notes)
    np.testing.assert_array_equal(modes[::2], codes)
    assert (modes[1::2] == NO_TRUE_MODE).all()
    assert notes["truth_gaps"]["mode"]["gaps"] == 20
    assert notes["truth_gaps"]["mode"]["points"] == 20
    (said,) = [n for n in report_reading_notes(notes) if "the true mode " in n]
    assert said.endswith("switches; it is sampled every 2 s (median), 2 steps of dt)")
    # every 1.5 dt: every point is within dt/2 of a sample, and takes the nearest
    notes = {}
    seconds = np.arange(0.0, 41.0, 1.5)  # to 40.5 s, half a step past the last point
    modes, _ = _align(_labels(seconds.tolist(), [0] * seconds.size), notes)
    assert (modes == 0).all() and "truth_gaps" not in notes
    # recorded only at its switches at 2 dt: held, its silence says it did not change
    notes = {}
    switches = _labels(np.arange(0.0, 41.0, 2.0).tolist(), [i % 2 for i in range(21)])
    modes, _ = _align(switches, notes)
    np.testing.assert_array_equal(modes, np.arange(41) // 2 % 2)
    assert "truth_gaps" not in notes


def test_a_true_mode_sampled_half_a_step_off_the_grid_is_held_as_before() -> None:
    """At k + 0.5 s every point is within dt/2 of a sample: no gap, the hold as it was."""
    seconds = (np.arange(0.0, 41.0) + 0.5).tolist()
    codes = [0] * 20 + [1] * 21
    notes: dict[str, Any] = {}
    modes, _ = _align(_labels([0.0, *seconds[:-1]], [0, *codes[:-1]]), notes)
    np.testing.assert_array_equal(modes, [0] * 21 + [1] * 20)
    assert "truth_gaps" not in notes
