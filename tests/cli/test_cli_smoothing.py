"""``--smooth`` and ``--mode-sequence`` on the command line (issue 12): one test per kind.

The smoother itself is tested in tests/estimators/; here: the flags reach the estimator as
its options ``smooth`` and ``mode_sequence`` (the same path as ``--set`` and a model file's
``[estimators.<name>]``), the outputs carry both the filtered and the smoothed estimates, and
an estimator without a smoother is refused in one line before the log is read.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import polars as pl
import pytest

from hybridlog.errors import OptionError
from hybridlog.jobs.compare import _smoothing_columns, compare
from hybridlog.jobs.overrides import parse_sets, prepare_estimators
from hybridlog.model.builtins import builtin_text
from tests.cli.test_cli import run
from tests.support.paths import ROOT, SAMPLE_LOGS, TANK_CSV

DC1 = SAMPLE_LOGS / "double_cart_case1.csv"


def test_analyze_smooth_writes_filtered_and_smoothed_estimates(tmp_path: Path) -> None:
    common = [str(TANK_CSV), "--estimator", "imm"]
    run(["analyze", *common, "--model", "three_tank_hstf", "--out", str(tmp_path / "f")])
    result = run(
        ["analyze", *common, "--model", "three_tank_hstf", "--smooth", "--set", "smoother=kim",
         "--mode-sequence", "viterbi", "--out", str(tmp_path / "s")]
    )  # fmt: skip
    assert "mode accuracy" in result.output and "(filtered " in result.output
    # Kim's guard refuses one step at sample 1 (test_smoothing.py; expectation correction, the
    # default, none): the summary line, report.json and report.md say that sample's smoothed
    # estimate is in part the filter's
    note = "the smoother fell back to the forward estimate on 1 of 300 samples (guard 1), which "
    assert f"; {note}carry 0.0" in result.output.splitlines()[0]
    assert result.output.splitlines()[0].endswith(" % of the smoothed estimates' weight")
    filtered = json.loads((tmp_path / "f" / "report.json").read_text())
    smoothed = json.loads((tmp_path / "s" / "report.json").read_text())
    assert "smoothing" not in filtered and filtered["options"]["smooth"] is False
    assert smoothed["options"]["smooth"] is True
    assert smoothed["options"]["mode_sequence"] == "viterbi"
    smoothing = smoothed["smoothing"]
    assert smoothing["method"] == "kim-rts" and smoothing["mode_sequence"] == "viterbi"
    # the filter's side is the plain run's; the output metrics stay the filter's prediction
    assert smoothing["filtered"]["mode_accuracy"] == filtered["modes"]["accuracy"]
    assert smoothing["smoothed"]["mode_accuracy"] == smoothed["modes"]["accuracy"]
    for x, state in filtered["states"].items():
        assert smoothing["filtered"]["states"][x] == state
    for key in ("outputs", "mse", "vaf", "fit"):
        assert smoothed[key] == filtered[key]
    assert smoothing["smoothed"]["fit"] is not None  # ŷ = h(x̂) through the model
    assert set(smoothing["smoothed"]["outputs"]) == set(filtered["outputs"])
    timeline = pl.read_csv(tmp_path / "s" / "timeline.csv")
    assert {"mode_filtered", "p_1_filtered"} <= set(timeline.columns)
    plain = pl.read_csv(tmp_path / "f" / "timeline.csv")
    assert timeline["mode_filtered"].to_list() == plain["mode"].to_list()
    assert "## Smoothing" in (tmp_path / "s" / "report.md").read_text()
    weight = smoothing["fallbacks"].pop("weight")  # the one refused step's share, over 300
    assert 0.05 / 300 < weight < 0.1 / 300
    assert smoothing["fallbacks"] == {
        "samples": 1,
        "of": 300,
        "by_cause": {"prediction": 0, "guard": 1, "rounding": 0, "covariance": 0},
    }
    assert f"- Fallbacks: {note}carry 0.0" in (tmp_path / "s" / "report.md").read_text()


def test_analyze_mode_sequence_kbest(tmp_path: Path) -> None:
    out = tmp_path / "k"
    run(["analyze", str(TANK_CSV), "--model", "three_tank_hstf", "--estimator", "imm",
         "--mode-sequence", "kbest", "--set", "beam=8", "--out", str(out)])  # fmt: skip
    report = json.loads((out / "report.json").read_text())
    assert report["options"]["mode_sequence"] == "kbest" and report["options"]["beam"] == 8
    smoothing = report["smoothing"]
    assert smoothing["method"] is None and smoothing["mode_sequence"] == "kbest"
    assert "8 best mode histories" in smoothing["description"]
    assert smoothing["smoothed"]["mode_accuracy"] == report["modes"]["accuracy"]
    assert "| metric | filtered | kbest | change |" in (out / "report.md").read_text()


def test_smooth_on_an_estimator_without_a_smoother_is_one_line_before_the_log_is_read(
    tmp_path: Path,
) -> None:
    missing = tmp_path / "no such log.csv"
    out = tmp_path / "out"
    args = ["analyze", str(missing), "--model", "double_cart_case1", "--estimator", "chiu"]
    result = run([*args, "--smooth", "--out", str(out)], expect=2)
    (line,) = result.stderr.strip().splitlines()
    assert line.startswith("hybridlog: error: --smooth: estimator 'chiu'")
    assert "does not offer it: it classifies each sample" in line and "imm" in line
    result = run([*args, "--mode-sequence", "viterbi", "--out", str(out)], expect=2)
    assert "--mode-sequence viterbi: estimator 'chiu'" in result.stderr
    assert not out.exists()


def test_the_flags_are_the_estimator_options(tmp_path: Path) -> None:
    """Library level: what each flag sets, the model file's smooth = true, --set conflicts."""
    model, overrides = parse_sets([], "three_tank_hstf")
    (imm,) = prepare_estimators(model, ["imm"], overrides, smooth=True, mode_sequence="viterbi")
    assert (imm.options.smooth, imm.options.mode_sequence) == (True, "viterbi")
    (plain,) = prepare_estimators(model, ["imm"], overrides)
    assert (plain.options.smooth, plain.options.mode_sequence) == (False, "argmax")
    model, overrides = parse_sets(["smooth=false"], "three_tank_hstf")
    with pytest.raises(OptionError, match=r"^--smooth: also given as --set smooth=false"):
        prepare_estimators(model, ["imm"], overrides, smooth=True)
    # smooth = true under [estimators.imm] is the same setting as --smooth
    path = tmp_path / "tank.toml"
    path.write_text(builtin_text("three_tank_hstf") + "\n[estimators.imm]\nsmooth = true\n")
    model, overrides = parse_sets([], path)
    (from_file,) = prepare_estimators(model, ["imm"], overrides)
    assert from_file.options == imm.options.__class__(smooth=True)
    (both,) = prepare_estimators(model, ["imm"], overrides, smooth=True)
    assert both.options == from_file.options


