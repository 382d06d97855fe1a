"""A ``--split-gaps`` piece too short to analyse is named as a piece: its number and span.

A log cut by ``--split-gaps`` into pieces of two samples each was refused with
``log.csv: too short: 2 samples on the model's grid``: the user could not tell that a piece
was meant, nor which one (the log itself held six samples).  The aligned signals now carry
the piece kept (:attr:`~hybridlog.signals.AlignedSignals.piece`) and name it in their
``source``, so every refusal about them (a report's "too short", an estimator's, a batch
log's one line) says ``log.csv (--split-gaps piece 1 of 3, t = 0 … 1 s, the longest)``.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hybridlog.io import ReadOptions, SignalSpec, load_signals
from hybridlog.jobs.batch import run_batch
from tests.support.cli import run_main

MODEL = """
name = "tiny"
dt = 1.0
states = ["x"]
inputs = ["u"]
outputs = ["y"]

[noise]
process = 0.5
measurement = 0.25

[initial]
state = [0.0]
covariance = 1.0

[modes.a]
f = ["x"]
h = ["x"]

[modes.b]
f = ["x + u"]
h = ["x"]
"""

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("a", "b"), dt=1.0)


def write(path: Path, times: list[int]) -> Path:
    path.write_text("t,u,y\n" + "".join(f"{t},1,{0.1 * t}\n" for t in times), encoding="utf-8")
    return path


@pytest.fixture
def model(tmp_path: Path) -> Path:
    path = tmp_path / "tiny.toml"
    path.write_text(MODEL, encoding="utf-8")
    return path


def test_the_signals_name_the_piece_they_hold(tmp_path: Path) -> None:
    log = write(tmp_path / "log.csv", [0, 1, 20, 21, 22, 23, 40, 41])
    signals = load_signals(log, SPEC, ReadOptions(split_gaps=True))
    piece = "--split-gaps piece 2 of 3, t = 20 … 23 s, the longest"
    assert signals.piece == piece and signals.source == f"{log} ({piece})"
    assert signals.rows(0, 2).piece == piece
    whole = load_signals(write(tmp_path / "whole.csv", [0, 1, 2, 3]), SPEC, ReadOptions())
    assert whole.piece == "" and whole.source == str(tmp_path / "whole.csv")


TOO_SHORT = (
    "{log} (--split-gaps piece 1 of 3, t = 0 … 1 s, the longest): too short: 2 samples on the "
    "model's grid (dt = 1 s); a report needs at least 3"
)


def test_analyze_names_the_piece_too_short_to_analyse(
    tmp_path: Path, model: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = write(tmp_path / "short.csv", [0, 1, 20, 21, 40, 41])
    out = tmp_path / "report"
    args = ["analyze", str(log), "--model", str(model), "--split-gaps", "--out", str(out)]
    code, printed = run_main([*args, "--estimator", "imm"], capsys)
    assert code == 2 and not out.exists()
    (line,) = printed.strip().splitlines()
    assert line.startswith("hybridlog: error: " + TOO_SHORT.format(log=log))


def test_a_batch_log_whose_piece_is_too_short_names_it(
    tmp_path: Path, model: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)  # a short path: the batch shortens a long line in its middle
    log = write(Path("short.csv"), [0, 1, 20, 21, 40, 41])
    outcome = run_batch(
        [log], model, out_dir=Path("out"), estimator="imm", read=ReadOptions(split_gaps=True)
    )
    (failed,) = outcome.logs
    assert failed.status == "failed" and failed.error is not None
    assert failed.error.startswith(TOO_SHORT.format(log=log))
