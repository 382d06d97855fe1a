"""numba compilation settings shared by every compiled kernel, and compilation on first use.

Importing this module does not import numba: :func:`jit` imports it when it decorates (so a
module of kernels pays for numba when *it* is imported), and :func:`compile_for` when it
first compiles.  Nothing is compiled at import time: :func:`jit` kernels compile on their
first call, :func:`compile_for` when a caller first needs a function for given arguments;
both keep the machine code in numba's on-disk cache (``cache=True``).

Where that cache is (:func:`machine_code_dir`) is chosen here, once per process, before
hybridlog's first function is handed to numba: ``<cache>/numba/<code>``, where ``<cache>``
is hybridlog's cache folder (:func:`cache_dir`, or ``$NUMBA_CACHE_DIR`` when set) and
``<code>`` a hash of every source file of the package (:func:`package_fingerprint`).
numba's own default kept each function's machine code beside its source file, stamped with
that one file: a loop compiled with the kernels of another file (``imm.py``'s loop with
``kernels.py``'s) was loaded after an upgrade that changed only the kernels, and ran the old
ones; and a read-only installation with no writable home (a container run as another user)
had nowhere to cache, which numba refused with an exception.
"""

from __future__ import annotations

import functools
import hashlib
import io
import os
import pickle
import re
import shutil
import sys
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, TypeVar, cast

from hybridlog import __version__
from hybridlog.errors import OutputError, absolute_folder_expected, environment_error
from hybridlog.limits import remedy

F = TypeVar("F", bound=Callable[..., Any])

OPTIONS: dict[str, Any] = {"cache": True, "error_model": "numpy", "nogil": True}
"""nopython, cached on disk, NumPy's floating-point error model (no exceptions), no GIL."""


BLAS_PROBE = "scipy.linalg.cython_blas"
"""What numba's array maths imports when its CPU target loads, to see whether BLAS is there."""


def set_up() -> None:
    """Import numba and set up its CPU target now, not in the first compile or cache load.

    That set-up takes 0.3-1 s of Python (it holds the GIL), the same for every kernel: a
    batch worker's forkserver does it once, while the batch process still checks the inputs,
    and ``analyze`` while a thread reads the log.  The target's typing and code-generation
    contexts are refreshed, as numba's compiler and its cache's loader do first, and nothing
    is compiled: compiling a one-line function for it took 0.025-0.03 s more (0.148 against
    0.115-0.129 s of CPU, three runs each) and left the loading of the filters' cached code
    no shorter.

    Loading the target imports ``numba.np.arraymath``, which probes for BLAS by importing
    :data:`BLAS_PROBE` (all of ``scipy.linalg``: 0.17 s and 13 MiB measured here).  Only
    numba's ``np.correlate``/``np.convolve`` read what the probe found (they then use a
    plain loop); hybridlog's kernels call no BLAS, and a kernel that calls ``np.dot`` still
    imports SciPy's BLAS when it is compiled (``numba.np.linalg.ensure_blas``).  So the probe
    is made to fail fast here, where SciPy is not loaded yet: for the moment of the set-up
    that one module is marked missing (``sys.modules[name] = None``).  Nothing else is
    importing it meanwhile: the readers running beside ``analyze``'s set-up use no SciPy.

    The refresh runs under numba's compiler lock, as numba's own compiler runs it: the
    target's registries are generators that two threads cannot advance at once, and two
    analyses started in threads of one process each set numba up ("generator already
    executing" from the second).
    """
    _numba()
    from numba.core.compiler_lock import global_compiler_lock
    from numba.core.registry import cpu_target

    with global_compiler_lock:
        probe_skipped = "scipy.linalg" not in sys.modules and BLAS_PROBE not in sys.modules
        if probe_skipped:
            sys.modules[BLAS_PROBE] = None  # type: ignore[assignment]
        try:
            cpu_target.typing_context.refresh()
            cpu_target.target_context.refresh()
        finally:
            if probe_skipped and sys.modules.get(BLAS_PROBE, 0) is None:
                del sys.modules[BLAS_PROBE]


