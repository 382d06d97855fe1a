"""``hybridlog cluster`` says what reading the log did, as ``analyze`` says it.

A log at half the model's rate (the model's dt wrong) bridged every other output sample,
and the clusters were fitted on measurements used twice (centres with ``y(k) = y(k-1)``); a
log at twice it lost every other sample; ``--drop-nonfinite`` dropped samples.  ``analyze``
prints the first two on stderr and report.md says all three; ``cluster`` said none of them.
The vectors holding a bridged output are left out of the fit and counted; a log at half
the model's rate has none left (every φ(k) holds y(k) or y(k-1) bridged): one-line refusal.
"""

import json
from pathlib import Path

import polars as pl

from tests.cli.test_cli import run
from tests.support.paths import SAMPLE_LOGS

_ROWS = 81


def _log(tmp_path: Path, name: str, frame: pl.DataFrame) -> Path:
    path = tmp_path / name
    frame.write_csv(path)
    return path


def _cluster(log: Path, tmp_path: Path, *extra: str, expect: int = 0) -> tuple[str, str]:
    out = tmp_path / f"{log.stem}_centers.json"
    args = ["cluster", str(log), "--model", "double_cart_case1", "--out", str(out), *extra]
    result = run(args, expect=expect)
    return result.stdout, result.stderr


def test_cluster_says_bridged_outputs_unused_samples_and_repairs(tmp_path: Path) -> None:
    frame = pl.read_csv(SAMPLE_LOGS / "double_cart_case1.csv").head(_ROWS)
    slow = _log(tmp_path, "slow.csv", frame.gather_every(2))
    fast = _log(
        tmp_path,
        "fast.csv",
        pl.concat([frame, frame.with_columns(pl.col("t") + 0.25)]).sort("t", maintain_order=True),
    )
    _, said = _cluster(slow, tmp_path, expect=2)
    assert said.startswith(
        f"hybridlog: error: {slow}: chiu cannot cluster its regression vectors φ(k) = [y(k), "
        "y(k-1), u(k-1)]: every one of its 80 regression vectors holds an output value the "
        "log did not measure"
    )
    assert "(an output sampled less often than every dt leaves no φ(k) whole; or" in said
    assert said.count("\n") == 1
    assert list(tmp_path.glob("slow_centers.*")) == []
    _, said = _cluster(fast, tmp_path)
    assert said.startswith("hybridlog: note: input u, output y each have 162 samples over the ")
    assert said.count("\n") == 1
    holed = _log(
        tmp_path,
        "holed.csv",
        frame.with_columns(
            pl.when(pl.int_range(pl.len()) == 40)
            .then(float("nan"))
            .otherwise(pl.col("y"))
            .alias("y")
        ),
    )
    printed, said = _cluster(holed, tmp_path, "--drop-nonfinite")
    assert "- NOTE: --drop-nonfinite dropped NaN or infinite samples: y 1\n" in printed
    assert said.startswith("hybridlog: warning: output y has no sample within dt/2 of 1 of 81 ")
    assert said.endswith(
        "and the 2 of 80 regression vectors φ(k) holding it were left out of the clusters' fit\n"
    )
    left_out = "from 78 regression vectors φ(k) = [y(k), y(k-1), u(k-1)] (2 regression vectors "
    assert left_out in printed
    centers = json.loads((tmp_path / "holed_centers.json").read_text(encoding="utf-8"))
    assert left_out in centers["chiu"]["notes"][0]
    quiet = run(
        [
            "-q",
            "cluster",
            str(holed),
            "--drop-nonfinite",
            "--model",
            "double_cart_case1",
            "--out",
            str(tmp_path / "q.json"),
        ]
    )
    assert quiet.stdout == quiet.stderr == ""