@pytest.mark.parametrize(
    ("model_name", "names", "option", "why"),
    [
        ("ice_clutch", [None], "smooth=true", "it takes the modes from the log's switching"),
        ("three_tank_hstf", ["hstf"], "beam=3", "kbest would drop eq. (24)'s fading"),
        ("double_cart_case1", ["hstf", "chiu"], "mode_sequence=viterbi", "Viterbi the per-"),
        ("three_tank_hstf", ["hstf"], "mode_sequence=argmax", "threshold rule of paper 000"),
    ],
)
def test_set_of_an_offline_option_no_estimator_has_is_refused_as_the_flag_is(
    model_name: str, names: list[str | None], option: str, why: str
) -> None:
    """``--set smooth=true`` (or ``mode_sequence``, ``beam``) on estimators without it: the
    reason and the estimators that have it, as ``--smooth``; not 'neither a parameter nor an
    estimator option'."""
    model, overrides = parse_sets([option], model_name)
    with pytest.raises(OptionError) as caught:
        prepare_estimators(model, names, overrides)
    message = str(caught.value)
    assert message.startswith(f"--set {option}: estimator '") and "does not offer it: " in message
    assert why in message and "(estimators that do: imm" in message
    # an estimator nobody named is the model's default, which the line says
    default = f"(the default_estimator of {model_name}) does not offer it"
    assert (default in message) == (names == [None])


