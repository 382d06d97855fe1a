"""Output paths that never cost the user a byte (SPEC §9).

Every command that writes goes through this module, in two steps:

1. **Check everything first.**  :func:`check_apart` refuses an output path that is, contains or
   sits inside any input (log, model file, centres file, ``--msg-dir``), with or without
   ``--force``; paths are compared after resolving symbolic links, ``..`` and relative parts,
   and by device and inode, so hard links and bind mounts are caught too.
   :func:`check_dir_target` and :func:`check_file_target` refuse existing targets unless
   ``--force``, and then unless hybridlog wrote them: a folder carries the :data:`MARKER` file
   listing what hybridlog wrote in it (or is a legacy report folder of ours); a file has a
   record beside it, ``.<name>.hybridlog`` (:func:`record_file`), naming the exact file
   hybridlog wrote (inode, size, modification time, and the SHA-256 of a small file or a
   report document), so a file the user wrote, put there or edited since is never
   replaced, while the same file in a copy of its folder that kept its content and times
   (``cp -a``, ``rsync -a``, a tar archive or CI cache restored) is still hybridlog's
   (:func:`_unchanged`).
2. **Then write atomically.**  :func:`atomic_output_dir` and :func:`atomic_files` write into
   temporary names next to the targets (``.<name>.hybridlog-tmp-<host>-<pid>-<hex>``) and
   rename them into place when all of them are complete; a folder that exists (empty, or
   ours with ``--force``) is filled in place instead, so that it stays the user's folder and
   a mount point can be written (:func:`publish_dir`, :func:`_fill_dir`); a failure removes
   them and leaves the targets as they were.  Temporaries of processes that died
   (``kill -9``) are removed by the next run writing to the same place
   (:func:`remove_stale_temporaries`).
"""

from __future__ import annotations

import contextlib
import csv
import datetime
import errno
import hashlib
import json
import os
import re
import secrets
import shutil
import socket
import stat
import sys
from collections.abc import Callable, Collection, Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path

from hybridlog import __version__
from hybridlog.errors import OutputError, as_name, excerpt, first_few
from hybridlog.limits import owner_masked

__all__ = [
    "MARKER",
    "PathLike",
    "atomic_files",
    "atomic_output_dir",
    "check_apart",
    "check_creatable",
    "check_dir_target",
    "check_distinct",
    "check_file_name",
    "check_file_target",
    "edited_files",
    "is_ours",
    "is_temporary",
    "output_path",
    "publish_dir",
    "publish_file",
    "record_file",
    "record_path",
    "recorded_files",
    "remove_stale_temporaries",
    "shown_output",
    "staging_dir",
    "temporary_name",
    "write_marker",
    "wrote_file",
]

PathLike = str | os.PathLike[str]

MARKER = ".hybridlog"
"""File hybridlog writes into every output folder it creates: version, command, process."""

_PATH_LIMIT = 240
_TEMPORARY = re.compile(
    r"^\..+\.hybridlog-(?:tmp|old)-(?P<host>[0-9a-f]{4})-(?P<pid>\d+)-[0-9a-f]{8}(?:\.[^.]*)?$"
)


def _shown(path: PathLike) -> str:
    """A path for an error message: escaped if it holds control characters, cut if huge."""
    return excerpt(os.fspath(path), _PATH_LIMIT)[1:-1]


def _check_umask(target: PathLike) -> None:
    """Refuse an output its owner could not read back or finish (:func:`owner_masked`)."""
    if (why := owner_masked()) is not None:
        raise OutputError(f"{_shown(target)}: {why}")


def output_path(target: PathLike) -> Path:
    """The absolute path the system writes when given ``target``: what every writer uses.

    The folder part is resolved as the system resolves it (symbolic links first, then
    ``..``), the last name kept as given: ``link/../run.csv`` with ``link`` a link to
    ``a/b`` is ``a/run.csv``, where ``open`` writes it, not ``./run.csv`` (which
    :func:`os.path.abspath` would make of it, and which :func:`check_apart`, comparing
    resolved paths, would not have checked).
    """
    _check_umask(target)
    path = os.path.join(os.getcwd(), os.fspath(target))
    folder, name = os.path.split(path.rstrip(os.sep) or os.sep)
    if name in ("", os.curdir, os.pardir):
        return Path(os.path.realpath(path))
    return Path(os.path.realpath(folder), name)


# --- outputs are never inputs ------------------------------------------------------------------


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
                    f"{option} {_shown(output)} {relation} the {item.what} "
                    f"{_shown(item.path)}; choose an output path outside every input"
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
            raise OutputError(f"{seen[resolved]} and {option} both name {_shown(path)}")
        seen[resolved] = option


