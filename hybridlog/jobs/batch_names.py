"""The names in a batch folder: each log's report folder, and the batch's own files.

:func:`folder_names` names each log's report folder by the log's path from the logs' common
folder; :data:`SUMMARY_NAMES` are the files every run writes beside them, which no report
folder at the top of the batch folder is named.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from hybridlog.errors import OptionError, excerpt
from hybridlog.outputs import MARKER, PathLike

__all__ = ["SUMMARY_NAMES", "folder_names"]


SUMMARY_NAMES = ("summary.md", "summary.csv", "summary.png")
"""The summaries every run of a batch writes into its batch folder."""


_RESERVED = frozenset({*SUMMARY_NAMES, MARKER})


def _escaped(part: str, top: bool) -> str:
    """A path component as a folder name: never hidden, never a batch file's name.

    A component whose text after leading ``_`` starts with ``.`` (or, at the top, is a batch
    file's name) gets one more ``_``; every other is kept.  The mapping is one-to-one: a
    kept name never looks like an escaped one.
    """
    bare = part.lstrip("_")
    if bare.startswith(".") or not bare or (top and bare in _RESERVED):
        return "_" + part
    return part


def folder_names(logs: Sequence[PathLike], searched: Sequence[PathLike] = ()) -> list[str]:
    """Each log's report folder, relative to the batch folder: its path from the logs' root.

    The root is the deepest folder holding every log and every folder of logs ``searched``
    (:func:`~hybridlog.jobs.batch_logs.batch_logs`), so ``d2/run.csv`` and ``d2/run.parquet``
    get ``run.csv`` and ``run.parquet`` (the suffix is kept), whatever the order of the
    arguments, and the logs found in ``runs/`` are named from ``runs/``, whichever of its
    subfolders hold them today.  Hidden names and names of the batch's own files are escaped
    (:func:`_escaped`).

    Raises
    ------
    OptionError
        When a log is given twice, or lies inside another log (a file inside a bag folder).
    """
    absolute = [os.path.abspath(log) for log in logs]
    if not absolute:
        return []
    folders = [os.path.dirname(path) for path in absolute]
    root = os.path.commonpath([*folders, *(os.path.abspath(f) for f in searched)])
    names: list[str] = []
    seen: dict[str, PathLike] = {}
    for log, path in zip(logs, absolute, strict=True):
        parts = Path(os.path.relpath(path, root)).parts
        name = "/".join(_escaped(part, k == 0) for k, part in enumerate(parts))
        if name in seen:
            raise OptionError(f"log {excerpt(str(log))} is given twice{_how_twice(path, searched)}")
        seen[name] = log
        names.append(name)
    for name in names:
        parent = name.rpartition("/")[0]
        while parent:
            if parent in seen:
                raise OptionError(
                    f"log {excerpt(str(seen[name]))} lies inside the log "
                    f"{excerpt(str(seen[parent]))}; give one of them"
                )
            parent = parent.rpartition("/")[0]
    return names


def _how_twice(path: str, searched: Sequence[PathLike]) -> str:
    """How a log came to be given twice: the folders of logs given that hold it, if any.

    ``batch runs runs/sub`` found ``runs/sub/b.csv`` in both folders; "log 'runs/sub/b.csv'
    is given twice" named a file the user never typed, and not the arguments to change.
    """
    holding = [
        excerpt(os.fspath(folder))
        for folder in searched
        if path.startswith(os.path.join(os.path.abspath(folder), ""))
    ]
    if not holding:
        return ""
    if len(set(holding)) == 1 and len(holding) > 1:
        return f" (the folder of logs {holding[0]} is given twice); give it once"
    if len(holding) == 1:
        return f" (as itself, and in the folder of logs {holding[0]}); give it once"
    return f" (in the folders of logs {', '.join(holding[:-1])} and {holding[-1]}); give it once"
