"""A log without a command ``unknown-mode``'s transition rules name is refused before any runs.

The check ran only as ``unknown-mode`` started: ``compare --estimators imm,unknown-mode`` ran
imm over the whole log and then lost its work to the refusal (exit 2).  It is now one of the
needs every command checks once the log is read
(:meth:`~hybridlog.estimators.capabilities.Capabilities.signals_mismatch`): ``analyze``,
``compare`` (every estimator named) and each log of a batch refuse before any estimator
runs, with one line naming the command, the rule's component and the rule.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest

import hybridlog.jobs.compare as compare_job
from hybridlog.errors import LogError
from hybridlog.jobs import analysis, batch_task
from hybridlog.jobs.analysis import analyze
from hybridlog.jobs.batch import run_batch
from hybridlog.jobs.compare import compare
from hybridlog.jobs.simulate import simulate_log
from tests.estimators.test_cpha_commands import VALVE

REFUSAL = (
    r"{log}: estimator 'unknown-mode' needs the command 'cmd' in the log, which a transition "
    r"rule of component 'valve' reads \({model}: components\.valve\.transitions\[0\]\.when\): "
    r"the rules are applied by the logged commands; map it with --map cmd=FIELD or \[signals\]"
)


@pytest.fixture(scope="module")
def no_command(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The commanded valve's model and a simulated log of it without its ``cmd`` column."""
    root = tmp_path_factory.mktemp("valve")
    model = root / "valve.toml"
    model.write_text(VALVE.replace("steps = 200", "steps = 40"), encoding="utf-8")
    full = root / "valve.csv"
    simulate_log(model, full, seed=1)
    lines = full.read_text(encoding="utf-8").splitlines()
    drop = lines[0].split(",").index("cmd")
    log = root / "no_cmd.csv"
    log.write_text(
        "\n".join(",".join(c for i, c in enumerate(x.split(",")) if i != drop) for x in lines)
        + "\n",
        encoding="utf-8",
    )
    return model, log


def refusal(model: Path, log: Path) -> str:
    return REFUSAL.format(log=re.escape(str(log)), model=re.escape(str(model)))


def _no_run(*args: Any, **kwargs: Any) -> Any:
    raise AssertionError("an estimator ran on a log that is refused")


def test_compare_refuses_before_the_estimators_named_first_run(
    no_command: tuple[Path, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    model, log = no_command
    monkeypatch.setattr(compare_job, "estimates", _no_run)
    out = tmp_path / "cmp"
    with pytest.raises(LogError) as raised:
        compare(log, model, ["imm", "unknown-mode"], out_dir=out)
    assert re.fullmatch(rf"--estimators unknown-mode: {refusal(model, log)}", str(raised.value))
    assert not out.exists()


def test_analyze_refuses_before_the_estimator_is_sent_the_log(
    no_command: tuple[Path, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    model, log = no_command
    monkeypatch.setattr(analysis, "estimates", _no_run)
    out = tmp_path / "report"
    with pytest.raises(LogError) as raised:
        analyze(log, model, estimator="unknown-mode", out_dir=out)
    assert re.fullmatch(refusal(model, log), str(raised.value))
    assert not out.exists()


def test_a_batch_log_is_refused_before_it_waits_for_memory_or_runs(
    no_command: tuple[Path, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    model, log = no_command
    monkeypatch.setattr(batch_task, "memory_reserved", _no_run)
    outcome = run_batch([log], model, out_dir=tmp_path / "batch", estimator="unknown-mode")
    (failed,) = outcome.logs
    assert failed.status == "failed" and failed.error is not None
    # the batch's one line shortens a long error in its middle, keeping its end
    assert failed.error.startswith(f"{log}: estimator 'unknown-mode'")
    assert failed.error.endswith(
        "ns[0].when): the rules are applied by the logged commands; map it with --map "
        "cmd=FIELD or [signals]"
    )
