"""Output paths that never cost the user a byte (SPEC §9).

Every command that writes goes through this package, in two steps:

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
   (:func:`~hybridlog.outputs.records._unchanged`).
2. **Then write atomically.**  :func:`atomic_output_dir` and :func:`atomic_files` write into
   temporary names next to the targets (``.<name>.hybridlog-tmp-<host>-<pid>-<hex>``) and
   rename them into place when all of them are complete; a folder that exists (empty, or
   ours with ``--force``) is filled in place instead, so that it stays the user's folder and
   a mount point can be written (:func:`publish_dir`,
   :func:`~hybridlog.outputs.publishing._fill_dir`); a failure removes them and leaves the
   targets as they were.  Temporaries of processes that died (``kill -9``) are removed by
   the next run writing to the same place (:func:`remove_stale_temporaries`).

The modules: :mod:`~hybridlog.outputs.paths` (:func:`output_path`, :data:`MARKER`),
:mod:`~hybridlog.outputs.overlaps` (outputs apart from inputs and from each other),
:mod:`~hybridlog.outputs.temporaries` (temporary names and their clean-up),
:mod:`~hybridlog.outputs.records` (what hybridlog wrote, and whether it changed since),
:mod:`~hybridlog.outputs.file_targets` and :mod:`~hybridlog.outputs.folder_targets` (the
checks of step 1), :mod:`~hybridlog.outputs.staging` (temporary folders, write errors) and
:mod:`~hybridlog.outputs.publishing` (step 2).  The names below are re-exported here.
"""

from __future__ import annotations

from hybridlog.outputs.file_targets import check_creatable, check_file_name, check_file_target
from hybridlog.outputs.folder_targets import check_dir_target
from hybridlog.outputs.overlaps import check_apart, check_distinct
from hybridlog.outputs.paths import MARKER, PathLike, output_path
from hybridlog.outputs.publishing import atomic_files, atomic_output_dir, publish_dir, publish_file
from hybridlog.outputs.records import (
    edited_files,
    is_ours,
    record_file,
    record_path,
    recorded_files,
    write_marker,
    wrote_file,
)
from hybridlog.outputs.staging import staging_dir
from hybridlog.outputs.temporaries import (
    is_temporary,
    remove_stale_temporaries,
    shown_output,
    temporary_name,
)

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
