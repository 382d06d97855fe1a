"""The command line on real files: outputs, CI gates, and bad input (exit 2, one line)."""

import json
import re
import subprocess
import sys

import polars as pl
import pytest
from click.testing import CliRunner

from hybridlog.cli import cli, main
from hybridlog.errors import ModelError
from hybridlog.model.builtins import builtin_names, builtin_reference, builtin_text
from hybridlog.model.cache import model_file
from hybridlog.model.loader import load_model
from tests.support.paths import ROOT, TANK_CSV

SAMPLE = TANK_CSV


def run(args, expect=0):
    """Run the CLI through ``main`` (which maps errors to exit codes) and check the code."""
    runner = CliRunner()
    result = runner.invoke(main_command, args, catch_exceptions=False)
    assert result.exit_code == expect, result.output + result.stderr
    return result


class _Main:
    """Click-runner adapter for ``main`` so the error → exit-code mapping is exercised."""

    name = "hybridlog"

    def main(self, args, prog_name=None, standalone_mode=True, **extra):
        try:
            main(list(args))
        except SystemExit as exit_:
            raise SystemExit(exit_.code) from None
        raise SystemExit(0)


main_command = _Main()


@pytest.fixture
def tank_log(tmp_path):
    path = tmp_path / "tank.csv"
    run(["simulate", "three_tank_hstf", "--out", str(path), "--seed", "3"])
    return path


def test_every_command_has_help_with_an_example():
    for name, command in cli.commands.items():
        assert command.help, name
        result = CliRunner().invoke(cli, [name, "--help"])
        assert result.exit_code == 0
        assert "Examples:" in result.output and "hybridlog " + name in result.output, name


def test_python_dash_m_runs_the_cli():
    done = subprocess.run(
        [sys.executable, "-m", "hybridlog", "models"], capture_output=True, text=True, check=False
    )
    assert done.returncode == 0, done.stderr
    assert "three_tank_hstf" in done.stdout


def test_models_lists_and_prints_builtins():
    assert "three_tank_hstf" in run(["models"]).output
    text = run(["models", "three_tank_hstf"]).output
    assert "[modes.1]" in text and "paper 000" in text
    assert run(["models", "nope"], expect=2).stderr.count("\n") == 1


@pytest.mark.parametrize("name", [" ", "three_tank_hstf "])
def test_a_model_name_with_blanks_is_shown_quoted(name: str) -> None:
    # " " printed "error: : neither a model file ...": the name did not show
    with pytest.raises(ModelError, match=rf"^{re.escape(repr(name))}: neither a model file"):
        model_file(name)


def test_builtins_are_valid_models_listed_without_sympy_by_their_reference():
    # `hybridlog models` reads names and references with tomllib alone (a light start); the
    # files are package data, so their validity is checked here rather than on every call.
    for name in builtin_names():
        model = load_model(name)
        assert builtin_reference(name) == model.reference != ""
        assert builtin_text(name).startswith(f'name = "{model.name}"')
    with pytest.raises(
        ModelError, match=r"^no_such: not a built-in model \(built-ins: .*three_tank"
    ):
        builtin_text("no_such")
    with pytest.raises(ModelError, match="not a built-in model"):
        builtin_text("../loader")


def test_simulate_writes_ground_truth_columns(tmp_path):
    out = tmp_path / "s.parquet"
    run(
        ["simulate", "three_tank_hstf", "--out", str(out), "--schedule", "1:5,3:5", "--steps", "30"]
    )
    frame = pl.read_parquet(out)
    assert frame.columns == ["t", "u", "y1", "y2", "y3", "mode", "x1", "x2", "x3"]
    assert frame.height == 31
    assert frame["mode"].to_list()[:12] == ["1"] * 6 + ["3"] * 5 + ["1"]
    # Same seed, same log; an existing file is never overwritten without --force.
    again = tmp_path / "again.parquet"
    run(
        [
            "simulate",
            "three_tank_hstf",
            "--out",
            str(again),
            "--schedule",
            "1:5,3:5",
            "--steps",
            "30",
        ]
    )
    assert pl.read_parquet(again).equals(frame)
    result = run(["simulate", "three_tank_hstf", "--out", str(out)], expect=2)
    assert "already exists" in result.stderr
    # --force replaces the file hybridlog wrote, never one of the user's (SPEC §9)
    run(["simulate", "three_tank_hstf", "--out", str(out), "--steps", "5", "--force"])
    assert pl.read_parquet(out).height == 6
    mine = tmp_path / "mine.parquet"
    frame.write_parquet(mine)
    result = run(["simulate", "three_tank_hstf", "--out", str(mine), "--force"], expect=2)
    assert "hybridlog did not write it" in result.stderr and result.stderr.count("\n") == 1
    assert pl.read_parquet(mine).equals(frame)


