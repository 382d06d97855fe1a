"""Checks of a target path before anything is written, and of an output file's target.

:func:`check_followable` and :func:`check_creatable` hold for files and folders alike;
:func:`check_file_name` and :func:`check_file_target` are a file's: replaced only with
``--force`` and only when hybridlog wrote it (:func:`~hybridlog.outputs.records.wrote_file`);
:func:`check_not_bookkeeping` refuses an output, file or folder, named as hybridlog's own
markers, records and temporaries are.
"""

from __future__ import annotations

import os
import stat
from collections.abc import Callable
from pathlib import Path

from hybridlog.errors import OutputError, excerpt
from hybridlog.outputs.paths import MARKER, PathLike, output_path, path_present, shown_path
from hybridlog.outputs.records import wrote_file
from hybridlog.outputs.temporaries import is_temporary, temporary_name

_TEMPORARY_OVERHEAD = len(".x.hybridlog-tmp-0000-4194304-00000000") - 1
"""How much longer than its target's name a temporary name can be (:func:`temporary_name`)."""

_ROOM_INSIDE = len("/.estimates.parquet") + _TEMPORARY_OVERHEAD
"""How much longer than an output folder's path the paths written in it can be: a report's
longest file name, as a temporary name (:func:`check_path_length` with ``folder``)."""


