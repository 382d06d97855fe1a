"""The table of log formats: every row read from a file other tools wrote, the suffix rules.

``open_log``, ``sniff``, the suffix cross-check, the lists of formats in errors and help and
``inspect`` all read :data:`~hybridlog.io.formats.FORMATS`; these tests hold every row to
a real file, so a row without a reader that works (or a reader outside the table) fails here.
"""

from __future__ import annotations

import json
import shutil
from collections import Counter
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import polars as pl
import pytest
from click.testing import CliRunner
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin
from rosbags.rosbag2 import Writer as Rosbag2Writer
from rosbags.typesys import Stores, get_typestore

from hybridlog.cli import cli
from hybridlog.errors import LogError, OptionError
from hybridlog.io import (
    FORMATS,
    LogSource,
    SignalSpec,
    format_inspection,
    formats,
    inspect_log,
    load_signals,
    open_log,
)
from hybridlog.io.formats import LogFormat, format_list, log_format, sniff
from hybridlog.io.message_topics import Topic
from hybridlog.io.messages import MessageSource
from hybridlog.io.options import ReadOptions
from hybridlog.model.loader import load_model
from tests.support.logfiles import (
    Channel,
    float64_cdr,
    scene,
    tank_run,
    write_mcap,
    write_mcap_cdr,
    write_ros1_bag,
    write_ros2_bag,
)
from tests.support.paths import SAMPLE_LOGS

SAMPLE = SAMPLE_LOGS


def _table(folder: Path, suffix: str) -> Path:
    columns = tank_run().columns
    frame = pl.DataFrame({name: columns[name] for name in ("t", "u", "y1", "y2", "y3")})
    path = folder / f"run{suffix}"
    if suffix == ".csv":
        frame.write_csv(path)
    else:
        frame.write_parquet(path)
    return path


def _db3(folder: Path) -> Path:
    return write_ros2_bag(folder / "bag", scene(tank_run()), "sqlite3") / "bag.db3"


# One writer of another tool (polars, mcap, rosbags) per row of the table, plus MCAP files
# for both of the MCAP row's readers; the keys before ":" must cover every row.
WRITERS: dict[str, Callable[[Path], Path]] = {
    "csv": lambda d: _table(d, ".csv"),
    "parquet": lambda d: _table(d, ".parquet"),
    "mcap": lambda d: write_mcap_cdr(d / "run.mcap", scene(tank_run())),
    "mcap:ros2": lambda d: write_ros2_bag(d / "bag", scene(tank_run()), "mcap") / "bag.mcap",
    "ros1-bag": lambda d: write_ros1_bag(d / "run.bag", scene(tank_run())),
    "ros2-db3": _db3,
    "ros2-bag": lambda d: write_ros2_bag(d / "bag", scene(tank_run()), "sqlite3"),
}
PROTOCOL = {"info", "fields", "explain_missing", "field_key", "read", "describe"}


def test_every_row_has_a_file_here() -> None:
    assert {key.split(":")[0] for key in WRITERS} == {f.name for f in FORMATS}


def test_the_table_is_consistent() -> None:
    names = [f.name for f in FORMATS]
    assert len(set(names)) == len(names)
    magics = [f.magic for f in FORMATS if f.magic]
    for magic in magics:  # no magic may start another, or the first row would shadow it
        assert [m for m in magics if m.startswith(magic)] == [magic]
    files = [suffix for f in FORMATS if not f.directory for suffix in f.suffixes]
    assert len(set(files)) == len(files)
    assert all(suffix.startswith(".") and suffix == suffix.lower() for suffix in files)
    assert all(f.index_file for f in FORMATS if f.directory)
    assert all(not f.misnamed or f.magic for f in FORMATS)  # misnamed is about content


def test_the_protocol_is_small() -> None:
    # What mapping, alignment and inspect need; helpers belong to the readers' base classes.
    assert {name for name in vars(LogSource) if not name.startswith("_")} == PROTOCOL


@pytest.mark.parametrize("key", list(WRITERS))
def test_each_row_reads_a_file_written_by_another_tool(key: str, tmp_path: Path) -> None:
    name = key.split(":")[0]
    log = WRITERS[key](tmp_path)
    row = log_format(log)
    assert row.name == name
    if not row.directory:
        assert sniff(log) is (row if row.magic else None)
    with open_log(log) as source:
        assert all(callable(getattr(source, member)) for member in PROTOCOL - {"info"})
        info = source.info
        assert info.path == str(log)
        assert info.format.split(" ")[0] == name
        # a log of messages names message paths, a table its columns (a new row is either)
        assert info.message_paths is isinstance(source, MessageSource)
        assert info.field_word == ("field" if info.message_paths else "column")
        field = "/pump/cmd.data" if info.message_paths else "u"
        assert field in source.fields()
        assert source.explain_missing(field, True) is None
        reading = source.read([field])
        assert reading.numeric[field].values.size == (19 if info.message_paths else 91)
        assert source.describe()["format"] == info.format
    assert inspect_log(log)["format"] == info.format
    # inspect prints the description: a reader's describe() without the keys of its family
    # (a table's path, rows, columns ...) passed here and failed `hybridlog inspect` itself
    assert format_inspection(inspect_log(log)).startswith(f"{log} ({info.format}")