def jit(function: F, **options: Any) -> F:
    """Compile ``function`` with numba (:data:`OPTIONS`, and ``options``) on its first call."""
    return cast(F, _numba().njit(**OPTIONS, **options)(function))


WITHOUT_REFCOUNTS: dict[str, Any] = {"_nrt": False}
"""numba's option compiling a function without its runtime (NRT; numba's
``register_jitable(_nrt=False)`` example): no reference counts on the arrays it is given or
slices, and no allocation (compiling one is an error, ``NRT required but not enabled``).

Compiled with the runtime, a function takes a reference to each array argument on entry and
drops it on return, and one to each view it slices, each an atomic ``lock inc``/``lock dec``
that numba's pruning pass leaves where loops and branches separate the pair.  In the IMM's
generic loop on a model's nine mode pairs they were 60 % of the time (``perf``: two
instructions of ``NRT_incref``/``NRT_decref``), 16 of them on every call of
``kalman_update`` alone.  The filters' kernels and their time loops allocate nothing (their
callers allocate the scratch), so they are compiled without."""


def jit_kernel(function: F) -> F:
    """:func:`jit` for a small kernel of the compiled loops that allocates nothing.

    Compiled :data:`WITHOUT_REFCOUNTS`, and inlined into its compiled callers (numba's
    ``forceinline``, LLVM's ``alwaysinline``): a call passes each array as its nine-word
    struct on the stack, and a kernel's loops over sizes it cannot know were most of the
    cost at the sizes of the filters (``kalman_update`` of 2 states and 1 output: 217 ns a
    call without refcounts, 78 ns inlined).  The arithmetic is the same, operation for
    operation (numba contracts no multiply-add), so the results are too.
    """
    return jit(function, forceinline=True, **WITHOUT_REFCOUNTS)


def jitable(function: F, *, refcounts: bool = True) -> F:
    """``function`` as plain Python when called from Python, compiled into a compiled caller.

    For the small steps the generic loops share that take model functions as arguments
    (numba cannot type a Python function passed to a compiled one): the plain-Python
    reference path (``jit=False``) calls them as they are, the compiled loops call their
    compiled version.  ``refcounts=False``: compiled with :data:`WITHOUT_REFCOUNTS`.
    """
    from numba.extending import register_jitable

    if refcounts:
        registered: F = register_jitable(function)
    else:
        registered = register_jitable(**WITHOUT_REFCOUNTS)(function)
    return registered


def jitable_kernel(function: F) -> F:
    """:func:`jitable` compiled :data:`WITHOUT_REFCOUNTS`: for a step that allocates nothing."""
    return jitable(function, refcounts=False)


def signature_of(arguments: Sequence[Any]) -> tuple[Any, ...]:
    """The numba argument types of a call (numba infers the result type from them).

    A compiled function passed as an argument (a numba dispatcher compiled for one explicit
    signature, as the model functions of :mod:`hybridlog.model.compiled` are) is typed as a
    first-class function of that signature, so a kernel taking it is compiled once for every
    model rather than once per model function.
    """
    from numba import types
    from numba.core.dispatcher import Dispatcher

    def type_of(value: Any) -> Any:
        if isinstance(value, Dispatcher):
            (signature,) = value.nopython_signatures
            return types.FunctionType(signature)
        return numba_typeof(value)

    return tuple(type_of(value) for value in arguments)


def numba_typeof(value: Any) -> Any:
    """The numba type of a Python value (``float64[:, ::1]`` for a C-contiguous 2-d array...)."""
    import numba

    return numba.typeof(value)  # type: ignore[no-untyped-call]


_COMPILED: dict[tuple[Callable[..., Any], Any], Callable[..., Any]] = {}
_LOCK = threading.Lock()