def test_smooth_on_the_models_default_estimator_names_the_default_not_the_option() -> None:
    model, overrides = parse_sets([], "double_cart_case1")
    with pytest.raises(OptionError) as caught:
        prepare_estimators(model, [None], overrides, smooth=True)
    assert str(caught.value).startswith(
        "--smooth: estimator 'chiu' (the default_estimator of double_cart_case1) does not offer"
    )
    with pytest.raises(OptionError, match=r"^--smooth: estimator 'chiu' \(--estimator\) does"):
        prepare_estimators(model, ["chiu"], overrides, smooth=True)


def test_compare_smooth_needs_a_smoother_in_every_estimator(tmp_path: Path) -> None:
    with pytest.raises(OptionError) as caught:
        compare(DC1, "double_cart_case1", ["imm", "chiu"], out_dir=tmp_path / "c", smooth=True)
    assert str(caught.value).startswith("--smooth: estimator 'chiu' (--estimators) does not")
    assert "--set smooth=true applies it only to the estimators that do" in str(caught.value)
    assert not (tmp_path / "c").exists()
    # --set smooth=true smooths the estimators that have a smoother, and the table says so
    done = compare(
        TANK_CSV,
        "three_tank_hstf",
        ["imm", "hstf"],
        out_dir=tmp_path / "c",
        sets=["smooth=true", "smoother=kim"],  # Kim's refuses one step there (the default none)
    )
    table = pl.read_csv(tmp_path / "c" / "comparison.csv")
    filtered_states = [f"filtered_state_rmse.x{k}" for k in (1, 2, 3)]
    assert table.columns[-7:] == [
        "smoothing", "filtered_mode_accuracy", *filtered_states, "smoothing_fallback_weight",
        "warnings",
    ]  # fmt: skip
    imm = done.reports["imm"].smoothing
    assert imm is not None and imm.method is not None
    row = table.filter(pl.col("estimator") == "imm")
    # each state's RMSE, the smoothed one and the filter's own beside it
    for x in ("x1", "x2", "x3"):
        assert row[f"state_rmse.{x}"][0] == done.reports["imm"].states[x].rmse
        assert row[f"filtered_state_rmse.{x}"][0] == imm.filtered.states[x].rmse
        assert row[f"state_rmse.{x}"][0] < row[f"filtered_state_rmse.{x}"][0]
    hstf_row = table.filter(pl.col("estimator") == "hstf")
    assert hstf_row["filtered_state_rmse.x1"][0] == hstf_row["state_rmse.x1"][0]
    assert row["filtered_mode_accuracy"][0] == pytest.approx(imm.filtered.mode_accuracy)
    assert row["mode_accuracy"][0] == pytest.approx(done.reports["imm"].modes.accuracy)
    assert row["smoothing"][0] == f"{imm.method}, argmax"
    assert imm.fallbacks is not None  # the one refused step's share, as report.json's
    assert row["smoothing_fallback_weight"][0] == imm.fallbacks.weight > 0.0
    if done.reports["hstf"].smoothing is None:  # hstf has no smoother (yet)
        hstf = table.filter(pl.col("estimator") == "hstf")
        assert hstf["smoothing"][0] == "none"
        # its own estimates: filtered_mode_accuracy compares the filters like for like (it
        # was empty, the filters' own accuracies in two columns)
        assert hstf["filtered_mode_accuracy"][0] == done.reports["hstf"].modes.accuracy
        assert hstf["smoothing_fallback_weight"][0] is None  # no smoother ran, and why says
        text = (tmp_path / "c" / "comparison.md").read_text()
        assert (
            "- `hstf` smoothing_fallback_weight: no smoother ran on its estimates, so none fell "
            "back to the filter's"
        ) in text.split("## Not available")[1]
        assert done.unlike == [
            "the mode metrics and the states' RMSEs of imm are of offline estimates"
        ]
        assert (
            "are of offline estimates (the `smoothing` column), the others' of their own "
            "estimates: `filtered_mode_accuracy` and `filtered_state_rmse.<x>` compare every "
            "estimator's own"
        ) in text


