"""Which logs ``hybridlog batch LOGS...`` names, in which order: folders of logs searched.

Kept apart from :mod:`hybridlog.jobs.batch` so that the command line can count the logs (for
its progress bar and to start the workers' forkserver) before it imports the batch job, which
imports polars and numpy; this module uses the standard library and the table of log formats
only.
"""

from __future__ import annotations

import contextlib
import os
import re
import unicodedata
from collections import Counter
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import NamedTuple

from hybridlog.errors import LogError, OptionError, as_name, excerpt, first_few, names_apart
from hybridlog.io.formats import LogFormat, format_list, indexed_log, log_format, logs_in
from hybridlog.outputs import MARKER, PathLike

__all__ = [
    "FoundLogs",
    "batch_logs",
    "header_time_applies",
    "header_time_note",
    "missing_pattern_hint",
    "natural_key",
    "recover_applies",
    "recover_note",
]

GLOB_CHARACTERS = frozenset("*?[")
"""What a shell expands in a word it is given unquoted."""


def natural_key(text: str) -> tuple[tuple[tuple[int, int | str], ...], str]:
    """Sort key that orders digit runs by value: ``s1, s2, s10`` rather than ``s1, s10, s2``.

    Names of equal value (``r1``, ``r01``, ``r001``) are ordered by their text: they kept
    the order they were given in, so the summaries' rows hung on the order of the arguments.
    A digit run is what the pattern matches, decimal digits (``isdecimal``): ``isdigit`` also
    took a superscript ``²`` for one, which ``int`` refuses (``run1²2.csv`` ended the batch).
    """
    parts = re.split(r"(\d+)", text)
    return (
        tuple((0, int(part)) if part.isdecimal() else (1, part) for part in parts if part),
        text,
    )


def missing_pattern_hint(log: PathLike) -> str:
    """A hint for a log that does not exist and whose name holds ``*``, ``?`` or ``[``; or ``""``.

    ``hybridlog batch 'logs/*.csv'`` (quoted, or a pattern that matched nothing in a shell
    that then passes it on) names one log called ``*.csv``: it fails as that log, and this
    says why.  hybridlog does not expand patterns itself (``run[1].csv`` is a file's name).
    """
    name = os.fsdecode(log)
    if GLOB_CHARACTERS.isdisjoint(name) or os.path.lexists(log):
        return ""
    return (
        "; a pattern the shell did not expand (quoted, or it matched nothing)? "
        "give it unquoted, or give the folder of logs"
    )


class FoundLogs(NamedTuple):
    """What :func:`batch_logs` found (:func:`~hybridlog.jobs.batch.run_batch` takes it as is)."""

    paths: list[str]
    """The logs, in natural order."""
    searched: list[str]
    """The folders of logs searched for them (kept apart from the outputs)."""
    notes: tuple[str, ...] = ()
    """What the search left out and why (a log found again under a second name)."""


