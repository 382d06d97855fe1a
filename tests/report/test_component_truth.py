"""A ``[components]`` model scored against the log's true mode of each component.

The log names each component's true mode in a ``mode.<component>`` column (what ``simulate``
writes).  Before, such a log's report said "the log has no ground-truth mode".  The report's
numbers are checked against the tables it wrote (the estimated ``mode.<component>`` columns
and the log's own truth), counted here without the report's code.
"""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import numpy as np
import polars as pl
import pytest

from hybridlog.errors import LogError, OptionError, ReportError
from hybridlog.io import ReadOptions
from hybridlog.jobs.analysis import analyze
from hybridlog.report import read_report
from tests.support.cpha import TRUTH_STEPS, cpha_truth_log
from tests.support.paths import SAMPLE_LOGS

N = TRUTH_STEPS
COMPONENTS = ("A1", "A2", "A3")


@pytest.fixture(scope="module")
def cpha(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The model file and a log of it with every component's true mode."""
    return cpha_truth_log(tmp_path_factory.mktemp("cpha"))


def _scored_by_hand(out: Path, log: Path, components: tuple[str, ...]) -> dict[str, float]:
    """Per-component accuracy from the written timeline and the log's own columns."""
    timeline = pl.read_csv(out / "timeline.csv", infer_schema=False)
    truth = pl.read_csv(log, infer_schema=False)
    right = {
        c: timeline[f"mode.{c}"].to_numpy() == truth[f"mode.{c}"].to_numpy() for c in components
    }
    scores = {c: float(r.mean()) for c, r in right.items()}
    scores["joint"] = float(np.logical_and.reduce(list(right.values())).mean())
    # the written truth is the log's
    for c in components:
        assert timeline[f"truth_mode.{c}"].to_list() == truth[f"mode.{c}"].to_list()
    return scores


def test_joint_modes_are_scored_per_component(cpha: tuple[Path, Path], tmp_path: Path) -> None:
    model_file, log = cpha
    out = tmp_path / "imm"
    analyze(log, model_file, out_dir=out, estimator="imm")
    report = json.loads((out / "report.json").read_text())
    modes = report["modes"]
    timeline = pl.read_csv(out / "timeline.csv", infer_schema=False)
    # each component's column is its part of the joint label (component_mode_columns' order)
    parts = [label.split("|") for label in timeline["mode"].to_list()]
    for j, c in enumerate(COMPONENTS):
        assert timeline[f"mode.{c}"].to_list() == [p[j] for p in parts]
    by_hand = _scored_by_hand(out, log, COMPONENTS)
    assert set(modes["components"]) == set(COMPONENTS)
    for c in COMPONENTS:
        component = modes["components"][c]
        assert component["accuracy"] == pytest.approx(by_hand[c], abs=1e-12)
        assert sum(sum(row.values()) for row in component["confusion"].values()) == N
    assert modes["accuracy"] == pytest.approx(by_hand["joint"], abs=1e-12)
    assert by_hand["A2"] > 0.8  # the estimator does find A2's switches
    a2 = modes["components"]["A2"]["detection"]
    assert a2["detected"] + a2["missed"] == 2
    assert "mode_accuracy" not in report["null_reasons"]
    assert report["null_reasons"]["missed_switches"].startswith("a [components] model")
    # report.json reads back (batch summaries and gates read it), and report.md shows it
    assert read_report(out / "report.json").modes.components["A2"].accuracy == pytest.approx(
        by_hand["A2"]
    )
    text = (out / "report.md").read_text()
    assert "### Component A2" in text and "every component right" in text
    # each component's estimated switches are said, as counted in its timeline column
    for c in COMPONENTS:
        column = timeline[f"mode.{c}"].to_list()
        changes = sum(a != b for a, b in itertools.pairwise(column))
        section = text.split(f"### Component {c}\n\n", 1)[1]
        noun = "switch" if changes == 1 else "switches"
        assert section.startswith(f"- {changes} estimated mode {noun}\n")


def test_a_log_with_only_some_components_truth(cpha: tuple[Path, Path], tmp_path: Path) -> None:
    model_file, log = cpha
    partial = tmp_path / "partial.csv"
    pl.read_csv(log).drop("mode.A3").rename({"mode.A2": "a2_truth"}).write_csv(partial)
    out = tmp_path / "partial"
    read = ReadOptions(maps=("truth.mode.A2=a2_truth",))
    analyze(partial, model_file, out_dir=out, estimator="imm", read=read)
    report = json.loads((out / "report.json").read_text())
    assert set(report["modes"]["components"]) == {"A1", "A2"}
    assert report["modes"]["accuracy"] is None
    assert "only some components" in report["null_reasons"]["mode_accuracy"]
    # the component without truth is named, not silently left out of report.md and .json
    assert report["modes"]["components_without_truth"] == ["A3"]
    assert "(not of A3)" in report["null_reasons"]["mode_accuracy"]
    assert read_report(out / "report.json").modes.components_without_truth == ("A3",)
    text = (out / "report.md").read_text()
    assert "only some components (not of A3): no joint accuracy" in text
    a3 = text.split("### Component A3\n\n", 1)[1].splitlines()[0]
    assert a3 == "- the log has no true mode of this component: it is not scored"
    # a report.json that says A2 has no truth while scoring it is refused on reading
    report["modes"]["components_without_truth"] = ["A2"]
    tampered = tmp_path / "tampered.json"
    tampered.write_text(json.dumps(report))
    with pytest.raises(ReportError, match=r"components_without_truth.*A2"):
        read_report(tampered)


def test_unknown_mode_on_the_sample_log_matches_its_own_tables(tmp_path: Path) -> None:
    log = SAMPLE_LOGS / "bioplex_pgc.csv"
    components = ("fr1", "fr2", "piv1", "piv2", "ls", "pgc")
    out = tmp_path / "bioplex"
    outcome = analyze(
        log,
        "bioplex_pgc",
        out_dir=out,
        fail_under=["mode_accuracy.fr2=0.99", "mode_accuracy.pgc=0.99"],
    )
    modes = outcome.report.modes
    by_hand = _scored_by_hand(out, log, components)
    for c in components:
        assert modes.components[c].accuracy == pytest.approx(by_hand[c], abs=1e-12)
    assert modes.accuracy == pytest.approx(by_hand["joint"], abs=1e-12)
    # the estimator's "unknown" is scored as a mode: the log's truth says unknown there too
    assert "unknown" in modes.components["fr2"].labels
    assert [g for g in outcome.gate_failures if "fr2" in g] and not [
        g for g in outcome.gate_failures if "pgc" in g
    ]


def test_bad_component_truth_is_refused_in_one_line(
    cpha: tuple[Path, Path], tmp_path: Path
) -> None:
    model_file, log = cpha
    wrong = tmp_path / "wrong.csv"
    frame = pl.read_csv(log)
    labels = frame["mode.A2"].to_list()
    labels[7] = "m99"
    frame.with_columns(pl.Series("mode.A2", labels)).write_csv(wrong)
    with pytest.raises(LogError) as info:
        analyze(wrong, model_file, out_dir=tmp_path / "r", estimator="imm")
    message = str(info.value)
    assert "\n" not in message and "column 'mode.A2'" in message
    assert "truth.mode.A2 'm99'" in message and "component 'A2'" in message
    with pytest.raises(OptionError, match=r"truth\.mode\.A9"):
        analyze(
            log,
            model_file,
            out_dir=tmp_path / "r",
            estimator="imm",
            read=ReadOptions(maps=("truth.mode.A9=x",)),
        )
    with pytest.raises(OptionError, match="'A9' is not a component; components: A1, A2, A3"):
        analyze(
            log,
            model_file,
            out_dir=tmp_path / "r",
            estimator="imm",
            fail_under=["mode_accuracy.A9=1"],
        )
    assert not (tmp_path / "r").exists()
