"""``hybridlog.jit``: numba's set-up, and where and how its machine code is cached.

``set_up``: numba's CPU target set up without SciPy's BLAS probe.  The cache: in a folder of
its own for each version of the package's code (``machine_code_dir``), so that an upgrade
never loads machine code compiled with another version's functions, and where the package
and the home cannot be written; a damaged entry is compiled again.
"""

from __future__ import annotations

import hashlib
import importlib
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from hybridlog import jit
from hybridlog.errors import OutputError

SET_UP = """
import sys
from hybridlog.jit import BLAS_PROBE, set_up
set_up()
loaded = "scipy.linalg" in sys.modules
import numba
import numpy as np

@numba.njit
def product(a, b):
    return np.dot(a, b)

# a kernel that calls BLAS still gets it: SciPy is imported when it is compiled
value = product(np.arange(3.0), np.arange(3.0))
print(loaded, BLAS_PROBE in sys.modules and sys.modules[BLAS_PROBE] is not None, value)
"""


def test_set_up_skips_the_blas_probe_and_blas_kernels_still_compile() -> None:
    done = subprocess.run(
        [sys.executable, "-c", SET_UP], capture_output=True, text=True, check=True
    )
    assert done.stdout.split() == ["False", "True", "5.0"]


SET_UP_IN_THREADS = """
import sys
import threading
from hybridlog.jit import set_up
sys.setswitchinterval(1e-6)  # switch threads as often as can be, inside numba's refresh
start = threading.Barrier(8)
errors = []
def each():
    start.wait()
    try:
        set_up()
    except Exception as error:
        errors.append(repr(error))
threads = [threading.Thread(target=each) for _ in range(8)]
for thread in threads:
    thread.start()
for thread in threads:
    thread.join()
print(errors)
"""


def test_set_up_in_threads_at_once() -> None:
    # two analyses started in threads of one process each set numba up: the refresh
    # advanced numba's registry generators from two threads, "generator already executing"
    done = subprocess.run(
        [sys.executable, "-c", SET_UP_IN_THREADS], capture_output=True, text=True, check=True
    )
    assert done.stdout.strip() == "[]"


def test_set_up_compiles_nothing() -> None:
    # a batch's workers wait for it in their forkserver: compiling a one-line function
    # there took 0.03 s, which loading the filters' cached code did not need
    from numba.core import event
    from numba.core.registry import cpu_target

    with event.install_recorder("numba:compile") as compiled:
        jit.set_up()
    assert compiled.buffer == []
    assert "_toplevel_target_context" in vars(cpu_target)  # the contexts kept, set up


CALLER = """
import sys
from pathlib import Path
import hybridlog.jit
hybridlog.jit.PACKAGE = Path(sys.argv[1])  # the two modules below stand for the package
sys.path.insert(0, sys.argv[1])
import caller
print(caller.twice(), flush=True)
"""


def _code(folder: Path, value: int) -> None:
    folder.mkdir(exist_ok=True)
    (folder / "callee.py").write_text(
        f"from hybridlog.jit import jit\n\n\n@jit\ndef value():\n    return {value}\n"
    )
    (folder / "caller.py").write_text(
        "from callee import value\nfrom hybridlog.jit import jit\n\n\n"
        "@jit\ndef twice():\n    return 2 * value()\n"
    )