# --- what hybridlog wrote ----------------------------------------------------------------------


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

    :func:`publish_dir` records them when it moves a finished folder into place; a folder
    without the list (a batch folder, one of an older version) gives None: not known.
    """
    record = _read_record(folder / MARKER)
    files = record.get(_FILES_KEY) if isinstance(record, dict) else None
    if not isinstance(files, list) or not all(isinstance(f, str) for f in files):
        return None
    return frozenset(files)


def _record_files(folder: Path) -> None:
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
    identities = {name: _file_identity(folder / name) for name in files}
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
        identity = _file_identity(folder / name)
        if identity is None:
            if _present(folder / name):  # a folder or link now stands under its name
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


def _file_identity(path: Path) -> dict[str, int] | None:
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
    process wrote (:func:`_file_identity` of it before it was moved, which a rename keeps):
    if ``target`` is another file by now (someone put theirs there in between), nothing is
    recorded.  A file of someone else's under the record's name is left alone, and a record
    that cannot be written is not an error: ``target`` is then simply never replaced (the
    safe side), as after a crash between the two.
    """
    identity = _file_identity(target)
    sidecar = record_path(target)
    if identity is None or (written is not None and identity != dict(written)):
        return
    if _present(sidecar) and _file_record(sidecar) is None:
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
    identity = _file_identity(target)
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


# --- checks of targets ------------------------------------------------------------------------

_TEMPORARY_OVERHEAD = len(".x.hybridlog-tmp-0000-4194304-00000000") - 1
"""How much longer than its target's name a temporary name can be (:func:`temporary_name`)."""


def _present(path: Path) -> bool:
    """Whether ``path`` exists (a dangling link counts); an unusable name is an error."""
    try:
        os.lstat(path)
    except (FileNotFoundError, NotADirectoryError):
        return False
    except OSError as err:
        raise OutputError(f"{_shown(path)}: {err.strerror}") from None
    return True


def check_followable(target: PathLike) -> None:
    """Refuse an output path, as given, that runs through a file: ``run.csv/../out``.

    :func:`output_path` resolves the folder part as :func:`os.path.realpath` does, which
    takes ``run.csv/..`` for ``run.csv``'s folder; the system refuses such a path (a file
    is no folder to go up from), so the outputs went to ``./out`` while the command printed
    ``run.csv/../out/report.md``, a path nobody could open; so through a missing folder
    (``missing/../out``).  A missing folder is no error otherwise (:func:`check_creatable`
    tells what can be made).

    Raises
    ------
    OutputError
        Naming the path and the part of it that is not a folder.
    """
    text = os.fspath(target)
    folder = text
    steps: list[str] = []
    while (parent := os.path.dirname(folder.rstrip(os.sep)) or "") not in ("", folder):
        steps.append(parent)
        folder = parent
    for step in reversed(steps):  # outermost first, as the system follows the path
        try:
            status = os.stat(step)
        except FileNotFoundError:
            # made later, unless the path goes up out of it: 'missing/../out' was written
            # to ./out, reported as missing/../out/report.md, which no one can open
            if os.pardir in text[len(step) :].split(os.sep):
                raise OutputError(
                    f"{_shown(target)}: cannot be created: {_shown(step)} does not exist, "
                    f"so '{os.pardir}' after it leads nowhere"
                ) from None
            return
        except (OSError, ValueError):  # unusable: told later
            return
        if not stat.S_ISDIR(status.st_mode):
            raise OutputError(
                f"{_shown(target)}: cannot be created: {_shown(step)} is not a folder"
            )


def check_creatable(target: Path) -> None:
    """Refuse an output path that cannot be created or replaced, before any work is done.

    The nearest existing folder above ``target`` must be a folder this process can create a
    file in (tried with a temporary name, removed at once), and every missing part of the
    path, and the temporary name written next to ``target``, must fit the file system's
    limit on a name.

    Raises
    ------
    OutputError
        Naming the path and what is wrong with it.
    """
    ancestor = target.parent
    missing = [target.name]
    while ancestor.parent != ancestor and not _present(ancestor):
        missing.append(ancestor.name)
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise OutputError(
            f"{_shown(target)}: cannot be created: {_shown(ancestor)} is not a folder"
        )
    try:
        limit = os.pathconf(ancestor, "PC_NAME_MAX")
    except (OSError, ValueError):
        limit = 255
    for name in missing:
        allowed = limit - _TEMPORARY_OVERHEAD if name == target.name else limit
        if len(os.fsencode(name)) > allowed:
            raise OutputError(
                f"{_shown(target)}: the name {excerpt(name, 40)} is too long "
                f"(at most {allowed} bytes here)"
            )
    probe = temporary_name(ancestor / "probe")
    try:
        os.close(os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600))
        os.unlink(probe)
    except OSError as err:
        raise OutputError(
            f"{_shown(target)}: cannot be created: no file can be made in "
            f"{_shown(ancestor)} ({err.strerror})"
        ) from None


