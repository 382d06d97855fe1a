"""``compare`` with ``switching-observer``, the estimator that reads the switching signal.

Two defects of the kind "compare ran what it could not vouch for, or compared unlike":

- a log without the switching signal was refused as ``switching-observer`` started, after
  the estimators named before it had run: their work was lost (on a long log, minutes)
  where the log could be refused before any ran;
- its mode accuracy of 1.0 (it reads the modes from the log's switching signal, which the
  mode metrics take as the true mode) stood beside ``sliding-mode``'s 0.96, an estimate,
  with nothing to say the two were not alike;
- a gate on a mode metric (``--fail-under mode_accuracy=0.9``), which its report can never
  meet (it scores none), ran every estimator and then failed its gate, exit 1, where the
  gate could be refused before any ran, as a gate on a smoother's fallbacks without one is.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

import hybridlog.jobs.compare as compare_job
from hybridlog.errors import LogError, OptionError
from hybridlog.jobs.compare import compare
from hybridlog.jobs.gate_checks import gates_for
from hybridlog.jobs.overrides import Overrides, prepare_estimators
from hybridlog.jobs.simulate import simulate_log
from hybridlog.model.cache import load_model

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

    monkeypatch.setattr(compare_job, "estimates", ran)
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


@pytest.mark.parametrize(
    ("option", "gate"),
    [
        ("fail_under", "mode_accuracy=0.5"),
        ("fail_over", "missed_switches=0"),
        ("fail_over", "detection_delay_s=1"),
    ],
)
def test_a_gate_on_a_mode_metric_the_switching_signal_gives_is_refused_before_any_run(
    tank: tuple[Path, Path],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    option: str,
    gate: str,
) -> None:
    model, log = tank

    def ran(*args: Any, **kwargs: Any) -> Any:
        raise AssertionError("an estimator ran under a gate that could never pass")

    monkeypatch.setattr(compare_job, "estimates", ran)
    out = tmp_path / "cmp"
    flag = "--" + option.replace("_", "-")
    metric = gate.partition("=")[0]
    with pytest.raises(
        OptionError,
        match=rf"^{flag} '{gate}': estimator 'switching-observer' scores no mode metric "
        rf"\(it reads its modes from the log's switching signal, the log's true mode\), so "
        rf"its report has no {metric} and this gate could never pass$",
    ):
        compare(log, model, BOTH, out_dir=out, **{option: [gate]})
    assert not out.exists()
    # the same gate on the estimator that estimates its modes alone is taken
    loaded = load_model(model)
    alone = prepare_estimators(loaded, ["sliding-mode"], Overrides())
    gates = gates_for(loaded, alone, **{"fail_under": (), "fail_over": (), option: [gate]})
    assert [g.metric for g in gates] == [metric]
