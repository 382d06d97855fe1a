"""A cache folder hybridlog cannot write (a read-only home, a file in its place, no home).

Every command loads its model through the cache of loaded models and compiled code:
``analyze`` with a read-only ``$HOME`` failed with "unexpected OSError in cache.py"; now it
is one line naming the cache folder and ``HYBRIDLOG_CACHE_DIR``, exit 2.  The folder is
always an absolute path: a relative ``$XDG_CACHE_HOME`` or ``$HOME`` put it in the folder the
command ran in.
"""

from __future__ import annotations

import os
import pwd
from collections.abc import Callable
from pathlib import Path

import pytest

from hybridlog import jit
from hybridlog.environment import check_environment
from hybridlog.errors import OptionError, OutputError
from hybridlog.model import compiled
from tests.support.paths import TANK_CSV

Main = Callable[[list[str]], tuple[int, str]]


def test_a_cache_folder_that_cannot_be_written_is_one_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, hybridlog_main: Main
) -> None:
    blocker = tmp_path / "cache"
    blocker.write_text("a file where the cache folder would be")
    monkeypatch.setenv("HYBRIDLOG_CACHE_DIR", str(blocker))
    out = tmp_path / "out"
    args = ["analyze", str(TANK_CSV), "--model", "three_tank_hstf", "--estimator", "imm"]
    code, err = hybridlog_main([*args, "--out", str(out)])
    assert code == 2 and err.count("\n") == 1, err
    assert err.startswith(f"hybridlog: error: cache folder {blocker}: cannot write model_")
    assert err.endswith("(Not a directory); set HYBRIDLOG_CACHE_DIR to a writable folder\n")
    assert not out.exists() and blocker.read_text().startswith("a file")
    # the compiled code's modules go through the same door
    with pytest.raises(OutputError, match=r"^cache folder .*: cannot write hstf_x\.py "):
        compiled.store(blocker / "models" / "hstf_x.py", "", replace=False)


@pytest.mark.parametrize(
    ("xdg", "home", "expected"),
    [
        ("/x/cache", "/h", "/x/cache/hybridlog"),
        ("relative/cache", "/h", "/h/.cache/hybridlog"),  # XDG: a relative path is ignored
        ("", "/h", "/h/.cache/hybridlog"),
        ("", "", "account"),  # Path.home() gave "/": the cache went to /.cache as root
        ("", "h", "account"),  # ... and to ./h/.cache
    ],
)
def test_the_cache_folder_is_always_an_absolute_path(
    monkeypatch: pytest.MonkeyPatch, xdg: str, home: str, expected: str
) -> None:
    monkeypatch.delenv("HYBRIDLOG_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", xdg)
    monkeypatch.setenv("HOME", home)
    account = Path(pwd.getpwuid(os.getuid()).pw_dir) / ".cache" / "hybridlog"
    assert jit.cache_dir() == (account if expected == "account" else Path(expected))


@pytest.mark.parametrize(("home", "said"), [(None, "not set"), ("", "'', not an absolute path")])
def test_no_home_and_no_cache_folder_set_is_one_line(
    monkeypatch: pytest.MonkeyPatch, home: str | None, said: str
) -> None:
    def unknown(uid: int) -> pwd.struct_passwd:
        raise KeyError(uid)

    for name in ("HYBRIDLOG_CACHE_DIR", "XDG_CACHE_HOME", "HOME"):
        monkeypatch.delenv(name, raising=False)
    if home is not None:
        monkeypatch.setenv("HOME", home)
    monkeypatch.setattr(pwd, "getpwuid", unknown)
    with pytest.raises(OutputError) as raised:
        jit.cache_dir()
    assert str(raised.value) == (
        f"no cache folder: HOME is {said} and user {os.getuid()} has no home in the password "
        "database; set HYBRIDLOG_CACHE_DIR to a writable folder"
    )


@pytest.mark.parametrize("name", ["HYBRIDLOG_CACHE_DIR", "NUMBA_CACHE_DIR"])
@pytest.mark.parametrize("value", ["cache", "./cache", "~/cache"])
def test_a_relative_cache_folder_variable_is_refused_everywhere_alike(
    monkeypatch: pytest.MonkeyPatch, name: str, value: str
) -> None:
    """``HYBRIDLOG_CACHE_DIR=cache`` was a cache in each working folder (each batch worker's,
    a Dask worker's): ``cd a; analyze ...; cd ../b; analyze ...`` compiled every model
    twice, into ``a/cache`` and ``b/cache``; ``NUMBA_CACHE_DIR=cache`` did so with the
    machine code.  Refused, by the CLI before any command (its workers are started after)
    and by the library, in the same words."""
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setenv(name, value)
    with pytest.raises(OptionError) as library:
        jit.machine_code_dir()  # reads both
    with pytest.raises(OptionError) as command:
        check_environment({name: value})
    expected = (
        "an absolute path ('~' is the shell's, and nothing expanded it here: write "
        '"$HOME/..." for a folder of your home)'
        if value.startswith("~")  # quoted, or set by a CI file: the hint was "$PWD/..."
        else "an absolute path (a relative one is a folder of each process's working folder, "
        'not one cache; write "$PWD/..." for the folder the shell is in)'
    )
    assert (
        str(library.value)
        == str(command.value)
        == (
            f"environment variable {name}={value!r}: expected {expected}; "
            "unset it or give it such a value"
        )
    )
    check_environment({name: ""})  # empty is unset, as numba and cache_dir take it
    monkeypatch.setenv(name, "/abs/cache")
    assert jit.machine_code_dir().parent == Path(
        "/abs/cache" if name == "NUMBA_CACHE_DIR" else "/abs/cache/numba"
    )


def test_the_library_jobs_refuse_a_relative_numba_cache_folder_before_anything(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``run_batch`` read ``NUMBA_CACHE_DIR`` only where numba is first set up: with
    ``jobs=1`` each log failed with the refusal (the batch folder written), with ``jobs=2``
    the workers' forkserver died warming up (a traceback, then ``EOFError``).  Refused, as
    the command line refuses it, before anything is written."""
    from hybridlog.jobs.analysis import analyze
    from hybridlog.jobs.batch import run_batch

    monkeypatch.setenv("NUMBA_CACHE_DIR", "cache")
    out = tmp_path / "out"
    for job in (
        lambda: run_batch([TANK_CSV], "three_tank_hstf", estimator="imm", out_dir=out),
        lambda: analyze(TANK_CSV, "three_tank_hstf", estimator="imm", out_dir=out),
    ):
        with pytest.raises(OptionError, match=r"^environment variable NUMBA_CACHE_DIR='cache'"):
            job()
        assert not out.exists()
