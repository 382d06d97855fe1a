"""The records of what hybridlog wrote, and whether it is still unchanged.

A folder carries :data:`~hybridlog.outputs.paths.MARKER` (:func:`write_marker`), listing the
files hybridlog wrote in it (:func:`record_folder_files`, :func:`recorded_files`); a file has
a record beside it, ``.<name>.hybridlog`` (:func:`record_file`, :func:`record_path`).  Both
hold each file's inode, size, modification time and, where cheap or worth it, SHA-256, so
that :func:`wrote_file` and :func:`edited_files` tell hybridlog's unchanged file, or a copy
that kept its content and times, from one the user wrote or edited (:func:`_unchanged`).
"""

from __future__ import annotations

import contextlib
import datetime
import hashlib
import json
import os
import socket
import stat
import sys
from collections.abc import Collection, Mapping
from pathlib import Path

from hybridlog import __version__
from hybridlog.errors import OutputError
from hybridlog.outputs.paths import MARKER, PathLike, path_present, shown_path
from hybridlog.outputs.temporaries import temporary_name


def write_marker(folder: Path) -> None:
    """Write :data:`MARKER` into ``folder``: this folder is hybridlog's to replace."""
    record = {
        "written_by": "hybridlog",
        "version": __version__,
        "command": [Path(sys.argv[0]).name, *sys.argv[1:]] if sys.argv else [],
        "pid": os.getpid(),
        "host": socket.gethostname(),
        "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
    }
    (folder / MARKER).write_text(json.dumps(record, indent=1) + "\n", encoding="utf-8")


_FILES_KEY = "files"


_IDENTITIES_KEY = "identities"


def recorded_files(folder: Path) -> Collection[str] | None:
    """The files (``/``-separated, relative) ``folder``'s :data:`MARKER` lists, or None.

    :func:`~hybridlog.outputs.publishing.publish_dir` records them when it moves a finished folder
    into place; a folder without the list (a batch folder, one of an older version) gives None: not
    known.
    """
    record = _read_record(folder / MARKER)
    files = record.get(_FILES_KEY) if isinstance(record, dict) else None
    if not isinstance(files, list) or not all(isinstance(f, str) for f in files):
        return None
    return frozenset(files)


def record_folder_files(folder: Path) -> None:
    """Add the list of the files in ``folder`` to its :data:`MARKER`, if it has one."""
    marker = folder / MARKER
    try:
        record = json.loads(marker.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return
    files = sorted(
        Path(parent, name).relative_to(folder).as_posix()
        for parent, _, names in os.walk(folder)
        for name in names
        if Path(parent, name) != marker
    )
    record[_FILES_KEY] = files
    identities = {name: file_identity(folder / name) for name in files}
    record[_IDENTITIES_KEY] = {
        name: _listed_entry(folder / name, identity)
        for name, identity in identities.items()
        if identity is not None
    }
    marker.write_text(json.dumps(record, indent=1) + "\n", encoding="utf-8")


def edited_files(folder: Path) -> list[str]:
    """The files ``folder``'s :data:`MARKER` lists that changed since hybridlog wrote them.

    Compared as :func:`wrote_file` compares a single file (:func:`_unchanged`): a report.md
    the user annotated, a table replaced by another file of the same name, but not the same
    files in a copy of the folder (``cp -a``, ``rsync -a``, a tar archive or CI cache
    restored).  A listed file that is gone is not a change (nothing of the user's is in
    it), nor is a file of a marker written before identities were recorded (not known).
    """
    record = _read_record(folder / MARKER)
    identities = record.get(_IDENTITIES_KEY) if isinstance(record, dict) else None
    if not isinstance(identities, dict):
        return []
    edited = []
    for name, recorded in sorted(identities.items()):
        identity = file_identity(folder / name)
        if identity is None:
            if path_present(folder / name):  # a folder or link now stands under its name
                edited.append(name)
            continue
        if not _listed_unchanged(recorded, identity, folder / name):
            edited.append(name)
    return edited


def _listed_entry(path: Path, identity: Mapping[str, int]) -> list[int | str]:
    """A marker's entry for a file: ``[inode, size, modified_ns]``, and its SHA-256 if worth it."""
    digest = _digest_worth_keeping(path, identity["size"])
    return [*(identity[key] for key in _COMPARED), *([] if digest is None else [digest])]


def _listed_unchanged(recorded: object, identity: Mapping[str, int], path: Path) -> bool:
    """:func:`_unchanged` for a marker's entry ``[inode, size, modified_ns(, sha256)]``.

    An entry of any other shape (an edited marker) is not hybridlog's record: changed.
    """
    if not isinstance(recorded, list) or len(recorded) not in (3, 4):
        return False
    numbers, digest = recorded[:3], recorded[3] if len(recorded) == 4 else None
    if not all(type(n) is int for n in numbers) or not isinstance(digest, str | None):
        return False
    return _unchanged(dict(zip(_COMPARED, numbers, strict=True)), digest, identity, path)


def record_path(target: Path) -> Path:
    """Where the record of a file hybridlog wrote lies: ``.<name>.hybridlog`` beside it."""
    return target.with_name(f".{target.name}{MARKER}")


def remove_written(target: Path, what: str, left: str) -> None:
    """Remove ``target``, a file hybridlog wrote, and its record (either may be gone already).

    Raises
    ------
    OutputError
        Where the system refuses, naming ``target`` as ``what`` (``the previous run's file``)
        and what leaving it would do (``left``).
    """
    try:
        target.unlink(missing_ok=True)
        record_path(target).unlink(missing_ok=True)
    except OSError as err:
        raise OutputError(  # the path whole, as the outputs' other refusals name theirs
            f"{shown_path(target)}: cannot remove {what}, which {left}: {err.strerror or err}"
        ) from err


def file_identity(path: Path) -> dict[str, int] | None:
    """What tells this regular file from any other, or from itself edited: None if no file."""
    try:
        status = os.lstat(path)
    except OSError:
        return None
    if not stat.S_ISREG(status.st_mode):
        return None
    return {
        "device": status.st_dev,
        "inode": status.st_ino,
        "size": status.st_size,
        "modified_ns": status.st_mtime_ns,
    }


_RECORD_LIMIT = 64 * 1024
"""The most a record or marker of hybridlog's can hold; anything larger is not one."""


def _read_record(path: Path) -> object:
    """The JSON of a record or marker at ``path``, or None.

    Read only from a regular file of at most :data:`_RECORD_LIMIT` bytes, never through a
    symbolic link and without waiting: a pipe, a device (``/dev/zero``), a link or a huge
    file under a record's name is not a record, and must neither hang nor exhaust memory.
    """
    flags = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0)
    try:
        handle = os.open(path, flags)
    except (OSError, ValueError):
        return None
    try:
        status = os.fstat(handle)
        if not stat.S_ISREG(status.st_mode) or status.st_size > _RECORD_LIMIT:
            return None
        data = os.read(handle, _RECORD_LIMIT + 1)
    except OSError:
        return None
    finally:
        os.close(handle)
    try:
        return json.loads(data.decode("utf-8")) if len(data) <= _RECORD_LIMIT else None
    except ValueError:  # UnicodeDecodeError too
        return None


