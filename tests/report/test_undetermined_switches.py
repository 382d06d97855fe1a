"""A true switch whose window the true mode's gaps cut short is undetermined, not missed.

A switch's detection window ends at the first sample without a true mode after it.  With
the true mode logged on two rows of three (a logger writing it at a lower rate), every window
was two samples long, and sliding-mode on three_tank_valves was scored "5 true switches, 0
detected, 5 missed" where the full truth gives 15 of 15 detected: the gaps cut the windows,
not anything the estimate did.  Such a switch is now neither detected nor missed: the log
cannot say whether the estimate changed into the new mode after the cut, before the truth
left it.  A detection inside the cut window still counts; an estimate already in the mode
before the switch still missed it.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from hybridlog.errors import ReportError
from hybridlog.report import mode_metrics
from hybridlog.report.document import read_report
from hybridlog.report.report_parts import ComponentSide, SmoothingMetrics
from hybridlog.signals import NO_TRUE_MODE
from tests.support.paths import SAMPLE_LOGS

X = NO_TRUE_MODE
IDS = ("a", "b")
VALVES_CSV = SAMPLE_LOGS / "three_tank_valves_test1.csv"


def _delays(truth: list[int], estimated: list[int]) -> mode_metrics.DetectionDelays:
    true = np.array(truth)
    return mode_metrics.detection_delays(
        np.arange(float(true.size)), np.array(estimated), true, IDS, 1.0, known=true != X
    )


def test_full_truth_has_no_undetermined_switch() -> None:
    truth = [0, 0, 1, 1, 1, 0, 0, 0, 1, 1]
    estimated = [0, 0, 0, 1, 1, 1, 0, 0, 0, 0]
    det = _delays(truth, estimated)
    plain = mode_metrics.detection_delays(
        np.arange(10.0), np.array(estimated), np.array(truth), IDS, 1.0
    )
    assert det == plain
    assert [(e.delay_s, e.missed, e.undetermined) for e in det.events] == [
        (1.0, False, False),
        (1.0, False, False),
        (None, True, False),  # the end of the log ends its window: a miss, as before
    ]
    assert (det.detected, det.missed, det.undetermined) == (2, 1, 0)
    assert det.events[2].miss_reason == (
        "the estimate never changed into mode b before the end of the log"
    )


def test_a_window_a_gap_cuts_short_without_a_detection_is_undetermined() -> None:
    # the switch into b at 2: the true mode's record stops at 3; the estimate changes into
    # b at 4, where the truth is b again, but the truth may have left b and come back in
    # the gap: the window is not extended across it
    det = _delays([0, 0, 1, X, 1, 1, 0, 0], [0, 0, 0, 0, 1, 1, 1, 0])
    switch, back = det.events
    assert (switch.t, switch.detected, switch.missed, switch.undetermined) == (
        2.0,
        False,
        False,
        True,
    )
    assert switch.miss_reason is None and switch.delay_s is None
    assert switch.undetermined_reason == (
        "the estimate had not changed into mode b when the true mode's record stops at t=3 s, "
        "and the log cannot say whether it did before the truth left the mode"
    )
    assert (back.t, back.delay_s) == (6.0, 1.0)
    assert (det.detected, det.missed, det.undetermined) == (1, 0, 1)


def test_a_detection_inside_a_cut_window_counts_with_its_delay() -> None:
    det = _delays([0, 0, 1, 1, X, 1], [0, 0, 0, 1, 1, 1])
    (switch,) = det.events
    assert (switch.detected_t, switch.delay_s, switch.undetermined) == (3.0, 1.0, False)
    assert (det.detected, det.missed, det.undetermined) == (1, 0, 0)


def test_an_estimate_already_in_the_mode_misses_the_switch_whatever_gaps_follow() -> None:
    det = _delays([0, 1, 1, X, X, 1], [1, 1, 1, 0, 1, 1])
    (switch,) = det.events
    assert (switch.missed, switch.undetermined) == (True, False)
    assert switch.miss_reason is not None and "already in mode b" in switch.miss_reason
    assert (det.detected, det.missed, det.undetermined) == (0, 1, 0)


def test_an_undetermined_switch_is_neither_detected_nor_missed() -> None:
    with pytest.raises(ValueError, match="neither detected nor missed"):
        mode_metrics.SwitchDetection(0.0, "a", "b", None, "missed", undetermined_reason="gap")
    with pytest.raises(ValueError, match="neither detected nor missed"):
        mode_metrics.SwitchDetection(0.0, "a", "b", 1.0, undetermined_reason="gap")


def test_smoothing_sides_write_undetermined_only_where_some_switch_is() -> None:
    side = SmoothingMetrics(
        mode_accuracy=1.0,
        confusion={"a": {"a": 1}},
        detection_delay_s=None,
        detection_max_s=None,
        detected=0,
        missed=1,
        estimated_switches=0,
        states={},
        outputs=None,
        fit=None,
    )
    assert "undetermined" not in side.to_dict()
    assert ComponentSide(1.0, None, None, 0, 1).to_dict().keys() == {
        "mode_accuracy",
        "detection_delay_s",
        "detection_max_s",
        "detected",
        "missed",
    }
    assert ComponentSide(1.0, None, None, 0, 1, undetermined=2).to_dict()["undetermined"] == 2


def _every_third_blank(tmp_path: Path) -> Path:
    with VALVES_CSV.open(newline="") as handle:
        header, *rows = list(csv.reader(handle))
    for k, row in enumerate(rows):
        if k % 3 == 2:
            row[header.index("mode")] = ""
    log = tmp_path / "valves_gappy_truth.csv"
    with log.open("w", newline="") as handle:
        csv.writer(handle).writerows([header, *rows])
    return log


@pytest.mark.filterwarnings("ignore")
def test_a_true_mode_on_two_rows_of_three_leaves_switches_undetermined_not_missed(
    tmp_path: Path,
) -> None:
    from hybridlog.cli_lines import summary_line
    from hybridlog.jobs.analysis import analyze

    full = analyze(
        VALVES_CSV, "three_tank_valves", estimator="sliding-mode", out_dir=tmp_path / "full"
    ).report
    assert full.modes.detection is not None
    assert (full.modes.detection.detected, full.modes.detection.missed) == (15, 0)
    assert full.modes.detection.undetermined == 0
    for name in ("report.json", "report.md"):  # a log with its whole truth: as before
        assert "undetermined" not in (tmp_path / "full" / name).read_text(encoding="utf-8")

    out = tmp_path / "gap"
    outcome = analyze(
        _every_third_blank(tmp_path),
        "three_tank_valves",
        estimator="sliding-mode",
        out_dir=out,
        fail_over=["missed_switches=0"],
    )
    report = outcome.report
    det = report.modes.detection
    assert det is not None and det.events
    n = len(det.events)
    assert (det.detected, det.missed, det.undetermined) == (0, 0, n)  # was 0, n, -
    assert not outcome.gate_failures  # missed_switches counts the definite misses
    data = json.loads((out / "report.json").read_text(encoding="utf-8"))
    detection = data["modes"]["detection"]
    assert (detection["missed"], detection["undetermined"]) == (0, n)
    assert all(e["miss_reason"] is None and e["undetermined_reason"] for e in detection["events"])
    assert data["gates"][0]["value"] == 0 and data["gates"][0]["passed"]
    assert "undetermined" in data["null_reasons"]["detection_delay_s"]
    markdown = (out / "report.md").read_text(encoding="utf-8")
    assert f"{n} true mode switches: 0 detected, 0 missed, {n} undetermined" in markdown
    assert "| undetermined: the estimate had not changed into mode" in markdown
    assert f"(not counting {n} undetermined true switches" in markdown  # the met gate
    assert "- Undetermined: a true switch not detected" in markdown
    assert summary_line(report).endswith(f"0 detected, 0 missed, {n} undetermined")
    assert read_report(out / "report.json").modes == report.modes  # read back as written


@pytest.mark.parametrize(
    ("edit", "key"),
    [
        (lambda d: d.update(undetermined=0), "undetermined"),
        (lambda d: d["events"][0].update(miss_reason="x"), "undetermined_reason"),
    ],
)
def test_a_report_whose_undetermined_switches_disagree_is_refused(
    tmp_path: Path, edit: object, key: str
) -> None:
    det = _delays([0, 0, 1, X, 1, 1, 0, 0], [0, 0, 0, 0, 1, 1, 1, 0])
    from hybridlog.report.report_parts import Detection

    data = Detection(mean_s=1.0, max_s=1.0, events=det.events).to_dict()
    assert callable(edit)
    edit(data)
    from hybridlog.report.report_reader import ReportReader

    with pytest.raises(ReportError, match=key):
        ReportReader("r.json").detection(data, "modes.detection")


def test_a_smoothed_run_says_its_undetermined_switches_on_both_sides() -> None:
    import dataclasses

    from hybridlog.report.build import build_report
    from hybridlog.report.document import Report
    from hybridlog.report.markdown import render_markdown
    from tests.report.test_plot_data import _run

    result, signals = _run(600, seed=3, smoothed=True)
    # a switch every 3 samples, and the sample after each without a true mode: each window
    # is the switch's own sample
    truth = np.repeat(np.arange(200) % 2, 3)
    truth[1::3] = NO_TRUE_MODE
    gappy = dataclasses.replace(signals, truth_modes=truth)
    report = build_report(result, gappy, log="l", model_name="m", dt=1.0)
    assert report.smoothing is not None and report.modes.detection is not None
    filtered, smoothed = report.smoothing.filtered, report.smoothing.smoothed
    assert smoothed.undetermined == report.modes.detection.undetermined > 0
    assert filtered.undetermined > 0
    assert smoothed.missed == report.modes.detection.missed
    data = json.loads(report.to_json())["smoothing"]
    assert [data[side]["undetermined"] for side in ("filtered", "smoothed")] == [
        filtered.undetermined,
        smoothed.undetermined,
    ]
    row = f"| true switches undetermined | {filtered.undetermined} | {smoothed.undetermined} |"
    assert row in render_markdown(report)
    assert Report.from_json(report.to_json()).smoothing == report.smoothing


def test_a_components_switch_rows_are_shown_where_either_side_has_some() -> None:
    import dataclasses

    from hybridlog.report.build import build_report
    from hybridlog.report.markdown import render_markdown
    from tests.report.test_plot_data import _run

    result, signals = _run(600, seed=3, smoothed=True)
    report = build_report(result, signals, log="l", model_name="m", dt=1.0)
    assert report.smoothing is not None

    def side(missed: int, undetermined: int) -> ComponentSide:
        return ComponentSide(0.5, None, None, 0, missed, undetermined)

    smoothing = dataclasses.replace(
        report.smoothing,
        filtered=dataclasses.replace(
            report.smoothing.filtered, components={"a": side(2, 0), "b": side(0, 0)}
        ),
        smoothed=dataclasses.replace(
            report.smoothing.smoothed, components={"a": side(1, 3), "b": side(0, 0)}
        ),
    )
    text = render_markdown(dataclasses.replace(report, smoothing=smoothing))
    assert "| component a: true switches missed | 2 | 1 |" in text
    assert "| component a: true switches undetermined | 0 | 3 |" in text
    assert "component b: true switches" not in text  # none on either side
