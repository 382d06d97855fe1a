"""The report of a smoothed run (issue 12): report.json's ``smoothing``, tables, report.md, plots.

The results are built by hand (a "filter" and a better "smoother" over the same synthetic
log), so these tests check the report layer alone: each side's metrics must be those the
report computes for that side's result on its own, and every value must come back from the
files.
"""

from __future__ import annotations

import copy
import dataclasses
import json
import re
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl
import pytest

from hybridlog.errors import ModelError, ReportError
from hybridlog.estimators.result import EstimationResult, Fallbacks, PostProcessing
from hybridlog.report import Report, build_report, read_report, render_markdown, write_report
from hybridlog.signals import AlignedSignals
from tests.report.test_report_files import DT, MODE_IDS, OUTPUTS, STATES, make_run

DESCRIPTION = "Kim (1994) smoother with an RTS backward step per mode, eqs. (1)-(3)"


def smoothed_run(
    *, truth: bool = True, mode_sequence: str = "argmax", smoothing: str | None = "kim-rts"
) -> tuple[EstimationResult, AlignedSignals]:
    """The run of ``make_run`` as the filter, and a result closer to the truth as the smoother."""
    filtered, signals = make_run(truth=truth)
    rng = np.random.default_rng(7)
    _, with_truth = make_run(truth=True)
    assert with_truth.truth_modes is not None and with_truth.truth_states is not None
    modes = with_truth.truth_modes.copy()
    modes[rng.random(modes.size) < 0.01] = 0  # a few errors remain
    probs = 0.05 + 0.85 * np.eye(len(MODE_IDS))[modes]
    probs /= probs.sum(axis=1, keepdims=True)
    x_true = np.nan_to_num(with_truth.truth_states) + 0.0
    means = 0.5 * (filtered.state_means + x_true)
    means[:, 1] = filtered.state_means[:, 1] + 0.01
    result = dataclasses.replace(
        filtered,
        modes=modes.astype(np.int64),
        mode_probabilities=probs,
        state_means=means,
        state_variances=0.5 * filtered.state_variances,
        post_processing=PostProcessing(
            smoothing=smoothing, mode_sequence=mode_sequence, description=DESCRIPTION,
            filtered=filtered,
        ),
    )  # fmt: skip
    return result, signals


def read_table(path: Path) -> pl.DataFrame:
    header = path.read_text().splitlines()[0].split(",")
    strings = {"mode", "truth_mode", "mode_filtered"}
    return pl.read_csv(path, schema={c: pl.String if c in strings else pl.Float64 for c in header})


def side_of(report: Report) -> dict[str, Any]:
    """The metrics ``smoothing.<side>`` must hold, from a report of that side's result alone."""
    modes = report.modes
    det = modes.detection
    confusion = modes.confusion
    return {
        "mode_accuracy": modes.accuracy,
        "confusion": None if confusion is None else {k: dict(v) for k, v in confusion.items()},
        "detection_delay_s": modes.detection_delay_s,
        "detection_max_s": None if det is None else det.max_s,
        "detected": None if det is None else det.detected,
        "missed": None if det is None else det.missed,
        "estimated_switches": len(modes.switches),
        "states": {x: s.to_dict() for x, s in report.states.items()},
    }  # fmt: skip


