"""``compare``'s numbers are each estimator's own: over which samples, and why one is n/a.

On a ``[components]`` model ``unknown-mode`` makes no one-step-ahead prediction of an
output no filter cluster determines, so its VAF, fit and MSE leave those rows out: on the
log below its VAF of yc1 is over 170 samples, imm's over 179, and the table showed
``unknown-mode`` 92.14 beside ``imm`` 90.95 with nothing to say the two were not over the
same samples.  An ``n/a`` cell (hstf's detection delay when it missed every switch) said
nothing of why; report.md did.  Now the table gets a column per count that differs,
comparison.md a "What the numbers are over" section (always: over how many samples each kind of
number is) and a "Not available" one, and the terminal a line.
"""

from __future__ import annotations

import csv
import dataclasses
import json
from pathlib import Path

import pytest

from hybridlog.jobs.compare import compare
from hybridlog.report import read_report
from hybridlog.report.comparison import samples_section, unequal_columns
from hybridlog.report.gates import null_reason
from tests.cli.test_cli import run
from tests.support.cpha import cpha_truth_log
from tests.support.paths import SAMPLE_LOGS

CART = SAMPLE_LOGS / "double_cart_case1.csv"


@pytest.fixture(scope="module")
def cpha(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A ``[components]`` model file and a 180-sample log of it."""
    return cpha_truth_log(tmp_path_factory.mktemp("cpha"))


def _rows(path: Path) -> dict[str, dict[str, str]]:
    with path.open(newline="") as file:
        return {row["estimator"]: row for row in csv.DictReader(file)}


def test_numbers_over_different_samples_say_so(cpha: tuple[Path, Path], tmp_path: Path) -> None:
    model, log = cpha
    out = tmp_path / "cmp"
    outcome = compare(log, model, ["imm", "unknown-mode"], out_dir=out)
    stored = {
        name: json.loads((out / name / "report.json").read_text()) for name in outcome.reports
    }
    counts = {name: report["outputs"]["yc1"]["samples"] for name, report in stored.items()}
    assert counts["imm"] > counts["unknown-mode"]  # the case this test is about
    rows = _rows(out / "comparison.csv")
    assert {name: int(row["output_samples.yc1"]) for name, row in rows.items()} == counts
    assert "output_samples.yc2" not in rows["imm"]  # the same for both: no column
    assert outcome.unlike == ["vaf, fit and mse are not over the same samples for every estimator"]
    header = outcome.table.splitlines()[0]
    assert "| samples_per_s | output_samples.yc1 | warnings |" in header
    text = (out / "comparison.md").read_text()
    assert (
        "- vaf, fit and mse: **not over the same samples**, so not like for like "
        "(`output_samples.yc1` in the table): `imm` over 179 samples of each output (yc1, "
        "yc2); `unknown-mode` over 170 samples of yc1 and 179 of yc2"
    ) in text
    assert "- the mode metrics: every estimator over 180 samples" in text


def test_the_same_samples_are_said_and_each_na_cell_gives_its_reason(tmp_path: Path) -> None:
    out = tmp_path / "cmp"
    outcome = compare(
        CART, "double_cart_case1", ["hstf", "imm"], out_dir=out, fail_over=["state_rmse.x1=1"]
    )
    assert outcome.unlike == []
    assert "_samples" not in outcome.table  # every count alike: no column
    text = (out / "comparison.md").read_text()
    section = text.split("## What the numbers are over\n\n", 1)[1].split("\n\n", 1)[0].splitlines()
    assert section == [
        "- vaf, fit and mse: every estimator over 1,000 samples of y",
        "- the mode metrics: every estimator over 1,001 samples",
        "- the states' RMSEs: every estimator over 1,001 samples of each state (x1, x2, x3, x4)",
    ]
    hstf = json.loads((out / "hstf" / "report.json").read_text())
    assert hstf["modes"]["detection_delay_s"] is None
    why = hstf["null_reasons"]["detection_delay_s"]
    unavailable = text.split("## Not available\n\n", 1)[1].split("\n\n", 1)[0].splitlines()
    assert unavailable == [f"- `hstf` detection_delay_s: {why}"]


def test_a_mean_that_leaves_out_an_output_is_named(tmp_path: Path) -> None:
    """A VAF that is the mean of 2 of 3 outputs beside one of all 3 is not like for like."""
    out = tmp_path / "cmp"
    compare(SAMPLE_LOGS / "three_tank_hstf.csv", "three_tank_hstf", ["imm"], out_dir=out)
    imm = read_report(out / "imm" / "report.json")
    y2 = dataclasses.replace(imm.outputs["y2"], vaf=None)
    partial = dataclasses.replace(
        imm,
        outputs={**imm.outputs, "y2": y2},
        null_reasons={**imm.null_reasons, "vaf.y2": "var(ŷ) = 0"},
    )
    fewer = dataclasses.replace(
        imm, outputs={**imm.outputs, "y2": dataclasses.replace(imm.outputs["y2"], samples=299)}
    )
    lines, unlike = samples_section({"imm": imm, "other": partial})
    assert unlike == ["vaf is a mean over other outputs for some estimators"]
    assert "- vaf of `other` is a mean that leaves out 1 of 3 outputs: vaf.y2 (var(ŷ) = 0)" in lines
    assert unequal_columns({"imm": imm, "other": fewer}) == ("output_samples.y2",)
    assert unequal_columns({"imm": imm}) == ()
    # one report (the others failed, or one estimator named): named, not "every estimator"
    alone, _ = samples_section({"imm": imm})
    assert "- vaf, fit and mse: `imm` over 300 samples of each output (y1, y2, y3)" in alone
    lines, unlike = samples_section({"other": partial})  # alone: said, but like for like
    assert unlike == [] and any("vaf of `other` is a mean that leaves out" in x for x in lines)
    # no output has a VAF: no mean at all, not "a mean that leaves out 3 of 3 outputs"
    none = dataclasses.replace(
        imm,
        outputs={y: dataclasses.replace(o, vaf=None) for y, o in imm.outputs.items()},
        null_reasons={**imm.null_reasons, **{f"vaf.{y}": "var(ŷ) = 0" for y in imm.outputs}},
    )
    lines, _ = samples_section({"imm": imm, "none": none})
    (said,) = [x for x in lines if x.startswith("- vaf of `none`")]
    assert said.startswith("- vaf of `none` has no value, as no output has one: 3 of 3 outputs")
    # no true mode: nothing scored, not "over 0 samples" (nor over an unknown number)
    blind = dataclasses.replace(imm, modes=dataclasses.replace(imm.modes, samples=None))
    lines, _ = samples_section({"imm": blind})
    assert "- the mode metrics: not scored, no sample to score" in lines


def test_the_terminal_says_when_numbers_are_not_over_the_same_samples(
    cpha: tuple[Path, Path], tmp_path: Path
) -> None:
    model, log = cpha
    out = tmp_path / "cmp"
    args = ["compare", str(log), "--model", str(model), "--estimators", "imm,unknown-mode"]
    result = run([*args, "--out", str(out)])
    assert (
        "hybridlog: not like for like: vaf, fit and mse are not over the same samples for "
        f"every estimator; see {out / 'comparison.md'}\n"
    ) in result.stderr
    assert "output_samples.yc1" in result.stdout


def test_a_state_without_samples_is_said_in_words(tmp_path: Path) -> None:
    """The states' line of a gated state the log has no truth of read "301 samples of x1 and
    no of x2"; it is "none of x2" (and "no samples of x2" first)."""
    out = tmp_path / "cmp"
    compare(SAMPLE_LOGS / "three_tank_hstf.csv", "three_tank_hstf", ["imm"], out_dir=out)
    imm = read_report(out / "imm" / "report.json")
    blind = dataclasses.replace(
        imm, states={**imm.states, "x2": dataclasses.replace(imm.states["x2"], samples=None)}
    )
    lines, _ = samples_section({"imm": blind}, ["x1", "x2"])
    assert "- the states' RMSEs: `imm` over 301 samples of x1 and none of x2" in lines
    lines, _ = samples_section({"imm": blind}, ["x2", "x1", "x3"])
    assert "- the states' RMSEs: `imm` over no samples of x2, 301 of x1 and 301 of x3" in lines


def test_offline_states_are_said_as_the_offline_modes_are() -> None:
    """A smoothed estimator's states' RMSEs beside a filter's were not said to be offline;
    a Viterbi path alone keeps the filter's states, and says so by saying nothing of them."""
    from hybridlog.report.report_parts import Smoothing
    from tests.report.test_report_gates import _side

    imm = read_report(
        Path(__file__).parents[1] / "data" / "reports" / "three_tank_hstf_imm.report.json"
    )

    def offline(method: str | None, sequence: str) -> Smoothing:
        return Smoothing(method, sequence, "d", _side(0.8, 0, 0.3), _side(0.9, 0, 0.2))

    for method, sequence, said in [
        ("kim-rts", "argmax", "the mode metrics and the states' RMSEs of smoothed"),
        (None, "viterbi", "the mode metrics of smoothed"),
    ]:
        reports = {
            "smoothed": dataclasses.replace(imm, smoothing=offline(method, sequence)),
            "filter": imm,
        }
        _, unlike = samples_section(reports, ["x1"])
        assert unlike == [f"{said} are of offline estimates"]


def test_a_smoothed_estimators_na_filtered_state_gives_its_reason() -> None:
    """comparison.md's "Not available" named the reason of an n/a ``filtered_mode_accuracy``
    cell of a smoothed estimator but not of an n/a ``filtered_state_rmse.<x>`` beside it."""
    from hybridlog.report.comparison import unavailable_section
    from hybridlog.report.report_parts import Smoothing, StateReport
    from tests.report.test_report_gates import _side

    imm = read_report(
        Path(__file__).parents[1] / "data" / "reports" / "three_tank_hstf_imm.report.json"
    )
    blind = dataclasses.replace(_side(None, 0, 0.3), states={"x1": StateReport(rmse=None)})
    smoothed = dataclasses.replace(
        imm,
        smoothing=Smoothing("kim-rts", "argmax", "d", blind, _side(0.9, 0, 0.2)),
        null_reasons={**imm.null_reasons, "state_rmse.x1": "no true x1 in the log"},
    )
    columns = ["estimator", "filtered_mode_accuracy", "filtered_state_rmse.x1"]
    lines = unavailable_section(
        columns,
        [["smoothed", None, None], ["filter", None, None]],
        {"smoothed": smoothed, "filter": imm},
        [],
    )
    assert lines[3:] == [
        f"- `smoothed` filtered_mode_accuracy: the filter's own: "
        f"{null_reason(smoothed, 'mode_accuracy')}",
        "- `smoothed` filtered_state_rmse.x1: the filter's own: no true x1 in the log",
    ]  # the filter's cells are its own metrics', whose reasons are given on their lines


def test_an_offline_pass_on_a_components_model_shows_each_components_two_sides(
    cpha: tuple[Path, Path], tmp_path: Path
) -> None:
    """The joint accuracy hides most of a gain (docs/smoothing.md): batch's summary.csv gives
    ``mode_accuracy.<c>`` and ``filtered_mode_accuracy.<c>`` per component; compare's table
    gave the joint pair alone, and a gate on ``mode_accuracy.A2`` added the offline column
    without the filter's beside it."""
    model, log = cpha
    out = tmp_path / "cmp"
    outcome = compare(
        log,
        model,
        ["imm", "unknown-mode"],
        out_dir=out,
        mode_sequence="kbest",
        fail_under=["mode_accuracy.A2=0.5"],
    )
    rows = _rows(out / "comparison.csv")
    columns = list(rows["imm"])
    for c in ("A1", "A2", "A3"):
        assert columns.count(f"mode_accuracy.{c}") == 1
        assert columns.index(f"filtered_mode_accuracy.{c}") == (
            columns.index(f"mode_accuracy.{c}") + 1
        )
    for name, row in rows.items():
        report = outcome.reports[name]
        assert report.smoothing is not None
        for c, side in report.smoothing.filtered.components.items():
            assert float(row[f"mode_accuracy.{c}"]) == report.modes.components[c].accuracy
            assert float(row[f"filtered_mode_accuracy.{c}"]) == side.mode_accuracy
    # the estimates differ from the filter's on some component, or this tests nothing
    assert any(
        row[f"mode_accuracy.{c}"] != row[f"filtered_mode_accuracy.{c}"]
        for row in rows.values()
        for c in ("A1", "A2", "A3")
    )
    # without an offline pass the table is as it was: no component column
    plain = tmp_path / "plain"
    compare(log, model, ["imm", "unknown-mode"], out_dir=plain)
    assert not any(".A" in column for column in _rows(plain / "comparison.csv")["imm"])
