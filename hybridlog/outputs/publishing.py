"""Atomic publishing: finished temporaries moved onto their targets, or nothing changed.

:func:`atomic_output_dir` and :func:`atomic_files` write into temporary names and move them
into place once all are complete (:func:`publish_dir`, :func:`publish_file`); an existing
folder is filled in place (:func:`_fill_dir`), every step undone on an exception.
"""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
from collections.abc import Callable, Collection, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

from hybridlog.errors import OutputError
from hybridlog.outputs.file_targets import check_file_target
from hybridlog.outputs.folder_targets import check_dir_target
from hybridlog.outputs.paths import MARKER, PathLike, path_present, shown_path
from hybridlog.outputs.records import (
    file_identity,
    record_file,
    record_folder_files,
    recorded_files,
    wrote_file,
)
from hybridlog.outputs.staging import prepare_parent, remove_created, staging_dir, storage_error
from hybridlog.outputs.temporaries import folder_entries, temporary_name


def _names(err: BaseException, path: Path) -> bool:
    """Whether ``err`` is an ``OSError`` about ``path``."""
    return isinstance(err, OSError) and err.filename is not None and Path(err.filename) == path


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

    Never clobbers ``target`` unless ``force`` and ``ours`` (see
    :func:`~hybridlog.outputs.file_targets.check_file_target`).

    Raises
    ------
    OutputError
        When ``target`` appeared meanwhile (without ``force``), is a folder or someone
        else's, or the move fails.
    """
    check_file_target(target, force=force, ours=ours)
    written = file_identity(staged)
    try:
        _move_file(staged, target, force=force)
    except OSError as err:
        raise OutputError(f"{shown_path(target)}: cannot be written ({err.strerror})") from err
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
        raise OutputError(
            f"{shown_path(target)}: already exists (use --force to replace it)"
        ) from None
    except OSError:
        if target.exists():
            raise OutputError(
                f"{shown_path(target)}: already exists (use --force to replace it)"
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

    The files of ``staged`` are recorded in its :data:`~hybridlog.outputs.paths.MARKER`
    (:func:`~hybridlog.outputs.records.recorded_files`), so that a later run replaces the folder
    only while it holds nothing else.  A missing ``target`` is ``staged`` renamed; an existing one
    (empty, or one of ours with ``force``) keeps its identity and gets ``staged``'s entries
    (:func:`_fill_dir`), ``recognised_by`` being the file that makes a folder ours
    (:data:`~hybridlog.outputs.paths.MARKER`; a ROS 2 bag's ``metadata.yaml``).

    Raises
    ------
    OutputError
        As :func:`~hybridlog.outputs.folder_targets.check_dir_target` with ``ours`` (checked again:
        the target may have appeared or changed meanwhile), or when a rename fails.
    """
    check_dir_target(target, force=force, ours=ours, written=written)
    record_folder_files(staged)
    try:
        if not path_present(target):
            os.rename(staged, target)
            return
        _fill_dir(staged, target, recognised_by)
    except OSError as err:
        raise OutputError(f"cannot move outputs into {shown_path(target)}: {err.strerror}") from err


@contextmanager
def atomic_output_dir(target: PathLike, *, force: bool = False) -> Iterator[Path]:
    """Write an output directory atomically, marked as hybridlog's.

    Yields a fresh temporary directory that already holds :data:`~hybridlog.outputs.paths.MARKER`;
    when the ``with`` block finishes without an exception its content becomes ``target``.  A missing
    ``target`` is created by renaming the temporary directory, made next to it; an existing one —
    empty, or with ``force`` one hybridlog wrote (see
    :func:`~hybridlog.outputs.folder_targets.check_dir_target`) — is kept and refreshed in place:
    the temporary directory is made inside it, and once it is complete the old entries are moved
    aside and the new ones in (:func:`_fill_dir`), so that the folder keeps its permissions, owner
    and set-group-ID bit and a mount point can be written.  On any exception (including one from a
    rename) the temporary directory is removed and ``target`` is left as it was.

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
        As :func:`~hybridlog.outputs.folder_targets.check_dir_target`, or when the folder cannot be
        created or filled.

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
       :data:`~hybridlog.outputs.paths.MARKER`, a bag's ``metadata.yaml``) are moved into a
       temporary folder inside ``target`` that carries a marker
       (:func:`~hybridlog.outputs.staging.staging_dir`), and a hard link to the old
       ``recognised_by`` is kept there (:func:`_place`);
    2. the new ``recognised_by`` replaces the old in one rename (:func:`_place`), so the
       folder never lacks it, and it lists everything the folder holds (perhaps more: a
       listed file that is gone is no change, :func:`~hybridlog.outputs.records.edited_files`);
    3. the new entries are moved in; the temporary folders, each still carrying its marker, are
       removed afterwards, or by the next run
       (:func:`~hybridlog.outputs.temporaries.remove_stale_temporaries`).

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
            for name in folder_entries(target, but={recognised_by}):
                _move(target / name, kept / name, undo)
            old = target / recognised_by
            if path_present(old):
                undo.callback(_quietly, _place, kept / recognised_by, old)
                _place(old, kept / recognised_by)
            else:
                undo.callback(_quietly, os.unlink, old)
            _place(staged / recognised_by, old)
            for name in folder_entries(staged, but={recognised_by}):
                _move(staged / name, target / name, undo)
            undo.pop_all()


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
    if path_present(target) and os.path.samefile(source, target):
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
        Replace existing files that hybridlog wrote (:func:`~hybridlog.outputs.records.wrote_file`);
        each file written is recorded beside it (:func:`~hybridlog.outputs.records.record_file`).
    ours:
        Instead, how the command recognises its own files; they are then not recorded
        unless ``recorded`` says so.
    recorded:
        Which of the targets (absolute, as :func:`~hybridlog.outputs.paths.output_path` gives them)
        to record beside them (:func:`~hybridlog.outputs.records.record_file`); default: all without
        ``ours``, none with it.

    Raises
    ------
    OutputError
        As :func:`~hybridlog.outputs.file_targets.check_file_target`, or when a file cannot be moved
        into place.
    """
    recognise = wrote_file if ours is None else ours
    if recorded is None:
        recorded = (lambda _: True) if ours is None else (lambda _: False)
    paths = [check_file_target(target, force=force, ours=recognise) for target in targets]
    created: list[Path] = []
    temporaries = [temporary_name(path, keep_suffix=True) for path in paths]
    try:
        for path in paths:
            created += prepare_parent(path)
        yield temporaries
        for path in paths:  # all still writable before the first is replaced
            check_file_target(path, force=force, ours=recognise)
        for staged, path in zip(temporaries, paths, strict=True):
            publish_file(staged, path, force=force, ours=recognise, record=recorded(path))
    except BaseException as err:
        for staged in temporaries:
            with contextlib.suppress(FileNotFoundError):
                staged.unlink()
        remove_created(created)
        named = [p for p, t in zip(paths, temporaries, strict=True) if _names(err, t)]
        if (refused := storage_error(named[0] if named else paths[0], err)) is not None:
            raise refused from err
        raise
