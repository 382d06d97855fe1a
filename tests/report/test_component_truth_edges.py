"""Per-component ground truth at its edges: a ``mode`` field beside it, the offline passes.

A ``[components]`` model has no mode of the whole model; a log may still hold a ``mode``
column (a controller's mode, the joint label), which is no truth of the model.  With
``--smooth`` or another mode sequence the report compares the filter's estimates with the
offline ones, and with the components' truth that comparison has an accuracy too.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import polars as pl
import pytest

from hybridlog.errors import OptionError, ReportError
from hybridlog.io import ReadOptions
from hybridlog.jobs.analysis import analyze
from hybridlog.report import evaluate_gates, parse_gates, read_report
from tests.support.cpha import TRUTH_STEPS, cpha_truth_log

N = TRUTH_STEPS
COMPONENTS = ("A1", "A2", "A3")


@pytest.fixture(scope="module")
def cpha(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The model file and a log with every component's true mode and a joint ``mode``."""
    return cpha_truth_log(tmp_path_factory.mktemp("cpha_edges"), joint_mode=True)


def test_a_mode_column_is_no_truth_of_a_components_model(
    cpha: tuple[Path, Path], tmp_path: Path
) -> None:
    model_file, log = cpha
    outcome = analyze(log, model_file, out_dir=tmp_path / "imm", estimator="imm")
    assert set(outcome.report.modes.components) == set(COMPONENTS)
    assert outcome.report.modes.accuracy is not None
    with pytest.raises(OptionError, match=r"unknown symbol 'truth\.mode'.*truth\.mode\.A1"):
        analyze(
            log,
            model_file,
            out_dir=tmp_path / "r",
            estimator="imm",
            read=ReadOptions(maps=("truth.mode=mode",)),
        )


@pytest.mark.parametrize(
    ("estimator", "options"),
    [
        ("imm", {"smooth": True}),
        ("imm", {"smooth": True, "mode_sequence": "viterbi"}),
        ("unknown-mode", {"mode_sequence": "kbest"}),
    ],
)
def test_the_offline_pass_is_scored_against_the_components_truth(
    cpha: tuple[Path, Path], tmp_path: Path, estimator: str, options: dict[str, object]
) -> None:
    model_file, log = cpha
    out = tmp_path / "offline"
    outcome = analyze(log, model_file, out_dir=out, estimator=estimator, **options)  # type: ignore[arg-type]
    smoothing = outcome.report.smoothing
    assert smoothing is not None
    # the offline side is the report's own estimate; the filter's is scored from its columns
    assert smoothing.smoothed.mode_accuracy == pytest.approx(outcome.report.modes.accuracy)
    timeline = pl.read_csv(out / "timeline.csv", infer_schema=False)
    truth = pl.read_csv(log, infer_schema=False)
    filtered = [label.split("|") for label in timeline["mode_filtered"].to_list()]
    right = [
        all(parts[j] == truth[f"mode.{c}"][k] for j, c in enumerate(COMPONENTS))
        for k, parts in enumerate(filtered)
    ]
    assert smoothing.filtered.mode_accuracy == pytest.approx(sum(right) / N, abs=1e-12)
    data = json.loads((out / "report.json").read_text())
    assert data["smoothing"]["filtered"]["mode_accuracy"] == smoothing.filtered.mode_accuracy
    text = (out / "report.md").read_text()
    assert "No ground-truth mode in the log" not in text
    # Each component on each side: report.json carried the joint accuracy alone, so the
    # gain per component (what mode_accuracy.<c> gates) was not there to see.
    for j, c in enumerate(COMPONENTS):
        own = [parts[j] == truth[f"mode.{c}"][k] for k, parts in enumerate(filtered)]
        side = smoothing.filtered.components[c]
        assert side.mode_accuracy == pytest.approx(sum(own) / N, abs=1e-12)
        offline = smoothing.smoothed.components[c]
        report = outcome.report.modes.components[c]
        assert offline.mode_accuracy == report.accuracy
        assert offline.detection_delay_s == report.detection_delay_s
        assert report.detection is not None and offline.missed == report.detection.missed
        assert data["smoothing"]["filtered"]["components"][c]["mode_accuracy"] == (
            side.mode_accuracy
        )
        assert f"| component {c}: mode accuracy (%) | {100 * side.mode_accuracy:.4f} |" in text
        # the filter's own mode of each component beside the offline one (timeline.csv held
        # the joint mode_filtered alone)
        assert timeline[f"mode.{c}_filtered"].to_list() == [parts[j] for parts in filtered]
        columns = timeline.columns
        assert columns.index(f"mode.{c}_filtered") == columns.index(f"mode.{c}") + 1
    assert read_report(out / "report.json").smoothing == smoothing
    # a gate on a component names the side it read and the filter's own value
    (failure,) = evaluate_gates(outcome.report, parse_gates([], ["mode_accuracy.A2=0"]))
    label = ", ".join(n for n in (smoothing.method, smoothing.mode_sequence) if n)
    own = smoothing.filtered.components["A2"].mode_accuracy
    assert own is not None
    assert f"(of the offline estimates: {label}; the filter's own: {own:.6g})" in failure