def compile_for(function: Callable[..., Any], arguments: Sequence[Any]) -> Callable[..., Any]:
    """``function`` compiled (or loaded from numba's cache) for the types of ``arguments``.

    The signature is derived from the arguments (:func:`signature_of`), never written by
    hand: adding an argument to a kernel is one edit, to the kernel and its call.  Each
    (function, signature) is compiled once per process.
    """
    signature = signature_of(arguments)
    key = (function, signature)
    with _LOCK:
        compiled = _COMPILED.get(key)
        if compiled is None:
            compiled = compile_signature(function, signature)
            _COMPILED[key] = compiled
    return compiled


DAMAGED_CACHE = (pickle.UnpicklingError, EOFError)
"""What numba raises loading a cache file cut short or zeroed (a full disk, a machine that
stopped mid-write, a partly restored CI cache): it writes each file whole, but never checks
one it reads, and failed so in every run after."""


def compile_signature(function: Callable[..., Any], signature: Any, **options: Any) -> Any:
    """``function`` compiled for ``signature`` (:data:`OPTIONS`, ``options``), or loaded from cache.

    A damaged cache entry (:data:`DAMAGED_CACHE`) is forgotten (numba's index of the function
    emptied) and the function compiled again, which writes the entry anew.
    """
    numba = _numba()
    try:
        return numba.njit(signature, **OPTIONS, **options)(function)
    except DAMAGED_CACHE:
        numba.njit(**OPTIONS, **options)(function)._cache.flush()
        return numba.njit(signature, **OPTIONS, **options)(function)


def cache_dir() -> Path:
    """The cache folder: ``$HYBRIDLOG_CACHE_DIR``, else ``$XDG_CACHE_HOME/hybridlog``.

    ``$XDG_CACHE_HOME`` defaults to ``~/.cache`` (:func:`home`), and one that is not an
    absolute path is ignored, as the XDG Base Directory specification says: a relative one
    put the cache in whatever folder the command ran in (a log folder, a CI checkout).  A
    relative ``$HYBRIDLOG_CACHE_DIR``, which did the same (and in each batch worker's own
    working folder, a Dask worker's too), is refused (:func:`cache_variable`): one
    cache wherever the command runs, as its name promises.  It
    holds the loaded models (:mod:`hybridlog.model.cache`), the generated modules
    (:mod:`hybridlog.model.compiled`), numba's machine code (:func:`machine_code_dir`) and,
    where matplotlib's own folders cannot be written, its settings and font list
    (:func:`hybridlog.launch.writable_matplotlib_folder`).

    Raises
    ------
    OutputError
        No folder is set and the home is unknown.
    OptionError
        ``$HYBRIDLOG_CACHE_DIR`` is not an absolute path.
    """
    override = cache_variable("HYBRIDLOG_CACHE_DIR")
    if override:
        return Path(override)
    base = os.environ.get("XDG_CACHE_HOME", "")
    if os.path.isabs(base):
        return Path(base) / "hybridlog"
    return home() / ".cache" / "hybridlog"


def cache_variable(name: str) -> str:
    """``$name`` of a cache folder (``HYBRIDLOG_CACHE_DIR``, ``NUMBA_CACHE_DIR``), ``""`` unset.

    Raises
    ------
    OptionError
        The value is not an absolute path (:func:`~hybridlog.errors.absolute_folder_expected`): a
        relative one is a cache in each process's working folder (each batch worker's, a Dask
        worker's), not one cache.
    """
    value = os.environ.get(name, "")
    if value and not os.path.isabs(value):
        raise environment_error(name, value, absolute_folder_expected(value))
    return value


def home() -> Path:
    """The user's home: ``$HOME`` where it is an absolute path, else the user's account's.

    Python's ``Path.home()`` took an empty ``HOME`` as ``/`` (run as root, the cache went
    to ``/.cache``) and a relative one as a folder of the current one.

    Raises
    ------
    OutputError
        ``HOME`` is not an absolute path and the user's account names no home.
    """
    given = os.environ.get("HOME", "")
    if os.path.isabs(given):
        return Path(given)
    import pwd

    try:
        account = pwd.getpwuid(os.getuid()).pw_dir
    except KeyError:
        account = ""
    if not os.path.isabs(account):
        said = "not set" if "HOME" not in os.environ else f"{given!r}, not an absolute path"
        raise OutputError(
            f"no cache folder: HOME is {said} and user {os.getuid()} has no home in the "
            "password database; set HYBRIDLOG_CACHE_DIR to a writable folder"
        )
    return Path(account)


