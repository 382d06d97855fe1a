"""``compare`` when one estimator fails on a valid log: a result, not bad input.

On the log below the IMM's EKF of mode ``a`` (``h = sqrt(x1)``) leaves the model's domain
and the run diverges, while the HSTF runs to the end.  ``compare`` wrote nothing and exited
2, so the HSTF's result was lost with it; now the IMM's row says why, the HSTF's report is
written, and the command exits 1, as ``batch`` does for a log that could not be analysed.
"""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from hybridlog.errors import DivergenceError, LogError, ModelError
from hybridlog.jobs.analysis import analyze
from hybridlog.jobs.compare import compare
from tests.support.paths import ROOT

SQRT = """
name = "sqrt_flat"
dt = 1.0
states = ["x1"]
inputs = ["u"]
outputs = ["y"]
[modes.a]
f = ["x1 + u"]
h = ["sqrt(x1)"]
[modes.b]
f = ["x1 - u"]
h = ["x1"]
[noise]
process = 0.1
measurement = 0.01
[initial]
state = [1.0]
covariance = 1.0
"""

DIVERGED = "sqrt.toml: imm diverged at t = 2 s (sample 2): the state estimate is not finite"


@pytest.fixture
def case(tmp_path: Path) -> tuple[Path, Path]:
    """A model file and a 60-sample log on which imm diverges and hstf does not."""
    model = tmp_path / "sqrt.toml"
    model.write_text(SQRT)
    y = 0.3 + np.random.default_rng(1).normal(0.0, 0.05, 60)
    log = tmp_path / "flat.csv"
    rows = [f"{float(t)!r},0.1,{float(v)!r}" for t, v in enumerate(y)]
    log.write_text("t,u,y\n" + "\n".join(rows) + "\n")
    return log, model


def _rows(path: Path) -> dict[str, dict[str, str]]:
    with path.open(newline="") as file:
        return {row["estimator"]: row for row in csv.DictReader(file)}


def test_the_failed_estimator_s_row_says_why_and_the_others_are_written(
    case: tuple[Path, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    log, model = case
    monkeypatch.chdir(tmp_path)  # the model named relatively, as its error names it
    out = tmp_path / "cmp"
    outcome = compare(log, model.name, ["imm", "hstf"], out_dir=out, fail_under=["vaf=0"])
    assert list(outcome.failures) == ["imm"] and outcome.failures["imm"].startswith(DIVERGED)
    assert list(outcome.reports) == ["hstf"] and outcome.gate_failures == []
    assert not (out / "imm").exists() and (out / "hstf" / "report.json").is_file()
    rows = _rows(out / "comparison.csv")
    assert list(rows) == ["imm", "hstf"]  # the order given
    assert rows["imm"]["error"] == outcome.failures["imm"]
    assert rows["imm"]["gates"] == "not analysed"
    assert all(rows["imm"][c] == "" for c in ("vaf", "fit", "mse", "samples_per_s"))
    assert rows["hstf"]["error"] == "" and rows["hstf"]["gates"] == "pass (1)"
    # the HSTF's numbers are those of its own analyze, as for a comparison without failure
    alone = analyze(log, model.name, estimator="hstf", out_dir=tmp_path / "alone")
    stored = json.loads((tmp_path / "alone" / "report.json").read_text())
    assert alone.report.vaf == stored["vaf"]
    for column in ("vaf", "fit", "mse"):
        assert rows["hstf"][column] == repr(stored[column]), column
    text = (out / "comparison.md").read_text()
    assert "| imm | n/a | n/a |" in text
    assert "| not analysed | n/a | sqrt.toml: imm diverged" in text  # no warnings: n/a
    assert "## Failed estimators (1 of 2)\n\n- `imm`: sqrt.toml: imm diverged" in text
    assert "[hstf/report.md](hstf/report.md)" in text and "imm/report.md" not in text
    # every estimator failed: the table still says why, and there is no report
    alone_imm = compare(log, model.name, ["imm"], out_dir=tmp_path / "only")
    assert alone_imm.reports == {} and list(alone_imm.failures) == ["imm"]
    assert sorted(p.name for p in (tmp_path / "only").iterdir()) == [
        ".hybridlog",
        "comparison.csv",
        "comparison.md",
    ]


def test_bad_input_found_while_an_estimator_runs_stays_bad_input(
    case: tuple[Path, Path], tmp_path: Path
) -> None:
    """Only a divergence is a result: a singular covariance (SPEC §9) and a log without the
    switching signal the estimator needs are refused when the run meets them, exit 2 and
    nothing written, not failed rows with exit 1."""
    log, _ = case
    singular = tmp_path / "singular.toml"
    singular.write_text(SQRT.replace("measurement = 0.01", "measurement = 0.0"))
    out = tmp_path / "cmp"
    with pytest.raises(ModelError, match=r"covariance of mode 'a' is singular") as caught:
        compare(log, singular, ["imm", "hstf"], out_dir=out)
    assert not isinstance(caught.value, DivergenceError) and not out.exists()
    source = (ROOT / "sample_logs" / "ice_clutch.csv").read_text().splitlines()
    header = source[0].split(",")
    keep = [i for i, name in enumerate(header) if name != "mode"]
    log = tmp_path / "clutch.csv"
    log.write_text("\n".join(",".join(line.split(",")[i] for i in keep) for line in source) + "\n")
    with pytest.raises(
        LogError, match=r"clutch\.csv: estimator 'switching-observer' needs the switching signal"
    ):
        compare(log, "ice_clutch", ["switching-observer"], out_dir=out)
    assert not out.exists()


CONSOLE = (
    "import sys; sys.argv = ['hybridlog', *sys.argv[1:]]; from hybridlog.cli import main; main()"
)


@pytest.mark.parametrize("order", ["imm,hstf", "hstf,imm"])
def test_the_console_script_exits_1_naming_the_failed_estimator(
    case: tuple[Path, Path], tmp_path: Path, order: str
) -> None:
    """As a user runs it, with its estimators' worker: the worker serves the estimator after
    a failed one, and is let go after a failed last one."""
    log, model = case
    out = tmp_path / "cmp"
    args = ["compare", str(log), "--model", str(model), "--estimators", order, "--out", str(out)]
    done = subprocess.run(
        [sys.executable, "-c", CONSOLE, *args],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 1, done.stderr
    assert "Traceback" not in done.stderr
    lines = done.stderr.splitlines()
    failed = [line for line in lines if line.startswith("hybridlog: estimator failed: imm: ")]
    assert len(failed) == 1 and "imm diverged at t = 2 s" in failed[0], done.stderr
    assert f"reports: {out / 'hstf' / 'report.md'}\n" in done.stdout
    assert list(_rows(out / "comparison.csv")) == order.split(",")
    assert (out / "hstf" / "report.json").is_file() and not (out / "imm").exists()
