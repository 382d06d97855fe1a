"""Outputs are never inputs: :func:`check_apart` and :func:`check_distinct` (SPEC §9).

Paths are compared after resolving symbolic links, ``..`` and relative parts, and by device
and inode, so hard links and bind mounts are caught too.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence

from hybridlog.errors import OutputError
from hybridlog.outputs.paths import PathLike, shown_path


def _identity(path: str) -> tuple[int, int] | None:
    try:
        status = os.stat(path)
    except (OSError, ValueError):
        return None
    return status.st_dev, status.st_ino


def _lineage(path: str) -> list[str]:
    """``path`` and its parent folders, innermost first (``path`` is absolute and resolved)."""
    chain = [path]
    while (parent := os.path.dirname(chain[-1])) != chain[-1]:
        chain.append(parent)
    return chain


class _Input:
    """An input path, resolved, with the identities of it and its parent folders."""

    def __init__(self, what: str, path: PathLike) -> None:
        self.what = what
        self.path = path
        self.resolved = os.path.realpath(path)
        self.identity = _identity(self.resolved)
        self.parents = (
            [] if self.identity is None else [_identity(p) for p in _lineage(self.resolved)[1:]]
        )


def _relation(output: str, lineage: Sequence[tuple[int, int] | None], given: _Input) -> str | None:
    """How resolved ``output`` overlaps ``given``: ``is``, ``contains``, ``is inside`` or none.

    ``lineage`` holds the identities (device, inode) of ``output`` and its parent folders,
    which catch other names of the same file or folder: hard links, bind mounts,
    case-insensitive disks.
    """
    if output == given.resolved:
        return "is"
    if given.resolved.startswith(output.rstrip(os.sep) + os.sep):
        return "contains"
    if output.startswith(given.resolved.rstrip(os.sep) + os.sep):
        return "is inside"
    if given.identity is None:
        return None
    if lineage[0] == given.identity:
        return "is"
    if given.identity in lineage[1:]:
        return "is inside"
    if lineage[0] is not None and lineage[0] in given.parents:
        return "contains"
    return None


def check_apart(
    outputs: Iterable[tuple[str, PathLike]], inputs: Iterable[tuple[str, PathLike]]
) -> None:
    """Refuse any output that is, contains or sits inside any input.

    Holds with or without ``--force``: replacing an output folder must never delete a log, a
    model file, a centres file or a message-definition folder.

    Parameters
    ----------
    outputs:
        ``(what, path)`` pairs, e.g. ``("--out", "report")``; ``what`` names the option.
    inputs:
        ``(what, path)`` pairs, e.g. ``("log", "p/log.csv")``.  Paths that do not exist are
        compared by name only.

    Raises
    ------
    OutputError
        Naming both paths, for the first overlap found.
    """
    given = [_Input(what, path) for what, path in inputs]
    for option, output in outputs:
        resolved = os.path.realpath(output)
        lineage = [_identity(p) for p in _lineage(resolved)]
        for item in given:
            relation = _relation(resolved, lineage, item)
            if relation is not None:
                raise OutputError(
                    f"{option} {shown_path(output)} {relation} the {item.what} "
                    f"{shown_path(item.path)}; choose an output path outside every input"
                )


def check_distinct(outputs: Sequence[tuple[str, PathLike]]) -> None:
    """Refuse two outputs of one command that name the same path.

    Raises
    ------
    OutputError
        Naming both options and the path.
    """
    seen: dict[str, str] = {}
    for option, path in outputs:
        resolved = os.path.realpath(path)
        if resolved in seen:
            raise OutputError(f"{seen[resolved]} and {option} both name {shown_path(path)}")
        seen[resolved] = option
