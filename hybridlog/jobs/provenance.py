"""What a batch result was made from: content hashes of logs, models and option files.

A batch skips a log only when its finished report records the same provenance as the run
about to be made (:func:`hybridlog.jobs.batch.run_batch`): the log's content hash, the
model's content hash, the settings that change results, and hybridlog's version.  Hashes are
SHA-256 of the bytes, read in chunks (a file is never held in memory whole); a folder (a
ROS 2 bag, a ``--msg-dir``) hashes every file below it, in sorted order, with its relative
path and size, so renaming, adding or removing a file inside it changes the hash too.
The versions of the libraries that compute the numbers are recorded too
(:func:`library_versions`).
"""

from __future__ import annotations

import functools
import hashlib
import os
import platform
from pathlib import Path

from hybridlog.errors import LogError, ModelError
from hybridlog.outputs import PathLike

__all__ = [
    "LIBRARIES",
    "content_hash",
    "folder_stamp",
    "library_versions",
    "log_stamp",
    "model_hash",
]

LIBRARIES = ("numpy", "scipy", "numba", "llvmlite", "sympy", "polars", "cvxpy", "clarabel")
"""The libraries whose code computes a report's numbers (the filters' machine code, the
linear algebra, the LMI solvers, the reading and resampling of the log)."""


def _file_digest(path: Path) -> bytes:
    with path.open("rb") as handle:
        return hashlib.file_digest(handle, "sha256").digest()


def _folder_files(folder: Path) -> list[Path]:
    files: list[Path] = []
    for parent, dirs, names in os.walk(folder):
        dirs.sort()
        files += [Path(parent) / name for name in sorted(names)]
    return files


def content_hash(path: PathLike, *, what: str = "log") -> str:
    """SHA-256 (hex) of a file's bytes, or of every file of a folder with its relative path.

    Raises
    ------
    LogError
        When the file or folder cannot be read (``what`` names it in the message).
    """
    target = Path(path)
    if target.exists() and not (target.is_file() or target.is_dir()):
        raise LogError(f"{what} {path}: not a regular file (a pipe, device or socket)")
    try:
        if not target.is_dir():
            return _file_digest(target).hex()
        digest = hashlib.sha256(b"folder\0")
        for file in _folder_files(target):
            relative = file.relative_to(target).as_posix().encode("utf-8", "surrogateescape")
            digest.update(len(relative).to_bytes(8, "little") + relative)
            digest.update(file.stat().st_size.to_bytes(8, "little"))
            digest.update(_file_digest(file))
        return digest.hexdigest()
    except OSError as err:
        raise LogError(f"{what} {path}: cannot read it: {err.strerror or err}") from err


def folder_stamp(folder: PathLike) -> str:
    """SHA-256 (hex) of what ``stat`` says of every file below ``folder``: cheap, not content.

    Its relative path, size and modification time: to tell, without reading a large folder
    (a ``--msg-dir`` of a whole ROS install), that it is as it was; when the stamp differs,
    :func:`content_hash` says whether the content does.  An unreadable folder stamps empty.
    """
    digest = hashlib.sha256(b"stamp\0")
    target = Path(folder)
    try:
        for file in _folder_files(target):
            state = file.stat()
            relative = file.relative_to(target).as_posix().encode("utf-8", "surrogateescape")
            digest.update(len(relative).to_bytes(8, "little") + relative)
            digest.update(state.st_size.to_bytes(8, "little"))
            digest.update(state.st_mtime_ns.to_bytes(16, "little", signed=True))
    except OSError:
        return ""
    return digest.hexdigest()


def log_stamp(log: PathLike) -> str:
    """What ``stat`` says of a log (a file, or every file of a bag folder): cheap, not content.

    Its size, modification time and file number (a file replaced by a rename is another
    file): taken before a log is hashed and again once it was read, a difference means the
    log changed meanwhile (a recorder still writing it), so the content read is not the one
    hashed.  A log that cannot be stat'ed stamps empty (it fails as that log when read).
    """
    target = Path(log)
    try:
        if target.is_dir():
            return folder_stamp(target)
        state = target.stat()
    except OSError:
        return ""
    return f"{state.st_size}:{state.st_mtime_ns}:{state.st_dev}:{state.st_ino}"


def model_hash(model_ref: PathLike) -> str:
    """SHA-256 (hex) of a model file's bytes, or of a built-in model's text.

    Called after the model was loaded, so ``model_ref`` names a file or a built-in.

    Raises
    ------
    ModelError
        When the model file cannot be read.
    """
    from hybridlog.model.cache import model_file

    path = model_file(os.fspath(model_ref))  # a folder named like a built-in is not the model
    if path is not None:
        try:
            return _file_digest(path).hex()
        except OSError as err:
            raise ModelError(f"{path}: cannot read model file: {err.strerror or err}") from err
    from hybridlog.model.builtins import builtin_text

    return hashlib.sha256(builtin_text(str(model_ref)).encode("utf-8")).hexdigest()


@functools.cache
def library_versions() -> dict[str, str]:
    """The installed version of each of :data:`LIBRARIES`, and Python's (once a process).

    A batch resumed after an upgrade (a nightly CI job installing the latest releases) kept
    the reports the old numba or solver computed, their numbers shown as current.  Read from
    the installed distributions (about 30 ms), without importing the libraries; one not
    installed is ``"absent"``.
    """
    from importlib.metadata import PackageNotFoundError, version

    found = {"python": platform.python_version()}
    for name in LIBRARIES:
        try:
            found[name] = version(name)
        except PackageNotFoundError:
            found[name] = "absent"
    return found
