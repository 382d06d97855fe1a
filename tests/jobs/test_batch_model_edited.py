"""A model or centres file edited while a batch runs never reaches a report recording the old.

Each worker process loads the model file when it gets its first log, after the batch process
hashed it for the reports' provenance.  Before, a model edited meanwhile (a nightly batch
running while someone saves the model) was used by the workers that started after the edit,
their reports recording the hash of the content checked before: put the first content back
and a re-run reused reports made with the other.  Now a worker whose model file no longer has
the hash of the batch fails its logs, saying why.
"""

from __future__ import annotations

import hashlib
import json
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import pytest

import hybridlog.jobs.batch_plan as batch_plan
import hybridlog.jobs.batch_task as batch_task
from hybridlog.errors import ModelError, OptionError
from hybridlog.estimators import Prepared
from hybridlog.io import ReadOptions
from hybridlog.io.writers import write_table
from hybridlog.jobs.batch import run_batch
from hybridlog.jobs.batch_outcomes import LogOutcome
from hybridlog.jobs.cluster import discover_modes
from hybridlog.model.builtins import builtin_text
from hybridlog.model.hybrid_model import HybridModel
from tests.support.logfiles import tank_run
from tests.support.paths import SAMPLE_LOGS

TANK = "three_tank_hstf"
DOUBLE_CART = SAMPLE_LOGS / "double_cart_case1.csv"
T = TypeVar("T")


def test_a_worker_that_starts_after_the_model_was_edited_fails_its_logs(tmp_path: Path) -> None:
    model = tmp_path / "tank.toml"
    model.write_text(builtin_text(TANK), encoding="utf-8")
    (tmp_path / "logs").mkdir()
    logs = [
        write_table(tmp_path / "logs" / f"s{k}.csv", tank_run(steps=30, seed=k).columns)
        for k in (1, 2)
    ]

    def edit_and_start_a_new_worker(outcome: LogOutcome) -> None:
        if Path(outcome.log).name == "s1.csv":
            model.write_text(builtin_text(TANK) + "\n# edited\n", encoding="utf-8")
            batch_task.WARM.clear()  # the next log goes to a worker that has loaded nothing yet

    outcome = run_batch(
        logs,
        model,
        out_dir=tmp_path / "out",
        estimator="imm",
        progress=edit_and_start_a_new_worker,
    )

    first, second = outcome.logs
    assert first.status == "done"
    assert second.status == "failed" and second.error is not None
    assert "model file changed since the batch started" in second.error
    assert str(model) in second.error
    assert not (tmp_path / "out" / "s2.csv").exists()
    # the log analysed before the edit records the content it was made from
    recorded = json.loads((tmp_path / "out" / "s1.csv" / "report.json").read_text("utf-8"))
    original = hashlib.sha256(builtin_text(TANK).encode("utf-8")).hexdigest()
    assert recorded["batch"]["model_sha256"] == original


def test_a_centres_file_edited_while_the_batch_runs_fails_the_later_logs(tmp_path: Path) -> None:
    """The same for a file an estimator option names (chiu's centres), hashed in the settings."""
    centres = tmp_path / "c.json"
    discover_modes(DOUBLE_CART, "double_cart_case1", out=centres, compare_kmeans=False)
    (tmp_path / "logs").mkdir()
    logs = [tmp_path / "logs" / f"s{k}.csv" for k in (1, 2)]
    for log in logs:
        shutil.copyfile(DOUBLE_CART, log)

    def edit_and_start_a_new_worker(outcome: LogOutcome) -> None:
        if Path(outcome.log).name == "s1.csv":  # the same centres, written another way
            centres.write_text(json.dumps(json.loads(centres.read_text("utf-8")), indent=1))
            batch_task.WARM.clear()

    outcome = run_batch(
        logs,
        "double_cart_case1",
        out_dir=tmp_path / "out",
        estimator="chiu",
        sets=[f"centers={centres}"],
        progress=edit_and_start_a_new_worker,
    )

    first, second = outcome.logs
    assert first.status == "done"
    assert second.status == "failed" and second.error is not None
    assert second.error.startswith(f"centres file '{centres}': changed since the batch started")


def test_a_msg_dir_edited_while_the_batch_runs_fails_the_later_logs(tmp_path: Path) -> None:
    """A ``--msg-dir`` is read with each log: each log checks it (hashed in the settings)."""
    msgs = tmp_path / "msgs" / "my_msgs" / "msg"
    msgs.mkdir(parents=True)
    (msgs / "Level.msg").write_text("float64 h\n", encoding="utf-8")
    (tmp_path / "logs").mkdir()
    logs = [
        write_table(tmp_path / "logs" / f"s{k}.csv", tank_run(steps=30, seed=k).columns)
        for k in (1, 2)
    ]

    def edit(outcome: LogOutcome) -> None:
        if Path(outcome.log).name == "s1.csv":
            (msgs / "Level.msg").write_text("float64 h\nfloat64 g\n", encoding="utf-8")

    outcome = run_batch(
        logs,
        TANK,
        out_dir=tmp_path / "out",
        estimator="imm",
        read=ReadOptions(msg_dirs=(str(tmp_path / "msgs"),)),
        progress=edit,
    )

    assert [o.status for o in outcome.logs] == ["done", "failed"]
    error = outcome.logs[1].error
    assert error is not None and error.startswith("--msg-dir folder ")
    assert "changed since the batch started" in error