_COMPARED = ("inode", "size", "modified_ns")
"""What of a file's identity is recorded to recognise it (:func:`_unchanged`)."""


_DIGESTED_LIMIT = 1 << 20
"""Files up to this size get their SHA-256 recorded when written (:func:`_digest_worth_keeping`)."""


_DIGESTED_SUFFIXES = frozenset({".json", ".md"})
"""Files recorded with their SHA-256 whatever their size: the documents a batch reuses
(report.json's numbers reach the summaries and the gates) and a user annotates."""


def _sha256(path: Path) -> str | None:
    """The SHA-256 of the regular file ``path`` (never through a link, never waiting)."""
    flags = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0)
    try:
        with os.fdopen(os.open(path, flags), "rb") as handle:
            if not stat.S_ISREG(os.fstat(handle.fileno()).st_mode):
                return None
            return hashlib.file_digest(handle, "sha256").hexdigest()
    except (OSError, ValueError):
        return None


def _digest_worth_keeping(path: Path, size: int) -> str | None:
    """The SHA-256 to record for a file hybridlog just wrote, or None: not worth its cost.

    Recorded for every file of at most :data:`_DIGESTED_LIMIT` bytes (a report, a plot,
    the tables of a short log, a summary: at most about a millisecond each) and for every
    report document (:data:`_DIGESTED_SUFFIXES`), not for the large tables of a long log:
    hashing the 145 MiB of tables of a 10^6-sample log costs 0.11 s (1.3 GB/s here), 8 % of
    the whole ``analyze`` (benchmarks/results.md).  Such a file is recognised by its size
    and modification time alone (:func:`_unchanged`).
    """
    if size > _DIGESTED_LIMIT and path.suffix not in _DIGESTED_SUFFIXES:
        return None
    return _sha256(path)


_SUB_SECOND_NS = 1_000
"""How far a copy's modification time may lie from the original's, below whole seconds:
a copy kept in microseconds, or as a float (Python's ``tarfile``, PAX: tens of ns off)."""


def kept_time(recorded_ns: int, current_ns: int) -> bool:
    """Whether ``current_ns`` is ``recorded_ns`` as a copy that kept it would give it back.

    ``cp -a``, ``rsync -a``, ``shutil.copy2`` and GNU tar's PAX archives keep nanoseconds;
    Python's PAX archives keep them as a float (:data:`_SUB_SECOND_NS`); GNU and ustar tar
    archives keep whole seconds only (a time of ``…:53.359`` comes back as ``…:53.000``,
    or rounded by other archivers).  Any other time is a change: an edit or a new file.
    """
    if abs(current_ns - recorded_ns) <= _SUB_SECOND_NS:
        return True
    return current_ns % 1_000_000_000 == 0 and abs(current_ns - recorded_ns) < 1_000_000_000


