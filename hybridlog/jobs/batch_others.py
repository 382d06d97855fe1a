"""What a batch folder holds besides this run's reports: found, told apart by kind, named.

A batch does not remove a report folder of no log of its run (a run over part of the logs
would lose the others'), but its report.md read as this run's to whoever opened the batch
folder or its CI artifact; the summaries and a note name them (:func:`other_folders`).
They are not all of one kind, and "renamed, moved or left out since an earlier run" fitted
only the first:

- ``log``: a batch's report (report.json's ``batch`` key) of a log not in this run;
- ``analyze``: a report ``hybridlog analyze`` wrote into a folder of the batch folder
  (:func:`~hybridlog.outputs.folder_targets.check_outside_batch` allows a new one), no
  ``batch`` key;
- ``compare``: a comparison ``hybridlog compare`` wrote there, named once (its folder with
  comparison.md/.csv), not as one report per estimator;
- ``batch``: another batch's folder (a marker listing no files) inside this one, named
  once: its own summaries name its reports, which are no report of this batch's (neither
  listed as logs left out, nor taken for reports of another estimator that refuse the run,
  :func:`hybridlog.jobs.batch_plan._check_same_run_kind`).
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import NamedTuple

from hybridlog.errors import excerpt, first_few
from hybridlog.jobs.batch_logs import natural_key
from hybridlog.outputs import MARKER, recorded_files

__all__ = ["OtherFolder", "folder_kind_text", "other_folders", "others_note", "report_folders"]

PROVENANCE_KEY = "batch"
"""Report key under which a batch records what the report was made from."""

COMPARISON_FILES = frozenset({"comparison.md", "comparison.csv"})
"""What ``hybridlog compare`` writes beside its reports, one folder per estimator."""


class OtherFolder(NamedTuple):
    """A folder below the batch folder of no log of this run."""

    name: str
    """Relative to the batch folder, ``/``-separated."""
    kind: str
    """``log``, ``analyze``, ``compare`` or ``batch`` (the module's docstring)."""


def report_folders(root: Path) -> Iterator[Path]:
    """Every output folder below ``root``, in walk order: reports, comparisons, batch folders.

    A report folder is a folder with hybridlog's marker and a report.json; a comparison
    (marker and comparison.md/.csv) and another batch's folder (a marker listing no files)
    are yielded once, what they hold not searched: their reports are theirs.  Hidden names
    (temporaries) and links are not searched.
    """
    for parent, subfolders, files in os.walk(root):
        here = Path(parent)
        if here != root and MARKER in files:
            if "report.json" in files or not COMPARISON_FILES.isdisjoint(files):
                yield here
                subfolders.clear()  # a report's own folders (plots) hold no report
                continue
            if recorded_files(here) is None:  # another batch's folder
                yield here
                subfolders.clear()
                continue
        subfolders[:] = [name for name in subfolders if not name.startswith(".")]


def _kind(folder: Path) -> str:
    """What ``folder`` (one :func:`report_folders` yields) is: ``OtherFolder.kind``."""
    if (folder / "report.json").is_file():
        try:
            with (folder / "report.json").open(encoding="utf-8") as handle:
                data = json.load(handle)
        except (OSError, ValueError):
            data = None
        # an unreadable one is taken as a batch's, as before: a log's left out
        if isinstance(data, dict) and PROVENANCE_KEY not in data:
            return "analyze"
        return "log"
    names: set[str] = set()
    if folder.is_dir():
        with os.scandir(folder) as entries:
            names = {entry.name for entry in entries}
    return "compare" if not COMPARISON_FILES.isdisjoint(names) else "batch"


_KIND_TEXTS = {
    "log": "the report an earlier run wrote for another log (since renamed or moved, or left out)",
    "analyze": "a report hybridlog analyze wrote there",
    "compare": "a comparison hybridlog compare wrote there",
    "batch": "another batch's folder",
}
"""What one folder of each kind is, in an error that names it."""


def folder_kind_text(folder: Path) -> str:
    """What ``folder`` (a report, a comparison or a batch folder) is, for an error naming it.

    A log's report folder that would lie inside or hold another output folder was said to
    be in "the report an earlier run wrote for another log" whatever that folder was: a
    comparison ``compare --out`` wrote into the batch folder, too.  One estimator's report
    of a comparison (``<out>/cmp/imm``) is named as such, with its comparison, not as a
    report ``analyze`` wrote.
    """
    kind = _kind(folder)
    if (
        kind == "analyze"
        and _kind(folder.parent) == "compare"
        and (folder.parent / MARKER).is_file()
    ):
        # an estimator's report of a comparison (<out>/cmp/imm) read as analyze's
        return (
            "one estimator's report of a comparison hybridlog compare wrote there "
            f"({excerpt(str(folder.parent))})"
        )
    return _KIND_TEXTS[kind]


def other_folders(root: Path, folders: Sequence[Path]) -> list[OtherFolder]:
    """The output folders below ``root`` of no log of this batch, by kind, in natural order.

    ``folders``: this run's logs' report folders.
    """
    ours = {os.path.abspath(folder) for folder in folders}
    found = [
        OtherFolder(here.relative_to(root).as_posix(), _kind(here))
        for here in report_folders(root)
        if os.path.abspath(here) not in ours
    ]
    return sorted(found, key=lambda other: natural_key(other.name))


_SHOWN = 3
"""How many folders of each kind the note names; the others are counted."""

_NOTE_KINDS = (
    (
        "log",
        "a report folder of logs not in this batch",
        "{} report folders of logs not in this batch",
        "renamed, moved or left out since an earlier run",
    ),
    (
        "analyze",
        "a report hybridlog analyze wrote into it",
        "{} reports hybridlog analyze wrote into it",
        "",
    ),
    (
        "compare",
        "a comparison hybridlog compare wrote into it",
        "{} comparisons hybridlog compare wrote into it",
        "",
    ),
    (
        "batch",
        "another batch's folder",
        "{} other batches' folders",
        "a batch's own summaries name its reports",
    ),
)
"""Each kind, what the note calls one and several of it, and why they are there."""


def others_note(others: Sequence[OtherFolder]) -> str:
    """The note on the folders of no log of this batch (:func:`other_folders`), by kind."""
    parts = []
    for kind, one, several, why in _NOTE_KINDS:
        names = [other.name for other in others if other.kind == kind]
        if not names:
            continue
        shown = first_few(names, _SHOWN, lambda name: excerpt(name, 60))
        count = several.format(len(names)) if len(names) > 1 else one
        parts.append(f"{count} ({shown}{'; ' + why if why else ''})")
    listed = ", ".join(parts[:-1]) + (" and " if len(parts) > 1 else "") + parts[-1]
    return f"--out holds {listed}: kept, and not in its summaries"
