"""A batch folder the disk cannot take leaves nothing behind (SPEC §9: no partially
written output)."""

from __future__ import annotations

import errno
from pathlib import Path

import pytest

from hybridlog.errors import OutputError
from hybridlog.io.writers import write_table
from hybridlog.jobs import batch_folders
from hybridlog.jobs.batch import run_batch
from hybridlog.outputs import MARKER
from tests.support.logfiles import tank_run


def test_a_batch_folder_whose_marker_the_disk_cannot_take_is_removed(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """On a full disk the batch made its folder, then writing its marker failed: the folder
    stayed behind, holding an empty ``.hybridlog``, after the error said it could not be
    created."""
    log = write_table(tmp_path / "logs" / "a.csv", tank_run().columns)

    def full_disk(folder: Path) -> None:
        (folder / MARKER).touch()  # created, then nothing fits in it
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(batch_folders, "write_marker", full_disk)
    out = tmp_path / "runs" / "nightly"
    with pytest.raises(OutputError, match=rf"^cannot create output directory {out}: No space"):
        run_batch([log], "three_tank_hstf", out_dir=out)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["logs"]
