"""Reading and writing ``centers.json`` (the format: :mod:`hybridlog.cluster.centers_file`).

``hybridlog cluster`` writes the file; ``analyze``/``compare``/``batch`` read it for the
``chiu`` and ``kmeans`` estimators' ``centers=FILE`` option and pass the parsed
:class:`~hybridlog.cluster.centers_file.CentersFile` to the estimator, which reads no file.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from hybridlog.cluster.centers_file import CentersFile, centers_json, parse_centers
from hybridlog.errors import ModelError, OptionError, OutputError
from hybridlog.model.toml_text import decode_model_file
from hybridlog.outputs import atomic_files

__all__ = ["read_centers", "write_centers"]


def read_centers(path: str | os.PathLike[str]) -> CentersFile:
    """Read and validate a ``centers.json``.

    Raises
    ------
    OptionError
        When the file is missing, unreadable, not JSON, of another format, or a needed key
        is wrong; the message names the file and the key.
    """
    source = Path(path)
    if source.exists() and not source.is_file():  # a pipe would block, /dev/zero never end
        raise OptionError(f"{source}: not a regular file (a folder, pipe or device)")
    try:
        data = source.read_bytes()
    except FileNotFoundError as err:
        raise OptionError(f"{source}: no such centers file") from err
    except OSError as err:
        raise OptionError(f"{source}: cannot be read ({err.strerror or err})") from err
    try:  # as a model file's: the line of the first byte that is not UTF-8, or UTF-16 named
        text = decode_model_file(data)
    except ModelError as err:  # read "cannot read: 'utf-8' codec can't decode byte 0xff in
        raise OptionError(f"{source}: {err}") from None  # position 0: invalid start byte"
    return parse_centers(text, str(source))


def write_centers(path: str | os.PathLike[str], content: Mapping[str, Any], *, force: bool) -> Path:
    """Write ``content`` (with ``format`` and ``version`` added) as JSON, atomically.

    Raises
    ------
    OutputError
        When ``path`` exists and ``force`` is false, or it cannot be written.
    """
    text = centers_json(content)
    with atomic_files([path], force=force) as (temporary,):
        try:
            temporary.write_text(text, encoding="utf-8")
        except OSError as err:
            raise OutputError(f"{path}: cannot write: {err.strerror}") from err
    return Path(path)
