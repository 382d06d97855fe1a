"""Checks of an output folder's target: :func:`check_dir_target`, :func:`check_outside_batch`.

A non-empty folder is replaced only with ``--force``, only when hybridlog wrote it, only
while it holds nothing but the unchanged files its marker lists, and never when it is part
of another output (a comparison's report, a report a batch's summaries name).
"""

from __future__ import annotations

import csv
import os
from collections.abc import Callable, Collection, Iterator, Sequence
from pathlib import Path

from hybridlog.errors import OutputError, as_name, excerpt, first_few
from hybridlog.outputs.file_targets import (
    check_creatable,
    check_followable,
    check_not_bookkeeping,
    check_path_length,
)
from hybridlog.outputs.paths import MARKER, PathLike, output_path, path_present, shown_path
from hybridlog.outputs.records import edited_files, is_ours, record_path, recorded_files
from hybridlog.outputs.temporaries import folder_entries, own_temporary, remove_stale_temporaries


def check_dir_target(
    target: PathLike,
    *,
    force: bool,
    ours: Callable[[Path], bool] | None = None,
    written: Callable[[Path], Collection[str] | None] = recorded_files,
    replacing: bool = True,
) -> Path:
    """Check that an output folder may be created or replaced; return its absolute path.

    A missing folder must be creatable (:func:`~hybridlog.outputs.file_targets.check_creatable`); an
    empty one is fine (the temporaries dead runs left in it removed,
    :func:`~hybridlog.outputs.temporaries.remove_stale_temporaries`).  A non-empty one is replaced
    only with ``force`` and only when hybridlog wrote it
    (:func:`~hybridlog.outputs.records.is_ours`, or the test ``ours`` of a writer whose folders
    record it another way), and, when it is about to be replaced (``replacing``), only if it holds
    nothing but what hybridlog wrote there (``written``: the files a folder's
    :data:`~hybridlog.outputs.paths.MARKER` lists,
    :func:`~hybridlog.outputs.records.recorded_files`) and none of those changed since (a user's
    notes appended to report.md): a user's own folder, or a note a user put into a report folder, is
    never wiped.  A folder that is part of another output (a comparison's report) is refused,
    present or not (:func:`_check_not_part`).  Without ``force`` the same checks run first, so that
    "use --force" is advised only for a folder it would replace.

    Raises
    ------
    OutputError
        When the target exists and is not a folder (or is a symbolic link), is not empty
        (without ``force``), holds files hybridlog did not write, or is part of another
        output hybridlog wrote.
    """
    check_followable(target)
    check_not_bookkeeping(target)
    path = output_path(target)
    if path.parent == path:
        raise OutputError(f"output directory {shown_path(target)} cannot be replaced")
    check_path_length(path, folder=True)  # first: no system call takes a longer path
    check_creatable(path)
    _check_not_part(path)
    if not path_present(path):
        return path
    if path.is_symlink():  # renamed over, or filled through: neither is the folder named
        pointed = os.readlink(path)
        where = "a folder" if path.is_dir() else "nothing" if not path.exists() else "a file"
        raise OutputError(
            f"output path {shown_path(path)} is a symbolic link (to {excerpt(pointed)}, {where}), "
            "which hybridlog does not write through; name the folder itself or another path"
        )
    if not path.is_dir():
        raise OutputError(f"output path {shown_path(path)} exists and is not a directory")
    remove_stale_temporaries(path)  # of a run killed while it filled the folder (_fill_dir)
    try:
        entries = folder_entries(path)  # this run's staging inside it is not content
    except OSError as err:
        raise OutputError(f"output directory {shown_path(path)}: {err.strerror}") from err
    if not entries:
        return path
    # Checked with or without ``force``: "use --force" is advised only where it would work.
    if not (is_ours(path) or (ours is not None and ours(path))):
        raise OutputError(
            f"output directory {shown_path(path)} is not empty: it holds files hybridlog did not "
            f"write ({_some(entries)}; no {MARKER} file), so --force will not delete it; choose "
            "another output directory or remove this one yourself"
        )
    if replacing:
        _check_only_ours(path, written(path))
        if edited := edited_files(path):
            raise OutputError(
                f"output directory {shown_path(path)} holds files changed since hybridlog wrote "
                f"them ({_some(edited)}), which replacing it would lose; move them out, or "
                "choose another output directory"
            )
    if not force:
        raise OutputError(
            f"output directory {shown_path(path)} is not empty; use --force to replace it"
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

    ``analyze --out cmp/imm --force`` replaced a comparison's report with a run of other settings
    (``compare --out cmp/imm`` with a comparison), and ``cmp``'s comparison.md then gave numbers,
    and links, that no report of it held: a folder the :data:`~hybridlog.outputs.paths.MARKER` of a
    folder above lists files in (:func:`~hybridlog.outputs.records.recorded_files`; a batch folder
    lists none, and a batch replaces its logs' reports itself) is written only with the folder it is
    part of, also when it was removed.
    """
    whole = _enclosing_output(path)
    if whole is not None:
        raise OutputError(
            f"output directory {shown_path(path)} is part of {shown_path(whole)}, which hybridlog "
            "wrote (its tables name what it holds), so it is not written on its own; "
            "write the whole folder again, or choose another output directory"
        )


def check_outside_batch(target: PathLike) -> None:
    """Refuse to replace an ``analyze`` or ``compare`` folder inside a batch folder.

    A batch folder's summaries (summary.md/.csv/.png, the JUnit file) give each log's numbers and
    name its report folder; ``analyze --out nightly/run.csv --force`` replaced that report with one
    of other settings (another log, other options), so the summaries gave numbers no report held,
    and :func:`_check_not_part`, which keeps a comparison's reports so, does not see a batch folder
    (its marker lists no files).  A batch folder is the nearest folder above with hybridlog's
    :data:`~hybridlog.outputs.paths.MARKER`, listing no files, beside a summary.csv hybridlog
    recorded (:func:`~hybridlog.outputs.records.record_file`); a folder there is refused when it is,
    or holds, a report folder summary.csv names (its ``folder`` column; all of them where it cannot
    be read).  Another replaces nothing the summaries name (the next batch lists it among the
    folders it did not write), so ``analyze`` in a working folder that is also a batch's output
    writes its own folder, and writes it again with ``--force``.

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
                f"output directory {shown_path(target)} is inside the batch folder "
                f"{shown_path(parent)}, whose summaries name its reports; run the batch again, "
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
            f"output directory {shown_path(path)} does not list what hybridlog wrote there (a "
            f"batch folder, one of an older version, or an edited {MARKER}), so --force "
            "will not replace it; remove it yourself or choose another output directory"
        )
    expected = {*written, MARKER}
    folders_expected = {p.as_posix() for f in expected for p in Path(f).parents} - {"."}
    foreign: list[str] = []
    nested: list[str] = []  # outputs of other runs written inside it since
    for folder, folders, files in os.walk(path):
        if folder == os.fspath(path):  # this run's staging inside it (publish_dir)
            folders[:] = [name for name in folders if not own_temporary(name)]
            files = [name for name in files if not own_temporary(name)]
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
            f"output directory {shown_path(path)} holds another output of hybridlog's, written "
            f"into it since ({_some(nested)}), which replacing it would delete; move it out, "
            "or choose another output directory"
        )
    if foreign:
        raise OutputError(
            f"output directory {shown_path(path)} holds files hybridlog did not write "
            f"({_some(foreign)}), which replacing it would delete; move them out, or choose "
            "another output directory"
        )


def _some(names: Sequence[str]) -> str:
    """``'a', 'b', 'c' and 2 more``: the first three of ``names``, quoted, and how many else."""
    return first_few(names, 3, lambda name: excerpt(name, 60))