def batch_logs(logs: Sequence[PathLike]) -> FoundLogs:
    """The logs ``hybridlog batch LOGS...`` names, in natural order, and the folders searched.

    A log file or a ROS 2 bag (a folder with ``metadata.yaml``) is itself; any other folder
    is a folder of logs, replaced by the logs in it and its subfolders
    (:func:`hybridlog.io.formats.logs_in`).  Anything else (a missing path, a file of no
    known format) stays, to fail as that log.  One file under two names (a symbolic or hard
    link) is one log (:func:`_one_name_each`).

    Raises
    ------
    OptionError
        For a folder that holds no log, and for a log given that is another log of the
        batch under a second name.
    LogError
        For a folder that cannot be listed.
    """
    found: list[str] = []
    given: list[str] = []
    folders: list[str] = []
    links: list[Path] = []
    hidden: list[Path] = []
    written: list[str] = []
    for log in logs:
        if os.path.isdir(log) and (Path(log) / MARKER).exists():
            written.append(os.fspath(log))  # ``logs/*`` once ``--out logs/out`` was written
        elif os.path.isdir(log) and not indexed_log(log):
            skipped = len(hidden)
            inside = logs_in(log, links, hidden)
            if not inside:
                raise OptionError(
                    f"LOGS: folder {excerpt(os.fspath(log))} holds no log "
                    f"({format_list()}; names starting with '.' and hybridlog's output "
                    f"folders are skipped{_hidden_in_empty(hidden[skipped:])})"
                )
            _check_new_folder(os.fspath(log), folders)
            folders.append(os.fspath(log))
            found += map(str, inside)
        else:
            given.append(os.fspath(log))
    if written and not (found or given):
        raise OptionError(
            f"LOGS: {excerpt(written[0])} is a folder hybridlog wrote (a report or a batch), "
            "which holds no log"
        )
    paths, notes = _one_name_each(found, given)
    notes += _written_note(written)
    notes += _links_note(links, [*folders, *given])
    notes += _hidden_note(hidden, paths)
    notes += _alike_note(paths)
    return FoundLogs(sorted(paths, key=natural_key), folders, tuple(notes))


def _written_note(written: Sequence[str]) -> list[str]:
    """The folders hybridlog wrote that LOGS named, left out: the batch's own ``--out`` too.

    ``batch logs/* --out logs/out`` ran once, then was refused ("folder 'logs/out' holds no
    log"): the shell's ``logs/*`` names the batch folder the first run wrote.
    """
    if not written:
        return []
    names = first_few(written, _HIDDEN_SHOWN, excerpt)
    what = "a folder" if len(written) == 1 else "folders"
    return [f"LOGS: left out {names}: {what} hybridlog wrote (reports or a batch), not logs"]


_HIDDEN_SHOWN = 3
"""How many logs of hidden names the note names; the others are counted."""


def _hidden_in_empty(hidden: Sequence[Path]) -> str:
    """The logs of hidden names a folder of logs held, for the error saying it holds none.

    Not a broken link (Emacs's lock ``.#run.csv`` of a file being edited): no log to give.
    """
    hidden = [path for path in hidden if os.path.exists(path)]
    if not hidden:
        return ""
    shown = first_few(hidden, _HIDDEN_SHOWN, lambda p: excerpt(os.fspath(p), 60))
    return f": it holds {shown}; give {'it' if len(hidden) == 1 else 'them'} as LOGS"


def _hidden_note(hidden: Sequence[Path], paths: Sequence[str]) -> list[str]:
    """The note (none, or one line) on logs of hidden names a folder of logs held.

    Names starting with ``.`` are not searched (:func:`hybridlog.io.formats.logs_in`), so a
    log so named (a recorder's ``.run.mcap`` it never renamed, a file hidden by mistake)
    was left out without a word: 499 of 500 logs analysed, the summaries and gates passing
    without the last.  One that is a log of the batch under another name (a hidden link to
    it, a log's link to it, or given as LOGS) is not named.  The logs' files are taken (a
    stat each) only when a hidden log is met.
    """
    if not hidden:
        return []
    given = {
        os.path.abspath(log) for log in paths if os.path.basename(log.rstrip(os.sep))[:1] == "."
    }
    analysed: set[tuple[int, int]] | None = None  # the logs' files, taken when needed
    left: list[str] = []
    for name in hidden:
        try:
            state = os.stat(name)
        except OSError:  # a broken link: no log
            continue
        if os.path.abspath(name) in given:
            continue
        # perhaps a log's other name: a hidden link to one, the file a log links to
        # (latest.mcap -> .current.mcap), another name of its file
        if analysed is None:
            analysed = set()
            for log in paths:
                with contextlib.suppress(OSError):
                    found = os.stat(log)
                    analysed.add((found.st_dev, found.st_ino))
        if (state.st_dev, state.st_ino) in analysed and state.st_ino != 0:
            continue
        left.append(os.fspath(name))
    if not left:
        return []
    shown = first_few(sorted(left, key=natural_key), _HIDDEN_SHOWN, lambda p: excerpt(p, 60))
    count = f"{len(left)} logs whose names start" if len(left) > 1 else "a log whose name starts"
    return [
        f"{count} with '.' {'were' if len(left) > 1 else 'was'} skipped ({shown}; hidden "
        "names are not searched for logs, nor folders starting with '.'): rename "
        f"{'them' if len(left) > 1 else 'it'}, or give {'them' if len(left) > 1 else 'it'} "
        "as LOGS, to analyse "
        f"{'them' if len(left) > 1 else 'it'}"
    ]