def check_followable(target: PathLike) -> None:
    """Refuse an output path, as given, that runs through a file: ``run.csv/../out``.

    :func:`~hybridlog.outputs.paths.output_path` resolves the folder part as
    :func:`os.path.realpath` does, which takes ``run.csv/..`` for ``run.csv``'s folder; the system
    refuses such a path (a file is no folder to go up from), so the outputs went to ``./out`` while
    the command printed ``run.csv/../out/report.md``, a path nobody could open; so through a missing
    folder (``missing/../out``).  A missing folder is no error otherwise (:func:`check_creatable`
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
                    f"{shown_path(target)}: cannot be created: {shown_path(step)} does not exist, "
                    f"so '{os.pardir}' after it leads nowhere"
                ) from None
            return
        except (OSError, ValueError):  # unusable: told later
            return
        if not stat.S_ISDIR(status.st_mode):
            raise OutputError(
                f"{shown_path(target)}: cannot be created: {shown_path(step)} is not a folder"
            )


def path_too_long(target: Path, *, folder: bool = False) -> str | None:
    """Why ``target`` (absolute) is a path the system would refuse as too long, or None.

    Its temporary name beside it, and for a ``folder`` the files written in it, must fit
    the file system's limit on a whole path (``PC_PATH_MAX``): a batch's report folder is
    its log's path below ``--out``, and a deep tree of logs under a long ``--out`` gave a
    path on which every ``exists()`` raised ``ENAMETOOLONG``, ending the whole batch as an
    unexpected ``OSError``.  No system call is made on ``target`` itself.
    """
    ancestor = target.parent
    while ancestor.parent != ancestor and not os.path.isdir(ancestor):
        ancestor = ancestor.parent
    try:
        limit = os.pathconf(ancestor, "PC_PATH_MAX") - 1  # the count holds the ending NUL
    except (OSError, ValueError):
        limit = 4095
    needed = len(os.fsencode(target)) + _TEMPORARY_OVERHEAD + (_ROOM_INSIDE if folder else 0)
    if needed <= limit:
        return None
    inside = " with its temporary name" + (" and the files written in it" if folder else "")
    return (
        f"{shown_path(target)}: the path is too long ({needed} bytes{inside}; at most {limit} here)"
    )


def check_path_length(target: Path, *, folder: bool = False) -> None:
    """Refuse a path the system would refuse as too long (:func:`path_too_long`).

    Raises
    ------
    OutputError
        Naming the path, its length and the limit.
    """
    if (why := path_too_long(target, folder=folder)) is not None:
        raise OutputError(why)


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
    check_path_length(target)
    ancestor = target.parent
    missing = [target.name]
    while ancestor.parent != ancestor and not path_present(ancestor):
        missing.append(ancestor.name)
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise OutputError(
            f"{shown_path(target)}: cannot be created: {shown_path(ancestor)} is not a folder"
        )
    try:
        limit = os.pathconf(ancestor, "PC_NAME_MAX")
    except (OSError, ValueError):
        limit = 255
    for name in missing:
        allowed = limit - _TEMPORARY_OVERHEAD if name == target.name else limit
        if len(os.fsencode(name)) > allowed:
            raise OutputError(
                f"{shown_path(target)}: the name {excerpt(name, 40)} is too long "
                f"(at most {allowed} bytes here)"
            )
    probe = temporary_name(ancestor / "probe")
    try:
        os.close(os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600))
        os.unlink(probe)
    except OSError as err:
        raise OutputError(
            f"{shown_path(target)}: cannot be created: no file can be made in "
            f"{shown_path(ancestor)} ({err.strerror})"
        ) from None


def check_file_name(target: PathLike, option: str = "") -> None:
    """Refuse a file to write whose name, as given, ends as a folder's: ``x.json/``, ``x/.``.

    ``open`` refuses such a name, but :class:`~pathlib.Path` drops the ``/`` (and a last
    ``.``), so ``cluster --out dir.json/``, where the user meant a folder, wrote a file
    ``dir.json``.  Called on the text given (a ``Path`` no longer has the ending), first by
    :func:`check_file_target`; ``option`` (``--out``) starts the message.  A name of
    hybridlog's own bookkeeping is refused too (:func:`check_not_bookkeeping`).

    Raises
    ------
    OutputError
        Naming the option and the path, and that a file is written there (or what
        hybridlog keeps under that name).
    """
    text = os.fspath(target)
    separators = os.sep + (os.altsep or "")
    last = os.path.basename(text)
    check_not_bookkeeping(target, option)
    if text.endswith(tuple(separators)):
        ending = text[len(text.rstrip(separators)) - len(text) :]
    elif last in (os.curdir, os.pardir):
        ending = text[-len(last) - 1 :] if len(text) > len(last) else last
    else:
        return
    prefix = f"{option} " if option else ""
    raise OutputError(
        f"{prefix}{shown_path(target)}: ends with {excerpt(ending, 20)}, which names a folder; "
        "name a file to write"
    )


def _bookkeeping_kind(name: str) -> str | None:
    """What of hybridlog's own bookkeeping a file or folder ``name`` is named as, if any.

    A folder's :data:`~hybridlog.outputs.paths.MARKER`, the record ``.<name>.hybridlog``
    beside a file hybridlog wrote (:func:`~hybridlog.outputs.records.record_path`), or a
    temporary (:func:`~hybridlog.outputs.temporaries.temporary_name`).
    """
    if name == MARKER:
        return f"marker (the {MARKER} file of a folder it wrote)"
    if name.startswith(".") and name.endswith(MARKER) and len(name) > len(MARKER) + 1:
        return f"record of a file it wrote ({excerpt(name[1 : -len(MARKER)])})"
    if is_temporary(name):
        return "temporary file"
    return None


def check_not_bookkeeping(target: PathLike, option: str = "") -> None:
    """Refuse an output named as hybridlog names its own bookkeeping (:func:`_bookkeeping_kind`).

    Written there, an output replaced what makes a folder hybridlog's, or what tells a file
    hybridlog wrote from one a user edited, once the same run wrote them (``batch --out o
    --junit o/.hybridlog`` wrote its JUnit XML over the batch folder's marker, and ``--junit
    o/.summary.md.hybridlog`` over summary.md's record, after which every run into ``o`` was
    refused: summary.md read as edited by hand); and a temporary's name is removed as a dead
    run's leftover.

    Raises
    ------
    OutputError
        Naming the option and the path, and what the name is hybridlog's for.
    """
    text = os.fspath(target)
    kind = _bookkeeping_kind(os.path.basename(text.rstrip(os.sep + (os.altsep or ""))))
    if kind is not None:
        prefix = f"{option} " if option else ""
        raise OutputError(
            f"{prefix}{shown_path(target)}: named as hybridlog's own {kind}; choose another name"
        )


def check_file_target(
    target: PathLike, *, force: bool, ours: Callable[[Path], bool] = wrote_file
) -> Path:
    """Check that an output file may be created, or replaced with ``force``.

    ``force`` replaces only a file hybridlog wrote (SPEC §9): by default one with a record beside it
    (:func:`~hybridlog.outputs.records.wrote_file`); ``ours`` recognises the files of a command that
    knows its own otherwise (a batch's summaries inside its folder, a JUnit file by its content).

    Raises
    ------
    OutputError
        When the target is a folder or another file that is not a regular one (a device, a
        pipe), is named as a folder (:func:`check_file_name`), exists and is not ``ours``
        (said so, with or without ``force``) or ``force`` is false, or cannot be created
        (:func:`check_creatable`).
    """
    check_file_name(target)
    check_followable(target)
    path = output_path(target)
    check_creatable(path)
    if path.is_dir():
        raise OutputError(f"{shown_path(target)}: is a directory; name a file to write")
    if path.exists() and not path.is_file():
        raise OutputError(
            f"{shown_path(target)}: exists and is not a regular file (a device, pipe or socket); "
            "hybridlog never replaces one"
        )
    # a file --force would not replace is said so first: "use --force to replace it" was
    # advised for a user's own file, which --force then refused
    if path_present(path) and not ours(path):
        raise OutputError(
            f"{shown_path(target)}: exists and hybridlog did not write it (or it changed since), "
            "so --force does not replace it; move it away or name another file"
        )
    if path_present(path) and not force:
        raise OutputError(f"{shown_path(target)}: already exists (use --force to replace it)")
    return path