PACKAGE = Path(__file__).parent
"""The package's folder, whose source files :func:`package_fingerprint` hashes."""


@functools.cache
def package_fingerprint() -> str:
    """A hash of hybridlog's version and of every source file of the package (about 20 ms).

    Any compiled function may take code or constants of another module into its machine code;
    so any change to the package, an upgrade or an edit, gives new machine code.
    """
    digest = hashlib.sha256(f"hybridlog {__version__};".encode())
    for source in sorted(PACKAGE.rglob("*.py")):
        digest.update(f"{source.relative_to(PACKAGE).as_posix()}:".encode())
        digest.update(source.read_bytes())
    return digest.hexdigest()[:16]


def machine_code_dir() -> Path:
    """The folder of this code's machine code: ``<$NUMBA_CACHE_DIR or cache/numba>/<code>``."""
    root = cache_variable("NUMBA_CACHE_DIR")
    base = Path(root) if root else cache_dir() / "numba"
    return base / package_fingerprint()


UNUSED_DAYS = 7
"""A folder of other code's machine code unused for this long is removed (:func:`_prune`)."""
_FINGERPRINT = re.compile(r"[0-9a-f]{16}")


def _prune(folder: Path) -> None:
    """Remove the folders of other code's machine code beside ``folder`` unused for a week.

    Run when ``folder`` was just made (new code): each edit of the package makes a folder,
    and each of an installation's processes marks its folder used when it starts.  Only
    names of :func:`package_fingerprint`'s form are touched (numba's own folders are not).
    """
    ended = time.time() - UNUSED_DAYS * 86400
    for other in folder.parent.iterdir():
        if other != folder and _FINGERPRINT.fullmatch(other.name):
            try:
                unused = other.stat().st_mtime < ended
            except OSError:
                continue
            if unused:
                shutil.rmtree(other, ignore_errors=True)


_PLACED: list[Path | None] = []
_PLACING = threading.Lock()


def _place_cache(numba: Any) -> Path | None:
    """Point numba's cache at :func:`machine_code_dir`; ``None`` where it cannot be made.

    There numba keeps its own places: a cache folder that cannot be written is named by the
    model cache (:func:`hybridlog.model.compiled.store`), which every command writes first.
    """
    try:
        folder = machine_code_dir()
        made = not folder.is_dir()
        folder.mkdir(parents=True, exist_ok=True)
        os.utime(folder)  # used now (:func:`_prune`)
    except (OSError, OutputError):
        return None
    if made:
        _prune(folder)
    numba.config.CACHE_DIR = str(folder)
    _name_failed_saves(folder)
    _check_entries(folder)
    return folder


def _name_failed_saves(folder: Path) -> None:
    """Make numba's failure to write a cache entry one line naming ``folder``.

    numba writes a function's machine code after compiling it, and let the ``OSError`` of a
    full disk or quota through: from the estimators' worker it reached ``analyze`` while
    the report was written, which named the ``--out`` folder as the one that was full.
    """
    from numba.core.caching import Cache

    save: Callable[[Any, Any, Any], None] = Cache.save_overload

    def save_overload(self: Any, sig: Any, data: Any) -> None:
        try:
            save(self, sig, data)
        except OSError as err:
            advice = remedy(err, "set HYBRIDLOG_CACHE_DIR to a writable folder")  # ulimit -f
            raise OutputError(
                f"cache folder {folder}: cannot write machine code ({err.strerror or err}); "
                f"{advice}"
            ) from err

    Cache.save_overload = save_overload  # type: ignore[method-assign]


class DamagedEntryError(OSError):
    """A machine-code entry whose bytes are not the ones written (:func:`_check_entries`)."""


