"""Round trip: one simulated run written in every format gives the same analysis as the CSV.

``hybridlog simulate`` writes the run as CSV, Parquet, MCAP (ROS 2 CDR, JSON, ROS 1), a ROS 1
bag and ROS 2 bags (sqlite3 and MCAP storage); each is analysed and must give the CSV's
report metrics and a byte-identical ``timeline.csv``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import polars as pl
import pytest
from click.testing import CliRunner

from hybridlog.cli import cli
from hybridlog.jobs.analysis import analyze

SCHEDULE = ["--schedule", "1:30,2:30,3:30", "--steps", "90", "--seed", "11"]

# name -> (simulate arguments after --out, path to analyse relative to the output)
FORMATS: dict[str, tuple[str, list[str], str]] = {
    "parquet": ("run.parquet", [], "run.parquet"),
    "mcap-cdr": ("run.mcap", [], "run.mcap"),
    "mcap-json": ("run_json.mcap", ["--encoding", "json"], "run_json.mcap"),
    "mcap-ros1": ("run_ros1.mcap", ["--encoding", "ros1"], "run_ros1.mcap"),
    "ros1-bag": ("run.bag", [], "run.bag"),
    "ros2-sqlite3": ("run_db3", ["--format", "ros2-sqlite3"], "run_db3"),
    "ros2-mcap": ("run_ros2mcap", ["--format", "ros2-mcap"], "run_ros2mcap"),
    "bare-db3": ("bare_db3", ["--format", "ros2-sqlite3"], "bare_db3/bare_db3.db3"),
    "bare-ros2-mcap": ("bare_mcap", ["--format", "ros2-mcap"], "bare_mcap/bare_mcap.mcap"),
}
METRIC_KEYS = ("samples", "dt", "t_start", "t_end", "outputs", "mse", "vaf", "modes", "states")


def simulate_to(folder: Path, out: str, extra: list[str]) -> None:
    result = CliRunner().invoke(
        cli, ["simulate", "three_tank_hstf", "--out", str(folder / out), *SCHEDULE, *extra]
    )
    assert result.exit_code == 0, result.output


def analysis(log: Path, out: Path) -> tuple[dict[str, Any], bytes]:
    outcome = analyze(log, "three_tank_hstf", out_dir=out, estimator="hstf")
    report = json.loads((out / "report.json").read_text())
    assert report == json.loads(outcome.report.to_json())
    return report, (out / "timeline.csv").read_bytes()


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict[str, Any], bytes]:
    folder = tmp_path_factory.mktemp("csv")
    simulate_to(folder, "run.csv", [])
    return analysis(folder / "run.csv", folder / "report")


@pytest.mark.parametrize("name", list(FORMATS))
def test_every_format_gives_the_csv_analysis(
    name: str, reference: tuple[dict[str, Any], bytes], tmp_path: Path
) -> None:
    out, extra, log = FORMATS[name]
    simulate_to(tmp_path, out, extra)
    report, timeline = analysis(tmp_path / log, tmp_path / "report")
    expected_report, expected_timeline = reference
    assert timeline == expected_timeline
    for key in METRIC_KEYS:
        assert report[key] == expected_report[key], key
    assert report["reading"]["time"] == "log"
    assert report["reading"]["format"] != "csv"


def sample_commands() -> list[list[str]]:
    """The ``simulate`` commands of ``sample_logs/README.md``: every sample log."""
    import re
    import shlex

    text = (Path(__file__).resolve().parents[2] / "sample_logs" / "README.md").read_text()
    commands = re.findall(r"`(hybridlog simulate [^`]*)`", text)
    return [shlex.split(c)[1:] for c in commands]


@pytest.mark.parametrize("args", sample_commands(), ids=lambda a: a[a.index("--out") + 1])
def test_sample_logs_are_what_their_commands_write(args: list[str], tmp_path: Path) -> None:
    root = Path(__file__).resolve().parents[2]
    at = args.index("--out") + 1
    sample = root / args[at]
    fresh = tmp_path / sample.name
    result = CliRunner().invoke(cli, [*args[:at], str(fresh), *args[at + 1 :]])
    assert result.exit_code == 0, result.output
    if sample.is_dir():
        names = sorted(p.name for p in sample.iterdir())
        assert names == sorted(p.name.replace(fresh.name, sample.name) for p in fresh.iterdir())
        for name in names:
            assert (fresh / name.replace(sample.name, fresh.name)).read_bytes() == (
                sample / name
            ).read_bytes(), name
    elif sample.suffix == ".parquet":
        # by content: a Parquet file's bytes record its writer's version ("Polars (python)
        # version 2.1.0 (build ...)"), and a fresh install may get a later polars
        written, kept = pl.read_parquet(fresh), pl.read_parquet(sample)
        assert written.schema == kept.schema
        assert written.equals(kept)
    else:
        assert fresh.read_bytes() == sample.read_bytes()