def test_the_smoothing_page_names_every_column_compare_adds() -> None:
    # docs/smoothing.md named smoothing, filtered_mode_accuracy and smoothing_fallback_weight,
    # not the filtered_state_rmse.<x> per state that compare adds beside them
    paragraphs = (ROOT / "docs" / "smoothing.md").read_text().split("\n\n")
    (paragraph,) = [p for p in paragraphs if p.startswith("`hybridlog compare` with `--smooth`")]
    for column in _smoothing_columns(["state_rmse.<x>"]):
        assert f"`{column}`" in " ".join(paragraph.split()), column


@pytest.mark.parametrize(
    ("mode_sequence", "offered_by", "why"),
    [
        ("viterbi", "imm", "Viterbi the per-sample argmax"),
        ("kbest", "imm, unknown-mode", "kbest would drop eq. (24)'s fading"),
        ("argmax", "imm, unknown-mode", "its mode is the threshold rule of paper 000 eq. (40)"),
    ],
)
def test_a_refusal_lists_the_estimators_that_offer_the_value_asked_for(
    mode_sequence: str, offered_by: str, why: str
) -> None:
    """unknown-mode has kbest but no viterbi: only the estimators with the value are named.

    The reason answers the value given: hstf's argmax is refused because its modes come
    from the θ rule of eq. (40) (it was the smoother's reason, Kim and Viterbi)."""
    model, overrides = parse_sets([], "three_tank_hstf")
    with pytest.raises(OptionError) as caught:
        prepare_estimators(model, ["hstf"], overrides, mode_sequence=mode_sequence)
    message = str(caught.value)
    assert message.startswith(
        f"--mode-sequence {mode_sequence}: estimator 'hstf' (--estimator) does not offer"
    )
    assert message.endswith(f"(estimators that do: {offered_by})")
    assert why in message and ("Kim" in message) == (mode_sequence != "argmax")


def test_a_value_one_of_several_estimators_lacks_says_how_to_give_it_to_the_others() -> None:
    """--set would give mode_sequence=viterbi to unknown-mode too, which refuses it: the
    refusal points to the model file's table of the estimators that offer it."""
    model, overrides = parse_sets([], "three_tank_hstf")
    with pytest.raises(OptionError) as caught:
        prepare_estimators(
            model,
            ["imm", "unknown-mode"],
            overrides,
            mode_sequence="viterbi",
            given_by="--estimators",
        )
    assert str(caught.value) == (
        "--mode-sequence viterbi: estimator 'unknown-mode' offers argmax, kbest; for imm alone, "
        'mode_sequence = "viterbi" under [estimators.imm] in the model file'
    )


def test_set_beam_without_kbest_is_refused_as_having_no_effect(tmp_path: Path) -> None:
    """``--set beam=5`` without ``mode_sequence = kbest`` ran imm's usual pass while
    report.json recorded beam 5 as the option used; now one line says why it has no effect.
    """
    model, overrides = parse_sets(["beam=5"], "three_tank_hstf")
    for flags in ({}, {"smooth": True}, {"mode_sequence": "viterbi"}):
        with pytest.raises(OptionError) as caught:
            prepare_estimators(model, ["imm"], overrides, **flags)  # type: ignore[arg-type]
        assert str(caught.value).startswith(
            "--set beam=5: has no effect on estimator 'imm': only mode_sequence = kbest keeps "
            "mode histories (here "
        )
    (kbest,) = prepare_estimators(model, ["imm"], overrides, mode_sequence="kbest")
    assert kbest.options.beam == 5
    # a model file's mode_sequence = "kbest" makes it count too
    path = tmp_path / "tank.toml"
    path.write_text(
        builtin_text("three_tank_hstf") + '\n[estimators.imm]\nmode_sequence = "kbest"\n'
    )
    model, overrides = parse_sets(["beam=5"], str(path))
    (from_file,) = prepare_estimators(model, ["imm"], overrides)
    assert from_file.options.beam == 5
    # compare: beam is refused only where no estimator having it reads it
    with pytest.raises(OptionError, match=r"^--set beam=5: has no effect on estimator 'imm'"):
        compare(
            TANK_CSV, "three_tank_hstf", ["imm", "hstf"], out_dir=tmp_path / "c", sets=["beam=5"]
        )
    assert not (tmp_path / "c").exists()


