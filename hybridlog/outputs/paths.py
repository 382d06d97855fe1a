"""What an output path is: where the system writes it, how an error shows it, the marker's name.

:func:`output_path` is the absolute path every writer uses; :func:`shown_path` the path as an
error message names it; :func:`path_present` whether something (a dangling link too) stands
under a name; :data:`MARKER` the file that makes a folder hybridlog's.
"""

from __future__ import annotations

import os
from pathlib import Path

from hybridlog.errors import OutputError, excerpt
from hybridlog.limits import owner_masked

PathLike = str | os.PathLike[str]


MARKER = ".hybridlog"
"""File hybridlog writes into every output folder it creates: version, command, process."""


_PATH_LIMIT = 240


def shown_path(path: PathLike) -> str:
    """A path for an error message: escaped if it holds control characters, cut if huge."""
    return excerpt(os.fspath(path), _PATH_LIMIT)[1:-1]


def _check_umask(target: PathLike) -> None:
    """Refuse an output its owner could not read back or finish (:func:`owner_masked`)."""
    if (why := owner_masked()) is not None:
        raise OutputError(f"{shown_path(target)}: {why}")


def output_path(target: PathLike) -> Path:
    """The absolute path the system writes when given ``target``: what every writer uses.

    The folder part is resolved as the system resolves it (symbolic links first, then ``..``), the
    last name kept as given: ``link/../run.csv`` with ``link`` a link to ``a/b`` is ``a/run.csv``,
    where ``open`` writes it, not ``./run.csv`` (which :func:`os.path.abspath` would make of it, and
    which :func:`~hybridlog.outputs.overlaps.check_apart`, comparing resolved paths, would not have
    checked).
    """
    _check_umask(target)
    path = os.path.join(os.getcwd(), os.fspath(target))
    folder, name = os.path.split(path.rstrip(os.sep) or os.sep)
    if name in ("", os.curdir, os.pardir):
        return Path(os.path.realpath(path))
    return Path(os.path.realpath(folder), name)


def path_present(path: Path) -> bool:
    """Whether ``path`` exists (a dangling link counts); an unusable name is an error."""
    try:
        os.lstat(path)
    except (FileNotFoundError, NotADirectoryError):
        return False
    except OSError as err:
        raise OutputError(f"{shown_path(path)}: {err.strerror}") from None
    return True