def _is_nonempty_dir(path: Path) -> bool:
    with os.scandir(path) as entries:
        return any(True for _ in entries)


def check_dir_target(
    target: PathLike,
    *,
    force: bool,
    ours: Callable[[Path], bool] | None = None,
    written: Callable[[Path], Collection[str] | None] = recorded_files,
    replacing: bool = True,
) -> Path:
    """Check that an output folder may be created or replaced; return its absolute path.

    A missing folder must be creatable (:func:`check_creatable`); an empty one is fine
    (the temporaries dead runs left in it removed, :func:`remove_stale_temporaries`).  A
    non-empty one is replaced only with ``force`` and only when hybridlog wrote it
    (:func:`is_ours`, or the test ``ours`` of a writer whose folders record it another way),
    and, when it is about to be replaced (``replacing``), only if it holds nothing but what
    hybridlog wrote there (``written``: the files a folder's :data:`MARKER` lists,
    :func:`recorded_files`) and none of those changed since (a user's notes appended to
    report.md): a user's own folder, or a note a user put into a report folder, is never
    wiped.  A folder that is part of another output (a comparison's report) is refused,
    present or not (:func:`_check_not_part`).  Without ``force`` the same checks run first,
    so that "use --force" is advised only for a folder it would replace.

    Raises
    ------
    OutputError
        When the target exists and is not a folder (or is a symbolic link), is not empty
        (without ``force``), holds files hybridlog did not write, or is part of another
        output hybridlog wrote.
    """
    check_followable(target)
    path = output_path(target)
    if path.parent == path:
        raise OutputError(f"output directory {_shown(target)} cannot be replaced")
    check_creatable(path)
    _check_not_part(path)
    if not _present(path):
        return path
    if path.is_symlink():  # renamed over, or filled through: neither is the folder named
        pointed = os.readlink(path)
        where = "a folder" if path.is_dir() else "nothing" if not path.exists() else "a file"
        raise OutputError(
            f"output path {_shown(path)} is a symbolic link (to {excerpt(pointed)}, {where}), "
            "which hybridlog does not write through; name the folder itself or another path"
        )
    if not path.is_dir():
        raise OutputError(f"output path {_shown(path)} exists and is not a directory")
    remove_stale_temporaries(path)  # of a run killed while it filled the folder (_fill_dir)
    try:
        nonempty = bool(_entries(path))  # this run's staging inside it is not content
    except OSError as err:
        raise OutputError(f"output directory {_shown(path)}: {err.strerror}") from err
    if not nonempty:
        return path
    # Checked with or without ``force``: "use --force" is advised only where it would work.
    if not (is_ours(path) or (ours is not None and ours(path))):
        raise OutputError(
            f"output directory {_shown(path)} is not empty: it holds files hybridlog did not "
            f"write (no {MARKER} file), so --force will not delete it; choose another output "
            "directory or remove this one yourself"
        )
    if replacing:
        _check_only_ours(path, written(path))
        if edited := edited_files(path):
            raise OutputError(
                f"output directory {_shown(path)} holds files changed since hybridlog wrote "
                f"them ({_some(edited)}), which replacing it would lose; move them out, or "
                "choose another output directory"
            )
    if not force:
        raise OutputError(
            f"output directory {_shown(path)} is not empty; use --force to replace it"
        )
    return path


def _marked_folders_above(path: Path) -> Iterator[Path]:
    """The folders above ``path`` that hold hybridlog's :data:`MARKER`, nearest first."""
    for parent in path.parents:
        try:
            if (parent / MARKER).is_file():
                yield parent
        except OSError:  # a folder above that cannot be searched holds no marker we read
            continue


def _enclosing_output(path: Path) -> Path | None:
    """The folder above ``path`` whose :data:`MARKER` lists files in ``path``, or None."""
    for parent in _marked_folders_above(path):
        inside = path.relative_to(parent).as_posix() + "/"
        if any(name.startswith(inside) for name in recorded_files(parent) or ()):
            return parent
    return None


