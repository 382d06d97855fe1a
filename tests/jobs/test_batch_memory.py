"""``batch --jobs N``: the logs the workers run at once are checked together against memory.

Each worker checked its log against the whole machine's available memory, as if it ran
alone: N logs that each fit alone were let through together, and the kernel killed them.
Now the pool's workers reserve their logs' needs in one ledger
(:class:`hybridlog.memory.MemoryLedger`): a log that fits alone but not beside the others
waits for them; one that cannot fit alone is refused as before.
"""

from __future__ import annotations

import os
import signal
import threading
import time
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

import hybridlog.memory
from hybridlog.cli import cli
from hybridlog.errors import LogError
from hybridlog.jobs.workers import WorkerPool
from hybridlog.memory import MemoryLedger, available_memory, reserved
from tests.support.paths import SAMPLE_LOGS

HOLD_S = 1.0


def _hold(need: int, die: bool = False) -> dict[str, Any]:
    """A batch worker's task: reserve ``need`` bytes for a while (nothing is allocated)."""
    signal.alarm(30)  # a slot never released would make this wait for ever
    with reserved([("the estimates", need)], what="log", remedy="r", error=LogError) as waited:
        started = time.monotonic()
        if die:
            os.kill(os.getpid(), signal.SIGKILL)
        time.sleep(HOLD_S)
        ended = time.monotonic()
    signal.alarm(0)
    return {"waited": waited, "held": (started, ended)}


def _died(index: int, reason: str) -> dict[str, Any]:
    return {"died": reason}


def _available() -> int:
    available = available_memory()
    if available is None:
        pytest.skip("the system says nothing of its memory")
    return available


def test_logs_that_fit_alone_but_not_together_run_one_after_the_other() -> None:
    need = int(0.6 * _available())
    with WorkerPool(2) as pool:
        first, second = pool.run(_hold, [(need,), (need,)], died=_died)
    (_, b), (c, _) = sorted([first["held"], second["held"]])
    assert b <= c, "both logs held their memory at once"
    assert max(first["waited"], second["waited"]) > 0.0
    small = int(0.2 * _available())
    with WorkerPool(2) as pool:
        results = pool.run(_hold, [(small,), (small,)], died=_died)
    assert [r["waited"] for r in results] == [0.0, 0.0]


def test_a_dead_workers_memory_is_given_back() -> None:
    need = int(0.6 * _available())
    with WorkerPool(2) as pool:
        dead, alive = pool.run(_hold, [(need, True), (need,)], died=_died)
        assert pool.ledger.held() == [0, 0]
    assert dead == {"died": "killed by signal SIGKILL"}
    assert "held" in alive


def test_the_ledger_waits_while_others_hold_and_refuses_what_cannot_fit_alone(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(hybridlog.memory, "available_memory", lambda: 10_000)
    monkeypatch.setattr(hybridlog.memory, "WAIT_POLL_S", 0.01)
    ledger = MemoryLedger(3)
    parts = [("the estimates", 6_000)]
    events: list[str] = []
    with ledger.reserve(0, parts, what="a", remedy="r", error=LogError) as waited:
        assert waited == 0.0 and ledger.held() == [6_000, 0, 0]
        # beside it: 3,000 fits at once; 6,000 waits; 11,000 never fits
        with ledger.reserve(1, [("x", 3_000)], what="b", remedy="r", error=LogError) as w:
            assert w == 0.0
        with (
            pytest.raises(LogError, match=r"^c would need about 0\.0 MB .* is available; r$"),
            ledger.reserve(2, [("x", 11_000)], what="c", remedy="r", error=LogError),
        ):
            pass

        def second() -> None:
            with ledger.reserve(1, parts, what="d", remedy="r", error=LogError) as w:
                events.append(f"second after {w:.2f}")

        thread = threading.Thread(target=second)
        thread.start()
        time.sleep(0.2)
        events.append("first done")
    thread.join(timeout=10)
    assert events[0] == "first done" and events[1].startswith("second after ")
    assert float(events[1].split()[-1]) >= 0.15
    assert ledger.held() == [0, 0, 0]


def test_the_command_says_when_logs_waited_for_memory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import hybridlog.jobs.batch as batch
    from hybridlog.jobs.batch_outcomes import BatchOutcome, LogOutcome

    def run_batch(found: Any, *args: Any, **kwargs: Any) -> BatchOutcome:
        logs = [
            LogOutcome(str(log), "f", "done", None, None, memory_wait_s=wait)
            for log, wait in zip(found.paths, (0.0, 2.5, 1.0), strict=True)
        ]
        return BatchOutcome(logs=logs, table="", gate_failures=[])

    monkeypatch.setattr(batch, "run_batch", run_batch)
    logs = [str(SAMPLE_LOGS / name) for name in ("bioplex_pgc.csv", "ice_clutch.csv")]
    logs.append(str(SAMPLE_LOGS / "three_tank_hstf.csv"))
    args = ["batch", *logs, "--model", "three_tank_hstf", "--out", str(tmp_path / "o")]
    result = CliRunner().invoke(cli, [*args, "--jobs", "3"])
    assert result.exit_code == 0, result.output
    assert result.stderr == (
        "hybridlog: note: 2 of 3 logs waited 4 s in all for memory held by the other "
        "workers' logs: --jobs 3 ran fewer logs at once where all would not fit\n"
    )


def test_the_ledger_leaves_nothing_for_the_resource_tracker(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # multiprocessing's semaphores are recorded by its resource tracker, which a SIGTERM to
    # the batch's process group kills: its successor printed a KeyError traceback
    from multiprocessing import resource_tracker

    recorded: list[tuple[str, str]] = []
    monkeypatch.setattr(
        resource_tracker, "register", lambda name, kind: recorded.append((name, kind))
    )
    with WorkerPool(2) as pool:
        results = pool.run(_hold, [(1,), (1,)], died=_died)
    assert all("held" in r for r in results) and recorded == []
