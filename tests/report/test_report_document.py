"""The typed Report: the same report.json and report.md bytes as before, read back checked.

The expectations in tests/data/reports/ were written by the code that built the report as a
dict (see its README); the typed report must reproduce them byte for byte, read them back
into an equal object, and refuse anything that is not a report with a one-line
``ReportError`` naming the file and the key, never another exception.
"""

from __future__ import annotations

import copy
import dataclasses
import json
import pickle
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hybridlog.errors import ReportError
from hybridlog.estimators.result import EstimationResult, Fallbacks
from hybridlog.report import Report, build_report, read_report, render_markdown
from hybridlog.report import build as build_module
from hybridlog.report.gates import METRICS, evaluate_gates, metric, parse_gates
from hybridlog.report.report_json import indented_json
from hybridlog.report.report_parts import Smoothing
from hybridlog.signals import AlignedSignals
from tests.report.test_report_files import DT, make_run
from tests.report.test_report_gates import _side

DATA = Path(__file__).parents[1] / "data" / "reports"
VERSION = "0.1.0"  # the version the expectations were written with


def sample_run(name: str) -> tuple[EstimationResult, AlignedSignals, dict[str, Any]]:
    """The stored result and signals of an analysis of a sample log (see the README)."""
    with np.load(DATA / f"{name}.npz") as stored:
        arrays = {key: stored[key] for key in stored.files}
    meta = json.loads(str(arrays.pop("meta")))
    result = EstimationResult(
        estimator=meta["estimator"],
        options=meta["options"],
        time=arrays["time"],
        mode_ids=tuple(meta["mode_ids"]),
        state_names=tuple(meta["state_names"]),
        output_names=tuple(meta["output_names"]),
        modes=arrays["modes"],
        mode_probabilities=arrays["mode_probabilities"],
        state_means=arrays["state_means"],
        state_variances=arrays["state_variances"],
        output_predictions=arrays["output_predictions"],
        runtime_s=meta["runtime_s"],
        compile_s=meta["compile_s"],
        notes=tuple(meta["notes"]),
    )
    signals = AlignedSignals(
        source=meta["source"],
        time=arrays["time"],
        input_names=tuple(meta["input_names"]),
        output_names=tuple(meta["output_names"]),
        inputs=arrays["inputs"],
        outputs=arrays["outputs"],
        truth_modes=arrays.get("truth_modes"),
        state_names=tuple(meta["state_names"]),
        truth_states=arrays.get("truth_states"),
    )
    return result, signals, meta


def sample_report(name: str) -> Report:
    result, signals, meta = sample_run(name)
    return build_report(
        result, signals, log=meta["log"], model_name=meta["model"], dt=meta["dt"],
        reading=meta["reading"],
    )  # fmt: skip


def _stuck() -> Report:
    result, signals = make_run(n=60)
    truth = np.repeat(np.array([0, 1, 2], dtype=np.int64), 20)
    return build_report(
        dataclasses.replace(result, modes=np.ones(60, dtype=np.int64), runtime_s=0.0),
        dataclasses.replace(signals, truth_modes=truth),
        log="run.csv",
        model_name="tanks",
        dt=DT,
    )


def _undefined() -> Report:
    result, signals = make_run(n=30)
    flat = result.output_predictions.copy()
    flat[1:, 0] = 4.0
    flat[5:7, 1] = np.nan
    outputs = signals.outputs.copy()
    outputs[:, 1] = 2.5
    return build_report(
        dataclasses.replace(result, output_predictions=flat, notes=("a | note",)),
        dataclasses.replace(signals, outputs=outputs),
        log="run.csv",
        model_name="tanks",
        dt=DT,
    )


def _synthetic(n: int = 400, seed: int = 0, truth: bool = True, **kw: Any) -> Report:
    result, signals = make_run(n=n, seed=seed, truth=truth)
    return build_report(result, signals, log="run.csv", model_name="tanks", dt=DT, **kw)


NO_TRUTH_READING: dict[str, Any] = {
    "format": "csv",
    "fields": {  # which field fed each symbol, and who chose it (reading.fields)
        "u": {"field": "u", "from": "default"},
        "y1": {"field": "level | `1`", "from": "--map"},
        "y2": {"field": "/y2.data", "from": "[signals]"},
    },
    "dropped": {"x1": 1},
}