def test_the_offline_pass_with_only_some_components_truth(
    cpha: tuple[Path, Path], tmp_path: Path
) -> None:
    """Its Smoothing section says the truth is partial, not that there is none."""
    model_file, log = cpha
    partial = tmp_path / "partial.csv"
    pl.read_csv(log).drop("mode.A3").write_csv(partial)
    out = tmp_path / "offline"
    outcome = analyze(partial, model_file, out_dir=out, estimator="imm", smooth=True)
    smoothing = outcome.report.smoothing
    assert smoothing is not None and smoothing.filtered.mode_accuracy is None
    assert set(smoothing.filtered.components) == {"A1", "A2"}
    smoothing_text = (out / "report.md").read_text().split("## Smoothing", 1)[1]
    assert "No ground-truth mode in the log" not in smoothing_text
    assert "The log has the true mode of only some components" in smoothing_text


@pytest.mark.parametrize(
    ("edit", "words"),
    [
        (lambda m: m["components"]["A2"].update(accuracy=7), "expected a fraction"),
        (lambda m: m.update(accuracy=-0.5), "expected a fraction"),
        (
            lambda m: m["components"]["A2"].update(components={"A1": m["components"]["A1"]}),
            "a component has no components",
        ),
        (lambda m: m.update(accuracy=1.0), "cannot be more frequent than one component right"),
    ],
)
def test_a_hand_edited_components_report_is_refused(
    cpha: tuple[Path, Path], tmp_path: Path, edit: Any, words: str
) -> None:
    model_file, log = cpha
    out = tmp_path / "imm"
    analyze(log, model_file, out_dir=out, estimator="imm")
    data = json.loads((out / "report.json").read_text())
    assert data["modes"]["components"]["A2"]["accuracy"] < 1.0  # so a joint 1.0 is a lie
    edit(data["modes"])
    edited = tmp_path / "edited.json"
    edited.write_text(json.dumps(data))
    with pytest.raises(ReportError, match=words):
        read_report(edited)


def test_a_gate_on_a_components_delay_says_why_it_has_none(
    cpha: tuple[Path, Path], tmp_path: Path
) -> None:
    model_file, log = cpha
    outcome = analyze(
        log,
        model_file,
        out_dir=tmp_path / "imm",
        estimator="imm",
        fail_over=["detection_delay_s.A1=5", "detection_delay_s.A2=1000"],
    )
    # A1's true mode never switches: said so, not "no true mode of this component"
    (failure,) = outcome.gate_failures
    assert "detection_delay_s.A1 is not available" in failure
    assert "the true mode of component A1 never switches" in failure
    assert "detection_delay_s.A2" not in outcome.report.null_reasons
