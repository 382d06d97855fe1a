"""Atomic output directories: all of a run's files appear together or not at all.

Everything is written into a hidden temporary directory next to the target (so on the same
filesystem) and renamed into place once complete.  A failure at any point removes the
temporary directory and leaves the target as it was.
"""

from __future__ import annotations

import os
import secrets
import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from hybridlog.errors import OutputError

__all__ = ["atomic_output_dir"]


def _is_nonempty_dir(path: Path) -> bool:
    with os.scandir(path) as entries:
        return any(True for _ in entries)


def check_target(target: Path, force: bool) -> None:
    """Refuse a target that exists and is not an empty directory, unless ``force``."""
    if not target.name:
        raise OutputError(f"output directory {str(target)!r} cannot be replaced")
    if not (target.exists() or target.is_symlink()):
        return
    if not target.is_dir() or target.is_symlink():
        raise OutputError(f"output path {target} exists and is not a directory")
    if not force and _is_nonempty_dir(target):
        raise OutputError(f"output directory {target} is not empty; use --force to replace it")


def _commit(tmp: Path, target: Path, force: bool) -> None:
    # Checked again: the target may have appeared while the outputs were written.
    check_target(target, force)
    if not target.exists():
        os.rename(tmp, target)
        return
    if not _is_nonempty_dir(target):
        os.rmdir(target)
        os.rename(tmp, target)
        return
    backup = target.with_name(f".{target.name}.old-{secrets.token_hex(4)}")
    os.rename(target, backup)
    try:
        os.rename(tmp, target)
    except BaseException:
        os.rename(backup, target)
        raise
    shutil.rmtree(backup, ignore_errors=True)


@contextmanager
def atomic_output_dir(target: str | os.PathLike[str], *, force: bool = False) -> Iterator[Path]:
    """Write an output directory atomically.

    Yields a fresh temporary directory; when the ``with`` block finishes without an
    exception it is renamed to ``target``.  An existing empty ``target`` is replaced; an
    existing non-empty one only with ``force``, and then only after the new directory is
    complete.  On any exception (including one from the rename) the temporary directory is
    removed and ``target`` is left untouched.

    Parameters
    ----------
    target:
        The output directory to create or replace.  Missing parents are created.
    force:
        Replace a non-empty existing directory.

    Yields
    ------
    pathlib.Path
        The temporary directory to write into.

    Raises
    ------
    OutputError
        When ``target`` is a non-empty directory and ``force`` is false, exists but is not a
        directory, or cannot be created or renamed.

    Examples
    --------
    >>> with atomic_output_dir("out") as tmp:  # doctest: +SKIP
    ...     (tmp / "report.json").write_text("{}")

    """
    path = Path(os.path.abspath(target))
    check_target(path, force)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f".{path.name}.tmp-{secrets.token_hex(4)}")
        tmp.mkdir()
    except OSError as err:
        raise OutputError(f"cannot create output directory {path}: {err.strerror}") from err
    try:
        yield tmp
        try:
            _commit(tmp, path, force)
        except OSError as err:
            raise OutputError(f"cannot move outputs into {path}: {err.strerror}") from err
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
