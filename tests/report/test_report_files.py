"""write_report: files on disk, metrics recomputed from them, atomic output directories."""

from __future__ import annotations

import dataclasses
import json
import math
import time
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl
import pytest

import hybridlog
from hybridlog.errors import OptionError, OutputError
from hybridlog.estimators.result import EstimationResult, ResultShapeError, TimelineColumn
from hybridlog.report import atomic_output_dir, build_report, write_report
from hybridlog.report import writer as writer_module
from hybridlog.report.markdown import render_markdown
from hybridlog.report.table_format import check_table_format
from hybridlog.signals import NO_TRUE_MODE, AlignedSignals

DT = 0.05
T0 = 12.5
MODE_IDS = ("off", "low", "high")
STATES = ("x1", "x2", "x3")
OUTPUTS = ("y1", "y2")


def make_run(
    n: int = 400, *, truth: bool = True, seed: int = 0
) -> tuple[EstimationResult, AlignedSignals]:
    """A synthetic run: switching truth, a lagging and noisy mode estimate, noisy states."""
    rng = np.random.default_rng(seed)
    time = (T0 + np.arange(n) * DT).astype(np.float64)
    lengths = rng.integers(20, 80, size=n)
    seg = np.repeat(np.arange(lengths.size), lengths)[:n]
    truth_modes = (seg + rng.integers(1, 3, size=lengths.size)[seg]) % 3
    est = np.roll(truth_modes, 4)
    est[:4] = truth_modes[0]
    flips = rng.random(n) < 0.03
    est[flips] = rng.integers(0, 3, size=int(flips.sum()))
    probs = rng.random((n, 3)) + 2.0 * np.eye(3)[est]
    probs /= probs.sum(axis=1, keepdims=True)
    x_true = np.cumsum(rng.normal(size=(n, 3)), axis=0)
    x_hat = x_true + 0.3 * rng.normal(size=(n, 3))
    x_var = rng.uniform(0.05, 0.2, size=(n, 3))
    x_var[:, 2] = np.nan  # an estimator that defines no variance for x3
    y = np.column_stack([x_true[:, 0], x_true[:, 1] - x_true[:, 2]]) + 0.1 * rng.normal(size=(n, 2))
    y_hat = y + 0.2 * rng.normal(size=(n, 2))
    y_hat[0] = np.nan
    truth_states = x_true.copy()
    truth_states[:, 1] = np.nan  # the log has no truth for x2
    result = EstimationResult(
        estimator="imm",
        options={"stay_probability": 0.95, "gains": np.eye(2), "name": "x", "n": np.int64(3)},
        time=time,
        mode_ids=MODE_IDS,
        state_names=STATES,
        output_names=OUTPUTS,
        modes=est.astype(np.int64),
        mode_probabilities=probs,
        state_means=x_hat,
        state_variances=x_var,
        output_predictions=y_hat,
        runtime_s=0.25,
        compile_s=1.5,
    )
    signals = AlignedSignals(
        source="run.csv",
        time=time,
        input_names=("u",),
        output_names=OUTPUTS,
        inputs=rng.normal(size=(n, 1)),
        outputs=y,
        truth_modes=truth_modes.astype(np.int64) if truth else None,
        state_names=STATES,
        truth_states=truth_states if truth else None,
    )
    return result, signals


def read_table(path: Path) -> pl.DataFrame:
    if path.suffix == ".parquet":
        return pl.read_parquet(path)
    header = path.read_text().splitlines()[0].split(",")
    strings = {"mode", "truth_mode"}
    schema = {
        c: (pl.String if c in strings or c.startswith("mode.") else pl.Float64) for c in header
    }
    return pl.read_csv(path, schema=schema)


def strict_json(path: Path) -> dict[str, Any]:
    def no_constants(name: str) -> None:
        raise AssertionError(f"non-strict JSON constant {name}")

    loaded: dict[str, Any] = json.loads(path.read_text(), parse_constant=no_constants)
    return loaded


def close(a: float | None, b: float | None) -> bool:
    if a is None or b is None:
        return a is None and b is None
    return math.isclose(a, b, rel_tol=1e-12, abs_tol=0.0)