SYNTHETIC: dict[str, Callable[[], Report]] = {
    "synthetic_truth": lambda: _synthetic(seed=3),
    "synthetic_no_truth": lambda: _synthetic(seed=3, truth=False, reading=NO_TRUTH_READING),
    "synthetic_stuck": _stuck,
    "synthetic_undefined": _undefined,
    "synthetic_long": lambda: _synthetic(n=4000, seed=5),  # more than 50 true switches
    "synthetic_extra": lambda: _synthetic(
        n=30, extra={"compile_s": 2.0, "split": np.float64(np.nan), "gap": [1, np.int64(2)]}
    ),
}
SAMPLES = sorted(p.name.removesuffix(".npz") for p in DATA.glob("*.npz"))
CASES = SAMPLES + list(SYNTHETIC)


def built(name: str) -> Report:
    return sample_report(name) if name in SAMPLES else SYNTHETIC[name]()


@pytest.fixture(autouse=True)
def _pinned_version(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(build_module, "__version__", VERSION)


def test_every_expectation_is_a_case() -> None:
    stems = {p.name.split(".")[0] for p in DATA.glob("*.report.json")}
    assert stems == set(CASES) and len(SAMPLES) == 3


@pytest.mark.parametrize("name", CASES)
def test_report_json_and_md_are_the_bytes_written_before(name: str) -> None:
    report = built(name)
    assert report.to_json() == (DATA / f"{name}.report.json").read_text(encoding="utf-8")
    assert render_markdown(report) == (DATA / f"{name}.report.md").read_text(encoding="utf-8")


@pytest.mark.parametrize("name", CASES)
def test_reading_back_gives_the_same_report(name: str) -> None:
    text = (DATA / f"{name}.report.json").read_text(encoding="utf-8")
    again = Report.from_json(text)
    assert again.to_json() == text
    assert again == built(name)
    assert render_markdown(again) == (DATA / f"{name}.report.md").read_text(encoding="utf-8")


def test_further_keys_join_the_report_as_when_read_back() -> None:
    # with_extra adds keys that name no attribute without reading the report back: the
    # report and its report.json are those of the round trip through from_dict it replaces
    base = _synthetic(n=400, seed=5)
    extra = {"parameters": {"A": 150.0}, "origins": {"parameters.A": "--set A=150"}}
    added = base.with_extra(extra, source="run.csv")
    read_back = Report.from_dict({**base.to_dict(), **extra}, source="run.csv")
    assert added == read_back
    assert added.to_json() == read_back.to_json()
    assert list(added.to_dict())[-2:] == ["parameters", "origins"]
    assert added.with_extra({"mse": 0.5}).mse == 0.5  # an attribute's key replaces it
    with pytest.raises(ReportError, match=r"^run.csv: 'origins' holds a number that is not fin"):
        base.with_extra({"origins": {"x": float("inf")}}, source="run.csv")


def test_attributes_hold_the_json_values() -> None:
    report = sample_report("three_tank_hstf_hstf")
    data = json.loads(report.to_json())
    assert (report.samples, report.estimator, report.dt) == (301, "hstf", 1.0)
    assert report.vaf == data["vaf"] and report.fit == data["fit"]
    assert report.outputs["y2"].fit == data["outputs"]["y2"]["fit"]
    assert report.states["x3"].rmse == data["states"]["x3"]["rmse"]
    modes = report.modes
    assert modes.accuracy == data["modes"]["accuracy"]
    assert modes.detection is not None
    assert (modes.detection.detected, modes.detection.missed) == (1, 1)
    missed = modes.detection.events[0]
    assert (missed.from_mode, missed.to_mode, missed.detected, missed.delay_s) == (
        "1",
        "2",
        False,
        None,
    )
    assert modes.detection_delay_s == data["modes"]["detection_delay_s"] == 19.0
    assert modes.confusion is not None and modes.confusion["3"]["2"] == 19
    assert report.reading == {"format": "csv", "time": "log"}
    assert report.notes and "θ-rule" in report.notes[0]


def test_every_gate_metric_reads_its_json_value() -> None:
    # The gates' typed accessors and report.json name the same numbers (SPEC §8 paths).
    report = sample_report("three_tank_hstf_imm")
    data = json.loads(report.to_json())
    paths = {
        "vaf": ("vaf",),
        "mse": ("mse",),
        "fit": ("fit",),
        "mode_accuracy": ("modes", "accuracy"),
        "detection_delay_s": ("modes", "detection_delay_s"),
        "missed_switches": ("modes", "detection", "missed"),
        "runtime_s": ("runtime_s",),
        "samples_per_s": ("samples_per_s",),
    }
    fallbacks = {
        "smoothing_fallback_weight": ("smoothing", "fallbacks", "weight"),
        "smoothing_fallback_samples": ("smoothing", "fallbacks", "samples"),
    }
    assert set(paths) | set(fallbacks) == set(METRICS)
    for name, path in paths.items():
        value: Any = data
        for key in path:
            value = value[key]
        assert metric(report, name) == value, name
    # of a smoothed run's report; a filter's has none (None: its gate fails, saying why)
    assert "smoothing" not in data and metric(report, "smoothing_fallback_weight") is None
    counted = Fallbacks(3, 4, {"prediction": 0, "guard": 3, "rounding": 1, "covariance": 0}, 0.25)
    smoothed = dataclasses.replace(
        report,
        smoothing=Smoothing(
            "kim-rts", "argmax", "d", _side(0.8, 0, 0.1), _side(0.9, 0, 0.1), counted
        ),
    )
    smoothed_data = json.loads(smoothed.to_json())
    for name, path in fallbacks.items():
        value = smoothed_data
        for key in path:
            value = value[key]
        assert metric(smoothed, name) == value, name
    for y in ("y1", "y2", "y3"):
        for name in ("vaf", "mse", "fit"):
            assert metric(report, f"{name}.{y}") == data["outputs"][y][name]
    for x in ("x1", "x2", "x3"):
        assert metric(report, f"state_rmse.{x}") == data["states"][x]["rmse"]
    assert isinstance(metric(report, "missed_switches"), int)


def test_the_report_cannot_be_changed() -> None:
    report = sample_report("three_tank_hstf_imm")
    with pytest.raises(dataclasses.FrozenInstanceError):
        report.vaf = 100.0  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        report.modes.accuracy = 1.0  # type: ignore[misc]
    data = report.to_dict()
    data["options"]["transition_matrix"][0][0] = 0.5
    data["modes"]["labels"].append("9")
    assert report.to_dict() != data
    assert report.to_dict()["options"]["transition_matrix"][0][0] == 0.95
    assert report.modes.labels == ("1", "2", "3")
    with pytest.raises(ValueError, match="extra keys"):
        dataclasses.replace(report, extra={"vaf": 1.0})


def test_a_report_crosses_process_boundaries() -> None:
    # batch --jobs N sends each log's report from its worker process through a pipe
    report = sample_report("double_cart_case1_chiu")
    assert pickle.loads(pickle.dumps(report)) == report


def test_a_report_of_an_earlier_version_is_read_with_its_gaps() -> None:
    data = json.loads((DATA / "three_tank_hstf_hstf.report.json").read_text(encoding="utf-8"))
    for key in ("fit", "compile_s", "notes", "null_reasons", "reading"):
        del data[key]
    for output in data["outputs"].values():
        del output["fit"], output["samples"]
    for event in data["modes"]["detection"]["events"]:
        del event["miss_reason"]
    old = Report.from_dict(data)
    assert old.fit is None and old.compile_s is None and old.notes == ()
    assert old.outputs["y1"].samples is None and old.null_reasons == {}
    assert old.vaf == data["vaf"]
    (message,) = evaluate_gates(old, parse_gates(["fit.y1=0"]))
    assert message.startswith("fit.y1 is not available (no finite one-step-ahead prediction)")
    md = render_markdown(old)
    assert "- compilation" not in md and "| y1 | 193.884 | 74.6549 | n/a |" in md


def valid() -> dict[str, Any]:
    loaded: dict[str, Any] = json.loads(
        (DATA / "three_tank_hstf_hstf.report.json").read_text(encoding="utf-8")
    )
    return loaded


def changed(edit: Callable[[dict[str, Any]], None]) -> str:
    data = valid()
    edit(data)
    return json.dumps(data)


DEEP = "[" * 100_000 + "]" * 100_000

MALFORMED: list[tuple[str | bytes, str]] = [
    ("", "not JSON (Expecting value at line 1, column 1)"),
    ('{"hybridlog_version": "0.1.0",', "not JSON"),
    ("[1, 2]", "not a hybridlog report (no 'hybridlog_version' key)"),
    ('{"estimator": "imm"}', "not a hybridlog report"),
    (DEEP, "not strict JSON (nested too deeply)"),
    ('{"vaf": NaN}', "not strict JSON (NaN is not a JSON number)"),
    (changed(lambda d: d.pop("modes")), "'modes' is missing"),
    (changed(lambda d: d.update(samples="301")), "'samples' is a string; expected a whole number"),
    (changed(lambda d: d.update(samples=-1)), "'samples' is -1; expected a count (>= 0)"),
    (changed(lambda d: d.update(vaf=True)), "'vaf' is true/false; expected a number or null"),
    (changed(lambda d: d.update(dt=None)), "'dt' is null; expected a number"),
    (changed(lambda d: d.update(dt=10**400)), "'dt' is not a finite number"),
    (changed(lambda d: d.update(options=[])), "'options' is a list; expected an object"),
    (changed(lambda d: d.update(notes=[1])), "'notes[0]' is a number; expected a string"),
    (
        changed(lambda d: d["outputs"]["y2"].update(mse="x")),
        "'outputs.y2.mse' is a string; expected a number or null",
    ),
    (changed(lambda d: d["outputs"]["y2"].pop("vaf")), "'outputs.y2.vaf' is missing"),
    (
        changed(lambda d: d["modes"]["detection"]["events"][1].update(t="x")),
        "'modes.detection.events[1].t' is a string; expected a number",
    ),
    (
        changed(lambda d: d["modes"]["detection"].update(missed=0)),
        "'modes.detection.missed' is 0 but the events say 1",
    ),
    (
        changed(lambda d: d["modes"]["detection"]["events"][0].update(detected=True)),
        "'modes.detection.events[0].detected' is true but detected_t is None",
    ),
    (
        changed(lambda d: d["modes"].update(detection_delay_s=1.0)),
        "'modes.detection_delay_s' is 1.0 but detection.mean_s is 19.0",
    ),
    (
        changed(lambda d: d["modes"]["dwell_s"].pop("2")),
        "'modes.dwell_s' has keys ['1', '3']; expected the mode labels ['1', '2', '3']",
    ),
    (
        changed(lambda d: d["modes"]["confusion"]["1"].update({"9": 0})),
        "'modes.confusion.1' has keys",
    ),
    (changed(lambda d: d["modes"]["switches"].append(7)), "'modes.switches[1]' is a number"),
    (changed(lambda d: d.update(reading="csv")), "'reading' is a string; expected an object"),
    (changed(lambda d: d.update(null_reasons={"vaf": None})), "'null_reasons.vaf' is null"),
    (
        changed(lambda d: d.update(options={"a": json.loads("[" * 70 + "]" * 70)})),
        "'options' is nested deeper than 64 levels",
    ),
    (
        changed(lambda d: d["reading"].update(rate=1e400)).replace("Infinity", "1e400"),
        "'reading' holds a number that is not finite",
    ),
]


@pytest.mark.parametrize(("text", "fragment"), MALFORMED, ids=range(len(MALFORMED)))
def test_a_malformed_or_foreign_report_is_one_line_naming_file_and_key(
    text: str | bytes, fragment: str
) -> None:
    with pytest.raises(ReportError) as info:
        Report.from_json(text, source="out/run/report.json")
    message = str(info.value)
    assert message.startswith("out/run/report.json: ")
    assert fragment in message
    assert "\n" not in message and len(message) < 300


def test_an_unreadable_file_is_a_report_error(tmp_path: Path) -> None:
    with pytest.raises(ReportError, match=r"missing\.json: cannot read the report: No such"):
        read_report(tmp_path / "missing.json")
    binary = tmp_path / "report.json"
    binary.write_bytes(b"\xff\xfe{}")
    with pytest.raises(ReportError, match=r"report\.json: cannot read the report: not UTF-8"):
        read_report(binary)
    binary.write_text(valid()["modes"]["labels"][0], encoding="utf-8")
    with pytest.raises(ReportError, match="not a hybridlog report"):
        read_report(binary)
    binary.write_text(json.dumps(valid()), encoding="utf-8")
    assert read_report(binary) == Report.from_dict(valid())


json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=5),
    lambda inner: (
        st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=5), inner, max_size=3)
    ),
    max_leaves=8,
)