@pytest.mark.parametrize("truth", [True, False], ids=["truth", "no-truth"])
def test_smoothing_holds_each_sides_metrics_and_reads_back(tmp_path: Path, truth: bool) -> None:
    result, signals = smoothed_run(truth=truth)
    assert result.post_processing is not None
    filtered = result.post_processing.filtered
    report = write_report(
        tmp_path / "out", result, signals, log="run.csv", model_name="m", dt=DT, plots=False
    )
    alone = {
        name: build_report(r, signals, log="run.csv", model_name="m", dt=DT)
        for name, r in (("filtered", filtered), ("smoothed", result))
    }
    data = json.loads((tmp_path / "out" / "report.json").read_text())
    smoothing = data["smoothing"]
    assert list(data)[list(data).index("null_reasons") + 1] == "smoothing"
    assert (smoothing["method"], smoothing["mode_sequence"]) == ("kim-rts", "argmax")
    assert smoothing["description"] == DESCRIPTION
    for side in ("filtered", "smoothed"):
        expected = side_of(alone[side])
        assert {k: smoothing[side][k] for k in expected} == expected
        # without the model at hand, the outputs the estimates explain are not known
        assert smoothing[side]["outputs"] is None and smoothing[side]["fit"] is None
    # the report's own modes and states are the smoothed ones; the outputs the filter's
    assert data["modes"] == alone["smoothed"].to_dict()["modes"]
    assert data["states"] == alone["smoothed"].to_dict()["states"]
    for key in ("outputs", "mse", "vaf", "fit"):
        assert data[key] == alone["filtered"].to_dict()[key]
    if truth:
        assert smoothing["smoothed"]["mode_accuracy"] > smoothing["filtered"]["mode_accuracy"]
    assert read_report(tmp_path / "out" / "report.json") == report
    assert "smoothing" not in alone["filtered"].to_dict()
    assert alone["filtered"].smoothing is None


def test_tables_hold_smoothed_values_and_the_filtered_ones_beside_them(tmp_path: Path) -> None:
    result, signals = smoothed_run()
    assert result.post_processing is not None
    filtered = result.post_processing.filtered
    write_report(
        tmp_path / "out", result, signals, log="run.csv", model_name="m", dt=DT, plots=False
    )
    timeline = read_table(tmp_path / "out" / "timeline.csv")
    estimates = read_table(tmp_path / "out" / "estimates.csv")
    ids = np.array(MODE_IDS)
    assert timeline.columns == [
        "t", "mode", *(f"p_{m}" for m in MODE_IDS), "mode_filtered",
        *(f"p_{m}_filtered" for m in MODE_IDS), "truth_mode",
    ]  # fmt: skip
    assert timeline["mode"].to_list() == ids[result.modes].tolist()
    assert timeline["mode_filtered"].to_list() == ids[filtered.modes].tolist()
    for j, m in enumerate(MODE_IDS):
        np.testing.assert_array_equal(
            timeline[f"p_{m}"].to_numpy(), result.mode_probabilities[:, j]
        )
        np.testing.assert_array_equal(
            timeline[f"p_{m}_filtered"].to_numpy(), filtered.mode_probabilities[:, j]
        )
    for i, x in enumerate(STATES):
        np.testing.assert_array_equal(estimates[f"{x}_hat"].to_numpy(), result.state_means[:, i])
        np.testing.assert_array_equal(
            estimates[f"{x}_hat_filtered"].to_numpy(), filtered.state_means[:, i]
        )
        np.testing.assert_array_equal(
            estimates[f"{x}_var_filtered"].to_numpy(), filtered.state_variances[:, i]
        )
    for j, y in enumerate(OUTPUTS):  # the filter's one-step-ahead prediction either way
        np.testing.assert_array_equal(
            estimates[f"{y}_hat"].to_numpy()[1:], filtered.output_predictions[1:, j]
        )
    assert not any(c.endswith("_filtered") for c in read_table_plain(tmp_path))


def read_table_plain(tmp_path: Path) -> list[str]:
    """The columns of both tables of the same run without post-processing."""
    result, signals = make_run()
    write_report(
        tmp_path / "plain", result, signals, log="run.csv", model_name="m", dt=DT, plots=False
    )
    columns: list[str] = []
    for name in ("timeline", "estimates"):
        columns += (tmp_path / "plain" / f"{name}.csv").read_text().splitlines()[0].split(",")
    return columns