def test_a_suffix_in_capitals_is_read_or_refused_by_its_case(tmp_path: Path) -> None:
    """rosbags reads a bare file by its suffix, in its case; hybridlog takes any case.

    ``simulate --out run.MCAP`` wrote a log that reading refused as rosbags' "Unrecognized
    storage format '.MCAP'"; it is read by the mcap library as an MCAP file of another name.
    A ``.DB3`` file, which only rosbags reads, is refused saying what to rename.
    """
    mcap = shutil.copy(SAMPLE / "three_tank_hstf.mcap", tmp_path / "run.MCAP")
    lower = shutil.copy(SAMPLE / "three_tank_hstf.mcap", tmp_path / "run.mcap")
    spec = SignalSpec(inputs=("u",), outputs=("y1",), states=(), mode_ids=("1", "2", "3"), dt=1)
    read = load_signals(mcap, spec, ReadOptions(maps=("u=/u.data", "y1=/y1.data")))
    again = load_signals(lower, spec, ReadOptions(maps=("u=/u.data", "y1=/y1.data")))
    np.testing.assert_array_equal(read.outputs, again.outputs)
    db3 = shutil.copy(_db3(tmp_path), tmp_path / "run.DB3")
    with pytest.raises(
        LogError, match=r"run\.DB3: a ROS 2 sqlite3 bag file must end in \.db3, in "
    ):
        open_log(db3)


def test_suffix_cross_check(tmp_path: Path) -> None:
    bag = shutil.copy(SAMPLE / "three_tank_hstf.bag", tmp_path / "bag.csv")
    with pytest.raises(LogError) as error:
        open_log(bag)
    assert str(error.value) == f"{bag}: is a ROS 1 bag; rename it to end in .bag to read it"
    db3 = shutil.copy(_db3(tmp_path), tmp_path / "run.bag")
    with pytest.raises(LogError) as error:
        open_log(db3)
    assert str(error.value) == f"{db3}: is an SQLite database; a ROS 2 bag file must end in .db3"
    text = tmp_path / "text.parquet"
    text.write_text("t,y\n0,1\n")
    with pytest.raises(LogError) as error:
        open_log(text)
    assert str(error.value) == f"{text}: not a Parquet file (wrong magic bytes)"
    other = tmp_path / "log.txt"
    other.write_text("t,y\n0,1\n")
    with pytest.raises(LogError) as error:
        open_log(other)
    assert str(error.value) == (
        f"{other}: unsupported log format (suffix '.txt'); supported: {format_list()}"
    )


@pytest.mark.parametrize(
    "storage", [StoragePlugin.SQLITE3, StoragePlugin.MCAP], ids=["sqlite3", "mcap"]
)
def test_a_file_of_a_ros2_bag_read_only_through_its_folder_names_the_folder(
    storage: StoragePlugin, tmp_path: Path
) -> None:
    # Its metadata.yaml, or its storage compressed per file (rosbags' and ros2 bag record's
    # --compression-mode file), was only an 'unsupported log format'.
    store = get_typestore(Stores.ROS2_HUMBLE)
    folder = tmp_path / "bag"
    writer = Rosbag2Writer(folder, version=9, storage_plugin=storage)
    writer.set_compression(CompressionMode.FILE, CompressionFormat.ZSTD)
    with writer:
        connection = writer.add_connection("/y", "std_msgs/msg/Float64", typestore=store)
        for k in range(5):
            message = store.types["std_msgs/msg/Float64"](data=float(k))
            writer.write(connection, k, store.serialize_cdr(message, "std_msgs/msg/Float64"))
    (compressed,) = folder.glob("*.zstd")
    for part in (folder / "metadata.yaml", compressed):
        with pytest.raises(LogError) as error:
            open_log(part)
        assert str(error.value).endswith(
            f"and ROS 2 bag directories; it is part of the ROS 2 bag {str(folder)!r}: give "
            "that folder as the log"
        )
    assert inspect_log(folder)["messages"] == 5


def test_parquet_content_is_read_whatever_its_name(tmp_path: Path) -> None:
    # Like MCAP: the content decides where the reader does not need the suffix.
    spec = SignalSpec.of(load_model("three_tank_hstf"))
    renamed = shutil.copy(SAMPLE / "three_tank_hstf.parquet", tmp_path / "exported.csv")
    read = load_signals(renamed, spec)
    expected = load_signals(SAMPLE / "three_tank_hstf.parquet", spec)
    np.testing.assert_array_equal(read.outputs, expected.outputs)
    np.testing.assert_array_equal(read.time, expected.time)
    np.testing.assert_array_equal(read.truth_modes, expected.truth_modes)