def test_inspect_json(tank_log):
    info = json.loads(run(["inspect", str(tank_log), "--json"]).output)
    assert info["rows"] == 301
    assert "y1" in json.dumps(info)


def test_analyze_writes_every_output(tank_log, tmp_path):
    out = tmp_path / "report"
    result = run(["analyze", str(tank_log), "--model", "three_tank_hstf", "--out", str(out)])
    assert str(out / "report.md") in result.output
    for name in (
        "report.json",
        "report.md",
        "timeline.csv",
        "estimates.csv",
        "plots/outputs.png",
        "plots/modes.png",
        "plots/states.png",
    ):
        assert (out / name).is_file(), name
    report = json.loads((out / "report.json").read_text())
    for key in (
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
        "modes",
        "states",
        "runtime_s",
        "samples_per_s",
    ):
        assert key in report, key
    for key in ("labels", "switches", "dwell_s", "accuracy", "confusion", "detection_delay_s"):
        assert key in report["modes"], key
    assert report["estimator"] == "hstf"  # the model's default_estimator
    assert report["samples"] == 301
    assert set(report["states"]) == {"x1", "x2", "x3"}
    timeline = pl.read_csv(out / "timeline.csv")
    assert timeline.columns == ["t", "mode", "p_1", "p_2", "p_3", "truth_mode"]


def test_existing_output_is_refused_then_replaced_with_force(tank_log, tmp_path):
    out = tmp_path / "report"
    args = ["analyze", str(tank_log), "--model", "three_tank_hstf", "--out", str(out)]
    run(args)
    before = (out / "report.json").read_bytes()
    result = run([*args, "--estimator", "imm"], expect=2)
    assert "--force" in result.stderr
    assert (out / "report.json").read_bytes() == before
    run([*args, "--estimator", "imm", "--force"])
    assert json.loads((out / "report.json").read_text())["estimator"] == "imm"


def test_gates_exit_one_naming_metric_value_and_bound(tank_log, tmp_path):
    base = ["analyze", str(tank_log), "--model", "three_tank_hstf", "--estimator", "imm"]
    run(
        [
            *base,
            "--out",
            str(tmp_path / "a"),
            "--fail-under",
            "mode_accuracy=0.5",
            "--fail-over",
            "mse=1000",
        ]
    )
    result = run([*base, "--out", str(tmp_path / "b"), "--fail-under", "vaf=99.9"], expect=1)
    report = json.loads((tmp_path / "b" / "report.json").read_text())
    assert f"vaf = {report['vaf']:.4g}" in result.stderr or "vaf =" in result.stderr
    assert "99.9" in result.stderr
    result = run([*base, "--out", str(tmp_path / "c"), "--fail-over", "mse.y1=0.001"], expect=1)
    assert "mse.y1" in result.stderr and "0.001" in result.stderr


def test_set_overrides_options_and_parameters(tank_log, tmp_path):
    out = tmp_path / "r"
    run(
        [
            "analyze",
            str(tank_log),
            "--model",
            "three_tank_hstf",
            "--out",
            str(out),
            "--set",
            "theta=0.9",
            "--set",
            "rho=0.5",
            "--set",
            "A=160",
        ]
    )
    options = json.loads((out / "report.json").read_text())["options"]
    assert options["theta"] == 0.9 and options["rho"] == 0.5


def _one_line_error(result, *fragments):
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("hybridlog: error: ")
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])
    assert "Traceback" not in result.output + result.stderr


def _bad_model(tmp_path, old, new):
    text = (ROOT / "hybridlog/model/builtin/three_tank_hstf.toml").read_text()
    assert old in text
    path = tmp_path / "bad.toml"
    path.write_text(text.replace(old, new, 1))
    return path


