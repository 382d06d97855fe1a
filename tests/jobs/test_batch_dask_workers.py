"""``hybridlog batch --scheduler``: the Dask workers are there, and fit for the batch.

A scheduler without workers made the batch wait forever, as did one whose workers all left
mid-batch; a worker with another hybridlog wrote reports recording its version; one started
in another folder read the batch's relative paths there (each log "cannot read it", or
another file of the same name).  Each is now one line naming the scheduler or the worker.
"""

from __future__ import annotations

import os
import re
import shutil
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

import hybridlog
from hybridlog import __version__
from hybridlog.errors import OptionError
from hybridlog.io.writers import write_table
from hybridlog.jobs import dask_backend
from hybridlog.jobs.batch import run_batch
from hybridlog.jobs.provenance import model_hash
from tests.support.logfiles import tank_run

distributed = pytest.importorskip("distributed")

TANK = "three_tank_hstf"

HELD = threading.Event()
"""Lets :func:`held_task`'s second task end (the workers are threads of this process)."""

FACTS: list[tuple[str, str]] = []
"""What :func:`reported_facts` says of a worker, one call after another (then the last)."""


def held_task(k: int) -> int:
    """A task of the batch; the second held until the test lets it go."""
    if k == 1:
        HELD.wait(timeout=30)
    return k


def reported_facts() -> tuple[str, str]:
    """A worker's hybridlog version and folder, as :data:`FACTS` has them."""
    return FACTS.pop(0) if len(FACTS) > 1 else FACTS[0]


SIGHT: list[bool] = []
"""Whether :func:`reported_sight` says a worker sees a path, one call after another."""


def reported_sight(path: str) -> bool:
    """Whether a worker sees ``path``, as :data:`SIGHT` has it (then the last)."""
    return SIGHT.pop(0) if len(SIGHT) > 1 else SIGHT[0]


def local_cluster(workers: int) -> distributed.LocalCluster:
    return distributed.LocalCluster(
        n_workers=workers,
        threads_per_worker=1,
        processes=False,  # threads of this process: quick to start, monkeypatches seen
        protocol="tcp",
        host="127.0.0.1",
        dashboard_address=":0",
    )


@pytest.fixture(scope="module")
def cluster() -> Iterator[distributed.LocalCluster]:
    with local_cluster(1) as running:
        yield running


