"""Temporary names next to the outputs, and their clean-up after processes that died.

:func:`temporary_name` makes ``.<name>.hybridlog-<kind>-<host>-<pid>-<hex>``;
:func:`is_temporary` and :func:`own_temporary` recognise them (any process's, this one's);
:func:`remove_stale_temporaries` removes those of dead processes on this host;
:func:`shown_output` names the output a temporary path stands for.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import re
import secrets
import shutil
import socket
from collections.abc import Collection
from pathlib import Path

from hybridlog.outputs.paths import MARKER, PathLike, shown_path

_TEMPORARY = re.compile(
    r"^\..+\.hybridlog-(?:tmp|old)-(?P<host>[0-9a-f]{4})-(?P<pid>\d+)-[0-9a-f]{8}(?:\.[^.]*)?$"
)


def _is_nonempty_dir(path: Path) -> bool:
    with os.scandir(path) as entries:
        return any(True for _ in entries)


def _host_tag() -> str:
    """Four hex digits of the host name, recorded in temporary names.

    Process ids are only compared on the host (or container) that made a name, so a run on
    a shared disk never removes the temporaries of a process running elsewhere.
    """
    return hashlib.sha1(socket.gethostname().encode(), usedforsecurity=False).hexdigest()[:4]


def temporary_name(target: Path, *, kind: str = "tmp", keep_suffix: bool = False) -> Path:
    """A fresh hidden name next to ``target`` naming this process and host.

    ``.<name>.hybridlog-<kind>-<host>-<pid>-<hex>``; with ``keep_suffix`` the suffix stays
    last (``.<stem>.hybridlog-tmp-<host>-<pid>-<hex><suffix>``), for writers that choose the
    format from it (matplotlib).
    """
    tag = f"hybridlog-{kind}-{_host_tag()}-{os.getpid()}-{secrets.token_hex(4)}"
    if keep_suffix and target.suffix:
        return target.with_name(f".{target.stem}.{tag}{target.suffix}")
    return target.with_name(f".{target.name}.{tag}")


def is_temporary(name: str) -> bool:
    """Whether ``name`` is a temporary name of :func:`temporary_name` (any process's)."""
    return _TEMPORARY.match(name) is not None


def own_temporary(name: str) -> bool:
    """Whether ``name`` is one of this process's temporary names (:func:`temporary_name`)."""
    match = _TEMPORARY.match(name)
    return match is not None and match["host"] == _host_tag() and int(match["pid"]) == os.getpid()


def _alive(pid: int) -> bool:
    """Whether process ``pid`` still runs (a zombie has exited: only its entry is left)."""
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return True  # someone else's process (or an absurd number): leave its files alone
    try:  # an orphan killed with its parent stays a zombie where nothing reaps it
        stat = (Path("/proc") / str(pid) / "stat").read_text()
    except OSError:
        return True  # no /proc (not Linux): the signal test above is all there is
    return stat.rsplit(")", 1)[-1].split()[:1] != ["Z"]


def remove_stale_temporaries(folder: PathLike, *, ours: Collection[int] = ()) -> list[Path]:
    """Remove temporaries that dead hybridlog processes left in ``folder``.

    Only names made by :func:`temporary_name` on this host whose process no longer runs are touched,
    and of folders only those that are empty or carry :data:`~hybridlog.outputs.paths.MARKER`, or
    were made by a process of ``ours``: processes the caller started and saw end (a batch's
    workers), whose folders are removed whatever they hold (a worker stopped while it removed its
    own folder may have removed the marker first, and a thread of it written a file after).

    Returns
    -------
    list of pathlib.Path
        What was removed.
    """
    removed: list[Path] = []
    host = _host_tag()
    try:
        with os.scandir(folder) as listing:
            entries = list(listing)
    except OSError:
        return removed
    for entry in entries:
        if not entry.name.startswith("."):
            continue
        match = _TEMPORARY.match(entry.name)
        if match is None or match["host"] != host or _alive(int(match["pid"])):
            continue
        path = Path(entry.path)
        with contextlib.suppress(OSError):
            if entry.is_dir(follow_symlinks=False):
                if (
                    int(match["pid"]) in ours
                    or (path / MARKER).is_file()
                    or not _is_nonempty_dir(path)
                ):
                    shutil.rmtree(path)
                    removed.append(path)
            else:
                path.unlink()
                removed.append(path)
    return removed


def shown_output(path: PathLike) -> str:
    """The output ``path`` stands for, as an error names it (escaped and cut, :func:`shown_path`).

    Each temporary name in it is replaced by its target's (:func:`temporary_name`).  An
    error met while writing a staged file names the file the user asked for, not the
    hidden temporary that no longer exists once the error is reported.
    """
    return shown_path(Path(*(_target_name(part) for part in Path(path).parts)))


def _target_name(name: str) -> str:
    """The name of the output a temporary name of :func:`temporary_name` stands for."""
    if _TEMPORARY.match(name) is None:
        return name
    stem, _, rest = name[1:].rpartition(".hybridlog-")
    return stem + rest[rest.find(".") :] if "." in rest else stem


def folder_entries(folder: Path, *, but: Collection[str] = ()) -> list[str]:
    """The names in ``folder`` but those of ``but`` and this process's temporaries, sorted."""
    return sorted(n for n in os.listdir(folder) if n not in but and not own_temporary(n))
