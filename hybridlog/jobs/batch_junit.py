"""The JUnit file a batch folder's last run wrote, remembered so that a later run withdraws it.

A batch run with ``--junit J`` and then without it (or with another file) left ``J`` as it
was: the previous run's test cases, its passed gates, presented as current to the CI step
that publishes ``J`` (``if: always()``), beside summaries of the new run.  The batch
folder's :data:`~hybridlog.outputs.MARKER` now records the JUnit file each run wrote (key
``junit``: its path, relative to the batch folder when inside it, its SHA-256 and
modification time, and the batch folder's inode), and the next run that does not write that
file removes it, with a note, before any log is analysed, as it removes its summaries: only
while it is that very file (the same SHA-256 and time: not one another batch or the user
wrote since, even of the same content, as another batch folder of the same logs writes to
a shared path), and, outside the batch folder, only from the folder that wrote it (the same
inode: a copy of the batch folder, ``cp -a``, is not the one that wrote a file outside it).
A relative path must stay inside the batch folder (a marker edited by hand to
``../../x`` names nothing of the folder's).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
from pathlib import Path
from typing import Any

from hybridlog.errors import excerpt
from hybridlog.outputs import (
    MARKER,
    PathLike,
    output_path,
    temporary_name,
)
from hybridlog.outputs.records import kept_time, remove_written
from hybridlog.report.junit import is_junit_of_ours

WHOLE_PATH = 4096
"""Linux's ``PATH_MAX``: the note naming the file removed quotes a path of any length whole."""

JUNIT_KEY = "junit"
"""The batch folder's marker's key for the JUnit file its last run wrote."""


def _digest(path: Path) -> str | None:
    try:
        with path.open("rb") as handle:
            return hashlib.file_digest(handle, "sha256").hexdigest()
    except OSError:
        return None


def _marker(root: Path) -> dict[str, Any] | None:
    """The batch folder's marker as a JSON object, or None (absent, unreadable, not ours)."""
    try:
        data = json.loads((root / MARKER).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) and data.get("written_by") == "hybridlog" else None


def _recorded(root: Path) -> Path | None:
    """The JUnit file the marker records as this folder's own, still as written, or None."""
    marker = _marker(root)
    entry = None if marker is None else marker.get(JUNIT_KEY)
    if not isinstance(entry, dict):
        return None
    path, digest, inode = entry.get("path"), entry.get("sha256"), entry.get("folder_inode")
    modified = entry.get("modified_ns")
    if not isinstance(path, str) or not isinstance(digest, str) or type(modified) is not int:
        return None
    target = Path(path)
    if not target.is_absolute():
        target = output_path(root / target)
        if Path(os.path.realpath(root)) not in target.parents:  # ../x: not the folder's own
            return None
    elif inode != _inode(root):  # a copy of the batch folder: the file is the original's
        return None
    if target.is_symlink() or not target.is_file() or not is_junit_of_ours(target):
        return None
    if not kept_time(modified, target.stat().st_mtime_ns):  # written since, by another
        return None
    return target if _digest(target) == digest else None


def _inode(folder: Path) -> int | None:
    try:
        return folder.stat().st_ino
    except OSError:
        return None


def withdraw_previous_junit(root: Path, junit: PathLike | None) -> str | None:
    """Remove the JUnit file the batch folder's last run wrote, unless this run writes it.

    Returns the note saying so, or None when there is nothing to remove.

    Raises
    ------
    OutputError
        When it cannot be removed, naming it.
    """
    previous = _recorded(root)
    if previous is None or (junit is not None and output_path(junit) == output_path(previous)):
        return None
    remove_written(
        previous, "the previous run's JUnit file", "would present its results as this run's"
    )
    instead = "none" if junit is None else f"--junit {excerpt(os.fspath(junit))}"
    return (  # the file removed named whole (escaped, never cut): the user may look for it
        f"removed {excerpt(str(previous), limit=WHOLE_PATH)}, the JUnit file of the previous "
        "run into --out "
        f"(its results would read as this run's); this run writes {instead}"
    )


def record_junit(root: Path, junit: PathLike | None) -> None:
    """Record in the batch folder's marker the JUnit file this run wrote (or that it wrote none).

    The marker is replaced atomically; one that cannot be read or written is left as it is
    (a JUnit file left unrecorded is only not withdrawn later, as before records).
    """
    marker = _marker(root)
    if marker is None:
        return
    marker.pop(JUNIT_KEY, None)
    if junit is not None:
        target = output_path(junit)
        digest = _digest(target)
        try:
            modified = target.stat().st_mtime_ns
        except OSError:
            return
        if digest is None:
            return
        inside = root in target.parents
        marker[JUNIT_KEY] = {
            "path": target.relative_to(root).as_posix() if inside else str(target),
            "sha256": digest,
            "modified_ns": modified,
            "folder_inode": _inode(root),
        }
    staged = temporary_name(root / MARKER)
    try:
        staged.write_text(json.dumps(marker, indent=1) + "\n", encoding="utf-8")
        os.replace(staged, root / MARKER)
    except OSError:
        with contextlib.suppress(OSError):
            staged.unlink()