@pytest.mark.parametrize(
    ("make_args", "fragments"),
    [
        (lambda t, log: [str(t / "missing.csv"), "--model", "three_tank_hstf"], ["missing.csv"]),
        (lambda t, log: [str(log), "--model", "no_such_model"], ["no_such_model"]),
        (
            lambda t, log: [str(log), "--model", "three_tank_hstf", "--estimator", "kalman"],
            ["kalman"],
        ),
        (lambda t, log: [str(log), "--model", "three_tank_hstf", "--set", "theta=2"], ["theta"]),
        (lambda t, log: [str(log), "--model", "three_tank_hstf", "--set", "gamma=1"], ["gamma"]),
        (lambda t, log: [str(log), "--model", "three_tank_hstf", "--map", "y9=y1"], ["y9"]),
        (lambda t, log: [str(log), "--model", "three_tank_hstf", "--map", "y1=level"], ["level"]),
        (
            lambda t, log: [str(log), "--model", "three_tank_hstf", "--fail-under", "vaff=3"],
            ["vaff"],
        ),
        (
            lambda t, log: [
                str(log),
                "--model",
                str(_bad_model(t, '"x1", "x2", "x3"]\n', '"x1", "x2", "x4"]\n')),
            ],
            ["bad.toml", "x4"],
        ),
        (
            lambda t, log: [str(log), "--model", str(_bad_model(t, "A = 154.0", 'A = "os"'))],
            ["bad.toml", "parameters.A"],
        ),
        (
            lambda t, log: [
                str(log),
                "--model",
                str(_bad_model(t, 'u = "20"', "u = \"__import__('os')\"")),
            ],
            ["bad.toml", "simulation.inputs.u"],
        ),
        (
            lambda t, log: [
                str(log),
                "--model",
                str(_bad_model(t, "measurement = 0.5", "measurement = 0.0")),
            ],
            ["singular"],
        ),
    ],
    ids=[
        "missing-log",
        "unknown-model",
        "unknown-estimator",
        "bad-option-value",
        "unknown-option",
        "map-unknown-symbol",
        "map-missing-column",
        "bad-gate",
        "model-unknown-symbol",
        "model-bad-parameter",
        "model-code-injection",
        "singular-noise",
    ],
)
def test_bad_input_is_one_line_exit_two_and_no_output(tank_log, tmp_path, make_args, fragments):
    out = tmp_path / "out"
    result = run(["analyze", *make_args(tmp_path, tank_log), "--out", str(out)], expect=2)
    _one_line_error(result, *fragments)
    assert not out.exists()
    assert not any(p.name.startswith(".out") for p in tmp_path.iterdir())