def test_set_beam_read_by_another_estimator_is_not_refused(tmp_path: Path) -> None:
    from tests.support.cpha import CPHA_EXAMPLE

    path = tmp_path / "cpha.toml"
    path.write_text(CPHA_EXAMPLE)
    model, overrides = parse_sets(["beam=7"], str(path))
    imm, unknown = prepare_estimators(model, ["imm", "unknown-mode"], overrides)
    assert imm.options.beam == 7 and unknown.options.beam == 7


def test_analyze_smoother_ec_writes_its_method_and_refuses_it_without_smooth(
    tmp_path: Path,
) -> None:
    """``--set smoother=ec`` with ``--smooth`` runs expectation correction, and report.json
    says so; without ``--smooth`` it would change nothing: one line, exit 2, no folder."""
    common = [str(TANK_CSV), "--model", "three_tank_hstf", "--estimator", "imm"]
    out = tmp_path / "ec"
    ran = run(["analyze", *common, "--smooth", "--set", "smoother=ec", "--out", str(out)])
    report = json.loads((out / "report.json").read_text())
    assert report["options"]["smoother"] == "ec"
    assert report["smoothing"]["fallbacks"]["samples"] == 0  # no step refused: no note
    assert "fell back" not in ran.output and "Fallbacks" not in (out / "report.md").read_text()
    assert report["smoothing"]["method"] == "ec-rts"
    assert "Barber 2006" in report["smoothing"]["description"]
    refused = tmp_path / "refused"
    result = run(["analyze", *common, "--set", "smoother=ec", "--out", str(refused)], expect=2)
    (line,) = result.stderr.strip().splitlines()
    assert line == (
        "hybridlog: error: --set smoother=ec: has no effect on estimator 'imm': only smooth = "
        "true runs a smoother (here smooth = false); add --smooth, or leave smoother unset"
    )
    assert not refused.exists()


def test_batch_smooth_summaries_find_the_logs_whose_smoother_fell_back(tmp_path: Path) -> None:
    # report.json had smoothing.fallbacks (the double cart: 99.1 % of the smoothed estimates'
    # weight is the filter's), summary.csv and summary.md of batch --smooth did not: among
    # thousands of logs those whose "smoothed" estimate is mostly the filter's were not found
    logs = tmp_path / "logs"
    logs.mkdir()
    lines = DC1.read_text().splitlines(keepends=True)
    (logs / "long.csv").write_text("".join(lines))
    (logs / "short.csv").write_text("".join(lines[:402]))  # 401 samples
    out = tmp_path / "out"
    common = ["batch", str(logs), "--model", "double_cart_case1", "--estimator", "imm"]
    run([*common, "--out", str(out / "plain")])
    with (out / "plain" / "summary.csv").open() as file:
        assert not any(c.startswith("smoothing") for c in next(csv.reader(file)))
    for _ in range(2):  # the second run reuses the reports: the same numbers, from report.json
        run([*common, "--smooth", "--out", str(out / "smooth")])
        with (out / "smooth" / "summary.csv").open() as file:
            table = {Path(r["log"]).name: r for r in csv.DictReader(file)}
        fallbacks = {
            name: json.loads((out / "smooth" / name / "report.json").read_text())["smoothing"][
                "fallbacks"
            ]
            for name in table
        }
        for name, found in fallbacks.items():
            assert found["samples"] > 0  # the guard refuses the double cart's steps
            assert int(table[name]["smoothing_fallback_samples"]) == found["samples"]
            assert float(table[name]["smoothing_fallback_weight"]) == found["weight"]
    assert {r["status"] for r in table.values()} == {"skipped"}
    text = (out / "smooth" / "summary.md").read_text()
    heading = "### Logs where the smoother fell back to the forward estimate (2 of 2)"
    named = text.split(heading)[1].split("\n## ")[0]
    worst, other = sorted(fallbacks, key=lambda name: -fallbacks[name]["weight"])
    assert 0 <= named.index(f"logs/{worst}: ") < named.index(f"logs/{other}: ")
    assert f"{100 * fallbacks[worst]['weight']:.1f} % of the weight" in named
