"""One ``analyze`` of a hostile log end to end: odd mode ids, a partial true state, gates."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import polars as pl

from tests.cli.test_cli import run

MODEL = r"""
name = "$\\frac{a}{b}$ | `m`"
time = "discrete"
dt = 0.1
states = ["x_1", "θ"]
inputs = ["u"]
outputs = ["y_1", "y2"]
default_estimator = "imm"

[modes."$x_1$"]
A = [[0.9, 0.0], [0.0, 0.8]]
B = [[1.0], [0.5]]
C = [[1.0, 0.0], [0.0, 1.0]]

[modes."$\\undefinedcmd{$ <i>|`"]
A = [[0.5, 0.0], [0.0, 0.7]]
B = [[1.0], [0.0]]
C = [[1.0, 0.0], [0.0, 1.0]]

[noise]
process = 0.01
measurement = 0.01

[initial]
state = [0.0, 0.0]
covariance = 1.0
mode = "$x_1$"

[simulation]
state = [0.0, 0.0]
[simulation.inputs]
u = "sin(t)"
"""
MODES = ("$x_1$", r"$\undefinedcmd{$ <i>|`")


def test_analyze_of_mathtext_modes_and_a_partial_true_state(tmp_path: Path) -> None:
    model = tmp_path / "model.toml"
    model.write_text(MODEL, encoding="utf-8")
    log = tmp_path / "run.csv"
    run(["simulate", str(model), "--out", str(log), "--steps", "200", "--seed", "1",
         "--schedule", f"{MODES[0]}:100,{MODES[1]}:100"])  # fmt: skip
    frame = pl.read_csv(log)
    truth = frame["x_1"].to_list()
    truth[50:190] = [None] * 140  # the true state's topic was silent for 14 s
    frame.with_columns(pl.Series("x_1", truth)).write_csv(log)
    out = tmp_path / "out"
    run(["analyze", str(log), "--model", str(model), "--out", str(out),
         "--fail-over", "state_rmse.x_1=10"])  # fmt: skip

    def refuse(constant: str) -> None:
        raise AssertionError(f"report.json holds {constant}")

    report = json.loads((out / "report.json").read_text(), parse_constant=refuse)
    estimates = pl.read_csv(out / "estimates.csv")
    known = estimates.select("x_1_hat", "x_1_true").drop_nulls()
    assert report["states"]["x_1"]["samples"] == known.height == 201 - 140
    error = (known["x_1_hat"] - known["x_1_true"]).to_numpy()
    assert math.isclose(report["states"]["x_1"]["rmse"], math.sqrt(np.mean(error**2)))
    assert report["states"]["θ"]["samples"] == 201
    assert "- x_1: RMSE over 61 of 201 samples" in (out / "report.md").read_text()
    assert report["modes"]["labels"] == list(MODES)
    assert {p.name for p in (out / "plots").iterdir()} == {"outputs.png", "modes.png", "states.png"}


HUGE_INPUT_MODEL = """
name = "huge_input"
time = "discrete"
dt = 1.0
states = ["x1"]
inputs = ["u"]
outputs = ["y1", "y2"]
default_estimator = "imm"

[modes.1]
A = [[0.0]]
B = [1.0]
C = [[1.0], [1.0]]

[modes.2]
A = [[0.0]]
B = [1.0]
C = [[1.0], [1.0]]

[noise]
process = 1e290
measurement = 1e290

[initial]
state = [0.0]
covariance = 1.0
mode = "1"
"""


def test_analyze_of_outputs_whose_mean_fit_overflows_a_sum(tmp_path: Path) -> None:
    """Two outputs of fit -1.33e308 % each: their mean is one, not 'numerical trouble'."""
    model = tmp_path / "model.toml"
    model.write_text(HUGE_INPUT_MODEL, encoding="utf-8")
    log = tmp_path / "run.csv"
    spread = [7.5e-163 if k % 2 else -7.5e-163 for k in range(60)]
    pl.DataFrame({"t": [float(k) for k in range(60)], "u": [1e144] * 60, "y1": spread,
                  "y2": spread}).write_csv(log)  # fmt: skip
    out = tmp_path / "out"
    run(["analyze", str(log), "--model", str(model), "--out", str(out)])
    report = json.loads((out / "report.json").read_text())
    fits = [report["outputs"][y]["fit"] for y in ("y1", "y2")]
    assert fits[0] == fits[1] < -0.9e308 and report["fit"] == fits[0]
