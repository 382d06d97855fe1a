"""A limit the caller set (``ulimit -n``, ``ulimit -u``) is named in the command's one line."""

from __future__ import annotations

import errno
import multiprocessing
import os
import resource
from collections.abc import Iterator
from pathlib import Path

import pytest

from hybridlog.cli_process import _failure
from hybridlog.limits import Limit, limit_reached
from tests.conftest import Main


def _too_many_open_files() -> OSError:
    """A real ``EMFILE``: pipes opened under a soft limit lowered to just above the open files."""
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    opened: list[int] = []
    resource.setrlimit(resource.RLIMIT_NOFILE, (len(os.listdir("/proc/self/fd")) + 4, hard))
    try:
        while True:
            opened.extend(os.pipe())
    except OSError as err:
        return err
    finally:
        resource.setrlimit(resource.RLIMIT_NOFILE, (soft, hard))
        for fd in opened:
            os.close(fd)


def test_too_many_open_files_names_ulimit_n() -> None:
    """``ulimit -n 16`` and ``batch --jobs 2`` was "unexpected OSError ... (a bug, ...)"."""
    err = _too_many_open_files()
    line = _failure(err)
    assert line.startswith("hybridlog: error: too many open files"), line
    assert "ulimit -n" in line and "unexpected" not in line and "\n" not in line


@pytest.fixture
def fork_refused(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """``fork`` failing as it does when the user's processes are at ``ulimit -u``."""

    def refuse() -> int:
        raise BlockingIOError(errno.EAGAIN, os.strerror(errno.EAGAIN))

    monkeypatch.setattr(os, "fork", refuse)
    yield


@pytest.mark.usefixtures("fork_refused")
def test_a_process_refused_names_ulimit_u() -> None:
    process = multiprocessing.get_context("fork").Process(target=print)
    with pytest.raises(OSError) as caught:
        process.start()
    line = _failure(caught.value)
    assert "ulimit -u" in line and "unexpected" not in line, line


def test_a_non_blocking_read_is_no_limit() -> None:
    """``EAGAIN`` of an empty non-blocking pipe is not ``ulimit -u``."""
    read, write = os.pipe()
    os.set_blocking(read, False)
    try:
        with pytest.raises(BlockingIOError) as caught:
            os.read(read, 1)
    finally:
        os.close(read)
        os.close(write)
    assert limit_reached(caught.value) is None
    assert "unexpected BlockingIOError" in _failure(caught.value)


def test_an_empty_memory_error_still_says_what_failed() -> None:
    """``MemoryError()`` (``ulimit -v``) gave "out of memory in csv_tally.py:61: ;"."""
    assert "out of memory: an allocation failed;" in _failure(MemoryError())
    # the remedy was "analyse a shorter log", also to `simulate`, which analyses none
    assert "simulate: fewer --steps" in _failure(MemoryError())


def test_a_umask_taking_the_owners_permissions_is_refused_before_writing(
    tmp_path: Path, hybridlog_main: Main
) -> None:
    """``umask 777``: ``analyze`` left its temporary folder, ``cluster`` mode-000 files."""
    target = tmp_path / "sim.csv"
    before = os.umask(0o777)
    try:
        code, err = hybridlog_main(
            ["simulate", "three_tank_hstf", "--steps", "20", "--out", str(target)]
        )
    finally:
        os.umask(before)
    assert code == 2 and err.count("\n") == 1 and "umask 0777" in err, err
    assert list(tmp_path.iterdir()) == []


def test_the_library_names_the_output_a_masking_umask_refuses(tmp_path: Path) -> None:
    """From Python no command line checks the umask first: the output's path does."""
    from hybridlog.errors import OutputError
    from hybridlog.jobs.simulate import simulate_log

    target = tmp_path / "sim.csv"
    before = os.umask(0o277)
    try:
        with pytest.raises(OutputError, match=rf"^{target}: umask 0277 takes its owner's own"):
            simulate_log("three_tank_hstf", target, steps=20)
    finally:
        os.umask(before)
    assert list(tmp_path.iterdir()) == []


def test_a_parallel_batch_under_a_masking_umask_starts_no_forkserver(tmp_path: Path) -> None:
    """The console script starts a batch's forkserver before the command runs: under
    ``umask 777`` its temporary folder was unreadable, and its clean-up printed a traceback
    after the command's one line.  The umask is checked first."""
    import subprocess
    import sys

    from tests.support.paths import SAMPLE_LOGS

    out = tmp_path / "out"
    command = (
        f"umask 777; exec {sys.executable} -m hybridlog batch "
        f"{SAMPLE_LOGS / 'three_tank_hstf.csv'} --model three_tank_hstf --estimator imm "
        f"--out {out} --jobs 2"
    )
    done = subprocess.run(["bash", "-c", command], capture_output=True, text=True, timeout=120)
    assert (done.returncode, done.stdout) == (2, "")
    assert done.stderr == (
        "hybridlog: error: umask 0777 takes its owner's own permissions from every file and "
        "folder written (they could not be read back); set a umask such as 022 or 077\n"
    )
    assert not out.exists()


def _past_the_size_limit(tmp_path: Path, size: int) -> tuple[OSError, Limit | None, int]:
    """A real ``EFBIG``: a write past a file size limit of ``size`` bytes (``setrlimit``),
    :func:`limit_reached` of it while the limit holds, and the soft limit before (restored)."""
    soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
    resource.setrlimit(resource.RLIMIT_FSIZE, (size, hard))
    try:
        with pytest.raises(OSError) as raised, (tmp_path / "big").open("wb") as handle:
            handle.write(b"x" * 10_000)
            handle.flush()
        limit = limit_reached(raised.value)
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))
    return raised.value, limit, soft