def test_report_md_has_a_smoothing_section_with_the_gain(tmp_path: Path) -> None:
    result, signals = smoothed_run(mode_sequence="viterbi")
    report = write_report(tmp_path / "out", result, signals, log="run.csv", model_name="m", dt=DT)
    text = (tmp_path / "out" / "report.md").read_text()
    assert text == render_markdown(report)
    section = text.split("## Smoothing", 1)[1].split("\n## ", 1)[0]
    assert "`kim-rts`" in section and "`viterbi`" in section and DESCRIPTION in section
    assert "one-step-ahead prediction" in section
    assert report.smoothing is not None
    f, s = report.smoothing.filtered, report.smoothing.smoothed
    assert f.mode_accuracy is not None and s.mode_accuracy is not None
    gain = 100 * (s.mode_accuracy - f.mode_accuracy)
    row = next(line for line in section.splitlines() if line.startswith("| mode accuracy"))
    assert row.split("|")[2:5] == [
        f" {100 * f.mode_accuracy:.4f} ", f" {100 * s.mode_accuracy:.4f} ", f" {gain:+.4g} "
    ]  # fmt: skip
    for x in STATES:
        assert f"| RMSE {x} |" in section
    for name in ("outputs.png", "modes.png", "states.png"):
        assert (tmp_path / "out" / "plots" / name).stat().st_size > 1000
    assert "| metric | filtered | smoothed | change |" in section
    # no model, so no outputs each side explains (as for a [components] model): no rows of
    # them, and no sentence announcing them
    assert s.outputs is None and "| fit of h(x̂)" not in section
    assert "output fit below" not in section
    post = result.post_processing
    assert post is not None
    carried = dataclasses.replace(  # each side's explained outputs carried: rows and sentence
        post, explained=signals.outputs + 0.1, filtered_explained=signals.outputs - 0.3
    )
    explained = dataclasses.replace(result, post_processing=carried)
    text = render_markdown(build_report(explained, signals, log="run.csv", model_name="m", dt=DT))
    assert "output fit below" in text and all(f"| fit of h(x̂) {y} (%) |" in text for y in OUTPUTS)
    only, signals = smoothed_run(mode_sequence="viterbi", smoothing=None)
    text = render_markdown(build_report(only, signals, log="run.csv", model_name="m", dt=DT))
    assert "| metric | filtered | viterbi | change |" in text
    assert "smoother: none (the filter's estimates); mode sequence: `viterbi`" in text
    plain, signals = make_run()
    assert "## Smoothing" not in render_markdown(
        build_report(plain, signals, log="run.csv", model_name="m", dt=DT)
    )


def _section(text: str, name: str) -> str:
    return text.split(f"## {name}\n", 1)[1].split("\n## ", 1)[0]


def test_report_md_says_under_each_table_which_estimates_it_is_of() -> None:
    """Only the Smoothing section, after the tables, said the output metrics were the
    filter's prediction and the modes and states the offline estimates'."""
    result, signals = smoothed_run(mode_sequence="viterbi")
    text = render_markdown(build_report(result, signals, log="run.csv", model_name="m", dt=DT))
    assert _section(text, "Outputs").startswith(
        "\nThe causal filter's one-step-ahead prediction ŷ(k|k−1), with or without an offline "
        "pass: it is the basis of MSE, VAF and fit (see Smoothing).\n\n| output |"
    )
    for name, what in (("Modes", "modes"), ("States", "states")):
        assert _section(text, name).startswith(
            f"\nOf the offline estimates (`kim-rts`, `viterbi`); the causal filter's own {what} "
            "are compared with them under Smoothing.\n"
        )
    only, signals = smoothed_run(mode_sequence="viterbi", smoothing=None)
    text = render_markdown(build_report(only, signals, log="run.csv", model_name="m", dt=DT))
    assert _section(text, "Modes").startswith("\nOf the offline estimates (`viterbi`);")
    assert _section(text, "States").startswith(
        "\nThe causal filter's own: the Viterbi path changes only the modes.\n"
    )
    plain, signals = make_run()
    text = render_markdown(build_report(plain, signals, log="run.csv", model_name="m", dt=DT))
    assert "offline" not in text and "causal filter's" not in text