def _check_not_part(path: Path) -> None:
    """Refuse an output folder that is part of another output hybridlog wrote.

    ``analyze --out cmp/imm --force`` replaced a comparison's report with a run of other
    settings (``compare --out cmp/imm`` with a comparison), and ``cmp``'s comparison.md
    then gave numbers, and links, that no report of it held: a folder the
    :data:`MARKER` of a folder above lists files in (:func:`recorded_files`; a batch folder
    lists none, and a batch replaces its logs' reports itself) is written only with the
    folder it is part of, also when it was removed.
    """
    whole = _enclosing_output(path)
    if whole is not None:
        raise OutputError(
            f"output directory {_shown(path)} is part of {_shown(whole)}, which hybridlog "
            "wrote (its tables name what it holds), so it is not written on its own; "
            "write the whole folder again, or choose another output directory"
        )


def check_outside_batch(target: PathLike) -> None:
    """Refuse to replace an ``analyze`` or ``compare`` folder inside a batch folder.

    A batch folder's summaries (summary.md/.csv/.png, the JUnit file) give each log's
    numbers and name its report folder; ``analyze --out nightly/run.csv --force`` replaced
    that report with one of other settings (another log, other options), so the summaries
    gave numbers no report held, and :func:`_check_not_part`, which keeps a comparison's
    reports so, does not see a batch folder (its marker lists no files).  A batch folder is
    the nearest folder above with hybridlog's :data:`MARKER`, listing no files, beside a
    summary.csv hybridlog recorded (:func:`record_file`); a folder there is refused when it
    is, or holds, a report folder summary.csv names (its ``folder`` column; all of them
    where it cannot be read).  Another replaces nothing the summaries name (the next batch
    lists it among the folders it did not write), so ``analyze`` in a working folder that is
    also a batch's output writes its own folder, and writes it again with ``--force``.

    Raises
    ------
    OutputError
        Naming the output folder and the batch folder.
    """
    path = output_path(target)
    if not os.path.lexists(path):
        return
    for parent in _marked_folders_above(path):
        summary = parent / "summary.csv"
        if recorded_files(parent) is None and record_path(summary).is_file():
            named = _summary_folders(summary)
            inside = as_name(path.relative_to(parent).as_posix())
            if named is not None and not any(
                name == inside or name.startswith(f"{inside}/") for name in named
            ):
                return
            raise OutputError(
                f"output directory {_shown(target)} is inside the batch folder "
                f"{_shown(parent)}, whose summaries name its reports; run the batch again, "
                "or choose another output directory"
            )
        return


def _summary_folders(summary: Path) -> list[str] | None:
    """The report folders a batch's summary.csv names (its ``folder`` column), or None.

    ``None`` where the file cannot be read as one (no such column): every folder of the
    batch folder is then taken for one of its reports.
    """
    try:
        with summary.open(encoding="utf-8", newline="") as handle:
            reader = csv.DictReader(handle)
            rows = list(reader)
            columns = reader.fieldnames or ()
    except (OSError, UnicodeError, csv.Error):
        return None
    if "folder" not in columns:
        return None
    return [row["folder"] for row in rows if row["folder"]]


def _check_only_ours(path: Path, written: Collection[str] | None) -> None:
    """Refuse to replace ``path`` if it holds anything besides ``written``.

    ``written`` None (a marker without its list of files: a batch folder, an older
    version's or an edited marker; a bag whose ``metadata.yaml`` lists no files) means that
    what hybridlog wrote there is not known, and then nothing is replaced.  Folders count
    too: one that holds no listed file, and a link to a folder, are the user's.
    """
    if written is None:
        raise OutputError(
            f"output directory {_shown(path)} does not list what hybridlog wrote there (a "
            f"batch folder, one of an older version, or an edited {MARKER}), so --force "
            "will not replace it; remove it yourself or choose another output directory"
        )
    expected = {*written, MARKER}
    folders_expected = {p.as_posix() for f in expected for p in Path(f).parents} - {"."}
    foreign: list[str] = []
    nested: list[str] = []  # outputs of other runs written inside it since
    for folder, folders, files in os.walk(path):
        if folder == os.fspath(path):  # this run's staging inside it (publish_dir)
            folders[:] = [name for name in folders if not _own_temporary(name)]
            files = [name for name in files if not _own_temporary(name)]
        for name in list(folders):
            relative = Path(folder, name).relative_to(path).as_posix()
            entry = Path(folder, name)
            nests = not entry.is_symlink() and (entry / MARKER).is_file()
            if relative not in folders_expected and nests:
                nested.append(relative + "/")
                folders.remove(name)
        folders.sort()
        for name in sorted(files):
            relative = Path(folder, name).relative_to(path).as_posix()
            if relative not in expected:
                foreign.append(relative)
        for name in folders:
            relative = Path(folder, name).relative_to(path).as_posix()
            entry = Path(folder, name)
            # a folder of the user's with files in it shows as those files
            if entry.is_symlink() or (
                relative not in folders_expected and not any(entry.iterdir())
            ):
                foreign.append(relative + "/")
    if nested:
        raise OutputError(
            f"output directory {_shown(path)} holds another output of hybridlog's, written "
            f"into it since ({_some(nested)}), which replacing it would delete; move it out, "
            "or choose another output directory"
        )
    if foreign:
        raise OutputError(
            f"output directory {_shown(path)} holds files hybridlog did not write "
            f"({_some(foreign)}), which replacing it would delete; move them out, or choose "
            "another output directory"
        )


