"""``compare`` with ``switching-observer``, the estimator that reads the switching signal.

Two defects of the kind "compare ran what it could not vouch for, or compared unlike":

- a log without the switching signal was refused as ``switching-observer`` started, after
  the estimators named before it had run: their work was lost (on a long log, minutes)
  where the log could be refused before any ran;
- its mode accuracy of 1.0 (it reads the modes from the log's switching signal, which the
  mode metrics take as the true mode) stood beside ``sliding-mode``'s 0.96, an estimate,
  with nothing to say the two were not alike.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from hybridlog.errors import LogError
from hybridlog.jobs import analysis
from hybridlog.jobs.analysis import compare
from hybridlog.jobs.simulate import simulate_log

TANK = """
name = "one_tank"
time = "continuous"
dt = 0.001
integration = {method = "euler", step = 0.001}
states = ["H1"]
inputs = ["q"]
outputs = ["y1"]
booleans = ["U1"]

[parameters]
C1 = 4.702e-5
a = 0.035
w = 0.035

[dynamics]
dx = ["(q - C1*sqrt(H1)*U1)/(a*w)"]
h = ["H1"]

[noise]
process = 0.0
measurement = 1e-12

[initial]
state = [0.22]
mode = "1"

[simulation]
state_min = [0.0]
schedule = "1:200,0:200,1:200"

[simulation.inputs]
q = "1.1e-5*(1 + 0.25*sin(2*pi*t/5))"

[estimators.sliding-mode]
drift_bound = 1e-3
gamma = 500.0
"""

BOTH = ["sliding-mode", "switching-observer"]


@pytest.fixture(scope="module")
def tank(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A one-tank boolean-affine model both estimators run, and a 601-sample log of it."""
    root = tmp_path_factory.mktemp("tank")
    model = root / "tank.toml"
    model.write_text(TANK)
    log = root / "log.csv"
    simulate_log(model, log, seed=1)
    return model, log


def test_a_log_without_the_switching_signal_is_refused_before_any_estimator_runs(
    tank: tuple[Path, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    model, log = tank
    lines = log.read_text().splitlines()
    mode = lines[0].split(",").index("mode")
    blind = tmp_path / "blind.csv"
    blind.write_text(
        "\n".join(",".join(c for i, c in enumerate(x.split(",")) if i != mode) for x in lines)
        + "\n"
    )

    def ran(*args: Any, **kwargs: Any) -> Any:
        raise AssertionError("an estimator ran on a log compare refuses")

    monkeypatch.setattr(analysis, "estimates", ran)
    out = tmp_path / "cmp"
    with pytest.raises(
        LogError,
        match=r"^--estimators switching-observer: .*blind\.csv: estimator 'switching-observer' "
        r"needs the switching signal in the log",
    ):
        compare(blind, model, BOTH, out_dir=out)
    assert not out.exists()


def test_mode_metrics_of_the_switching_signal_are_said_not_to_be_an_estimate(
    tank: tuple[Path, Path], tmp_path: Path
) -> None:
    model, log = tank
    out = tmp_path / "cmp"
    outcome = compare(log, model, BOTH, out_dir=out)
    # it scored 1.0, the log's true mode against itself, and a gate on it passed
    given = outcome.reports["switching-observer"]
    assert given.modes.accuracy is None and given.modes.confusion is None
    assert "given, not estimated" in given.null_reasons["mode_accuracy"]
    assert outcome.reports["sliding-mode"].modes.accuracy is not None
    text = (out / "comparison.md").read_text()
    assert (
        "- `switching-observer` has no mode metrics: it reads its modes from the log's "
        "switching signal, the log's true mode, so they would score that signal against itself\n"
    ) in text