def test_a_filtered_result_that_does_not_line_up_is_a_programming_error() -> None:
    result, signals = smoothed_run()
    assert result.post_processing is not None
    short = make_run(n=399)[0]
    broken = dataclasses.replace(
        result, post_processing=dataclasses.replace(result.post_processing, filtered=short)
    )
    with pytest.raises(ValueError, match="does not line up"):
        build_report(broken, signals, log="run.csv", model_name="m", dt=DT)


def _report_data() -> dict[str, Any]:
    result, signals = smoothed_run()
    data: dict[str, Any] = build_report(
        result, signals, log="run.csv", model_name="m", dt=DT
    ).to_dict()
    return data


def _set(data: dict[str, Any], path: str, value: object) -> dict[str, Any]:
    changed = copy.deepcopy(data)
    *parents, last = path.split(".")
    target = changed
    for key in parents:
        target = target[key]
    if value is _DELETE:
        del target[last]
    else:
        target[last] = value
    return changed


_DELETE = object()


@pytest.mark.parametrize(
    ("path", "value", "message"),
    [
        ("smoothing", [], "'smoothing' is a list; expected an object"),
        ("smoothing.method", 3, "'smoothing.method' is a number; expected a string"),
        ("smoothing.mode_sequence", "best", "'smoothing.mode_sequence' is 'best'; expected one"),
        ("smoothing.description", _DELETE, "'smoothing.description' is missing"),
        ("smoothing.filtered", _DELETE, "'smoothing.filtered' is missing"),
        ("smoothing.smoothed.mode_accuracy", "0.9", "'smoothing.smoothed.mode_accuracy' is a str"),
        ("smoothing.filtered.confusion.off", {"off": 1}, "'smoothing.filtered.confusion.off' has"),
        ("smoothing.smoothed.states", {"x1": {"rmse": 1.0}}, "'smoothing.smoothed.states' has"),
        ("smoothing.smoothed.missed", None, "'smoothing.smoothed.missed' must be null exactly"),
        ("smoothing.filtered.confusion", None, "'smoothing.filtered' holds mode_accuracy, conf"),
        (
            "smoothing.filtered.estimated_switches",
            -1,
            "'smoothing.filtered.estimated_switches' is -1",
        ),
        ("smoothing.smoothed.outputs", {"y1": 1}, "'smoothing.smoothed.outputs.y1' is a number"),
    ],
)
def test_a_malformed_smoothing_is_a_report_error_naming_the_key(
    path: str, value: object, message: str
) -> None:
    text = json.dumps(_set(_report_data(), path, value))
    with pytest.raises(ReportError, match="^r.json: " + re.escape(message)):
        Report.from_json(text, source="r.json")


FELL_BACK = Fallbacks(
    12, 399, {"prediction": 0, "guard": 12, "rounding": 3, "covariance": 0}, weight=0.02
)


def test_fallbacks_reach_report_json_and_report_md_and_read_back(tmp_path: Path) -> None:
    """Where the smoother left the forward estimate standing: ``smoothing.fallbacks`` of
    report.json (read back), a line of report.md's Smoothing section when any sample did,
    none when none did; absent where no smoother ran (a report of an earlier version reads
    as ``None``)."""
    result, signals = smoothed_run()
    post = result.post_processing
    assert post is not None
    for fallbacks in (FELL_BACK, dataclasses.replace(FELL_BACK, samples=0, weight=0.0, by_cause={
        "prediction": 0, "guard": 0, "rounding": 0, "covariance": 0})):  # fmt: skip
        counted = dataclasses.replace(
            result, post_processing=dataclasses.replace(post, fallbacks=fallbacks)
        )
        out = tmp_path / str(fallbacks.samples)
        report = write_report(out, counted, signals, log="run.csv", model_name="m", dt=DT)
        data = json.loads((out / "report.json").read_text())
        assert data["smoothing"]["fallbacks"] == {
            "samples": fallbacks.samples,
            "of": fallbacks.of,
            "by_cause": fallbacks.by_cause,
            "weight": fallbacks.weight,
        }
        assert read_report(out / "report.json") == report
        assert report.smoothing is not None and report.smoothing.fallbacks == fallbacks
        section = (out / "report.md").read_text().split("## Smoothing", 1)[1]
        line = (
            "- Fallbacks: the smoother fell back to the forward estimate on 12 of 399 samples "
            "(guard 12, rounding 3), which carry 2.0 % of the smoothed estimates' weight."
            " On those samples the smoothed estimate is, in part or whole, the forward pass's"
            ' (docs/smoothing.md, "The algorithms", and "Why the guard fires on models with'
            ' more states than outputs" there).'
        )
        assert (line in section) == (fallbacks.samples > 0)
    data = _report_data()
    assert "fallbacks" not in data["smoothing"]  # none carried: not counted
    assert Report.from_dict(data).smoothing.fallbacks is None  # type: ignore[union-attr]