_LINKS_SHOWN = 3
"""How many links to folders not searched the note names; the others are counted."""


def _links_note(links: Sequence[Path], searched: Sequence[str]) -> list[str]:
    """The note (none, or one line) on links to folders that a folder of logs held.

    They are not searched (:func:`hybridlog.io.formats.logs_in`), so the logs only they
    lead to were left out of the batch without a word, its summaries and gates passing
    without them.  A link into a folder searched anyway (or to a log given), whose logs the
    batch has under their own names, is not named.
    """
    reached = [os.path.realpath(path) for path in searched]
    left: list[str] = []
    for link in links:
        target = os.path.realpath(link)
        if not any(target == r or target.startswith(r.rstrip(os.sep) + os.sep) for r in reached):
            left.append(os.fspath(link))
    if not left:
        return []
    shown = first_few(sorted(left, key=natural_key), _LINKS_SHOWN, lambda p: excerpt(p, 60))
    count = f"{len(left)} links to folders were" if len(left) > 1 else "a link to a folder was"
    return [
        f"{count} not searched for logs ({shown}; links to folders are not followed): "
        "give the folder it leads to as LOGS to analyse its logs"
    ]


_ALIKE_SHOWN = 2
"""How many groups of logs whose names read alike the note names; the others are counted."""


def _alike_note(paths: Sequence[str]) -> list[str]:
    """The note (none, or one line) on logs whose names differ only in their Unicode form.

    ``café.csv`` with ``é`` one character (NFC) and with ``e`` and a combining accent (NFD,
    as macOS writes names) are two files on most file systems, two logs of the batch, whose
    names read alike: the summaries write them apart
    (:func:`~hybridlog.errors.names_apart`), but their report folders are one folder where
    the file system takes both names for one (macOS), and a reader takes them for one log.
    """
    # a name that is ASCII is its own NFC form: only one beyond ASCII can read as another
    # (even as an ASCII one: KELVIN SIGN is K in NFC)
    beyond = [path for path in paths if not path.isascii()]
    if not beyond:
        return []
    groups: dict[str, list[str]] = {}
    for path in beyond:
        groups.setdefault(unicodedata.normalize("NFC", as_name(path)), []).append(path)
    for path in paths:
        if path.isascii() and (name := as_name(path)) in groups:
            groups[name].append(path)
    alike = [
        sorted(group, key=natural_key)
        for group in groups.values()
        if len({as_name(p) for p in group}) > 1
    ]
    if not alike:
        return []
    shown = first_few(
        alike,
        _ALIKE_SHOWN,
        lambda group: " and ".join(
            excerpt(name, 60) for name in names_apart([as_name(p) for p in group])
        ),
        separator="; ",
        before_more="; and ",
    )
    return [
        f"{sum(map(len, alike))} logs have names that read alike, differing only in how their "
        f"letters are encoded (Unicode NFC and NFD: {shown}): the summaries write them "
        "with \\u escapes, and their report folders would be one where the file system takes "
        f"both names for one (macOS); rename one{' of each' if len(alike) > 1 else ''}"
    ]


