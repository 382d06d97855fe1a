"""Mode metrics over a true mode with samples without one in the middle (a sampled true
mode's gap, ``reading.truth_gaps``).

The metrics scored from the true mode's first sample on and refused any sample without one
after it ('a true mode without truth after its first sample'); the readers held the gap's
label, so the estimate was scored against a guess, and a switch inside the gap was given a
delay from the time the guess ended.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from hybridlog.report import mode_metrics
from hybridlog.report.coverage import samples_coverage
from hybridlog.signals import NO_TRUE_MODE, ComponentTruth
from tests.report.test_plot_data import TRUE_LABELS, _run

X = NO_TRUE_MODE
IDS = ("a", "b")


def test_a_switch_across_a_gap_has_no_event_and_a_window_stops_at_a_gap() -> None:
    time = np.arange(12.0)
    truth = np.array([0, 0, 1, 1, X, X, X, 0, 0, 1, 1, 1])
    estimated = np.array([0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 1])
    det = mode_metrics.detection_delays(time, estimated, truth, IDS, 1.0, known=truth != X)
    switch_2, switch_9 = det.events  # 1 -> 0 across 4..6 happened at an unknown time: none
    assert (switch_2.t, switch_2.detected_t) == (2.0, None)  # no change into b before 4
    assert switch_2.miss_reason is None  # undetermined, not missed (test_undetermined_switches)
    assert switch_2.undetermined_reason == (
        "the estimate had not changed into mode b when the true mode's record stops at t=4 s, "
        "and the log cannot say whether it did before the truth left the mode"
    )  # its change into b at 5 s is in the gap, where the truth may have left b: not a hit
    assert (switch_9.t, switch_9.delay_s) == (9.0, 1.0)  # after the gap: measured


def test_a_switch_right_after_a_gap_is_measured_from_two_samples_with_truth() -> None:
    time = np.arange(8.0)
    truth = np.array([0, 0, X, X, 0, 1, 1, 1])
    estimated = np.array([0, 0, 0, 0, 0, 0, 1, 1])
    det = mode_metrics.detection_delays(time, estimated, truth, IDS, 1.0, known=truth != X)
    (event,) = det.events
    assert (event.t, event.delay_s) == (5.0, 1.0)
    # the same labels without the mask: the gap's -1 is no mode
    plain = mode_metrics.detection_delays(time, estimated, np.where(truth == X, 0, truth), IDS, 1.0)
    assert [e.t for e in plain.events] == [5.0]


def test_a_component_with_a_gap_is_scored_outside_it() -> None:
    from hybridlog.report.build import build_report

    result, signals = _run(600, seed=5, components=True)
    codes = signals.truth_components["A"].codes.copy()
    codes[200:300] = NO_TRUE_MODE
    gap = dataclasses.replace(signals, truth_components={"A": ComponentTruth(TRUE_LABELS, codes)})
    report = build_report(result, gap, log="l", model_name="m", dt=1.0)
    component = report.modes.components["A"]
    assert component.samples == 500
    confusion = component.confusion
    assert confusion is not None and sum(sum(r.values()) for r in confusion.values()) == 500
    assert component.detection is not None and component.detection.events
    times = signals.time
    assert not [
        e for e in component.detection.events if times[200] <= e.t <= times[300]
    ]  # no switch in the gap or at its end is measured


def test_coverage_says_where_the_true_mode_has_no_sample() -> None:
    one = {"start": 99.0, "end": 181.0, "seconds": 82.0, "gaps": 1, "points": 81, "of": 301}
    reading = {"truth_gaps": {"mode": one}}
    assert samples_coverage(220, 301, reading) == (
        "220 of 301 samples (the true mode has no sample from t = 99 to 181 s)"
    )
    several = {**one, "gaps": 3, "points": 120}
    late = {"at": 5.0, "samples": 296, "of": 301}
    reading = {"truth_starts": {"mode.fr2": late}, "truth_gaps": {"mode.fr2": several}}
    assert samples_coverage(176, 301, reading, only="mode.fr2") == (
        "176 of 301 samples (the true mode.fr2 starts at t = 5 s; the true mode.fr2 has no "
        "sample in 3 stretches (120 samples), the longest from t = 99 to 181 s (82 s))"
    )
    assert samples_coverage(176, 301, reading, only="mode.other") == "176 of 301 samples"