def _places(value: Any, path: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Every key path inside a parsed JSON value."""
    places = [path]
    if isinstance(value, dict):
        for key, item in value.items():
            places += _places(item, (*path, key))
    elif isinstance(value, list):
        for index, item in enumerate(value):
            places += _places(item, (*path, index))
    return places


PLACES = _places(valid())


@given(st.sampled_from(PLACES[1:]), json_values | st.just(...))
@settings(max_examples=300, deadline=None)
def test_any_value_anywhere_is_read_or_refused_never_a_crash(
    place: tuple[Any, ...], value: Any
) -> None:
    data = copy.deepcopy(valid())
    parent = data
    for key in place[:-1]:
        parent = parent[key]
    if value is ...:  # remove the key or list item
        del parent[place[-1]]
    else:
        parent[place[-1]] = value
    try:
        report = Report.from_dict(data, source="r.json")
    except ReportError as err:
        assert str(err).startswith("r.json: ") and "\n" not in str(err)
    else:
        assert Report.from_json(report.to_json()) == report
        render_markdown(report)


def test_batch_reads_earlier_reports_through_the_typed_report(tmp_path: Path) -> None:
    # A report.json of the same model and estimator is reused only when it is a report:
    # a malformed one is redone (it used to be "skipped" and then crash the summary).
    from hybridlog.io.writers import write_table
    from hybridlog.jobs.batch import run_batch
    from hybridlog.outputs.records import record_folder_files
    from tests.support.logfiles import tank_run

    log = write_table(tmp_path / "run.csv", tank_run(steps=60).columns)
    out = tmp_path / "batch"

    def batch() -> tuple[str, Report | None]:
        (outcome,) = run_batch([log], "three_tank_hstf", estimator="imm", out_dir=out).logs
        return outcome.status, outcome.report

    status, done = batch()
    assert status == "done" and done is not None
    assert batch() == ("skipped", done)  # read back equal to what was written
    stored = out / "run.csv" / "report.json"  # issue 9: the folder keeps the suffix
    stored.write_text(
        '{"hybridlog_version": "0.1.0", "model": "three_tank_hstf", "estimator": "imm"}'
    )
    record_folder_files(stored.parent)  # as hybridlog wrote it (an edit would be the user's)
    status, again = batch()
    assert status == "done" and again is not None and again.vaf == done.vaf
    assert read_report(stored) == again


TEXT = (DATA / "synthetic_stuck.report.json").read_bytes()


@given(st.lists(st.tuples(st.integers(0, len(TEXT) - 1), st.integers(0, 255)), max_size=4))
@settings(max_examples=300, deadline=None)
def test_any_damaged_file_is_read_or_refused_never_a_crash(flips: list[tuple[int, int]]) -> None:
    damaged = bytearray(TEXT)
    for offset, byte in flips:
        damaged[offset] = byte
    try:
        report = Report.from_json(bytes(damaged), source="r.json")
    except ReportError as err:
        assert str(err).startswith("r.json: ") and "\n" not in str(err)
    else:
        assert Report.from_json(report.to_json()) == report


_JSON_VALUES = st.recursive(
    st.none()
    | st.booleans()
    | st.integers()
    | st.floats(allow_nan=False, allow_infinity=False)
    | st.text(),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(), inner, max_size=4),
    max_leaves=25,
)


def _a_list_holds_a_container(value: Any) -> bool:
    if isinstance(value, dict):
        return any(_a_list_holds_a_container(item) for item in value.values())
    if isinstance(value, list):
        return any(isinstance(item, dict | list) for item in value)
    return False


@settings(max_examples=300, deadline=None)
@given(_JSON_VALUES)
def test_indented_json_is_the_value_and_indent_2_but_for_a_lists_items(value: Any) -> None:
    text = indented_json(value)
    assert json.loads(text) == value
    if not _a_list_holds_a_container(value):  # only a list's items are written on one line
        assert text == json.dumps(value, indent=2)


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -float("inf")])
def test_indented_json_refuses_non_finite_numbers_anywhere(bad: float) -> None:
    for value in ({"x": bad}, {"x": [{"y": bad}]}, [[bad]]):
        with pytest.raises(ValueError, match="not JSON compliant"):
            indented_json(value)
