"""A ROS 2 bag whose metadata.yaml lists one storage file twice in relative_file_paths.

rosbags opens the file once per listing and yields each message twice: the bag was refused
as "40 message(s) have the same log time as the one before ... --sort keeps the last of
each", a remedy for a fault of the metadata, and with ``--sort`` read every message twice
over.  It is refused naming metadata.yaml and the file.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, inspect_log, load_signals
from hybridlog.io.rosbag_reader import _listed_files, unlisted_storage_files
from tests.support.logfiles import write_uy_bag

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1", "2"), dt=0.1)
MAPS = ("u=/u.data", "y=/y.data")


def _relist(folder: Path, names: list[str]) -> None:
    meta = folder / "metadata.yaml"
    text = meta.read_text()
    listing = "relative_file_paths:\n  - bag.db3\n"
    assert listing in text
    listed = "".join(f"  - {n}\n" for n in names) if names else ""
    written = "relative_file_paths:" + ("\n" + listed if names else " []\n")
    meta.write_text(text.replace(listing, written))


@pytest.mark.parametrize("sort", [False, True])
def test_a_storage_file_listed_twice_is_refused_naming_it(sort: bool, tmp_path: Path) -> None:
    folder = write_uy_bag(tmp_path / "bag")
    load_signals(folder, SPEC, ReadOptions(maps=MAPS, sort=sort))  # read once: good
    _relist(folder, ["bag.db3", "bag.db3"])
    expected = (
        "metadata.yaml lists the storage file 'bag.db3' 2 times in relative_file_paths, "
        "which would read its messages as often: list it once"
    )
    with pytest.raises(LogError) as error:
        load_signals(folder, SPEC, ReadOptions(maps=MAPS, sort=sort))
    assert str(error.value).endswith(expected) and "\n" not in str(error.value)
    with pytest.raises(LogError, match="2 times in relative_file_paths"):
        inspect_log(folder)


def test_an_empty_listing_still_names_the_files_it_leaves_out(tmp_path: Path) -> None:
    folder = write_uy_bag(tmp_path / "bag")
    _relist(folder, [])
    assert unlisted_storage_files(folder, _listed_files(folder)) == ["bag.db3"]


def test_a_bag_reads_its_listing_once(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """metadata.yaml was parsed twice per bag, by rosbags and again by hybridlog for its
    listing (ruamel's pure-Python parser: some 10 ms of a small bag's 25); the listing is
    the storage files rosbags opened."""
    from ruamel.yaml import YAML

    folder = write_uy_bag(tmp_path / "bag")
    calls = []
    load = YAML.load
    monkeypatch.setattr(YAML, "load", lambda self, text: calls.append(1) or load(self, text))
    signals = load_signals(folder, SPEC, ReadOptions(maps=MAPS))
    assert len(signals.time) == 20 and calls == [1]


def test_a_bag_compressed_per_file_lists_its_file(tmp_path: Path) -> None:
    """rosbags unpacks such a bag's files into a folder of its own: the listing is read from
    metadata.yaml then, not from the names of the files rosbags opened (bag.db3, which
    would call the bag's own bag.db3.zstd unlisted)."""
    folder = write_uy_bag(tmp_path / "bag", per_file=True)
    assert [p.name for p in folder.glob("*.zstd")] == ["bag.db3.zstd"]
    notes: dict[str, object] = {}
    signals = load_signals(folder, SPEC, ReadOptions(maps=MAPS), notes=notes)
    assert len(signals.time) == 20 and "unlisted_files" not in notes