def test_the_fallback_line_points_to_why_the_guard_fires_only_where_it_did(
    tmp_path: Path,
) -> None:
    """The guard refuses steps by construction on models with fewer outputs than states (the
    docs say why, with numbers); a line whose steps the rounding probe alone refused does not
    send the reader there."""
    result, signals = smoothed_run()
    post = result.post_processing
    assert post is not None
    causes = {"prediction": 0, "guard": 0, "rounding": 3, "covariance": 0}
    for by_cause, pointed in ((FELL_BACK.by_cause, True), (causes, False)):
        fallbacks = dataclasses.replace(FELL_BACK, by_cause=by_cause)
        counted = dataclasses.replace(
            result, post_processing=dataclasses.replace(post, fallbacks=fallbacks)
        )
        out = tmp_path / str(pointed)
        write_report(out, counted, signals, log="run.csv", model_name="m", dt=DT)
        line = next(
            line
            for line in (out / "report.md").read_text().splitlines()
            if line.startswith("- Fallbacks:")
        )
        assert ("Why the guard fires on models with more states than outputs" in line) == pointed
        assert line.endswith("there).") == pointed


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"samples": 400}, "'smoothing.fallbacks.samples' is 400, more than of (399)"),
        ({"samples": 16}, "'smoothing.fallbacks.by_cause' counts"),
        ({"samples": 2}, "'smoothing.fallbacks.by_cause' counts"),
        ({"by_cause": {"guard": 12}}, "'smoothing.fallbacks.by_cause' has keys ['guard']"),
        ({"by_cause": {**FELL_BACK.by_cause, "guard": -1}}, "'smoothing.fallbacks.by_cause.g"),
        ({"of": None}, "'smoothing.fallbacks.of' is"),
        ({"of": 300}, "'smoothing.fallbacks.of' is 300; expected 399 (samples − 1"),
        ({"weight": 0.0}, "'smoothing.fallbacks.weight' is 0.0; expected above 0 and at most"),
        ({"weight": 0.5}, "'smoothing.fallbacks.weight' is 0.5; expected above 0 and at most"),
        ({"weight": "x"}, "'smoothing.fallbacks.weight' is"),
        ({"weight": None}, "'smoothing.fallbacks.weight' is"),
    ],
)
def test_malformed_fallbacks_are_a_report_error_naming_the_key(
    change: dict[str, object], message: str
) -> None:
    fallbacks = {
        "samples": 12,
        "of": 399,
        "by_cause": dict(FELL_BACK.by_cause),
        "weight": 0.02,
        **change,
    }
    data = _set(_report_data(), "smoothing.fallbacks", fallbacks)
    with pytest.raises(ReportError, match="^r.json: " + re.escape(message)):
        Report.from_json(json.dumps(data), source="r.json")


def test_fallbacks_without_a_smoother_are_a_report_error() -> None:
    data = _set(_report_data(), "smoothing.method", None)
    fallbacks = {
        "samples": 0,
        "of": 399,
        "by_cause": dict.fromkeys(FELL_BACK.by_cause, 0),
        "weight": 0.0,
    }
    data = _set(data, "smoothing.fallbacks", fallbacks)
    with pytest.raises(ReportError, match=re.escape("'smoothing.fallbacks' is set but no smoo")):
        Report.from_json(json.dumps(data), source="r.json")