def _some(names: Sequence[str]) -> str:
    """``'a', 'b', 'c' and 2 more``: the first three of ``names``, quoted, and how many else."""
    return first_few(names, 3, lambda name: excerpt(name, 60))


def check_file_name(target: PathLike, option: str = "") -> None:
    """Refuse a file to write whose name, as given, ends as a folder's: ``x.json/``, ``x/.``.

    ``open`` refuses such a name, but :class:`~pathlib.Path` drops the ``/`` (and a last
    ``.``), so ``cluster --out dir.json/``, where the user meant a folder, wrote a file
    ``dir.json``.  Called on the text given (a ``Path`` no longer has the ending), first by
    :func:`check_file_target`; ``option`` (``--out``) starts the message.

    Raises
    ------
    OutputError
        Naming the option and the path, and that a file is written there.
    """
    text = os.fspath(target)
    separators = os.sep + (os.altsep or "")
    last = os.path.basename(text)
    if text.endswith(tuple(separators)):
        ending = text[len(text.rstrip(separators)) - len(text) :]
    elif last in (os.curdir, os.pardir):
        ending = text[-len(last) - 1 :] if len(text) > len(last) else last
    else:
        return
    prefix = f"{option} " if option else ""
    raise OutputError(
        f"{prefix}{_shown(target)}: ends with {excerpt(ending, 20)}, which names a folder; "
        "name a file to write"
    )


def check_file_target(
    target: PathLike, *, force: bool, ours: Callable[[Path], bool] = wrote_file
) -> Path:
    """Check that an output file may be created, or replaced with ``force``.

    ``force`` replaces only a file hybridlog wrote (SPEC §9): by default one with a record
    beside it (:func:`wrote_file`); ``ours`` recognises the files of a command that knows
    its own otherwise (a batch's summaries inside its folder, a JUnit file by its content).

    Raises
    ------
    OutputError
        When the target is a folder or another file that is not a regular one (a device, a
        pipe), is named as a folder (:func:`check_file_name`), exists and ``force`` is false
        or it is not ``ours``, or cannot be created (:func:`check_creatable`).
    """
    check_file_name(target)
    check_followable(target)
    path = output_path(target)
    check_creatable(path)
    if path.is_dir():
        raise OutputError(f"{_shown(target)}: is a directory; name a file to write")
    if path.exists() and not path.is_file():
        raise OutputError(
            f"{_shown(target)}: exists and is not a regular file (a device, pipe or socket); "
            "hybridlog never replaces one"
        )
    if _present(path) and not force:
        raise OutputError(f"{_shown(target)}: already exists (use --force to replace it)")
    if _present(path) and not ours(path):
        raise OutputError(
            f"{_shown(target)}: exists and hybridlog did not write it (or it changed since), "
            "so --force does not replace it; move it away or name another file"
        )
    return path


# --- temporary names and their clean-up --------------------------------------------------------


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


def _own_temporary(name: str) -> bool:
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

    Only names made by :func:`temporary_name` on this host whose process no longer runs are
    touched, and of folders only those that are empty or carry :data:`MARKER`, or were made
    by a process of ``ours``: processes the caller started and saw end (a batch's workers),
    whose folders are removed whatever they hold (a worker stopped while it removed its own
    folder may have removed the marker first, and a thread of it written a file after).

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


def _prepare_parent(target: Path) -> list[Path]:
    """Create the missing parent folders of ``target``; return them, innermost first.

    Also removes temporaries of dead processes from the parent (see
    :func:`remove_stale_temporaries`).
    """
    missing = [p for p in target.parents if not p.exists()]
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        _remove_created(missing)
        raise OutputError(f"cannot create folder {_shown(target.parent)}: {err.strerror}") from err
    remove_stale_temporaries(target.parent)
    return missing


_STORAGE_ERRORS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EROFS})
"""What the file system answers a write it cannot take: full, over quota, over the size
limit (``ulimit -f``), read-only (remounted so)."""