def _check_new_folder(folder: str, folders: Sequence[str]) -> None:
    """Refuse a folder of logs that is one given before under another name (a link to it).

    Every log in it would be found twice; the same name given twice is refused with the
    logs' folders (:func:`hybridlog.jobs.batch_names.folder_names`).
    """
    for earlier in folders:
        if os.path.abspath(earlier) != os.path.abspath(folder) and os.path.samefile(
            earlier, folder
        ):
            raise OptionError(
                f"LOGS: the folder of logs {excerpt(folder)} is the folder of logs "
                f"{excerpt(earlier)} (through a symbolic link); give it once"
            )


_SHOWN_TWICE = 3
"""How many logs found under a second name the note names; the others are counted."""


def _one_name_each(found: Sequence[str], given: Sequence[str]) -> tuple[list[str], list[str]]:
    """The logs ``found`` in folders and ``given`` as themselves, each file under one name.

    A file reached by two paths that differ as text (a link to a log beside it, a hard
    link, a folder of logs and a link to it given both) was analysed twice, counted twice in
    the summaries and gated twice.  Of names found in folders, where the user cannot leave
    one out, the log keeps one (not a symbolic link, then the first in natural order) and a
    note names the others; a name given as itself is refused, as a path given twice is
    (:func:`hybridlog.jobs.batch_names.folder_names`, which also refuses paths equal as text).

    Returns
    -------
    The logs, and the note (none, or one line) on the names left out.

    Raises
    ------
    OptionError
        Naming a log given that is another log of the batch under another name.
    """
    entries = [(path, False) for path in found] + [(path, True) for path in given]
    by_file: dict[tuple[int, int], list[tuple[str, bool]]] = {}
    for path, is_given in entries:
        try:
            state = os.stat(path)
        except OSError:  # fails as that log, with the reason
            continue
        if state.st_ino == 0:  # a file system without file numbers tells no file apart
            continue
        by_file.setdefault((state.st_dev, state.st_ino), []).append((path, is_given))
    left_out: dict[str, str] = {}
    for names in by_file.values():
        if len({os.path.abspath(path) for path, _ in names}) < 2:
            continue
        for path, is_given in names:
            other = next((o for o, _ in names if os.path.abspath(o) != os.path.abspath(path)), path)
            if is_given:
                raise OptionError(
                    f"log {excerpt(path)} is the same file as the log {excerpt(other)} "
                    f"({_link_kind(path, other)}); give it once"
                )
        kept = min(
            (path for path, _ in names),
            key=lambda path: (os.path.islink(path), natural_key(path)),
        )
        left_out.update((path, kept) for path, _ in names if path != kept)
    if not left_out:
        return [*found, *given], []
    shown = sorted(left_out, key=natural_key)
    pairs = first_few(
        shown, _SHOWN_TWICE, lambda p: f"{excerpt(p, 60)} as {excerpt(left_out[p], 60)}"
    )
    count = f"{len(shown)} logs were" if len(shown) > 1 else "a log was"
    note = (
        f"{count} found again under another name (a symbolic or hard link to a log of the "
        f"batch) and analysed once, as that log: {pairs}"
    )
    return [p for p in [*found, *given] if p not in left_out], [note]


def _link_kind(path: str, other: str) -> str:
    """How two names of one file are related, for an error."""
    if os.path.realpath(path) == os.path.realpath(other):
        return "through a symbolic link"
    return "a hard link to it"


def recover_applies(log: PathLike) -> bool:
    """Whether ``--recover`` reads ``log``: a bare MCAP file (``LogFormat.recovers``).

    A log whose format cannot be told counts as one it applies to: it fails as that log
    when it is opened, with the reason.
    """
    try:
        return log_format(log).recovers
    except LogError:
        return True


def header_time_applies(log: PathLike) -> bool:
    """Whether ``--time header`` reads ``log``: a bag or an MCAP file (``LogFormat.stamped``).

    A log whose format cannot be told counts as one it applies to, as for
    :func:`recover_applies`.
    """
    try:
        return log_format(log).stamped
    except LogError:
        return True


