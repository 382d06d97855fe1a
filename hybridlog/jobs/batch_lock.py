"""One batch at a time in a batch folder: an advisory lock on the folder while a batch runs.

Two batches run into one ``--out`` at once (two CI jobs, a cron run overlapping the last)
each redid the logs the other had just written, when their options differed, and each wrote
summaries from its own outcomes: the last to finish left a summary.csv whose numbers were
not those of the report.json files it links to.  The batch process holds an exclusive
:func:`fcntl.flock` on the batch folder from when it is prepared until its summaries are
written; a second batch is refused then, before it writes anything.  The kernel releases the
lock when the process ends however it ends (``kill -9``), so a crashed batch never blocks
the run that resumes it.  A file system that cannot lock (some network file systems) runs
the batch unlocked, as before.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import os
from collections.abc import Iterator
from pathlib import Path

from hybridlog.errors import OutputError, excerpt

__all__ = ["batch_folder_lock"]


@contextlib.contextmanager
def batch_folder_lock(root: Path) -> Iterator[None]:
    """Hold the batch folder ``root`` (which exists) for this batch while the block runs.

    Raises
    ------
    OutputError
        When another batch holds it, naming the folder.
    """
    try:
        fd = os.open(root, os.O_RDONLY | os.O_DIRECTORY)
    except OSError:  # cannot be opened to lock: its writes fail later, with their reason
        yield
        return
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as err:
            if err.errno not in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                yield  # no locks on this file system
                return
            raise OutputError(
                f"--out {excerpt(str(root), 240)[1:-1]}: another hybridlog batch is running "
                "into this folder; wait for it to end (the next run resumes from it), or "
                "choose another --out"
            ) from None
        yield
    finally:
        os.close(fd)