def recompute(timeline: pl.DataFrame, estimates: pl.DataFrame, dt: float) -> dict[str, Any]:
    """Every metric of report.json, computed independently from the two tables."""
    out: dict[str, Any] = {"outputs": {}, "states": {}, "modes": {}}
    for y in OUTPUTS:
        d = estimates.select(pl.col(y), pl.col(f"{y}_hat")).drop_nulls()
        e = d[y] - d[f"{y}_hat"]
        mse = float((e * e).mean())  # type: ignore[arg-type]
        var_e = float(e.var(ddof=0))  # type: ignore[arg-type]
        var_hat = float(d[f"{y}_hat"].var(ddof=0))  # type: ignore[arg-type]
        vaf = max(1.0 - var_e / var_hat, 0.0) * 100.0
        # MATLAB compare's NRMSE fit: 100 (1 - |y - ŷ| / |y - mean(y)|)
        spread = d[y] - d[y].mean()
        fit = 100.0 * (1.0 - math.sqrt(float((e * e).sum())) / math.sqrt(float((spread**2).sum())))
        out["outputs"][y] = {"mse": mse, "vaf": vaf, "fit": fit, "samples": d.height}
    for key in ("mse", "vaf", "fit"):
        out[key] = sum(v[key] for v in out["outputs"].values()) / len(OUTPUTS)
    for x in STATES:
        if f"{x}_true" in estimates.columns:
            d = estimates.select(pl.col(f"{x}_hat"), pl.col(f"{x}_true")).drop_nulls()
            err = d[f"{x}_hat"] - d[f"{x}_true"]
            out["states"][x] = {"rmse": math.sqrt(float((err * err).mean()))}  # type: ignore[arg-type]
        else:
            out["states"][x] = {"rmse": None}

    t = timeline["t"].to_list()
    mode = timeline["mode"].to_list()
    labels = [c.removeprefix("p_") for c in timeline.columns if c.startswith("p_")]
    modes: dict[str, Any] = {"labels": labels}
    modes["switches"] = [
        {"t": t[k], "from": mode[k - 1], "to": mode[k]}
        for k in range(1, len(mode))
        if mode[k] != mode[k - 1]
    ]
    dwell = dict.fromkeys(labels, 0.0)
    for k, m in enumerate(mode):
        dwell[m] += (t[k + 1] - t[k]) if k + 1 < len(t) else dt
    modes["dwell_s"] = dwell
    if "truth_mode" in timeline.columns:
        truth = timeline["truth_mode"].to_list()
        modes["accuracy"] = sum(a == b for a, b in zip(mode, truth, strict=True)) / len(mode)
        counts = timeline.group_by("truth_mode", "mode").len().rows()  # (true, estimated, count)
        confusion = {a: dict.fromkeys(labels, 0) for a in labels}
        for a, b, c in counts:
            confusion[a][b] = c
        modes["confusion"] = confusion
        delays = []
        starts = [k for k in range(1, len(truth)) if truth[k] != truth[k - 1]]
        for i, s in enumerate(starts):
            end = starts[i + 1] if i + 1 < len(starts) else len(truth)
            # detected only by an estimated change *into* the new mode (SPEC §8)
            hit = next(
                (k for k in range(s, end) if mode[k] == truth[s] != mode[k - 1]),
                None,
            )
            if hit is not None:
                delays.append(t[hit] - t[s])
        modes["detection_delay_s"] = sum(delays) / len(delays) if delays else None
        modes["missed"] = len(starts) - len(delays)
    else:
        modes["accuracy"] = modes["confusion"] = modes["detection_delay_s"] = None
    out["modes"] = modes
    out["samples"] = timeline.height
    out["t_start"] = t[0]
    out["t_end"] = t[-1]
    return out


def assert_report_matches(report: dict[str, Any], again: dict[str, Any]) -> None:
    for y in OUTPUTS:
        for key in ("mse", "vaf", "fit"):
            assert close(report["outputs"][y][key], again["outputs"][y][key]), (y, key)
        assert report["outputs"][y]["samples"] == again["outputs"][y]["samples"]
    for key in ("mse", "vaf", "fit"):
        assert close(report[key], again[key]), key
    for x in STATES:
        assert close(report["states"][x]["rmse"], again["states"][x]["rmse"]), x
    m, m2 = report["modes"], again["modes"]
    assert m["labels"] == m2["labels"]
    assert len(m["switches"]) == len(m2["switches"])
    for s, s2 in zip(m["switches"], m2["switches"], strict=True):
        assert (s["from"], s["to"]) == (s2["from"], s2["to"])
        assert close(s["t"], s2["t"])
    for label in m["labels"]:
        assert close(m["dwell_s"][label], m2["dwell_s"][label]), label
    assert close(m["accuracy"], m2["accuracy"])
    assert m["confusion"] == m2["confusion"]
    assert close(m["detection_delay_s"], m2["detection_delay_s"])
    if m2["accuracy"] is not None:
        assert m["detection"]["missed"] == m2["missed"]
    assert report["samples"] == again["samples"]
    assert close(report["t_start"], again["t_start"])
    assert close(report["t_end"], again["t_end"])


SPEC_KEYS = {
    "hybridlog_version",
    "log",
    "model",
    "estimator",
    "options",
    "samples",
    "dt",
    "t_start",
    "t_end",
    "outputs",
    "mse",
    "vaf",
    "fit",
    "modes",
    "states",
    "runtime_s",
    "samples_per_s",
}
MODE_KEYS = {"labels", "switches", "dwell_s", "accuracy", "confusion", "detection_delay_s"}