_OS_ERROR = re.compile(r"\(os error (\d+)\)")
"""How polars (Rust's ``std::io::Error``) names the system's error number in its messages."""


def _storage_error(target: PathLike, err: BaseException) -> OutputError | None:
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
    # an output written inside another's temporary folder (compare's per estimator) is
    # named where it was to go
    return OutputError(f"{shown_output(target)}: cannot be written ({os.strerror(number)})")


def shown_output(path: PathLike) -> str:
    """The output ``path`` stands for, as an error names it (escaped and cut, :func:`_shown`).

    Each temporary name in it is replaced by its target's (:func:`temporary_name`).  An
    error met while writing a staged file names the file the user asked for, not the
    hidden temporary that no longer exists once the error is reported.
    """
    return _shown(Path(*(_target_name(part) for part in Path(path).parts)))


def _target_name(name: str) -> str:
    """The name of the output a temporary name of :func:`temporary_name` stands for."""
    if _TEMPORARY.match(name) is None:
        return name
    stem, _, rest = name[1:].rpartition(".hybridlog-")
    return stem + rest[rest.find(".") :] if "." in rest else stem


def _names(err: BaseException, path: Path) -> bool:
    """Whether ``err`` is an ``OSError`` about ``path``."""
    return isinstance(err, OSError) and err.filename is not None and Path(err.filename) == path


def _remove_created(folders: Sequence[Path]) -> None:
    """Remove folders made for outputs that were never written (deepest first)."""
    for folder in sorted(folders, key=lambda f: len(f.parts), reverse=True):
        with contextlib.suppress(OSError):
            folder.rmdir()


# --- publishing --------------------------------------------------------------------------------


def publish_file(
    staged: Path,
    target: Path,
    *,
    force: bool,
    ours: Callable[[Path], bool] = wrote_file,
    record: bool = True,
) -> None:
    """Move the finished ``staged`` file to ``target`` and record it (:func:`record_file`).

    ``record`` false is for files whose command recognises them otherwise (``ours``).

    Never clobbers ``target`` unless ``force`` and ``ours`` (see :func:`check_file_target`).

    Raises
    ------
    OutputError
        When ``target`` appeared meanwhile (without ``force``), is a folder or someone
        else's, or the move fails.
    """
    check_file_target(target, force=force, ours=ours)
    written = _file_identity(staged)
    try:
        _move_file(staged, target, force=force)
    except OSError as err:
        raise OutputError(f"{_shown(target)}: cannot be written ({err.strerror})") from err
    if record and written is not None:
        record_file(target, written=written)


def _move_file(staged: Path, target: Path, *, force: bool) -> None:
    if force:
        os.replace(staged, target)
        return
    try:
        # A hard link fails if ``target`` appeared meanwhile, unlike a rename.
        os.link(staged, target)
    except FileExistsError:
        raise OutputError(f"{_shown(target)}: already exists (use --force to replace it)") from None
    except OSError:
        if target.exists():
            raise OutputError(
                f"{_shown(target)}: already exists (use --force to replace it)"
            ) from None
        os.replace(staged, target)
    else:
        staged.unlink()


def publish_dir(
    staged: Path,
    target: Path,
    *,
    force: bool,
    ours: Callable[[Path], bool] | None = None,
    written: Callable[[Path], Collection[str] | None] = recorded_files,
    recognised_by: str = MARKER,
) -> None:
    """Move the finished folder ``staged`` to ``target``, filling an existing one in place.

    The files of ``staged`` are recorded in its :data:`MARKER` (:func:`recorded_files`), so
    that a later run replaces the folder only while it holds nothing else.  A missing
    ``target`` is ``staged`` renamed; an existing one (empty, or one of ours with ``force``)
    keeps its identity and gets ``staged``'s entries (:func:`_fill_dir`), ``recognised_by``
    being the file that makes a folder ours (:data:`MARKER`; a ROS 2 bag's
    ``metadata.yaml``).

    Raises
    ------
    OutputError
        As :func:`check_dir_target` with ``ours`` (checked again: the target may have
        appeared or changed meanwhile), or when a rename fails.
    """
    check_dir_target(target, force=force, ours=ours, written=written)
    _record_files(staged)
    try:
        if not _present(target):
            os.rename(staged, target)
            return
        _fill_dir(staged, target, recognised_by)
    except OSError as err:
        raise OutputError(f"cannot move outputs into {_shown(target)}: {err.strerror}") from err