def _run(folder: Path, environment: dict[str, str]) -> str:
    done = subprocess.run(
        [sys.executable, "-c", CALLER, str(folder)],
        capture_output=True,
        text=True,
        env=environment,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout.strip()


def _environment(tmp_path: Path) -> dict[str, str]:
    environment = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    environment["HYBRIDLOG_CACHE_DIR"] = str(tmp_path / "cache")
    environment["PYTHONPATH"] = str(Path(__file__).parents[1])
    return environment


def test_machine_code_of_changed_code_is_never_loaded(tmp_path: Path) -> None:
    # numba stamps a function's cache with its own file only: after an upgrade that changed
    # kernels.py alone, imm.py's loop was loaded with the old kernels compiled into it
    code = tmp_path / "code"
    environment = _environment(tmp_path)
    _code(code, 1)
    assert _run(code, environment) == "2"
    (code / "callee.py").write_text((code / "callee.py").read_text().replace("1", "5"))
    assert _run(code, environment) == "10"
    folders = sorted(p.name for p in (tmp_path / "cache" / "numba").iterdir())
    assert len(folders) == 2 and all(len(name) == 16 for name in folders)


def test_a_damaged_index_of_a_function_compiled_on_first_call_is_compiled_again(
    tmp_path: Path,
) -> None:
    # numba's loader, not compile_signature, reads the index (.nbi) of a function jit()
    # compiles on its first call: one damaged failed every later run with "pickle data was
    # truncated" (an analyze from the IMM's result check on)
    code = tmp_path / "code"
    environment = _environment(tmp_path)
    _code(code, 1)
    assert _run(code, environment) == "2"
    indexes = list((tmp_path / "cache" / "numba").glob("*/*/*.nbi"))
    assert len(indexes) == 2, indexes  # caller.twice and callee.value
    for index in indexes:
        index.write_bytes(b"damaged")
    assert _run(code, environment) == "2"
    assert _run(code, environment) == "2"  # the indexes written anew, and read
    assert all(index.stat().st_size > len(b"damaged") for index in indexes)


def test_machine_code_is_cached_where_the_code_and_home_cannot_be_written(
    tmp_path: Path,
) -> None:
    # a read-only installation run by a user without a writable home (a container's
    # `--user`): numba found no folder and raised "cannot cache function ...: no locator"
    code = tmp_path / "code"
    _code(code, 1)
    (code / "__pycache__").write_text("a file where numba would write")
    blocked = tmp_path / "blocked"
    blocked.write_text("not a folder")
    environment = _environment(tmp_path)
    environment.update(HOME=str(blocked), XDG_CACHE_HOME=str(blocked))
    assert _run(code, environment) == "2"
    index = list((tmp_path / "cache" / "numba").glob("*/*/caller.twice-*.nbi"))
    assert len(index) == 1, index


def _cached_add(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, name: str) -> tuple[Any, Path]:
    """Module ``name``'s ``add`` compiled into numba's cache, and its entry's file (``.nbc``).

    The process then forgets it has compiled it, as the next process would not have.
    """
    import numba

    (tmp_path / f"{name}.py").write_text("def add(a, b):\n    return a + b\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    module = importlib.import_module(name)
    jit.set_up()  # the cache placed, as before any of hybridlog's functions
    assert jit.compile_for(module.add, (1.0, 2.0))(1.0, 2.0) == 3.0
    folder = f"{tmp_path.name}_{hashlib.sha1(str(tmp_path).encode()).hexdigest()}"  # numba's
    (data,) = (Path(numba.config.CACHE_DIR) / folder).glob(f"{name}.add-*.nbc")
    monkeypatch.setattr(jit, "_COMPILED", {})
    return module, data


def test_a_damaged_cache_entry_is_compiled_again(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # a file cut short (a full disk, a machine that stopped, a partly restored CI cache)
    # failed to unpickle in every run: "unexpected UnpicklingError"
    module, data = _cached_add(tmp_path, monkeypatch, "damaged_cache_kernel")
    with data.open("r+b") as file:
        file.truncate(100)
    assert jit.compile_for(module.add, (1.0, 2.0))(1.0, 2.0) == 3.0
    assert data.stat().st_size > 100  # written anew


def test_a_cache_entry_whose_bytes_changed_is_compiled_again(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # numba loaded an entry as long as it unpickled: a byte changed in its machine code (a
    # bit flipped on a disk, a partly restored CI cache) failed every run after with
    # "unexpected RuntimeError: LLVM bitcode parsing error", or, where it still parsed, ran
    # changed code
    module, data = _cached_add(tmp_path, monkeypatch, "changed_cache_kernel")
    changed = bytearray(data.read_bytes())
    changed[len(changed) // 2] ^= 0x10  # inside the pickled code, which still unpickles
    data.write_bytes(changed)
    compiled: Any = jit.compile_for(module.add, (1.0, 2.0))
    assert not compiled.stats.cache_hits, "the changed entry was loaded"
    assert compiled(1.0, 2.0) == 3.0
    assert data.read_bytes() != bytes(changed)  # written anew


def test_entries_beside_a_relative_cache_folder_keep_numbas_format(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # NUMBA_CACHE_DIR=relcache and a user's cache=True function imported from a zip file
    # (numba caches it under an absolute path of its own): os.path.commonpath raised "Can't
    # mix absolute and relative paths" from numba's cache, for every such function
    from numba.core.caching import IndexDataCacheFile

    for method in ("_save_data", "_load_data"):
        monkeypatch.setattr(IndexDataCacheFile, method, getattr(IndexDataCacheFile, method))
    monkeypatch.chdir(tmp_path)
    jit._check_entries(Path("relcache", "0123456789abcdef"))
    for where, ours in (
        (tmp_path / "zip_cache", False),
        (Path("relcache/0123456789abcdef/m"), True),
    ):
        where.mkdir(parents=True)
        entry = IndexDataCacheFile(str(where), "f-1.py311", "stamp")
        entry._save_data("f-1.py311.1.nbc", ("code",))
        stored = (where / "f-1.py311.1.nbc").read_bytes()
        assert (stored[:32] == hashlib.sha256(stored[32:]).digest()) == ours
        assert entry._load_data("f-1.py311.1.nbc") == ("code",)


def test_a_full_cache_folder_is_one_line_naming_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # numba's OSError reached analyze while its report was written, which named the --out
    # folder as the full one
    import errno

    import numba
    from numba.core.caching import IndexDataCacheFile

    def full(self: object, name: str, data: object) -> None:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    (tmp_path / "full_cache_kernel.py").write_text("def add(a, b):\n    return a + b\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    module = importlib.import_module("full_cache_kernel")
    jit.set_up()  # the cache placed, as before any of hybridlog's functions
    monkeypatch.setattr(IndexDataCacheFile, "_save_data", full)
    with pytest.raises(OutputError) as raised:
        jit.compile_for(module.add, (1.0, 2.0))
    assert str(raised.value) == (
        f"cache folder {numba.config.CACHE_DIR}: cannot write machine code (No space left on "
        "device); set HYBRIDLOG_CACHE_DIR to a writable folder"
    )


def test_a_file_size_limit_met_by_the_cache_is_named_not_the_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``ulimit -f 64`` and a cold cache: "cannot write machine code (File too large); set
    HYBRIDLOG_CACHE_DIR to a writable folder", which no folder mends; the limit is named."""
    import resource

    import numba

    (tmp_path / "limited_cache_kernel.py").write_text(
        "import numpy as np\n\ndef total(a):\n    return np.sum(np.cumsum(np.sort(a)) ** 2)\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    module = importlib.import_module("limited_cache_kernel")
    jit.set_up()
    soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
    resource.setrlimit(resource.RLIMIT_FSIZE, (1024, hard))  # a real EFBIG, as ulimit -f 1
    try:
        with pytest.raises(OutputError) as raised:
            jit.compile_for(module.total, (np.zeros(3),))
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))
    assert str(raised.value) == (
        f"cache folder {numba.config.CACHE_DIR}: cannot write machine code (File too large); "
        "this process may write files of 1,024 bytes at most: ulimit -f 1; raise the limit "
        "(ulimit -f unlimited)"
    )