@pytest.mark.parametrize("table_format", ["csv", "parquet"])
@pytest.mark.parametrize("truth", [True, False], ids=["truth", "no-truth"])
def test_report_json_matches_metrics_recomputed_from_tables(
    tmp_path: Path, truth: bool, table_format: str
) -> None:
    result, signals = make_run(truth=truth, seed=3)
    out = tmp_path / "out"
    returned = write_report(
        out, result, signals, log="run.csv", model_name="tanks", dt=DT, table_format=table_format
    )
    report = strict_json(out / "report.json")
    assert report == returned.to_dict()
    assert report.keys() >= SPEC_KEYS
    assert report["modes"].keys() >= MODE_KEYS
    assert report["hybridlog_version"] == hybridlog.__version__
    assert (report["log"], report["model"], report["estimator"]) == ("run.csv", "tanks", "imm")
    assert report["options"] == {
        "stay_probability": 0.95,
        "gains": [[1.0, 0.0], [0.0, 1.0]],
        "name": "x",
        "n": 3,
    }
    assert report["dt"] == DT
    assert report["samples_per_s"] == pytest.approx(400 / 0.25)
    assert report["compile_s"] == 1.5

    timeline = read_table(out / f"timeline.{table_format}")
    estimates = read_table(out / f"estimates.{table_format}")
    assert timeline.columns == ["t", "mode", "p_off", "p_low", "p_high"] + (
        ["truth_mode"] if truth else []
    )
    expected_est = ["t", "x1_hat", "x1_var", "x2_hat", "x2_var", "x3_hat", "x3_var"]
    expected_est += ["y1_hat", "y1", "y2_hat", "y2"]
    expected_est += ["x1_true", "x3_true"] if truth else []
    assert estimates.columns == expected_est
    assert timeline.height == estimates.height == 400

    again = recompute(timeline, estimates, DT)
    assert_report_matches(report, again)
    if truth:
        assert report["modes"]["accuracy"] is not None
        assert report["modes"]["detection_delay_s"] is not None
        assert report["modes"]["detection"]["detected"] > 0
        assert report["states"]["x2"]["rmse"] is None  # NaN truth column
        assert report["states"]["x1"]["rmse"] is not None
    else:
        for key in ("accuracy", "confusion", "detection_delay_s", "detection"):
            assert report["modes"][key] is None
        assert all(s["rmse"] is None for s in report["states"].values())

    assert {p.name for p in (out / "plots").iterdir()} == {
        "outputs.png",
        "modes.png",
        "states.png",
    }
    for png in (out / "plots").iterdir():
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    md = (out / "report.md").read_text()
    assert "| y1 |" in md and "| x1 |" in md
    assert ("Confusion" in md) == truth


def test_csv_writes_missing_values_as_empty_cells(tmp_path: Path) -> None:
    result, signals = make_run(n=50)
    write_report(tmp_path / "o", result, signals, log="l", model_name="m", dt=DT)
    lines = (tmp_path / "o" / "estimates.csv").read_text().splitlines()
    header = lines[0].split(",")
    row0 = dict(zip(header, lines[1].split(","), strict=True))
    row1 = dict(zip(header, lines[2].split(","), strict=True))
    assert row0["y1_hat"] == row0["y2_hat"] == ""  # no prediction for the prior
    assert row1["x3_var"] == ""  # no variance defined
    assert "nan" not in (tmp_path / "o" / "estimates.csv").read_text().lower()
    assert float(row1["y1_hat"]) == result.output_predictions[1, 0]  # full precision


def test_timeline_values(tmp_path: Path) -> None:
    result, signals = make_run(n=60)
    write_report(tmp_path / "o", result, signals, log="l", model_name="m", dt=DT)
    timeline = read_table(tmp_path / "o" / "timeline.csv")
    assert timeline["mode"].to_list() == [result.mode_ids[m] for m in result.modes]
    assert signals.truth_modes is not None
    assert timeline["truth_mode"].to_list() == [MODE_IDS[i] for i in signals.truth_modes]
    np.testing.assert_array_equal(timeline["p_low"].to_numpy(), result.mode_probabilities[:, 1])
    np.testing.assert_array_equal(timeline["t"].to_numpy(), result.time)