@contextmanager
def atomic_output_dir(target: PathLike, *, force: bool = False) -> Iterator[Path]:
    """Write an output directory atomically, marked as hybridlog's.

    Yields a fresh temporary directory that already holds :data:`MARKER`; when the ``with``
    block finishes without an exception its content becomes ``target``.  A missing
    ``target`` is created by renaming the temporary directory, made next to it; an
    existing one — empty, or with ``force`` one hybridlog wrote (see
    :func:`check_dir_target`) — is kept and refreshed in place: the temporary directory is
    made inside it, and once it is complete the old entries are moved aside and the new
    ones in (:func:`_fill_dir`), so that the folder keeps its permissions, owner and
    set-group-ID bit and a mount point can be written.  On any exception (including one
    from a rename) the temporary directory is removed and ``target`` is left as it was.

    Parameters
    ----------
    target:
        The output directory to create or refresh.  Missing parents are created.
    force:
        Replace the content of a non-empty existing directory of hybridlog's.

    Yields
    ------
    pathlib.Path
        The temporary directory to write into.

    Raises
    ------
    OutputError
        As :func:`check_dir_target`, or when the folder cannot be created or filled.

    Examples
    --------
    >>> with atomic_output_dir("out") as tmp:  # doctest: +SKIP
    ...     (tmp / "report.json").write_text("{}")

    """
    path = check_dir_target(target, force=force)
    with staging_dir(path, inside=path.is_dir()) as tmp:
        yield tmp
        publish_dir(tmp, path, force=force)


def _fill_dir(staged: Path, target: Path, recognised_by: str) -> None:
    """Make the existing folder ``target`` hold ``staged``'s entries instead of its own.

    Renaming a finished folder over ``target`` replaced the user's folder (a private
    ``chmod 700`` one became ``755``, a group's lost its set-group-ID, a shell inside it was
    left in a deleted folder) and failed on a mount point (``Device or resource busy``: a
    container's ``-v $PWD/out:/out``).  So the folder stays, and its entries change, in an
    order that leaves a folder hybridlog recognises, and that the next run with ``--force``
    cleans up, whenever a ``kill -9`` strikes:

    1. the old entries but ``recognised_by`` (the file that makes the folder ours:
       :data:`MARKER`, a bag's ``metadata.yaml``) are moved into a temporary folder inside
       ``target`` that carries a marker (:func:`staging_dir`), and a hard link to the old
       ``recognised_by`` is kept there (:func:`_place`);
    2. the new ``recognised_by`` replaces the old in one rename (:func:`_place`), so the
       folder never lacks it, and it lists everything the folder holds (perhaps more: a
       listed file that is gone is no change, :func:`edited_files`);
    3. the new entries are moved in; the temporary folders, each still carrying its
       marker, are removed afterwards, or by the next run (:func:`remove_stale_temporaries`).

    An exception at any step (a failed rename, Ctrl-C, a signal raised as one) undoes the
    steps done, last first: the old entries are back and nothing else.  Both folders lie on
    ``target``'s file system (``staged`` inside ``target``, or beside it when ``target``
    appeared meanwhile), so every step is a rename.

    Raises
    ------
    OSError
        When a rename fails (its steps undone).
    """
    with staging_dir(target, inside=True, kind="old") as aside:
        kept = aside / target.name
        kept.mkdir()
        with contextlib.ExitStack() as undo:
            for name in _entries(target, but={recognised_by}):
                _move(target / name, kept / name, undo)
            old = target / recognised_by
            if _present(old):
                undo.callback(_quietly, _place, kept / recognised_by, old)
                _place(old, kept / recognised_by)
            else:
                undo.callback(_quietly, os.unlink, old)
            _place(staged / recognised_by, old)
            for name in _entries(staged, but={recognised_by}):
                _move(staged / name, target / name, undo)
            undo.pop_all()


def _entries(folder: Path, *, but: Collection[str] = ()) -> list[str]:
    """The names in ``folder`` but those of ``but`` and this process's temporaries, sorted."""
    return sorted(n for n in os.listdir(folder) if n not in but and not _own_temporary(n))


def _move(source: Path, target: Path, undo: contextlib.ExitStack) -> None:
    """Rename ``source`` to ``target``, the rename back pushed onto ``undo`` first.

    First, so that an exception (Ctrl-C) right after the rename cannot leave it out of the
    undoing; undone before it happened, the rename back finds nothing and does nothing.
    """
    undo.callback(_quietly, os.rename, target, source)
    os.rename(source, target)