@pytest.fixture
def quick(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(dask_backend, "WORKER_WAIT_S", 0.2)
    monkeypatch.setattr(dask_backend, "POLL_S", 0.02)
    monkeypatch.setattr(dask_backend, "STOP_WAIT_S", 0.05)


def test_a_scheduler_without_workers_is_an_error_not_a_wait(tmp_path: Path, quick: None) -> None:
    log = write_table(tmp_path / "s1.csv", tank_run(steps=20, seed=1).columns)
    with local_cluster(0) as empty:
        address = empty.scheduler_address
        with pytest.raises(OptionError) as err:
            run_batch([log], TANK, out_dir=tmp_path / "out", scheduler=address)
    assert str(err.value) == (
        f"--scheduler {address}: the scheduler has no workers (none joined within 0.2 s); "
        f"start some: dask worker {address}"
    )
    assert not (tmp_path / "out").exists()  # refused before anything was written


def test_workers_that_all_leave_mid_batch_stop_it(quick: None) -> None:
    HELD.clear()
    with local_cluster(1) as leaving:
        client = dask_backend.connect(leaving.scheduler_address)
        workers = dask_backend.check_workers(
            client, leaving.scheduler_address, [], (TANK, model_hash(TANK))
        )
        arrived: list[int] = []

        def leave(k: int) -> None:
            arrived.append(k)
            leaving.scale(0)  # the second task is running: its worker leaves with it

        try:
            with pytest.raises(OptionError, match=r"\(every worker left mid-batch, 1 of 3"):
                dask_backend.run_on_dask(
                    held_task, [(0,), (1,), (2,)], client, workers, died=lambda k, _: -k, done=leave
                )
        finally:
            HELD.set()
    assert arrived == [0]


def test_a_worker_of_another_version_is_refused(
    tmp_path: Path, cluster: distributed.LocalCluster, monkeypatch: pytest.MonkeyPatch
) -> None:
    log = write_table(tmp_path / "s1.csv", tank_run(steps=20, seed=1).columns)
    monkeypatch.setattr(dask_backend, "_worker_facts", reported_facts)
    FACTS[:] = [("0.0.1", os.getcwd())]
    with pytest.raises(OptionError, match=rf"has hybridlog 0\.0\.1, this process {__version__}"):
        run_batch([log], TANK, out_dir=tmp_path / "out", scheduler=cluster.scheduler_address)
    assert not (tmp_path / "out").exists()


def test_a_worker_in_another_folder_is_refused_for_relative_paths(
    tmp_path: Path, cluster: distributed.LocalCluster, monkeypatch: pytest.MonkeyPatch
) -> None:
    write_table(tmp_path / "logs" / "s1.csv", tank_run(steps=20, seed=1).columns)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(dask_backend, "_worker_facts", reported_facts)
    FACTS[:] = [(__version__, "/")]
    with pytest.raises(OptionError, match=r"runs in '/', not in .* relative path 'logs/s1\.csv'"):
        run_batch(["logs/s1.csv"], TANK, out_dir="out", scheduler=cluster.scheduler_address)
    assert not (tmp_path / "out").exists()
    # absolute paths name the same files wherever the worker runs
    outcome = run_batch(
        [tmp_path / "logs" / "s1.csv"],
        TANK,
        out_dir=tmp_path / "out",
        scheduler=cluster.scheduler_address,
    )
    assert [log.status for log in outcome.logs] == ["done"]


def test_a_worker_that_joins_unfit_fails_its_logs_naming_why(
    tmp_path: Path, cluster: distributed.LocalCluster, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Checked when the batch starts, a worker may join later: each task checks it again."""
    log = write_table(tmp_path / "s1.csv", tank_run(steps=20, seed=1).columns)
    monkeypatch.setattr(dask_backend, "_worker_facts", reported_facts)
    FACTS[:] = [(__version__, os.getcwd()), ("0.0.1", os.getcwd())]
    outcome = run_batch([log], TANK, out_dir=tmp_path / "out", scheduler=cluster.scheduler_address)
    (failed,) = outcome.logs
    assert failed.status == "failed"
    assert failed.error is not None
    assert failed.error.startswith("on the Dask cluster: OptionError: the Dask worker tcp://")
    assert "has hybridlog 0.0.1" in failed.error  # not "worker process died": it lives on


def test_the_documented_wait_is_the_constant() -> None:
    from click.testing import CliRunner

    from hybridlog.cli import cli

    wait = f"{dask_backend.WORKER_WAIT_S:g} s"
    help_text = " ".join(CliRunner().invoke(cli, ["batch", "--help"]).output.split())
    assert f"Without workers for {wait}" in help_text
    readme = " ".join((Path(__file__).parents[2] / "README.md").read_text().split())
    assert f"waited for {wait} at most" in readme


def test_a_worker_that_does_not_see_an_input_is_refused(
    tmp_path: Path, cluster: distributed.LocalCluster, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A model file only on the client made every log fail alone; now one line, nothing written."""
    log = write_table(tmp_path / "s1.csv", tank_run(steps=20, seed=1).columns)
    model = tmp_path / "tank.toml"
    shutil.copyfile(Path(hybridlog.__file__).parent / "model" / "builtin" / f"{TANK}.toml", model)
    monkeypatch.setattr(dask_backend, "_first_unseen", lambda paths: paths.index(str(model)))
    with pytest.raises(
        OptionError, match=r"does not see the model file '.*tank\.toml'; the workers"
    ):
        run_batch([log], model, out_dir=tmp_path / "out", scheduler=cluster.scheduler_address)
    assert not (tmp_path / "out").exists()
    # a log no one sees fails alone, as in a local batch
    monkeypatch.setattr(dask_backend, "_first_unseen", lambda paths: -1)
    outcome = run_batch(
        [log, tmp_path / "gone.csv"],
        TANK,
        out_dir=tmp_path / "out",
        scheduler=cluster.scheduler_address,
    )
    assert {Path(o.log).name: o.status for o in outcome.logs} == {
        "gone.csv": "failed",
        "s1.csv": "done",
    }


def test_a_worker_that_reads_another_model_is_refused(
    tmp_path: Path, cluster: distributed.LocalCluster, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A worker's built-in model of other sources: each log failed 'the model file changed'."""
    log = write_table(tmp_path / "s1.csv", tank_run(steps=20, seed=1).columns)
    monkeypatch.setattr(dask_backend, "_model_digest", lambda ref: "0" * 64)
    with pytest.raises(
        OptionError, match=r"reads another model 'three_tank_hstf' \(SHA-256 0{12} "
    ):
        run_batch([log], TANK, out_dir=tmp_path / "out", scheduler=cluster.scheduler_address)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    ("failed", "counted"),
    [
        (set(), "1 of 3 logs done, which the next run skips"),
        # counted as done, a log that failed (which the next run redoes)
        ({0}, "0 of 3 logs done, which the next run skips; 1 failed, which it redoes"),
    ],
)
def test_tasks_cancelled_on_the_cluster_end_the_batch_in_one_line(
    quick: None, failed: set[int], counted: str
) -> None:
    """The scheduler lost, or the tasks cancelled from its dashboard: it read 'unexpected
    FuturesCancelledError ... (a bug ...)' with Dask's list of keys."""
    HELD.clear()
    with local_cluster(1) as running:
        client = dask_backend.connect(running.scheduler_address)
        workers = dask_backend.check_workers(
            client, running.scheduler_address, [], (TANK, model_hash(TANK))
        )

        def cancel_all(k: int) -> None:  # as another client of the scheduler may
            futures = [distributed.Future(key, client) for key in list(client.futures)]
            client.cancel(futures, force=True)

        try:
            with pytest.raises(OptionError) as err:
                dask_backend.run_on_dask(
                    held_task,
                    [(0,), (1,), (2,)],
                    client,
                    workers,
                    died=lambda k, _: -k,
                    done=cancel_all,
                    kept=lambda k: k not in failed,
                )
        finally:
            HELD.set()
    assert str(err.value) == (
        f"--scheduler {running.scheduler_address}: the batch ended mid-way (its tasks were "
        f"cancelled: by a client of the scheduler); {counted}"
    )


def test_a_worker_that_does_not_see_the_batch_folder_is_refused_and_it_is_removed(
    tmp_path: Path, cluster: distributed.LocalCluster, monkeypatch: pytest.MonkeyPatch
) -> None:
    """--out on the client's disk only: each worker wrote its reports on its own disk, and
    the summaries named folders missing here.  Now one line naming the worker and the folder,
    and what this run made of the folder is removed (an earlier run's folder is kept)."""
    log = write_table(tmp_path / "logs" / "s1.csv", tank_run(steps=20, seed=1).columns)
    monkeypatch.setattr(dask_backend, "_sees", lambda path: False)
    out = tmp_path / "new" / "out"
    with pytest.raises(OptionError) as err:
        run_batch([log], TANK, out_dir=out, scheduler=cluster.scheduler_address)
    (worker,) = cluster.scheduler.workers
    said = str(err.value)  # the folder's path is cut in the middle where it is long
    assert said.startswith(
        f"--scheduler {cluster.scheduler_address}: the Dask worker {worker} does not see --out '"
    )
    assert "' (not on a shared file system?); its reports would go to its own disk" in said
    assert out.name in said
    assert not (tmp_path / "new").exists()  # made by this run: removed, parents too
    # an empty folder given: left empty; an earlier run's batch folder: left as it was
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(OptionError, match="does not see --out"):
        run_batch([log], TANK, out_dir=empty, scheduler=cluster.scheduler_address)
    assert list(empty.iterdir()) == []
    monkeypatch.setattr(dask_backend, "_sees", os.path.exists)
    earlier = tmp_path / "earlier"
    run_batch([log], TANK, out_dir=earlier, scheduler=cluster.scheduler_address)
    before = sorted(p.relative_to(earlier) for p in earlier.rglob("*"))
    monkeypatch.setattr(dask_backend, "_sees", lambda path: False)
    with pytest.raises(OptionError, match="does not see --out"):
        run_batch([log], TANK, out_dir=earlier, scheduler=cluster.scheduler_address)
    assert sorted(p.relative_to(earlier) for p in earlier.rglob("*")) == before


def test_a_worker_that_joins_without_the_batch_folder_fails_its_logs(
    tmp_path: Path, cluster: distributed.LocalCluster, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Seen when the batch starts, a worker may join later that does not: each task checks."""
    log = write_table(tmp_path / "s1.csv", tank_run(steps=20, seed=1).columns)
    monkeypatch.setattr(dask_backend, "_sees", reported_sight)
    SIGHT[:] = [True, False]  # the check at the start; then the task's
    out = tmp_path / "out"
    outcome = run_batch([log], TANK, out_dir=out, scheduler=cluster.scheduler_address)
    (failed,) = outcome.logs
    assert failed.status == "failed"
    assert failed.error is not None
    assert failed.error.startswith("on the Dask cluster: OptionError: the Dask worker tcp://")
    assert f"does not see --out '{out}' (not on a shared file system?)" in failed.error
    # the file each task looks for is removed with the batch: nothing of it is left
    assert "shared" not in " ".join(p.name for p in out.iterdir())
    assert (out / "summary.md").is_file()


def _pause(cluster: distributed.LocalCluster) -> None:
    """Pause the cluster's worker as Dask does: its process now past its memory limit."""
    from distributed.core import Status

    (worker,) = cluster.workers.values()
    worker.memory_manager.memory_limit = 1_000_000  # its monitor pauses it within 0.1 s
    states = cluster.scheduler.workers.values()
    for _ in range(500):  # the scheduler hears of it over TCP
        if all(state.status == Status.paused for state in states):
            return
        threading.Event().wait(0.01)
    raise AssertionError("the scheduler did not see the worker paused")


def test_a_scheduler_whose_workers_are_all_paused_is_an_error_not_a_wait(
    tmp_path: Path, quick: None
) -> None:
    """A worker paused for memory took no task: the batch waited for good, without a word.

    hybridlog's imports alone (about 280 MB) leave a worker of ``--memory-limit 350MB`` past
    Dask's pause fraction (80 %) once the checks have run.
    """
    log = write_table(tmp_path / "s1.csv", tank_run(steps=20, seed=1).columns)
    with local_cluster(1) as paused:
        _pause(paused)
        address = paused.scheduler_address
        with pytest.raises(OptionError) as err:
            run_batch([log], TANK, out_dir=tmp_path / "out", scheduler=address)
    assert str(err.value).startswith(
        f"--scheduler {address}: every Dask worker is paused, so none runs a log (before the "
        "first log; none resumed within 0.2 s): tcp://127.0.0.1:"
    )
    limit = r" \([\d,]+ MB of its [\d,]+ MB memory limit\); Dask pauses a worker whose process"
    assert re.search(limit, str(err.value))
    assert not (tmp_path / "out").exists()


def test_workers_that_are_all_paused_mid_batch_stop_it(quick: None) -> None:
    HELD.clear()
    with local_cluster(1) as pausing:
        client = dask_backend.connect(pausing.scheduler_address)
        workers = dask_backend.check_workers(
            client, pausing.scheduler_address, [], (TANK, model_hash(TANK))
        )
        arrived: list[int] = []

        def pause(k: int) -> None:
            arrived.append(k)
            _pause(pausing)  # the second task runs on: the third is never started

        try:
            with pytest.raises(OptionError, match=r"is paused, .* \(mid-batch, 1 of 3 logs done"):
                dask_backend.run_on_dask(
                    held_task, [(0,), (1,), (2,)], client, workers, died=lambda k, _: -k, done=pause
                )
        finally:
            HELD.set()
    assert arrived == [0]