def test_format_lists_in_errors_and_help_come_from_the_table() -> None:
    # every file row's suffixes in the table's order, then the directories: the list today is
    # ".csv, .parquet, .mcap, .bag, .db3 and ROS 2 bag directories" (a new row joins it)
    suffixes = [s for f in FORMATS if not f.directory for s in f.suffixes]
    folders = [f.title for f in FORMATS if f.directory]
    assert format_list() == f"{', '.join(suffixes)} and {', '.join(folders)}"
    assert {".csv", ".parquet", ".mcap", ".bag", ".db3"} <= set(suffixes)
    listed = format_list(titles=True)
    assert all(f.title in listed for f in FORMATS)
    result = CliRunner().invoke(cli, ["inspect", "--help"], terminal_width=400)
    assert result.exit_code == 0
    assert listed in " ".join(result.output.split())


def test_inspect_counts_agree_with_their_nouns(tmp_path: Path) -> None:
    one_row = tmp_path / "one.csv"
    one_row.write_text("t,y\n0,1\n")
    assert format_inspection(inspect_log(one_row)).splitlines()[0] == f"{one_row} (csv, 1 row)"
    gap = tmp_path / "gap.csv"
    gap.write_text("t,y\n0,1\n1,1\n2,1\n5,1\n")
    text = format_inspection(inspect_log(gap))
    assert f"{gap} (csv, 4 rows)" in text
    assert "time gaps: 1 step longer than 1.5 x the median step" in text
    single = write_mcap(tmp_path / "one.mcap", [Channel("/y")], [(0, 0, float64_cdr(1.0))])
    first = format_inspection(inspect_log(single)).splitlines()[0]
    assert first == f"{single} (mcap, profile 'ros2', 1 message, 1 topic)"
    two = write_mcap(
        tmp_path / "two.mcap",
        [Channel("/y"), Channel("/u")],
        [(0, 0, float64_cdr(1.0)), (1, 0, float64_cdr(2.0))],
    )
    assert "2 messages, 2 topics)" in format_inspection(inspect_log(two)).splitlines()[0]


# ------------------------------------------------------------------ the recipe, followed


class JsonLinesSource(MessageSource):
    """A log of JSON lines ``{"topic", "log_ns", "message"}``: a new format as the recipe in
    docs/architecture.md says, one reader class (this) and one table row (below)."""

    def __init__(self, path: Path, options: ReadOptions, log_format: LogFormat) -> None:
        super().__init__(path, options, log_format.name)
        self._lines = [json.loads(line) for line in path.read_text().splitlines() if line]
        for name, count in Counter(line["topic"] for line in self._lines).items():
            self._topics[name] = Topic(name, "", "json", count, decode=json.loads)

    def _iter_raw(self, topics: set[str]) -> Iterator[tuple[str, int, bytes]]:
        for line in self._lines:
            if line["topic"] in topics:
                yield line["topic"], line["log_ns"], json.dumps(line["message"]).encode()

    def close(self) -> None:
        self._lines = []


JSON_LINES = LogFormat(
    "jsonl", "a JSON lines log", "JSON lines", (".jsonl",), f"{__name__}:JsonLinesSource"
)


def test_a_format_is_one_reader_class_and_one_row(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(formats, "FORMATS", (JSON_LINES, *FORMATS))
    run = tank_run()
    topics = {"u": "/u", "y1": "/y1", "y2": "/y2", "y3": "/y3", "mode": "/truth/mode"}
    topics.update({x: f"/truth/{x}" for x in ("x1", "x2", "x3")})
    lines = [
        {"topic": topic, "log_ns": int(t), "message": {"data": run.columns[column][k]}}
        for k, t in enumerate(run.time_ns)
        for column, topic in topics.items()
    ]
    log = tmp_path / "run.jsonl"
    log.write_text("".join(json.dumps(line, default=float) + "\n" for line in lines))
    spec = SignalSpec.of(run.model)
    read = load_signals(log, spec)
    expected = load_signals(_table(tmp_path, ".parquet"), spec)
    np.testing.assert_array_equal(read.time, expected.time)
    np.testing.assert_array_equal(read.inputs, expected.inputs)
    np.testing.assert_array_equal(read.outputs, expected.outputs)
    assert inspect_log(log)["messages"] == len(lines)
    assert format_inspection(inspect_log(log)).startswith(f"{log} (jsonl, ")
    assert "JSON lines (.jsonl)" in format_list(titles=True)


def test_time_header_is_refused_by_the_table_for_a_format_without_stamps(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # --recover was refused from the table (LogFormat.recovers), but --time header was left to
    # each reader: a new row's reader that did not refuse it read its own times without a word
    monkeypatch.setattr(formats, "FORMATS", (JSON_LINES, *FORMATS))
    log = tmp_path / "run.jsonl"
    log.write_text(json.dumps({"topic": "/u", "log_ns": 0, "message": {"data": 1.0}}) + "\n")
    with pytest.raises(OptionError) as refused:
        open_log(log, ReadOptions(time="header"))
    assert str(refused.value) == (
        f"--time header: {log} is a JSON lines log; its time column is the only time it has "
        "(use --time log)"
    )
    for row in FORMATS:  # the rows of today: bags and MCAP files read stamps, tables do not
        assert row.stamped is (row.name not in ("csv", "parquet")), row.name
