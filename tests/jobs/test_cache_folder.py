"""A cache folder hybridlog cannot write (a read-only home, a file in its place, no home).

Every command loads its model through the cache of loaded models and compiled code:
``analyze`` with a read-only ``$HOME`` failed with "unexpected OSError in cache.py"; now it
is one line naming the cache folder and ``HYBRIDLOG_CACHE_DIR``, exit 2.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from hybridlog import jit
from hybridlog.errors import OutputError
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


def test_no_home_and_no_cache_folder_set_is_one_line(monkeypatch: pytest.MonkeyPatch) -> None:
    def unknown() -> Path:
        raise RuntimeError("Could not determine home directory.")

    for name in ("HYBRIDLOG_CACHE_DIR", "XDG_CACHE_HOME", "HOME"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr(Path, "home", staticmethod(unknown))
    with pytest.raises(OutputError) as raised:
        jit.cache_dir()
    assert str(raised.value) == (
        "no cache folder: Could not determine home directory; set HYBRIDLOG_CACHE_DIR to a "
        "writable folder"
    )
