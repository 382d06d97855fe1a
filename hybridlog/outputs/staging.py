"""Temporary folders next to their targets (:func:`staging_dir`), and the errors of writing.

:func:`prepare_parent` makes an output's missing folders (:func:`remove_created` takes them
back); :func:`storage_error` turns a write the file system refused (full, over quota,
``ulimit -f``, read-only) into the one-line :class:`~hybridlog.errors.OutputError` it is.
"""

from __future__ import annotations

import contextlib
import errno
import os
import re
import shutil
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

from hybridlog.errors import OutputError
from hybridlog.limits import limit_reached
from hybridlog.outputs.paths import PathLike, output_path, shown_path
from hybridlog.outputs.records import write_marker
from hybridlog.outputs.temporaries import remove_stale_temporaries, shown_output, temporary_name


def prepare_parent(target: Path) -> list[Path]:
    """Create the missing parent folders of ``target``; return them, innermost first.

    Also removes temporaries of dead processes from the parent (see
    :func:`~hybridlog.outputs.temporaries.remove_stale_temporaries`).
    """
    missing = [p for p in target.parents if not p.exists()]
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        remove_created(missing)
        raise OutputError(
            f"cannot create folder {shown_path(target.parent)}: {err.strerror}"
        ) from err
    remove_stale_temporaries(target.parent)
    return missing


_STORAGE_ERRORS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EROFS})
"""What the file system answers a write it cannot take: full, over quota, over the size
limit (``ulimit -f``), read-only (remounted so)."""


_OS_ERROR = re.compile(r"\(os error (\d+)\)")
"""How polars (Rust's ``std::io::Error``) names the system's error number in its messages."""


def storage_error(target: PathLike, err: BaseException) -> OutputError | None:
    """``err`` as the one-line :class:`OutputError` it is, if the file system refused a write.

    A full disk, a quota, a file size limit or a read-only file system met while writing
    the outputs is the user's condition, not a bug: the error names the output and the
    system's reason.  Python's writers give the number (``errno``); polars' give it in
    their text only (``... (os error 28)``), in an ``OSError`` or an error of their own.
    """
    number = err.errno if isinstance(err, OSError) else None
    if number is None and isinstance(err, Exception):
        found = _OS_ERROR.search(str(err))
        number = int(found[1]) if found else None
    if number not in _STORAGE_ERRORS:
        return None
    limit = limit_reached(OSError(number, os.strerror(number)))
    # an output written inside another's temporary folder (compare's per estimator) is
    # named where it was to go
    return OutputError(
        f"{shown_output(target)}: cannot be written ({os.strerror(number)}"
        f"{'' if limit is None else f': {limit.detail}; {limit.advice}'})"
    )


def remove_created(folders: Sequence[Path]) -> None:
    """Remove folders made for outputs that were never written (deepest first)."""
    for folder in sorted(folders, key=lambda f: len(f.parts), reverse=True):
        with contextlib.suppress(OSError):
            folder.rmdir()


@contextmanager
def staging_dir(target: PathLike, *, inside: bool = False, kind: str = "tmp") -> Iterator[Path]:
    """A temporary folder next to ``target`` (same filesystem), always removed afterwards.

    For writers that must create their output under its final name themselves (a ROS 2 bag names its
    storage file after its folder): write ``staging / target.name``, then
    :func:`~hybridlog.outputs.publishing.publish_file` or
    :func:`~hybridlog.outputs.publishing.publish_dir` it.  With ``inside``, the folder is made in
    ``target``, an existing folder, on its file system (a mount point's), for
    :func:`~hybridlog.outputs.publishing.publish_dir` to fill it in place; ``kind`` as for
    :func:`~hybridlog.outputs.temporaries.temporary_name`.

    Raises
    ------
    OutputError
        When the folder cannot be created.
    """
    path = output_path(target)
    if inside:
        created: list[Path] = []
        area = temporary_name(path / path.name, kind=kind)
    else:
        created = prepare_parent(path)
        area = temporary_name(path, kind=kind)
    try:
        try:
            area.mkdir()
            write_marker(area)
        except OSError as err:
            raise OutputError(f"{shown_path(target)}: cannot be written ({err.strerror})") from err
        yield area
    except BaseException as err:
        removed = _removed_meanwhile(target, area, err)  # before it is removed here
        shutil.rmtree(area, ignore_errors=True)
        remove_created(created)
        if (refused := storage_error(target, err)) is not None:
            raise refused from err
        if removed is not None:
            raise removed from err
        raise
    shutil.rmtree(area, ignore_errors=True)


def _removed_meanwhile(target: PathLike, area: Path, err: BaseException) -> OutputError | None:
    """``err`` as the one-line :class:`OutputError` it is, if ``area`` was removed meanwhile.

    An output folder deleted while a batch writes its reports (``rm -rf out`` of a run
    thought finished) took the temporary folders being written: their next write failed
    with Python's own ``FileNotFoundError`` naming a temporary name, as the log's error.
    """
    if not isinstance(err, FileNotFoundError) or area.exists():
        return None
    return OutputError(
        f"{shown_path(target)}: cannot be written: the folder it was being written in was "
        "removed meanwhile (by another program, or with a folder holding it)"
    )