def test_a_file_past_the_size_limit_names_ulimit_f(tmp_path: Path) -> None:
    """A real ``EFBIG`` under ``ulimit -f``: the limit and its value, in ``ulimit``'s blocks;
    without a limit (the file system's own largest file) none is named."""
    raised, limit, soft = _past_the_size_limit(tmp_path, 4096)
    assert raised.errno == errno.EFBIG
    assert limit is not None
    assert limit.detail == "this process may write files of 4,096 bytes at most: ulimit -f 4"
    if soft == resource.RLIM_INFINITY:
        assert limit_reached(OSError(errno.EFBIG, os.strerror(errno.EFBIG))) is None


def test_a_size_limit_not_of_whole_blocks_is_not_written_as_ulimit_f_rounded_down(
    tmp_path: Path,
) -> None:
    """``prlimit --fsize=1000``: bash's ``ulimit -f`` counts blocks of 1,024 bytes, and the
    line read "1,000 bytes at most: ulimit -f 0", a limit that allows no write at all."""
    _, limit, _ = _past_the_size_limit(tmp_path, 1000)
    assert limit is not None
    assert limit.detail == (
        "this process may write files of 1,000 bytes at most (not a whole number of "
        "ulimit -f's blocks of 1,024 bytes)"
    )


def test_the_model_cache_past_the_size_limit_names_the_limit_not_the_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``ulimit -f 1`` and a cold cache: the model's first cache file met the limit, and the
    line said "set HYBRIDLOG_CACHE_DIR to a writable folder", which no folder mends."""
    from hybridlog.errors import OutputError
    from hybridlog.model.compiled import store

    monkeypatch.setenv("HYBRIDLOG_CACHE_DIR", str(tmp_path / "cache"))
    soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
    resource.setrlimit(resource.RLIMIT_FSIZE, (1024, hard))
    try:
        with pytest.raises(OutputError) as raised:
            store(tmp_path / "cache" / "model_x.json", "x" * 10_000, replace=False)
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))
    assert str(raised.value).endswith(
        "cannot write model_x.json (File too large); this process may write files of 1,024 "
        "bytes at most: ulimit -f 1; raise the limit (ulimit -f unlimited)"
    )