def _check_entries(folder: Path) -> None:
    """Write machine-code entries under ``folder`` with their SHA-256; load them if it matches.

    numba loads an entry (a ``.nbc`` file: the pickled machine code) without checking it: one
    changed byte that still unpickles (a bit flipped on a disk, a partly restored CI cache)
    failed every later run with "LLVM bitcode parsing error", or, where it still parsed,
    ran changed code.  An entry whose digest differs is :class:`DamagedEntryError`, an
    ``OSError``, which numba's loader takes for a missing file: the function is compiled
    again and the entry written anew.  A function's index (its ``.nbi`` file, which names
    the entries of each signature) is written with its digest too, and one that differs
    read as empty, as numba reads the index of another numba version: a damaged index
    failed every later run of a function :func:`jit` compiles on its first call (numba's
    loader, not :func:`compile_signature`, reads it) with "pickle data was truncated", and
    its saves too.  Entries outside ``folder`` (other programs' numba caches) keep numba's
    format.
    """
    from numba.core.caching import IndexDataCacheFile

    save: Callable[[Any, str, Any], None] = IndexDataCacheFile._save_data
    load: Callable[[Any, str], Any] = IndexDataCacheFile._load_data
    save_index: Callable[[Any, Any], None] = IndexDataCacheFile._save_index
    load_index: Callable[[Any], Any] = IndexDataCacheFile._load_index
    root = os.path.abspath(folder)

    def ours(cache_file: Any) -> bool:
        # as absolute paths: a relative NUMBA_CACHE_DIR beside another locator's absolute
        # path (a module imported from a zip file) made os.path.commonpath raise
        path = os.path.abspath(str(cache_file._cache_path))
        return path == root or path.startswith(root + os.sep)

    def save_data(self: Any, name: str, data: Any) -> None:
        if not ours(self):
            return save(self, name, data)
        blob = self._dump(data)
        with self._open_for_write(self._data_path(name)) as file:
            file.write(hashlib.sha256(blob).digest() + blob)

    def load_data(self: Any, name: str) -> Any:
        if not ours(self):
            return load(self, name)
        path = self._data_path(name)
        with open(path, "rb") as file:
            stored = file.read()
        digest, blob = stored[:_DIGEST_BYTES], stored[_DIGEST_BYTES:]
        if hashlib.sha256(blob).digest() != digest:
            raise DamagedEntryError(f"{path}: not the bytes written")
        return pickle.loads(blob)

    def save_index_data(self: Any, overloads: Any) -> None:
        if not ours(self):
            return save_index(self, overloads)
        blob = pickle.dumps(self._version, protocol=-1)
        blob += self._dump((self._source_stamp, overloads))
        with self._open_for_write(self._index_path) as file:
            file.write(hashlib.sha256(blob).digest() + blob)

    def load_index_data(self: Any) -> Any:
        if not ours(self):
            return load_index(self)
        try:
            with open(self._index_path, "rb") as file:
                stored = file.read()
        except FileNotFoundError:
            return {}
        digest, blob = stored[:_DIGEST_BYTES], stored[_DIGEST_BYTES:]
        if hashlib.sha256(blob).digest() != digest:
            return {}  # damaged: compiled again, and the index written anew
        with io.BytesIO(blob) as stream:
            if pickle.load(stream) != self._version:
                return {}
            stamp, overloads = pickle.loads(stream.read())
        return overloads if stamp == self._source_stamp else {}

    IndexDataCacheFile._save_data = save_data  # type: ignore[method-assign]
    IndexDataCacheFile._load_data = load_data  # type: ignore[method-assign]
    IndexDataCacheFile._save_index = save_index_data  # type: ignore[method-assign]
    IndexDataCacheFile._load_index = load_index_data  # type: ignore[method-assign]


_DIGEST_BYTES = hashlib.sha256().digest_size


def _numba() -> Any:
    """numba, its cache placed (:func:`_place_cache`) before the process's first function."""
    import numba

    with _PLACING:
        if not _PLACED:
            _PLACED.append(_place_cache(numba))
    return numba