def _unchanged(
    recorded: Mapping[str, object], digest: object, identity: Mapping[str, int], path: Path
) -> bool:
    """Whether the file ``path`` (``identity`` now) is the one ``recorded``, or a copy of it.

    The cheap identity decides first: another size is a change; the same inode must have
    the very modification time recorded (the file itself, not edited since), and another
    inode (a copy: ``cp -a``, ``rsync -a``, a tar archive or CI cache restored) a time a
    copy keeps (:func:`kept_time`).  Then, where a SHA-256 was recorded
    (:func:`_digest_worth_keeping`), the content must have it: an edit of the same size
    whose time was put back (``touch -d``) is caught.  A large table recorded without one is
    taken on its size and time: an edit of the same size whose time was forged back is
    not seen in it (as it was not before digests, by inode, for an edit in place).
    """
    if recorded.get("size") != identity["size"]:
        return False
    modified = recorded.get("modified_ns")
    if type(modified) is not int:
        return False
    if recorded.get("inode") == identity["inode"]:
        if modified != identity["modified_ns"]:
            return False
    elif not kept_time(modified, identity["modified_ns"]):
        return False
    if digest is None:
        return True
    return isinstance(digest, str) and _sha256(path) == digest


def _file_record(path: Path) -> dict[str, object] | None:
    record = _read_record(path)
    if not isinstance(record, dict) or record.get("written_by") != "hybridlog":
        return None
    return record


def record_file(target: Path, *, written: Mapping[str, int] | None = None) -> None:
    """Record beside ``target`` that hybridlog wrote it, as it is now (:func:`wrote_file`).

    Written after ``target`` is in place.  ``written`` is the identity of the file this
    process wrote (:func:`file_identity` of it before it was moved, which a rename keeps):
    if ``target`` is another file by now (someone put theirs there in between), nothing is
    recorded.  A file of someone else's under the record's name is left alone, and a record
    that cannot be written is not an error: ``target`` is then simply never replaced (the
    safe side), as after a crash between the two.
    """
    identity = file_identity(target)
    sidecar = record_path(target)
    if identity is None or (written is not None and identity != dict(written)):
        return
    if path_present(sidecar) and _file_record(sidecar) is None:
        return
    digest = _digest_worth_keeping(target, identity["size"])
    record = {
        "written_by": "hybridlog",
        "version": __version__,
        "file": target.name,
        **identity,
        **({} if digest is None else {"sha256": digest}),
        "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
    }
    staged = temporary_name(sidecar)
    try:
        staged.write_text(json.dumps(record, indent=1) + "\n", encoding="utf-8")
        os.replace(staged, sidecar)
    except OSError:
        with contextlib.suppress(OSError):
            staged.unlink()


def wrote_file(target: Path) -> bool:
    """Whether hybridlog wrote the file ``target`` and nobody changed it since.

    True when the record beside it (:func:`record_file`) names this file under this name,
    unchanged (:func:`_unchanged`: size, modification time, content where its SHA-256 was
    recorded), itself or a copy of it that kept its time along with its record (the
    folder copied with ``cp -a``, ``rsync -a``, restored from a tar archive or CI cache).
    A file put in its place, edited, copied from elsewhere without its time or its record,
    or written before records existed is not hybridlog's to replace.

    The device is recorded but not compared: the record lies in the file's own folder, so
    on its file system, and the number a system gives a file system is not stable (an NFS
    or FUSE mount, a btrfs subvolume get a new one when mounted again), which would make
    hybridlog's own unchanged file a stranger after a reboot.
    """
    record = _file_record(record_path(target))
    identity = file_identity(target)
    return (
        record is not None
        and identity is not None
        and record.get("file") == target.name
        and _unchanged(record, record.get("sha256"), identity, target)
    )


def _starts_with(path: Path, start: str) -> bool:
    try:
        with path.open(encoding="utf-8") as handle:
            return handle.read(len(start)) == start
    except (OSError, UnicodeDecodeError):
        return False


def _legacy(folder: Path) -> bool:
    """A report, comparison or batch folder written before hybridlog wrote markers."""
    report = folder / "report.json"
    if report.is_file():
        try:
            data = json.loads(report.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return False
        return isinstance(data, dict) and "hybridlog_version" in data
    return (
        _starts_with(folder / "comparison.md", "# ")
        and _starts_with(folder / "comparison.csv", "estimator,")
    ) or (
        _starts_with(folder / "summary.md", "# Batch: ")
        and _starts_with(folder / "summary.csv", "log,status,")
    )


def is_ours(folder: PathLike) -> bool:
    """Whether hybridlog wrote ``folder``: it holds :data:`MARKER`, or is a legacy report."""
    path = Path(folder)
    return (path / MARKER).is_file() or _legacy(path)