@pytest.mark.parametrize(
    ("mutate", "fragments"),
    [
        (lambda text: text.replace("\n5.0,", "\n5.0x,", 1), ["line 7", "'t'"]),
        (lambda text: text.replace(",20.0,", ",abc,", 3), ["line", "'u'", "abc"]),
        (lambda text: text.replace("\n3.0,", "\n1.5,", 1), ["line 5", "backwards"]),
        (lambda text: text.replace(",20.0,", ",nan,", 1), ["'u'", "nan"]),
        (lambda text: "", ["empty"]),
        (lambda text: text[: len(text) // 2], ["truncated"]),
    ],
    ids=["bad-time", "text-cell", "time-backwards", "nan", "empty", "truncated"],
)
def test_bad_log_content(tank_log, tmp_path, mutate, fragments):
    bad = tmp_path / "bad.csv"
    bad.write_text(mutate(tank_log.read_text()))
    out = tmp_path / "out"
    result = run(["analyze", str(bad), "--model", "three_tank_hstf", "--out", str(out)], expect=2)
    _one_line_error(result, "bad.csv", *fragments)
    assert not out.exists()


def test_debug_shows_the_traceback(tmp_path):
    with pytest.raises(Exception, match="no_such_model"):
        main(
            [
                "--debug",
                "analyze",
                str(SAMPLE),
                "--model",
                "no_such_model",
                "--out",
                str(tmp_path / "o"),
            ]
        )


def test_debug_keeps_exit_code_2_for_bad_input(tmp_path):
    # SPEC §4: exit 1 means a CI gate failed, 2 bad input; --debug only adds the traceback.
    # It re-raised out of the process, whose exit code was then Python's 1: a pipeline run
    # with --debug read a missing log as a failed gate.
    out = tmp_path / "o"
    args = ["--debug", "analyze", str(tmp_path / "missing.csv"), "--model", "three_tank_hstf"]
    done = subprocess.run(
        [sys.executable, "-m", "hybridlog", *args, "--out", str(out)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 2, done.stderr
    assert "Traceback (most recent call last)" in done.stderr
    last = done.stderr.strip().splitlines()[-1]
    assert last.startswith("hybridlog: error: ") and "missing.csv: no such file" in last
    assert not out.exists()


def test_compare_writes_side_by_side_table(tank_log, tmp_path):
    out = tmp_path / "cmp"
    result = run(
        [
            "compare",
            str(tank_log),
            "--model",
            "three_tank_hstf",
            "--estimators",
            "hstf,imm",
            "--out",
            str(out),
        ]
    )
    assert "| hstf |" in result.output and "| imm |" in result.output
    table = pl.read_csv(out / "comparison.csv")
    assert table["estimator"].to_list() == ["hstf", "imm"]
    for name in ("hstf", "imm"):
        report = json.loads((out / name / "report.json").read_text())
        assert report["estimator"] == name
        assert table.filter(pl.col("estimator") == name)["vaf"][0] == pytest.approx(report["vaf"])
        assert table.filter(pl.col("estimator") == name)["fit"][0] == pytest.approx(report["fit"])
    # The paper-faithful HSTF's report says in one sentence why it underperforms (issue 7).
    hstf_md = (out / "hstf" / "report.md").read_text()
    assert "likelihood=faded is the paper's eq. (35)" in hstf_md and "docs/three_tank.md" in hstf_md
    assert "docs/three_tank.md" not in (out / "imm" / "report.md").read_text()
    assert "## Notes on `hstf`" in (out / "comparison.md").read_text()
    assert str(out / "hstf" / "report.md") in result.output


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        (
            ["simulate", "three_tank_hstf", "--out", "{tmp}/s.csv", "--schedule", "1:10,7:3"],
            "unknown mode '7'",
        ),
        (["simulate", "three_tank_hstf", "--out", "{tmp}/s.csv", "--schedule", "1:ten"], "'ten'"),
        (["simulate", "three_tank_hstf", "--out", "{tmp}/s.txt"], "s.txt"),
        (["inspect", "{tmp}/nothing.csv"], "nothing.csv"),
        (["models", "three_tank"], "three_tank"),
    ],
)
def test_other_commands_reject_bad_input_in_one_line(tmp_path, args, fragment):
    result = run([a.format(tmp=tmp_path) for a in args], expect=2)
    _one_line_error(result, fragment)
    assert not (tmp_path / "s.csv").exists()


def _cart_log(path, y, u=0.01):
    """A double_cart_case1 log with the given cells of output y and input u = u * k."""
    rows = [f"{0.5 * k},{u * k},{cell}" for k, cell in enumerate(y)]
    path.write_text("t,u,y\n" + "\n".join(rows) + "\n")
    return path


def test_cluster_takes_the_read_option_its_error_suggests(tmp_path):
    cells = [f"{(-1) ** (k // 7) * (1 + 0.01 * k)}" for k in range(40)]
    log = _cart_log(tmp_path / "spike.csv", [*cells[:9], "1e200", *cells[10:]])
    args = ["cluster", str(log), "--model", "double_cart_case1", "--out", str(tmp_path / "c.json")]
    _one_line_error(run(args, expect=2), "spike.csv, line 11", "--drop-nonfinite drops")
    assert list(tmp_path.iterdir()) == [log]
    run([*args, "--drop-nonfinite"])
    reading = json.loads((tmp_path / "c.json").read_text())["reading"]
    assert reading["out_of_range_dropped"] == {"y": 1}


def test_cluster_compare_kmeans_on_one_repeated_regression_vector_says_why_not(tmp_path):
    # Chiu's clustering takes the one vector as one centre; k-means's error stopped the
    # command and chiu's centres were not written: the comparison now says why in one line
    log = _cart_log(tmp_path / "flat.csv", ["1.0"] * 30, u=0.0)
    args = ["cluster", str(log), "--model", "double_cart_case1", "--out", str(tmp_path / "c.json")]
    result = run([*args, "--compare-kmeans"])
    said = [line for line in result.stdout.splitlines() if line.startswith("- kmeans")]
    assert said == [
        "- kmeans: not compared, k-means could not run: clusters: the data have fewer than 2 "
        "distinct points (1 among 29)"
    ], result.stdout
    assert len(json.loads((tmp_path / "c.json").read_text())["chiu"]["centers"]) == 1


def test_log_without_truth_gives_null_truth_metrics_and_gates_say_so(tank_log, tmp_path):
    plain = tmp_path / "plain.csv"
    pl.read_csv(tank_log).select("t", "u", "y1", "y2", "y3").write_csv(plain)
    out = tmp_path / "r"
    result = run(
        [
            "analyze",
            str(plain),
            "--model",
            "three_tank_hstf",
            "--estimator",
            "imm",
            "--out",
            str(out),
            "--fail-under",
            "mode_accuracy=0.5",
        ],
        expect=1,
    )
    assert "mode_accuracy" in result.stderr and "not available" in result.stderr
    report = json.loads((out / "report.json").read_text())
    assert report["modes"]["accuracy"] is None
    assert report["modes"]["confusion"] is None
    assert report["modes"]["detection_delay_s"] is None
    assert all(v["rmse"] is None for v in report["states"].values())
    assert report["vaf"] is not None
    assert "truth_mode" not in pl.read_csv(out / "timeline.csv").columns


@pytest.mark.parametrize(
    ("args", "line"),
    [
        (
            ["analyze", "{log}", "--model", "three_tank_hstf", "--max-gap", "abc"],
            "hybridlog analyze: --max-gap: expected a finite number, got 'abc' "
            "(see hybridlog analyze --help)",
        ),
        (
            ["analyze", "{log}", "--model", "three_tank_hstf", "--bogus"],
            "hybridlog analyze: no such option '--bogus'",
        ),
        (["analyze", "--model", "three_tank_hstf"], "hybridlog analyze: missing argument 'LOG'"),
        (["compare", "{log}", "--model", "three_tank_hstf"], "missing option '--estimators'"),
        (
            ["simulate", "three_tank_hstf", "--out", "{tmp}/s.csv", "--seed", "-1"],
            "hybridlog simulate: --seed: expected a whole number of at least 0, got -1",
        ),
        (["frobnicate"], "hybridlog: no such command 'frobnicate' (see hybridlog --help)"),
    ],
    ids=["bad-float", "unknown-option", "missing-argument", "missing-option", "seed", "command"],
)
def test_usage_errors_are_one_line_exit_two(tmp_path, args, line):
    result = run([a.format(log=SAMPLE, tmp=tmp_path) for a in args], expect=2)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and line in lines[0], result.stderr
    assert "Usage:" not in result.output + result.stderr
    assert not (tmp_path / "s.csv").exists()


def test_quiet_and_debug_work_after_the_subcommand(tmp_path):
    out = tmp_path / "r"
    args = ["analyze", str(SAMPLE), "--model", "three_tank_hstf", "--estimator", "imm"]
    assert run([*args, "--out", str(out), "-q"]).output == ""
    assert run(["-q", *args, "--out", str(tmp_path / "r2")]).output == ""
    assert "report:" in run([*args, "--out", str(tmp_path / "r3")]).output
    with pytest.raises(Exception, match="no_such_model"):
        main(["models", "no_such_model", "--debug"])


def test_every_failure_is_one_bounded_printable_line(monkeypatch):
    # The last guard in main(): hybridlog errors, numerical warnings and unexpected
    # exceptions all become one short line; other warnings become one-line notes.
    import warnings

    import numpy as np

    from hybridlog import cli as cli_module
    from hybridlog import cli_lines
    from hybridlog.errors import LogError

    def huge_error():
        raise LogError("z.csv: " + "\x00" * 16384 + "\n" + "(" * 18000)

    def overflow():
        return [str(np.exp(np.float64(1000.0)))]

    def unexpected():
        raise KeyError("boom")

    def library_warning():
        warnings.warn("a library changed its mind\nover two lines", UserWarning, stacklevel=1)
        return []

    cases = [
        (huge_error, 2, "hybridlog: error: z.csv: \\x00\\x00"),
        (overflow, 2, "hybridlog: error: numerical trouble in cli.py:"),
        (unexpected, 2, "hybridlog: error: unexpected KeyError in cli.py:"),
        (library_warning, 0, "hybridlog: note: UserWarning: a library changed its mind over"),
    ]
    for replacement, code, start in cases:
        monkeypatch.setattr(cli_module, "builtin_names", replacement)
        result = run(["models"], expect=code)
        lines = result.stderr.splitlines()
        assert len(lines) == 1, result.stderr
        assert lines[0].startswith(start), lines[0]
        assert len(lines[0]) <= cli_lines.MAX_MESSAGE + 2 and lines[0].isprintable()
        assert "Traceback" not in result.stderr and "Warning:" not in result.stderr[len(start) :]


def test_corrupt_parquet_value_and_short_log_are_refused(tmp_path):
    # Issue 7: a corrupted Parquet gave truth x1 = -1e271, RMSE "n/a", exit 0 and a raw numpy
    # RuntimeWarning; 1- and 2-row logs gave exit 0 with "VAF 100 %".
    frame = pl.read_csv(SAMPLE)
    bad = tmp_path / "bad.parquet"
    frame.with_columns(
        pl.when(pl.col("t") == 42.0).then(-1e271).otherwise(pl.col("x1")).alias("x1")
    ).write_parquet(bad)
    args = ["--model", "three_tank_hstf", "--estimator", "imm"]
    result = run(["analyze", str(bad), *args, "--out", str(tmp_path / "o")], expect=2)
    _one_line_error(result, "bad.parquet, row 43, column 'x1'", "truth.x1 at t=42 s")
    out = tmp_path / "dropped"
    run(["analyze", str(bad), *args, "--out", str(out), "--drop-nonfinite"])
    report = json.loads((out / "report.json").read_text())
    assert report["reading"]["out_of_range_dropped"] == {"x1": 1}
    assert report["states"]["x1"]["rmse"] < 5.0
    short = tmp_path / "short.csv"
    frame.head(2).write_csv(short)
    result = run(["analyze", str(short), *args, "--out", str(tmp_path / "s")], expect=2)
    _one_line_error(result, "short.csv: too short: 2 samples", "at least 3")
    assert not (tmp_path / "s").exists()


def test_the_summary_line_groups_the_thousands_of_its_counts() -> None:
    """``9,999 true switches: 9,980 detected, 19 missed``: every count grouped alike."""
    from dataclasses import replace

    from hybridlog.cli_lines import summary_line
    from hybridlog.report.document import read_report

    report = read_report(ROOT / "tests/data/reports/double_cart_case1_chiu.report.json")
    detection = report.modes.detection
    assert detection is not None and (detection.detected, detection.missed) == (24, 24)
    many = replace(detection, events=detection.events * 50)
    line = summary_line(replace(report, modes=replace(report.modes, detection=many)))
    assert line.endswith(", 2,400 true switches: 1,200 detected, 1,200 missed")


def test_what_is_printed_on_stdout_holds_no_byte_a_terminal_acts_on() -> None:
    """A log named with an escape sequence or bytes that are not UTF-8: shown \\xNN."""
    from hybridlog.cli_lines import for_terminal

    shown = for_terminal("report: run\x1b[31m\udcff/report.md\n\tnext line")
    assert shown == "report: run\\x1b[31m\\xff/report.md\n\tnext line"
    shown.encode("utf-8")  # a surrogate would raise here


def test_the_lines_naming_what_was_written_are_one_a_path(tmp_path):
    # a folder named with a line break split 'report: ...' and the summary line in two
    folder = tmp_path / "a\nb"
    folder.mkdir()
    log = folder / "log.csv"
    log.write_bytes(TANK_CSV.read_bytes())
    result = run(["analyze", str(log), "--model", "three_tank_hstf", "--out", str(folder / "o")])
    lines = result.stdout.splitlines()
    assert len(lines) == 2, lines
    assert lines[0].startswith(f"hstf on {tmp_path}/a\\nb/log.csv: 301 samples")
    assert lines[1] == f"report: {tmp_path}/a\\nb/o/report.md"
