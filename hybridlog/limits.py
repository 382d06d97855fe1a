"""The process's limits: a ``ulimit`` an operating-system error came from, and its umask.

``ulimit -n 16`` left ``batch --jobs 2`` failing with "unexpected OSError in workers.py:409:
[Errno 24] Too many open files (a bug, ...)": a limit the caller set, not a bug.  The
command's one line now names the limit, its value and what to do (:func:`limit_reached`).
"""

from __future__ import annotations

import errno
import resource
import traceback
from dataclasses import dataclass
from pathlib import Path

__all__ = ["Limit", "limit_reached", "owner_masked", "remedy", "umask"]

_STARTERS = frozenset({"popen_fork.py", "forkserver.py", "subprocess.py", "threading.py"})
"""The standard library's modules where a process or thread is started."""


@dataclass(frozen=True)
class Limit:
    """What ran out, for the command's one line, and what the user can do about it."""

    what: str
    detail: str
    advice: str


def _soft(which: int) -> str:
    """The soft limit ``which`` as ``ulimit`` shows it (``unlimited`` or a number)."""
    soft, _ = resource.getrlimit(which)
    return "unlimited" if soft == resource.RLIM_INFINITY else str(soft)


def _starting(err: OSError) -> bool:
    """Whether ``err`` was raised where a process or thread is started."""
    frames = traceback.extract_tb(err.__traceback__)
    return any(Path(frame.filename).name in _STARTERS for frame in frames)


def limit_reached(err: OSError) -> Limit | None:
    """The limit ``err`` reports reached, or ``None`` for any other error.

    ``EMFILE``: this process's open files (``ulimit -n``); ``ENFILE``: the system's;
    ``EAGAIN`` raised where a process or thread is started (``fork`` in :mod:`multiprocessing`
    or :mod:`subprocess`): the user's processes (``ulimit -u``).  Python raises every
    ``EAGAIN`` as a :class:`BlockingIOError`, a non-blocking read's too: only the place tells
    them apart.  ``EFBIG`` under a file size limit (``ulimit -f``; without one it is the file
    system's own largest file): a write past it.
    """
    if err.errno == errno.EFBIG and (size := _soft(resource.RLIMIT_FSIZE)) != "unlimited":
        # bash's ulimit -f counts blocks of 1,024 bytes; a limit of 1,000 (prlimit, setrlimit)
        # read "ulimit -f 0", which allows no write at all
        blocks = int(size) // 1024
        shown = (
            f": ulimit -f {blocks}"
            if int(size) % 1024 == 0
            else " (not a whole number of ulimit -f's blocks of 1,024 bytes)"
        )
        return Limit(
            "a file reached the size limit",
            f"this process may write files of {int(size):,} bytes at most{shown}",
            "raise the limit (ulimit -f unlimited)",
        )
    if err.errno == errno.EMFILE:
        files = _soft(resource.RLIMIT_NOFILE)
        return Limit(
            "too many open files",
            f"this process may have {files} open: ulimit -n {files}",
            "raise the limit (ulimit -n 1024) or run fewer --jobs",
        )
    if err.errno == errno.ENFILE:
        return Limit(
            "too many open files",
            "the system's table of open files is full",
            "close other programs' files or raise fs.file-max",
        )
    if err.errno == errno.EAGAIN and _starting(err):
        processes = _soft(resource.RLIMIT_NPROC)
        return Limit(
            "no process or thread could be started",
            f"the user's processes are at their limit: ulimit -u {processes}",
            "raise the limit (ulimit -u), end other processes of this user, or run fewer --jobs",
        )
    return None


def remedy(err: OSError, otherwise: str) -> str:
    """What to do about ``err``: the limit it met and how to raise it, else ``otherwise``.

    Where a folder could not be written (the caches: "set HYBRIDLOG_CACHE_DIR to a writable
    folder"), which no other folder mends when the limit was met.
    """
    limit = limit_reached(err)
    return otherwise if limit is None else f"{limit.detail}; {limit.advice}"


def umask() -> int | None:
    """The process's umask, read from ``/proc/self/status`` (``None`` where it does not say).

    Not :func:`os.umask`, which sets it to read it: another thread (polars', the plots')
    creating a file in between would get the stand-in.
    """
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    return None


def owner_masked() -> str | None:
    """Why the process's umask makes its outputs unusable, or ``None`` when it does not.

    A umask masking any of the owner's own bits (``umask 777``, a user's, not root's, who is
    not held by them): ``analyze`` failed on its own temporary folder and left it behind
    (``.tank_report.hybridlog-tmp-...``, mode 000, which nothing could list to remove),
    ``batch --jobs 2`` printed a traceback of multiprocessing's clean-up of its own temporary
    folder after its one line, and ``cluster`` wrote files of mode 000.
    """
    mask = umask()
    if mask is None or not mask & 0o700:
        return None
    return (
        f"umask {mask:04o} takes its owner's own permissions from every file and folder "
        "written (they could not be read back); set a umask such as 022 or 077"
    )