def test_a_msg_dir_is_read_again_only_when_stat_says_it_changed(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A --msg-dir may be a whole ROS install: a log does not hash it again while unchanged."""
    msgs = tmp_path / "msgs" / "my_msgs" / "msg"
    msgs.mkdir(parents=True)
    (msgs / "Level.msg").write_text("float64 h\n", encoding="utf-8")
    (tmp_path / "logs").mkdir()
    logs = [
        write_table(tmp_path / "logs" / f"s{k}.csv", tank_run(steps=30, seed=k).columns)
        for k in (1, 2, 3)
    ]
    hashed: list[str] = []
    content_hash = batch_task.content_hash

    def counted(path: str, *, what: str = "log") -> str:
        hashed.append(what)
        return content_hash(path, what=what)

    monkeypatch.setattr(batch_plan, "content_hash", counted)  # the settings
    monkeypatch.setattr(batch_task, "content_hash", counted)  # each log's checks
    outcome = run_batch(
        logs,
        TANK,
        out_dir=tmp_path / "out",
        estimator="imm",
        read=ReadOptions(msg_dirs=(str(tmp_path / "msgs"),)),
    )
    assert [o.status for o in outcome.logs] == ["done"] * 3
    assert hashed.count("--msg-dir folder") == 1  # for the settings, once


def _saving_meanwhile(model: Path, read: Callable[..., T]) -> Callable[..., T]:
    """``read`` (the model's), the model file saved first: between its hash and its read."""

    def saved_then_read(*args: object) -> T:
        model.write_text(builtin_text(TANK) + "\n# edited\n", encoding="utf-8")
        return read(*args)

    return saved_then_read


def test_a_model_saved_between_its_hash_and_its_read_stops_the_batch(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The batch hashed the model, then read it for the logs its own process analyses: an
    edit saved in between was loaded under the hash of the content before it (reports said
    they were made from a model they were not)."""
    model = tmp_path / "tank.toml"
    model.write_text(builtin_text(TANK), encoding="utf-8")
    (tmp_path / "logs").mkdir()
    log = write_table(tmp_path / "logs" / "s1.csv", tank_run(steps=30, seed=1).columns)
    monkeypatch.setattr(batch_plan, "parse_sets", _saving_meanwhile(model, batch_plan.parse_sets))

    with pytest.raises(ModelError, match="the model file changed since the batch started"):
        run_batch([log], model, out_dir=tmp_path / "out", estimator="imm")
    assert not (tmp_path / "out").exists()


def test_a_model_saved_between_a_workers_hash_and_its_read_fails_its_logs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The same in a worker that loads the model for its first log."""
    model = tmp_path / "tank.toml"
    model.write_text(builtin_text(TANK), encoding="utf-8")
    (tmp_path / "logs").mkdir()
    logs = [
        write_table(tmp_path / "logs" / f"s{k}.csv", tank_run(steps=30, seed=k).columns)
        for k in (1, 2)
    ]
    monkeypatch.setattr(batch_task, "parse_sets", _saving_meanwhile(model, batch_task.parse_sets))

    def start_a_new_worker(outcome: LogOutcome) -> None:
        batch_task.WARM.clear()  # the next log goes to a worker that has loaded nothing yet

    outcome = run_batch(
        logs, model, out_dir=tmp_path / "out", estimator="imm", progress=start_a_new_worker
    )

    first, second = outcome.logs
    assert first.status == "done"
    assert second.status == "failed" and second.error is not None
    assert second.error.startswith(f"{model}: the model file changed since the batch started")
    assert not (tmp_path / "out" / "s2.csv").exists()


def test_a_centres_file_saved_between_its_hash_and_its_read_stops_the_batch(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The same for a file an estimator option names, hashed in the settings, then read."""
    centres = tmp_path / "c.json"
    discover_modes(DOUBLE_CART, "double_cart_case1", out=centres, compare_kmeans=False)
    (tmp_path / "logs").mkdir()
    log = tmp_path / "logs" / "s1.csv"
    shutil.copyfile(DOUBLE_CART, log)
    estimator_inputs = batch_plan.estimator_inputs

    def saved_meanwhile(prepared: Prepared, model: HybridModel) -> dict[str, Any]:
        centres.write_text(json.dumps(json.loads(centres.read_text("utf-8")), indent=1))
        return estimator_inputs(prepared, model)

    monkeypatch.setattr(batch_plan, "estimator_inputs", saved_meanwhile)
    with pytest.raises(OptionError, match=r"centres file .*: changed since the batch started"):
        run_batch(
            [log],
            "double_cart_case1",
            out_dir=tmp_path / "out",
            estimator="chiu",
            sets=[f"centers={centres}"],
        )
    assert not (tmp_path / "out").exists()


def test_a_msg_dir_edited_while_a_log_is_read_fails_that_log(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A ``--msg-dir`` is checked after each log's read too: an edit saved during the read
    was read under the hash of the content before it."""
    msgs = tmp_path / "msgs" / "my_msgs" / "msg"
    msgs.mkdir(parents=True)
    (msgs / "Level.msg").write_text("float64 h\n", encoding="utf-8")
    (tmp_path / "logs").mkdir()
    log = write_table(tmp_path / "logs" / "s1.csv", tank_run(steps=30, seed=1).columns)
    read_log = batch_task.read_log

    def edited_while_read(*args: Any) -> Any:
        signals = read_log(*args)
        (msgs / "Level.msg").write_text("float64 h\nfloat64 g\n", encoding="utf-8")
        return signals

    monkeypatch.setattr(batch_task, "read_log", edited_while_read)
    outcome = run_batch(
        [log],
        TANK,
        out_dir=tmp_path / "out",
        estimator="imm",
        read=ReadOptions(msg_dirs=(str(tmp_path / "msgs"),)),
    )

    (only,) = outcome.logs
    assert only.status == "failed" and only.error is not None
    assert only.error.startswith("--msg-dir folder ")
    assert "changed since the batch started" in only.error
    assert not (tmp_path / "out" / "s1.csv").exists()