def test_smoothing_null_reads_as_none() -> None:
    data = _set(_report_data(), "smoothing", None)
    assert Report.from_dict(data).smoothing is None


def test_a_model_whose_names_make_one_column_name_twice_is_refused(tmp_path: Path) -> None:
    """A mode 'low_filtered' beside a mode 'low': timeline.csv's p_low_filtered held the
    filter's probability of mode 'low' and the smoothed one of mode 'low_filtered' was not
    written; a state 'x1' beside an output 'x1_hat': estimates.csv's x1_hat held the measured
    output, the state's estimate was not written."""
    result, signals = smoothed_run()

    def renamed(**names: Any) -> EstimationResult:
        post = result.post_processing
        assert post is not None
        filtered = dataclasses.replace(post.filtered, **names)
        return dataclasses.replace(
            result, **names, post_processing=dataclasses.replace(post, filtered=filtered)
        )

    out = tmp_path / "out"
    with pytest.raises(ModelError) as caught:
        write_report(
            out,
            renamed(mode_ids=("off", "low", "low_filtered")),
            signals,
            log="run.csv",
            model_name="m",
            dt=DT,
        )
    assert str(caught.value) == (
        "the timeline table: two columns would be named 'p_low_filtered': the probability of "
        "mode 'low_filtered' and the filter's probability of mode 'low'; rename a mode, state "
        "or output of the model"
    )
    assert not out.exists()
    outputs = ("x1_hat", *OUTPUTS[1:])
    with pytest.raises(ModelError, match="'x1_hat': the estimate of state 'x1' and the measured"):
        write_report(
            out,
            renamed(output_names=outputs),
            dataclasses.replace(signals, output_names=outputs),
            log="run.csv",
            model_name="m",
            dt=DT,
        )
    assert not out.exists()


def _with_switches(report: Report, filtered: tuple[int, int], offline: tuple[int, int]) -> str:
    """report.md of ``report`` with each side's (detected, missed) true switches and delays."""
    smoothing = report.smoothing
    assert smoothing is not None
    sides = [
        dataclasses.replace(
            side, detected=detected, missed=missed, detection_delay_s=delay, detection_max_s=delay
        )
        for side, (detected, missed), delay in (
            (smoothing.filtered, filtered, 0.5),
            (smoothing.smoothed, offline, 0.0),
        )
    ]
    replaced = dataclasses.replace(smoothing, filtered=sides[0], smoothed=sides[1])
    return _section(render_markdown(dataclasses.replace(report, smoothing=replaced)), "Smoothing")


def test_detection_delays_over_other_switches_are_not_compared() -> None:
    """A mean delay is over the switches a side detected: a smoother that missed two switches
    the filter caught showed "detection delay, mean | 0.428571 | 0 | -0.428571" (and the max
    -2), read as a faster detection, where its mean left out the two it missed."""
    result, signals = smoothed_run()
    report = build_report(result, signals, log="run.csv", model_name="m", dt=DT)

    def delay_rows(text: str) -> list[str]:
        return [line for line in text.splitlines() if line.startswith("| detection delay")]

    both = _with_switches(report, (7, 0), (7, 0))  # every switch detected on both sides
    assert delay_rows(both) == [
        "| detection delay, mean (s) | 0.5 | 0 | -0.5 |",
        "| detection delay, max (s) | 0.5 | 0 | -0.5 |",
    ]
    assert "not given" not in both
    other = _with_switches(report, (7, 0), (5, 2))
    assert delay_rows(other) == [
        "| detection delay, mean (s) | 0.5 | 0 | n/a (other switches) |",
        "| detection delay, max (s) | 0.5 | 0 | n/a (other switches) |",
    ]
    assert "so their change is not given (see true switches missed)" in other
    # as many detected on each side, some missed: which ones the counts cannot tell
    same_count = _with_switches(report, (5, 2), (5, 2))
    assert all(row.endswith("| n/a (switches missed) |") for row in delay_rows(same_count))