def test_estimator_timeline_columns_follow_the_standard_ones(tmp_path: Path) -> None:
    result, signals = make_run(n=40)
    n = result.n_samples
    delta = np.linspace(-0.2, 1.2, n)
    delta[3] = np.nan
    component = (np.arange(n) // 10 % 3).astype(np.int64)
    extra = (
        TimelineColumn("delta_tilde.d1", delta),
        TimelineColumn("mode.valve", component, labels=("open", "closed", "unknown")),
    )
    result = dataclasses.replace(result, timeline_columns=extra)
    write_report(tmp_path / "o", result, signals, log="l", model_name="m", dt=DT)
    timeline = read_table(tmp_path / "o" / "timeline.csv")
    assert timeline.columns[-2:] == ["delta_tilde.d1", "mode.valve"]
    assert timeline["delta_tilde.d1"][3] is None
    np.testing.assert_array_equal(timeline["delta_tilde.d1"].to_numpy()[4:], delta[4:])
    assert timeline["mode.valve"].to_list() == [("open", "closed", "unknown")[i] for i in component]


@pytest.mark.parametrize(
    "column",
    [
        TimelineColumn("mode", np.zeros(5)),  # a standard column's name
        TimelineColumn("x", np.zeros(4)),  # wrong length
        TimelineColumn("x", np.zeros(5, dtype=np.int64)),  # labels missing
        TimelineColumn("x", np.full(5, 2, dtype=np.int64), labels=("a", "b")),  # out of range
    ],
)
def test_a_bad_timeline_column_is_a_defect_of_the_estimator(column: TimelineColumn) -> None:
    result, _ = make_run(n=5)
    with pytest.raises(ResultShapeError, match="timeline column"):
        dataclasses.replace(result, timeline_columns=(column,))


@pytest.mark.parametrize("table_format", ["csv", "parquet"])
def test_streamed_tables_equal_the_whole_frame(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, table_format: str
) -> None:
    """Tables are streamed in batches; the files hold what one whole frame would write (and
    a table of one batch is written whole, without the sink: 2 ms less per table)."""
    from hybridlog.report import tables

    result, signals = make_run(n=250)
    fmt = check_table_format(table_format)
    for build in (tables.timeline_table, tables.estimates_table):
        table = build(result, signals)
        monkeypatch.setattr(tables, "BATCH_ROWS", 64)  # 250 rows: four batches, the last short
        streamed = tables.write_table(table, tmp_path / f"streamed_{build.__name__}", fmt)
        monkeypatch.setattr(tables, "BATCH_ROWS", 250)  # one batch
        whole = tables.write_table(table, tmp_path / f"whole_{build.__name__}", fmt)
        if fmt == "csv":
            assert streamed.read_bytes() == whole.read_bytes()
        else:
            got, want = pl.read_parquet(streamed), pl.read_parquet(whole)
            assert got.schema == want.schema
            assert got.equals(want)  # nulls where NaN, labels, order of rows
        assert read_table(streamed).height == 250


def test_a_lazy_table_projects_filters_and_limits_like_its_frame(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from hybridlog.report import tables

    monkeypatch.setattr(tables, "BATCH_ROWS", 16)
    result, signals = make_run(n=100)
    table = tables.timeline_table(result, signals)
    frame = table.frame()
    for query in (
        lambda f: f.select("t", "mode"),
        lambda f: f.filter(pl.col("mode") == "low").select("p_low"),
        lambda f: f.head(37),
        lambda f: f.filter(pl.col("t") > T0 + 2.0).head(5),
    ):
        assert query(table.lazy()).collect().equals(query(frame.lazy()).collect())


def test_extra_keys_are_merged(tmp_path: Path) -> None:
    result, signals = make_run(n=30)
    report = write_report(
        tmp_path / "o",
        result,
        signals,
        log="l",
        model_name="m",
        dt=DT,
        extra={"compile_s": 2.0, "split": np.float64(np.nan), "gap": [1, np.int64(2)]},
    ).to_dict()
    assert report["compile_s"] == 2.0
    assert report["split"] is None
    assert strict_json(tmp_path / "o" / "report.json")["gap"] == [1, 2]


def test_zero_runtime_gives_null_speed(tmp_path: Path) -> None:
    result, signals = make_run(n=30)
    from dataclasses import replace

    report = write_report(
        tmp_path / "o", replace(result, runtime_s=0.0), signals, log="l", model_name="m", dt=DT
    ).to_dict()
    assert report["samples_per_s"] is None


def test_large_run_is_quick(tmp_path: Path) -> None:
    import time

    result, signals = make_run(n=100_000, seed=1)
    start = time.perf_counter()
    write_report(tmp_path / "o", result, signals, log="l", model_name="m", dt=DT)
    assert time.perf_counter() - start < 20.0


def test_unknown_table_format_is_an_option_error(tmp_path: Path) -> None:
    result, signals = make_run(n=20)
    with pytest.raises(OptionError, match="xlsx"):
        write_report(
            tmp_path / "o", result, signals, log="l", model_name="m", dt=DT, table_format="xlsx"
        )
    assert not (tmp_path / "o").exists()


# --- atomic output directories ----------------------------------------------------------------


def snapshot(directory: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(directory)): p.read_bytes() for p in directory.rglob("*") if p.is_file()
    }


def test_existing_nonempty_dir_is_refused_and_untouched(tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    result, signals = make_run(n=20)
    with pytest.raises(OutputError, match="not empty") as info:
        write_report(out, result, signals, log="l", model_name="m", dt=DT)
    assert str(out) in str(info.value)
    assert "\n" not in str(info.value)
    assert snapshot(out) == {"keep.txt": b"mine"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_force_replaces_an_existing_dir(tmp_path: Path) -> None:
    # --force replaces only a folder hybridlog wrote (SPEC §9); a user's own folder is
    # refused (tests/jobs/test_outputs_safety.py).
    out = tmp_path / "out"
    result, signals = make_run(n=20)
    write_report(out, result, signals, log="l", model_name="m", dt=DT)
    (out / "report.md").unlink()  # a file hybridlog wrote, gone: nothing of the user's lost
    write_report(out, result, signals, log="l", model_name="m", dt=DT, force=True)
    assert (out / "report.md").is_file() and (out / "report.json").is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    # a file hybridlog wrote there and the user edited is the user's: never replaced
    (out / "report.md").write_text("edited")
    with pytest.raises(OutputError, match=r"changed since hybridlog wrote them \('report.md'\)"):
        write_report(out, result, signals, log="l", model_name="m", dt=DT, force=True)
    assert (out / "report.md").read_text() == "edited"
    (out / "report.md").unlink()
    # a file hybridlog did not write there is never deleted with the folder
    (out / "old.txt").write_text("old")
    with pytest.raises(OutputError, match=r"holds files hybridlog did not write \('old.txt'\)"):
        write_report(out, result, signals, log="l", model_name="m", dt=DT, force=True)
    assert (out / "old.txt").read_text() == "old"
    (out / "old.txt").unlink()
    # another output written into it since is named as hybridlog's, not as the user's files
    write_report(out / "sub", result, signals, log="l", model_name="m", dt=DT)
    with pytest.raises(OutputError, match=r"holds another output of hybridlog's, .* \('sub/'\)"):
        write_report(out, result, signals, log="l", model_name="m", dt=DT, force=True)
    assert (out / "sub" / "report.json").is_file()


def test_empty_existing_dir_and_missing_parents_are_fine(tmp_path: Path) -> None:
    result, signals = make_run(n=20)
    (tmp_path / "empty").mkdir()
    write_report(tmp_path / "empty", result, signals, log="l", model_name="m", dt=DT)
    assert (tmp_path / "empty" / "report.md").is_file()
    write_report(tmp_path / "a" / "b" / "c", result, signals, log="l", model_name="m", dt=DT)
    assert (tmp_path / "a" / "b" / "c" / "timeline.csv").is_file()


@pytest.mark.parametrize("existing", [False, True])
def test_failure_while_writing_leaves_nothing_behind(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, existing: bool
) -> None:
    out = tmp_path / "out"
    result, signals = make_run(n=20)
    if existing:  # an earlier report (--force replaces only what hybridlog wrote)
        write_report(out, result, signals, log="l", model_name="m", dt=DT)
        before = snapshot(out)

    def broken(*args: object) -> list[Path]:
        raise RuntimeError("disk on fire")

    monkeypatch.setattr(writer_module, "draw_into", broken)
    with pytest.raises(RuntimeError, match="disk on fire"):
        write_report(out, result, signals, log="l", model_name="m", dt=DT, force=True)
    if existing:
        assert snapshot(out) == before
        assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    else:
        assert list(tmp_path.iterdir()) == []


def test_a_failure_beside_the_drawing_waits_for_it_and_leaves_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The plots are drawn in a thread; a failure meanwhile (report.md is written beside the
    drawing) must not remove the folder under the thread (nor leave what it writes
    afterwards)."""
    import threading

    out = tmp_path / "out"
    result, signals = make_run(n=20)
    drawn = threading.Event()

    def slow_plots(plot_dir: Path, *args: object) -> list[Path]:
        plot_dir.mkdir()
        time.sleep(0.2)  # still drawing when report.md fails
        (plot_dir / "outputs.png").write_bytes(b"png")
        drawn.set()
        return [plot_dir / "outputs.png"]

    def broken(*args: object) -> None:
        raise RuntimeError("disk on fire")

    monkeypatch.setattr(writer_module, "draw_into", slow_plots)
    monkeypatch.setattr(writer_module, "render_markdown", broken)
    with pytest.raises(RuntimeError, match="disk on fire"):
        write_report(out, result, signals, log="l", model_name="m", dt=DT)
    assert drawn.is_set()  # waited for, before the temporary folder was removed
    assert list(tmp_path.iterdir()) == []


def test_atomic_output_dir_refuses_a_file(tmp_path: Path) -> None:
    target = tmp_path / "file"
    target.write_text("x")
    with pytest.raises(OutputError, match="not a directory"), atomic_output_dir(target, force=True):
        pass
    assert target.read_text() == "x"


def test_atomic_output_dir_writes_only_on_success(tmp_path: Path) -> None:
    target = tmp_path / "t"
    with atomic_output_dir(target) as tmp:
        (tmp / "a.txt").write_text("a")
        assert tmp.parent == tmp_path
        assert not target.exists()
    assert (target / "a.txt").read_text() == "a"
    assert [p.name for p in tmp_path.iterdir()] == ["t"]


def test_a_switch_into_the_mode_the_estimate_is_stuck_in_is_reported_missed(
    tmp_path: Path,
) -> None:
    from dataclasses import replace

    result, signals = make_run(n=60)
    truth = np.repeat(np.array([0, 1, 2], dtype=np.int64), 20)
    stuck = np.ones(60, dtype=np.int64)  # wrongly in "low" from the start, never leaves
    report = write_report(
        tmp_path / "o",
        replace(result, modes=stuck),
        replace(signals, truth_modes=truth),
        log="l",
        model_name="m",
        dt=DT,
    ).to_dict()
    detection = report["modes"]["detection"]
    assert (detection["detected"], detection["missed"]) == (0, 2)
    into_low, into_high = detection["events"]
    assert into_low["to"] == "low" and into_low["detected"] is False
    assert into_low["delay_s"] is None
    assert "already in mode low" in into_low["miss_reason"]
    assert "never changed into mode high" in into_high["miss_reason"]
    assert report["modes"]["detection_delay_s"] is None
    assert report["null_reasons"]["detection_delay_s"] == "every true switch (2) was missed"
    md = (tmp_path / "o" / "report.md").read_text()
    assert "2 true mode switches: 0 detected, 2 missed" in md
    assert "missed: the estimate was already in mode low" in md
    assert "first estimated change *into* the new mode" in md  # the definition is documented
    assert "0 estimated mode switches." in md


def test_undefined_metrics_are_null_with_their_reason(tmp_path: Path) -> None:
    from dataclasses import replace

    result, signals = make_run(n=30)
    flat = result.output_predictions.copy()
    flat[1:, 0] = 4.0  # a constant prediction of y1: var(ŷ) = 0
    flat[5:7, 1] = np.nan  # a filter that produced no prediction of y2 at two samples
    outputs = signals.outputs.copy()
    outputs[:, 1] = 2.5  # a constant measurement of y2: ‖y − ȳ‖ = 0
    report = write_report(
        tmp_path / "o",
        replace(result, output_predictions=flat),
        replace(signals, outputs=outputs),
        log="l",
        model_name="m",
        dt=DT,
    ).to_dict()
    assert report["outputs"]["y1"]["vaf"] is None and report["outputs"]["y1"]["fit"] is not None
    assert report["outputs"]["y2"]["fit"] is None and report["outputs"]["y2"]["vaf"] is not None
    assert report["vaf"] == report["outputs"]["y2"]["vaf"]  # mean over outputs where defined
    reasons = report["null_reasons"]
    assert reasons["vaf.y1"].startswith("var(ŷ) = 0")
    assert reasons["fit.y2"].startswith("‖y − mean(y)‖ = 0")
    assert "vaf" not in reasons and "mse.y1" not in reasons
    md = (tmp_path / "o" / "report.md").read_text()
    assert "- vaf.y1 is n/a: var(ŷ) = 0" in md
    assert report["outputs"]["y2"]["samples"] == 27 and report["outputs"]["y1"]["samples"] == 29
    assert "- y2: metrics over 27 of 29 samples" in md and "- y1: metrics over" not in md
    assert "| y1 | " in md and "| n/a |" in md


def test_a_diverged_output_is_never_left_out_of_the_means(tmp_path: Path) -> None:
    """MSE of a prediction whose squared error overflows is beyond float64's range, not
    undefined: the mean MSE
    left y2 out (0.04 from y1 alone, so --fail-over mse=1 passed on a diverged run), and
    report.md wrote fit -1.3e201 as a number of 200 digits."""
    from dataclasses import replace

    from hybridlog.report.gates import evaluate_gates, parse_gates

    result, signals = make_run(n=30)
    diverged = result.output_predictions.copy()
    diverged[1:, 1] = 1e200 * np.arange(1.0, 30.0)  # y2's error overflows float64
    written = write_report(
        tmp_path / "o",
        replace(result, output_predictions=diverged),
        signals,
        log="l",
        model_name="m",
        dt=DT,
    )
    report = written.to_dict()
    assert report["outputs"]["y2"]["mse"] is None and report["outputs"]["y1"]["mse"] < 1
    assert report["mse"] is None
    assert report["null_reasons"]["mse"].startswith(
        "a mean over the outputs cannot leave out mse.y2, which float64 cannot hold: MSE ≈ "
    )
    assert report["vaf"] is not None  # VAF 0 for y2: its variance ratio overflows, defined
    (failure,) = evaluate_gates(written, parse_gates([], ["mse=1"]))
    assert failure.startswith("mse is not available (a mean over the outputs cannot leave out")
    md = (tmp_path / "o" / "report.md").read_text()
    assert report["fit"] < -1e199 and "e+20" in md
    cells = [cell for line in md.splitlines() if line.startswith("|") for cell in line.split("|")]
    assert max(map(len, cells)) < 30  # no number of 200 digits


def test_report_md_reads_well(tmp_path: Path) -> None:
    from dataclasses import replace

    result, signals = make_run(n=40)
    one_switch = np.repeat(np.array([0, 2], dtype=np.int64), 20)
    write_report(
        tmp_path / "o",
        replace(result, modes=one_switch, runtime_s=0.00031),
        signals,
        log="l",
        model_name="m",
        dt=DT,
    )
    md = (tmp_path / "o" / "report.md").read_text()
    assert "1 estimated mode switch." in md
    assert "- estimation: 310 µs (129,032 samples/s)" in md
    assert "- compilation: 1.5 s" in md


@pytest.mark.parametrize("n", [1, 2])
def test_a_run_too_short_for_the_metrics_is_refused(tmp_path: Path, n: int) -> None:
    # Issue 7: 1- and 2-row logs gave exit 0 with "VAF 100 %".
    from hybridlog.errors import LogError
    from hybridlog.report.build import MIN_SAMPLES

    result, signals = make_run(n=n)
    with pytest.raises(LogError, match=rf"^short\.csv: too short: {n} samples? .* at least 3"):
        write_report(tmp_path / "o", result, signals, log="short.csv", model_name="m", dt=DT)
    assert not (tmp_path / "o").exists()
    result, signals = make_run(n=MIN_SAMPLES)
    write_report(tmp_path / "o", result, signals, log="short.csv", model_name="m", dt=DT)


def test_tables_for_people_format_numbers_per_column() -> None:
    from hybridlog.report.markdown import duration, plural
    from hybridlog.report.summary_tables import markdown_table

    table = markdown_table(
        ("estimator", "vaf", "mse", "samples_per_s", "missed", "error"),
        [
            ["hstf", 66.8775, 110.028, 491277.3, 1, None],
            ["imm", 87.3912, 5.66412, 1668410.2, 0, "a | b"],
        ],
    )
    assert table.splitlines() == [
        "| estimator | vaf | mse | samples_per_s | missed | error |",
        "|---|---:|---:|---:|---:|---|",
        "| hstf | 66.88 | 110.028 | 491,277 | 1 | n/a |",
        "| imm | 87.39 | 5.664 | 1,668,410 | 0 | a \\| b |",
    ]
    spread = markdown_table(("mse",), [[9.76e-6], [0.1419]])  # paper 001: would need 9 decimals
    assert spread.splitlines()[2:] == ["| 9.760e-06 |", "| 1.419e-01 |"]
    huge = markdown_table(("fit",), [[-1.346e201]])  # a diverged run: it was 201 digits
    assert huge.splitlines()[2:] == ["| -1.346e+201 |"]
    assert [duration(s) for s in (0.00031, 2.5e-6, 12.345, 0.0, None)] == [
        "310 µs",
        "2.5 µs",
        "12.3 s",
        "0 s",
        "n/a",
    ]
    assert [plural(n, "switch") for n in (0, 1, 2, 1500)] == [
        "0 switches",
        "1 switch",
        "2 switches",
        "1,500 switches",
    ]


def test_report_md_says_what_the_users_repairs_of_the_log_changed(tmp_path: Path) -> None:
    """--split-gaps analysed one piece of a log and --drop-nonfinite took samples out, which
    report.json's ``reading`` recorded but report.md did not say: its sample count and time
    span read like the whole log's."""
    from hybridlog.io import ReadOptions
    from hybridlog.jobs.analysis import analyze
    from tests.support.paths import TANK_CSV

    frame = pl.read_csv(TANK_CSV)
    gapped = tmp_path / "gapped.csv"
    frame.filter((pl.col("t") < 100) | (pl.col("t") >= 130)).write_csv(gapped)
    done = analyze(
        gapped, "three_tank_hstf", out_dir=tmp_path / "g", estimator="imm", smooth=True,
        read=ReadOptions(split_gaps=True),
    )  # fmt: skip
    assert done.report is not None
    end = frame["t"][-1]
    note = (
        "NOTE: --split-gaps: 1 output gap longer than max_gap (t = 99 … 130 s) cut the log "
        f"into 2 pieces; the longest is analysed, t = 130 … {end:g} s; not analysed: "
        "t = 0 … 99 s"
    )
    assert note in done.report.notes
    assert f"- {note}" in (tmp_path / "g" / "report.md").read_text()
    y1 = frame["y1"].to_numpy().copy()
    y1[[5, 17, 40]] = np.nan
    holed = tmp_path / "holed.csv"
    frame.with_columns(pl.Series("y1", y1)).write_csv(holed)
    done = analyze(
        holed, "three_tank_hstf", out_dir=tmp_path / "h", estimator="imm",
        read=ReadOptions(drop_nonfinite=True),
    )  # fmt: skip
    assert done.report is not None
    assert "NOTE: --drop-nonfinite dropped NaN or infinite samples: y1 3" in done.report.notes
    written = json.loads((tmp_path / "h" / "report.json").read_text())
    assert written["reading"]["nonfinite_dropped"] == {"y1": 3}
    assert "NOTE: --drop-nonfinite dropped NaN or infinite samples: y1 3" in written["notes"]
    shuffled = tmp_path / "shuffled.csv"
    pl.concat([frame[:10], frame[12:13], frame[10:12], frame[12:]]).write_csv(shuffled)
    done = analyze(
        shuffled, "three_tank_hstf", out_dir=tmp_path / "s", estimator="imm",
        read=ReadOptions(sort=True),
    )  # fmt: skip
    assert done.report is not None
    assert done.report.notes[-2:] == (
        "NOTE: --sort put samples that went back in time in order: 1 row",
        "NOTE: --sort dropped samples of a time already seen, keeping the last: 1 row",
    )


def test_report_md_says_what_sort_merged_and_which_truth_was_not_used(tmp_path: Path) -> None:
    """--sort merging a long-format CSV's rows (a row per signal), and ground truth found by
    default but without samples, were in report.json's ``reading`` only."""
    from hybridlog.io import ReadOptions
    from hybridlog.jobs.analysis import analyze
    from tests.support.paths import TANK_CSV

    frame = pl.read_csv(TANK_CSV).select("t", "u", "y1", "y2", "y3")
    # a row per signal: the input at each time, then the outputs at the same time
    empty = {name: pl.lit(None, dtype=pl.Float64) for name in ("u", "y1", "y2", "y3")}
    inputs = frame.select("t", "u").with_columns(**{k: v for k, v in empty.items() if k != "u"})
    outputs = frame.select("t", "y1", "y2", "y3").with_columns(u=empty["u"])
    columns = ["t", "u", "y1", "y2", "y3"]
    long = pl.concat([inputs.select(columns), outputs.select(columns)]).sort(
        "t", maintain_order=True
    )
    long = long.with_columns(mode=pl.lit(None, dtype=pl.Int64))
    path = tmp_path / "long.csv"
    long.write_csv(path)
    done = analyze(
        path, "three_tank_hstf", out_dir=tmp_path / "out", estimator="imm",
        read=ReadOptions(sort=True),
    )  # fmt: skip
    assert done.report is not None
    rows = frame.height
    assert done.report.samples == rows
    expected = (
        "NOTE: --sort merged rows of a time already seen into that time's sample, column by "
        f"column: {rows:,} rows",
        "NOTE: ground truth fields without samples, not used: truth.mode (column 'mode')",
    )
    assert all(note in done.report.notes for note in expected), done.report.notes
    text = (tmp_path / "out" / "report.md").read_text()
    assert all(f"- {note}" in text for note in expected)


def test_a_true_mode_starting_late_is_scored_over_the_samples_it_covers(tmp_path: Path) -> None:
    """A true mode that starts late was refused when read, while a true state that starts
    late is scored over the samples it covers (states.<x>.samples).  The samples before its
    first have no true mode (NO_TRUE_MODE): accuracy, confusion and switches are of the rest,
    counted in modes.samples, said in report.md, and the timeline leaves their truth empty."""
    result, signals = make_run(seed=3)
    assert signals.truth_modes is not None
    start = 57
    late = signals.truth_modes.copy()
    late[:start] = NO_TRUE_MODE
    report = write_report(
        tmp_path / "o", result, dataclasses.replace(signals, truth_modes=late),
        log="run.csv", model_name="m", dt=DT,
    )  # fmt: skip
    covered = dataclasses.replace(signals.rows(start, 400), truth_modes=late[start:])
    alone = build_report(result.rows(start, 400), covered, log="run.csv", model_name="m", dt=DT)
    modes = report.modes
    assert modes.samples == 400 - start and alone.modes.samples == 400 - start
    # the same as the covered samples scored alone: no switch from the uncovered part
    assert modes.accuracy == alone.modes.accuracy
    assert modes.confusion == alone.modes.confusion
    assert modes.detection == alone.modes.detection
    assert sum(sum(row.values()) for row in (modes.confusion or {}).values()) == 400 - start
    assert modes.detection is not None
    assert all(e.t >= signals.time[start] for e in modes.detection.events)
    assert strict_json(tmp_path / "o" / "report.json")["modes"]["samples"] == 400 - start
    md = (tmp_path / "o" / "report.md").read_text()
    assert f"% over {400 - start} of 400 samples (those with a true mode)" in md
    timeline = pl.read_csv(tmp_path / "o" / "timeline.csv")
    assert timeline["truth_mode"].null_count() == start
    assert timeline["truth_mode"][start:].to_list() == [MODE_IDS[m] for m in late[start:]]
    # a truth that covers every sample: no count in report.md
    whole = build_report(result, signals, log="run.csv", model_name="m", dt=DT)
    assert whole.modes.samples == 400
    assert " samples (those with a true mode)" not in render_markdown(whole)