def _quietly(step: Callable[..., object], *args: Path) -> None:
    """Undo a step as well as can be: a failure here must not hide the error undone."""
    with contextlib.suppress(OSError):
        step(*args)


def _place(source: Path, target: Path) -> None:
    """Put the file ``source`` at ``target`` in one rename, ``source`` kept.

    A hard link to it under a temporary name is renamed over ``target``: no moment without
    a ``target``, no byte written (it works on a full disk); a copy where the file system
    has no hard links (FAT, some network and FUSE file systems).  Nothing is done when
    ``target`` is ``source``'s file already (a rename onto a link of the same file would do
    nothing and leave the temporary name).
    """
    if _present(target) and os.path.samefile(source, target):
        return
    staged = temporary_name(target)
    try:
        try:
            os.link(source, staged)
        except OSError as err:
            if err.errno not in _NO_LINKS:
                raise
            shutil.copyfile(source, staged)
        os.replace(staged, target)
    except BaseException:
        with contextlib.suppress(OSError):
            staged.unlink()
        raise


_NO_LINKS = frozenset({errno.EPERM, errno.EOPNOTSUPP, errno.ENOTSUP, errno.EMLINK})
"""What ``link`` answers on a file system without hard links (or out of them)."""


@contextmanager
def staging_dir(target: PathLike, *, inside: bool = False, kind: str = "tmp") -> Iterator[Path]:
    """A temporary folder next to ``target`` (same filesystem), always removed afterwards.

    For writers that must create their output under its final name themselves (a ROS 2 bag
    names its storage file after its folder): write ``staging / target.name``, then
    :func:`publish_file` or :func:`publish_dir` it.  With ``inside``, the folder is made in
    ``target``, an existing folder, on its file system (a mount point's), for
    :func:`publish_dir` to fill it in place; ``kind`` as for :func:`temporary_name`.

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
        created = _prepare_parent(path)
        area = temporary_name(path, kind=kind)
    try:
        try:
            area.mkdir()
            write_marker(area)
        except OSError as err:
            raise OutputError(f"{_shown(target)}: cannot be written ({err.strerror})") from err
        yield area
    except BaseException as err:
        shutil.rmtree(area, ignore_errors=True)
        _remove_created(created)
        if (refused := _storage_error(target, err)) is not None:
            raise refused from err
        raise
    shutil.rmtree(area, ignore_errors=True)


@contextmanager
def atomic_files(
    targets: Sequence[PathLike],
    *,
    force: bool = False,
    ours: Callable[[Path], bool] | None = None,
    recorded: Callable[[Path], bool] | None = None,
) -> Iterator[list[Path]]:
    """Write several output files so that they appear only when all were written.

    Yields one temporary path per target (next to it, same suffix, not yet created); when the
    ``with`` block finishes without an exception each is moved onto its target.  On any
    exception the temporaries are removed and the targets are left as they were.

    Parameters
    ----------
    targets:
        Output files; existing ones are replaced only with ``force``.  Missing parent folders
        are created.
    force:
        Replace existing files that hybridlog wrote (:func:`wrote_file`); each file written
        is recorded beside it (:func:`record_file`).
    ours:
        Instead, how the command recognises its own files; they are then not recorded
        unless ``recorded`` says so.
    recorded:
        Which of the targets (absolute, as :func:`output_path` gives them) to record beside
        them (:func:`record_file`); default: all without ``ours``, none with it.

    Raises
    ------
    OutputError
        As :func:`check_file_target`, or when a file cannot be moved into place.
    """
    recognise = wrote_file if ours is None else ours
    if recorded is None:
        recorded = (lambda _: True) if ours is None else (lambda _: False)
    paths = [check_file_target(target, force=force, ours=recognise) for target in targets]
    created: list[Path] = []
    temporaries = [temporary_name(path, keep_suffix=True) for path in paths]
    try:
        for path in paths:
            created += _prepare_parent(path)
        yield temporaries
        for path in paths:  # all still writable before the first is replaced
            check_file_target(path, force=force, ours=recognise)
        for staged, path in zip(temporaries, paths, strict=True):
            publish_file(staged, path, force=force, ours=recognise, record=recorded(path))
    except BaseException as err:
        for staged in temporaries:
            with contextlib.suppress(FileNotFoundError):
                staged.unlink()
        _remove_created(created)
        named = [p for p, t in zip(paths, temporaries, strict=True) if _names(err, t)]
        if (refused := _storage_error(named[0] if named else paths[0], err)) is not None:
            raise refused from err
        raise