def _others(logs: Sequence[str], applies: Callable[[LogFormat], bool]) -> Counter[str]:
    """How many of ``logs`` are of each format an option does not apply to."""
    others: Counter[str] = Counter()
    for log in logs:
        try:
            found = log_format(log)
        except LogError:  # fails as that log, with the reason
            continue
        if not applies(found):
            others[found.name] += 1
    return others


def _counted_apart(
    logs: Sequence[str],
    applies: Callable[[LogFormat], bool],
    flag: str,
    kind: str,
    why: str,
) -> tuple[int, int, str] | None:
    """How many of ``logs`` an option ``flag`` applies to, how many not, and their formats.

    ``(read, rest, kinds)``: ``kinds`` the formats of the ``rest`` as ``2 csv, 1 parquet``.
    None: it applies to every log (or none can be told).

    Raises
    ------
    OptionError
        When it applies to no log: ``<flag>: no log of the batch is <kind> (<kinds>);
        <why>: leave it out``.
    """
    others = _others(logs, applies)
    if not others:
        return None
    kinds = ", ".join(f"{count} {name}" for name, count in sorted(others.items()))
    rest = sum(others.values())
    read = len(logs) - rest
    if read == 0:
        raise OptionError(f"{flag}: no log of the batch is {kind} ({kinds}); {why}: leave it out")
    return read, rest, kinds


def recover_note(logs: Sequence[str]) -> str | None:
    """What ``--recover`` does over a batch's ``logs``, some of which may not be MCAP files.

    ``analyze`` refuses ``--recover`` for a log of another format, which never reads it
    (``--recover: log.csv is a CSV file; ...``); over a folder of logs of mixed formats
    it means "recover the MCAP files that need it", so the other logs are read as they are
    and this note says how many they are, of which formats.  None: every log is an MCAP
    file (or none can be told).

    Raises
    ------
    OptionError
        When no log of the batch is an MCAP file: the option applies to none of them.
    """
    counted = _counted_apart(
        logs,
        lambda found: found.recovers,
        "--recover",
        "an MCAP file",
        "--recover reads only an unfinished or damaged MCAP file (sequentially, up to its "
        "first bad record)",
    )
    if counted is None:
        return None
    read, rest, kinds = counted
    return (
        f"--recover: applied to the {f'{read} MCAP files' if read > 1 else 'MCAP file'} of the "
        "batch; "
        + (
            f"the other {rest} logs ({kinds}) are not MCAP files and are read as they are"
            if rest > 1
            else f"the other log ({kinds}) is not an MCAP file and is read as it is"
        )
    )


def header_time_note(logs: Sequence[str]) -> str | None:
    """What ``--time header`` does over a batch's ``logs``, some of which may be tables.

    ``analyze`` refuses ``--time header`` for a CSV or Parquet file, whose time column is
    the only time it has; over a folder of logs of mixed formats it means "the bags' and
    MCAP files' header stamps", so the tables are read by their time column (each of them
    failed, telling to use ``--time log``, which the bags of the batch could not be given)
    and this note says how many they are.  None: every log is a bag or an MCAP file.

    Raises
    ------
    OptionError
        When every log of the batch is a table: the option applies to none of them (each
        log failed, and the reports of an earlier run were removed with it).
    """
    counted = _counted_apart(
        logs,
        lambda found: found.stamped,
        "--time header",
        "a bag or an MCAP file",
        "a table's time column is the only time it has",
    )
    if counted is None:
        return None
    read, rest, kinds = counted
    stamped = f"{read} bags and MCAP files" if read > 1 else "bag or MCAP file"
    return f"--time header: applied to the {stamped} of the batch; " + (
        f"the other {rest} logs ({kinds}) are tables, read by their time column"
        if rest > 1
        else f"the other log ({kinds}) is a table, read by its time column"
    )
