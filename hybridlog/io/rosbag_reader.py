"""ROS 1 and ROS 2 bags through rosbags' bag readers.

Reads ROS 1 ``.bag`` files (``rosbags.rosbag1``), ROS 2 bag directories (``metadata.yaml``
with sqlite3 or MCAP storage), bare ROS 2 ``.db3`` files and bare ``ros2``-profile MCAP files
that carry a complete summary (``rosbags.rosbag2``).  Messages are read raw and reduced by
:class:`~hybridlog.io.messages.MessageSource`.

What this adds to rosbags' readers:

- Each topic's message definition is parsed on its own (:mod:`.definitions`), where
  rosbags' ``AnyReader`` parses them all at once and refuses the bag when one fails: a
  definition rosbags cannot parse, or whose stored type hash does not match it, makes only
  its topic undecodable.  So does a topic whose connections store different definitions of
  its type (two nodes built from different versions of a message): one definition decodes a
  topic, and would read the other's bytes as wrong numbers.
- In a bag directory, topics are matched between ``metadata.yaml`` and the storage files by
  name and type (rosbags also compares their QoS text, so a bag whose metadata was written
  by another ROS version reads as empty); where the two disagree (QoS, counts, topics),
  ``reading["metadata"]`` says so and the storage files, which hold the messages, win.
  Storage files in the folder that ``metadata.yaml`` does not list, which rosbags passes
  over, are named in ``reading["unlisted_files"]`` (:func:`unlisted_storage_files`).
- A ``.db3`` file is checked against the size its header records and for a write-ahead log
  beside it holding committed writes (:func:`check_sqlite`): rosbags opens the file
  immutable and would leave those messages out without a word.
- MCAP storage files are checked like bare MCAP files first (CRCs, footer; see
  :func:`~hybridlog.io.mcap_reader.check_mcap`), and whatever rosbags raises on a damaged
  file becomes a :class:`~hybridlog.errors.LogError` naming the file.
- QoS profiles rosbags cannot parse (in ``metadata.yaml`` or a ``.db3`` file's ``topics``
  table), on which it raises in its own words naming no topic, are found when it has
  failed to open the bag (nothing is read ahead for a bag it opens) and refused naming the
  topic and what they hold (:mod:`.bag_qos`).
- A topic's name, type or message count of another kind than rosbags' reader expects (text,
  text, a whole number: ``metadata.yaml`` is YAML, a ``.db3`` file's columns are typed by
  their values) is refused naming where it is written, the topic and the field
  (:func:`_check_connections`); rosbags takes whatever the file holds.
"""

from __future__ import annotations

import contextlib
import re
import shlex
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from hybridlog.errors import HybridlogError, LogError, excerpt
from hybridlog.io.bag_qos import bag_qos_problem
from hybridlog.io.definitions import (
    DefinitionError,
    definition_key,
    digest_problem,
    first_line,
    normal_type,
    types_from_msg_dirs,
    typestore_for,
)
from hybridlog.io.formats import LogFormat
from hybridlog.io.mcap_reader import (
    UnfinishedLogError,
    check_mcap,
    count_readable,
    recover_hint,
    rosbags_summary_problem,
)
from hybridlog.io.mcap_side_records import SideRecords
from hybridlog.io.message_topics import Topic
from hybridlog.io.messages import MessageSource
from hybridlog.io.options import ReadOptions

SCHEMALESS = "__schemaless__"


def check_sqlite(path: Path) -> None:
    """Refuse an SQLite file shorter than the size its header records.

    SQLite keeps no checksums, but its header records the page size and (when the "version
    valid for" number equals the change counter) the number of pages: a file cut short does
    not add up.  SQLite itself reads a cut-off last page as zeros, which turns the last
    messages' bytes into other numbers without any error.  (Bytes after the last page are
    ignored by SQLite and harmless.)

    Raises
    ------
    LogError
        Naming the file, its size and the size its header records.
    """
    try:
        size = path.stat().st_size
        with path.open("rb") as handle:
            header = handle.read(100)
    except OSError as err:
        raise LogError(f"{path}: cannot be read ({err.strerror})") from err
    if len(header) < 100:
        return  # sqlite reports a file this short itself
    page_size = int.from_bytes(header[16:18], "big")
    page_size = 65536 if page_size == 1 else page_size
    pages = int.from_bytes(header[28:32], "big")
    valid = header[24:28] == header[92:96] and pages > 0
    if valid and size < page_size * pages:
        raise LogError(
            f"{path}: damaged SQLite database: {size} bytes where its header records "
            f"{pages} pages of {page_size} bytes ({page_size * pages} bytes); the file is cut off"
        )
    wal = path.with_name(f"{path.name}-wal")
    committed = _committed_wal_frames(wal)
    if committed:
        raise LogError(
            f"{path}: {wal.name} beside it holds writes not yet in the database "
            f"({committed} pages; the recorder was killed or is still recording), which "
            "the bag reader would leave out; move them in with: "
            f"sqlite3 {shlex.quote(str(path))} 'PRAGMA wal_checkpoint(TRUNCATE)'"
        )


_WAL_MAGIC = (0x377F0682, 0x377F0683)
"""The first four bytes (big-endian) of an SQLite write-ahead log."""


def _committed_wal_frames(wal: Path) -> int:
    """The pages of the transactions committed to an SQLite write-ahead log (0: none, no log).

    rosbags opens a ``.db3`` file immutable, as it has to (a reader must not write beside a
    bag), and SQLite then reads the database file alone: what a recorder wrote to
    ``<file>-wal`` and had not checkpointed into it -- the last seconds of a killed
    recording -- was left out without a word.  A frame belongs to the log when its salts
    are the header's; the pages up to its last commit frame were committed.  (Frames a
    checkpoint already copied in are counted too: the log does not say which; the
    checkpoint that the error suggests empties it either way.)
    """
    try:
        with wal.open("rb") as handle:
            header = handle.read(32)
            if len(header) < 32 or int.from_bytes(header[:4], "big") not in _WAL_MAGIC:
                return 0
            page_size = int.from_bytes(header[8:12], "big")
            page_size = 65536 if page_size == 1 else page_size
            salts, size = header[16:24], wal.stat().st_size
            frames = committed = 0
            while len(frame := handle.read(24)) == 24 and frame[8:16] == salts:
                if handle.seek(page_size, 1) > size:  # a frame cut off: never committed
                    break
                frames += 1
                if int.from_bytes(frame[4:8], "big"):  # a commit frame: the database's size
                    committed = frames
            return committed
    except OSError:
        return 0


def _said(text: str) -> str:
    """A library's error text, escaped and cut short (:func:`~hybridlog.errors.excerpt`)."""
    return excerpt(text)[1:-1]


def _raised_in(err: BaseException, function: str) -> bool:
    """Whether ``err`` was raised in a function of that name (its traceback's innermost frame)."""
    trace = err.__traceback__
    while trace is not None and trace.tb_next is not None:
        trace = trace.tb_next
    return trace is not None and trace.tb_frame.f_code.co_name == function


def _qos_text(connection: Any) -> str:
    return repr(getattr(connection.ext, "offered_qos_profiles", None))


_CONNECTION_FIELDS: tuple[tuple[str, str, type], ...] = (
    ("topic", "name", str),
    ("msgtype", "type", str),
    ("msgcount", "message count", int),
)
"""What rosbags' connection holds of a topic: attribute, the field's name, its kind."""


def _check_connections(connections: Any, where: str) -> None:
    """Refuse a connection whose topic name, type or message count is not of its kind.

    ``where`` names the file that lists them.  Topics are sorted and matched by name and type,
    and counts compared: a name YAML reads as a number or ``null``, or a ``.db3`` value
    stored as a blob, failed there with Python's ``TypeError`` and no file named.
    """
    for number, connection in enumerate(connections, 1):
        for attribute, field, kind in _CONNECTION_FIELDS:
            value = getattr(connection, attribute)
            if not isinstance(value, kind) or isinstance(value, bool):
                name = connection.topic
                topic = excerpt(name) if isinstance(name, str) else f"#{number}"
                shown = excerpt(value) if isinstance(value, str) else excerpt(repr(value))[1:-1]
                raise LogError(
                    f"{where}: topic {topic}: its {field} is {shown}, "
                    f"not {'text' if kind is str else 'a whole number'}"
                )


class BagSource(MessageSource):
    """A bag read through rosbags' bag readers (see the module docstring).

    Parameters
    ----------
    path:
        A ``.bag`` file, a ROS 2 bag directory, a ``.db3`` file or a ``ros2``-profile
        ``.mcap`` whose summary rosbags can index.
    options:
        How to read it (``msg_dirs`` is used here, the rest by the base class).
    log_format:
        The row of the table of formats the content matched: ``ros1-bag``, ``ros2-bag``
        (directory), ``ros2-db3`` or ``mcap``.

    Raises
    ------
    LogError
        When the bag cannot be opened (naming why in one line).
    """

    def __init__(self, path: str | Path, options: ReadOptions, log_format: LogFormat) -> None:
        super().__init__(path, options, log_format.name)
        kind = self._kind = log_format.name
        self._ros1 = kind == "ros1-bag"
        self._directory = log_format.directory
        if kind == "mcap":
            self._details["profile"] = "ros2"
        self._reader: Any = None
        # (storage reader, its connections): where messages are read from.
        self._storages: list[tuple[Any, list[Any]]] = []
        self._per_message_zstd = False
        self._listed: list[str] | None = None  # metadata.yaml's storage files, once read
        if log_format.directory:
            self._check_mcap_storage()
            for file in sorted(self._file.glob("*.db3")):
                check_sqlite(file)
        elif kind == "ros2-db3":
            if self._file.suffix not in log_format.suffixes:  # x.DB3: the suffix is read
                raise LogError(
                    f"{self.path}: a ROS 2 sqlite3 bag file must end in .db3, in lower case "
                    "(rosbags, which reads it, takes the format from its name): rename it"
                )
            check_sqlite(self._file)
        try:
            self._open()
            extra = types_from_msg_dirs(self.options.msg_dirs) if self.options.msg_dirs else {}
            self._topics = self._make_topics(extra)
        except HybridlogError:
            self.close()
            raise
        except Exception as err:  # rosbags raises assorted errors on damaged bags
            self.close()
            raise LogError(self._open_problem(err)) from None

    def _side_records(self) -> SideRecords | None:
        """A ``ros2``-profile MCAP file's attachments and metadata records (walked for)."""
        if self._kind != "mcap":
            return None
        with self._file.open("rb") as handle:
            return SideRecords.walk(handle)

    # ------------------------------------------------------------------ opening

    def _check_mcap_storage(self) -> None:
        """Check the MCAP storage files of a bag directory as bare MCAP files are checked."""
        for file in sorted(self._file.glob("*.mcap")):
            layout = check_mcap(file)
            if not layout.finished:
                readable, _ = count_readable(file)
                state = (
                    f"has a damaged summary section ({layout.problem})"
                    if layout.summary_damaged
                    else f"is unfinished ({layout.problem}: the recorder was killed?)"
                )
                finding = f"the bag's MCAP storage file {file.name} {state}; " + (
                    f"{readable} messages are readable"
                    if readable
                    else "no message in it is readable"
                )
                hint = f": analyse {file} with --recover" if readable else ""
                raise UnfinishedLogError(
                    f"{self.path}: {finding}{hint}", file=file, finding=finding, readable=readable
                )
            problem = (
                rosbags_summary_problem(file, storage=True) if layout.profile == "ros2" else None
            )
            if problem is not None:
                raise LogError(
                    f"{self.path}: rosbags' bag reader cannot index its MCAP storage file "
                    f"{file.name} ({problem}); analyse the file itself: {file}"
                )

    def _open(self) -> None:
        if self._ros1:
            from hybridlog.io.ros1_index import Ros1Reader

            reader: Any = Ros1Reader(self._file)
            reader.open()
            self._reader = reader
            self._storages = [(reader, list(reader.connections))]
            _check_connections(reader.connections, self.path)
            return
        from rosbags.rosbag2 import Reader as Ros2Reader

        reader = Ros2Reader(self._file)
        reader.open()
        self._reader = reader
        storage = reader.storage
        storages = getattr(storage, "storages", None)
        if storages is None:  # a bare .db3 or .mcap
            self._storages = [(storage, list(storage.connections))]
            _check_connections(storage.connections, self.path)
            return
        # rosbags opened one storage per listed file, in order, at the path it lists
        # (unless it unpacked them, per-file compressed, into a temporary folder): their
        # names are the list, without parsing metadata.yaml a second time (ruamel's pure
        # Python parser takes some 10-20 ms of a small bag's 25).
        self._listed = (
            _listed_files(self._file)
            if reader.compression_mode == "file"
            else [Path(str(s.path)).name for s in storages]
        )
        _refuse_listed_twice(self._listed, self.path)
        self._storages = [(s, list(s.connections)) for s in storages]
        _check_connections(reader.connections, f"{self.path}: metadata.yaml")
        for _, connections in self._storages:
            _check_connections(connections, self.path)
        self._per_message_zstd = reader.compression_mode == "message"
        plugin = type(storages[0]).__name__ if storages else ""
        self._format += " (mcap)" if "Mcap" in plugin else " (sqlite3)"

    def _open_problem(self, err: BaseException) -> str:
        qos = None if self._ros1 or self._kind == "mcap" else bag_qos_problem(self._file)
        if qos is not None:  # rosbags says it in its own words, naming no topic
            return f"{self.path}: rosbags, which reads ROS 2 bags, cannot open it: {qos}"
        text = _said(first_line(err))
        if isinstance(err, FileNotFoundError) and "metadata" in text:
            inside = sorted(p.name for p in self._file.glob("*") if p.suffix in (".db3", ".mcap"))
            hint = f"; open the file inside it directly: {inside[0]}" if inside else ""
            return (
                f"{self.path}: a ROS 2 bag directory needs metadata.yaml, which this one lacks "
                f"(the recorder did not finish?){hint}"
            )
        if "Invalid bag metadata" in text or "metadata key is missing" in text:
            return f"{self.path}: metadata.yaml: {_metadata_problem(self._file, text)}"
        if "Profile is not ros2" in text:
            return (
                f"{self.path}: holds an MCAP file whose profile is not 'ros2', so it is not a "
                "ROS 2 bag; open the .mcap file itself (read with the mcap library)"
            )
        if "index looks damaged" in text:
            field = re.search(r"Could not read string field '(\w+)'", text)
            if field is not None:  # rosbags reads a missing field and bytes not UTF-8 alike
                return (
                    f"{self.path}: damaged ROS 1 bag: a connection record's {field[1]!r} is "
                    "missing or not UTF-8 text (a corrupt file: ROS names are ASCII)"
                )
            return (
                f"{self.path}: damaged ROS 1 bag: its index cannot be read (the file is cut off "
                "or corrupt; `rosbag reindex` may rebuild it)"
            )
        if "not indexed" in text:
            return (
                f"{self.path}: the ROS 1 bag is not indexed (its recording did not finish); "
                "run `rosbag reindex` on it"
            )
        if "Cannot open database" in text or type(err).__module__.startswith(("sqlite", "apsw")):
            reason = _said(first_line(err).rsplit(": ", 1)[-1])
            return f"{self.path}: not a readable ROS 2 bag database ({reason})"
        if isinstance(err, KeyError) and _raised_in(err, "get_msgdef"):
            # rosbags looks a stored definition's encoding up in a dict: its text was the key
            return (
                f"{self.path}: a topic's message definition is stored in the encoding {text}, "
                "which rosbags does not read (ros2msg or ros2idl)"
            )
        if "File magic is invalid" in text:
            return f"{self.path}: not a {self._format} file (wrong magic bytes)"
        if "seems to be empty" in text:
            return f"{self.path}: empty file"
        return f"{self.path}: cannot open the {self._format} file ({text})"

    # ------------------------------------------------------------------ topics

    def _make_topics(self, extra: dict[str, Any]) -> dict[str, Topic]:
        grouped: dict[str, list[Any]] = {}
        for _, connections in self._storages:
            for connection in connections:
                grouped.setdefault(connection.topic, []).append(connection)
        stores: dict[tuple[str, str, str], Any] = {}
        topics: dict[str, Topic] = {}
        for name, connections in grouped.items():
            # ROS 1's spelling, std_msgs/Float64, as the mcap reader takes it: rosbags keeps a
            # connection's name as stored but parses its definition as std_msgs/msg/Float64.
            msgtypes = {normal_type(c.msgtype) for c in connections}
            msgtype = normal_type(connections[0].msgtype)
            counts = [c.msgcount for c in connections]
            count = sum(counts) if all(c >= 0 for c in counts) else None
            topic = Topic(name, msgtype, "ros1" if self._ros1 else "cdr", count)
            formats = {getattr(c.ext, "serialization_format", "ros1") for c in connections}
            definitions = _definitions(connections)
            if len(msgtypes) > 1:
                topic.problem = f"has several message types ({', '.join(sorted(msgtypes))})"
            elif len(definitions) > 1:
                # One definition decodes the topic: another's messages would be read with it.
                listed = ", ".join(
                    f"{label}{'' if n is None else f' ({n} message' + 's' * (n != 1) + ')'}"
                    for label, n in definitions.items()
                )
                topic.problem = f"has connections with different definitions of it: {listed}"
            elif msgtype == SCHEMALESS:
                topic.msgtype = ""
                topic.problem = "schemaless channel: its messages cannot be decoded"
            elif not self._ros1 and formats != {"cdr"}:
                topic.problem = (
                    f"message encoding {', '.join(sorted(formats))!r} is not CDR, which a "
                    "ROS 2 bag requires"
                )
            else:
                self._define(topic, connections[0], stores, extra)
            topics[name] = topic
        if self._directory:
            self._compare_metadata(topics)
        return topics

    def _define(
        self, topic: Topic, connection: Any, stores: dict[tuple[str, str, str], Any], extra: Any
    ) -> None:
        """Give ``topic`` its type store from the connection's stored definition."""
        definition = connection.msgdef
        encoding = {"MSG": "msg", "IDL": "idl"}.get(definition.format.name, "")
        key = (topic.msgtype, encoding, definition.data)
        try:
            store = stores.get(key)
            if store is None:
                store = stores[key] = typestore_for(
                    topic.msgtype, encoding, definition.data, ros1=self._ros1, extra=extra
                )
        except DefinitionError as err:
            topic.problem = str(err)
            return
        if encoding:
            problem = digest_problem(
                store,
                topic.msgtype,
                connection.digest,
                ros1=self._ros1,
                stored=bool(definition.data.strip()),
            )
            if problem is not None:
                topic.problem = problem
                return
        topic.typedefs = store.fielddefs
        msgtype = topic.msgtype
        if self._ros1:
            topic.decode = lambda data: store.deserialize_ros1(data, msgtype)
        else:
            topic.decode = lambda data: store.deserialize_cdr(data, msgtype)

    def _compare_metadata(self, topics: dict[str, Topic]) -> None:
        """Match ``metadata.yaml``'s topics to the storage's by name and type; note differences."""
        storage_topics: dict[tuple[str, str], list[Any]] = {}
        for _, connections in self._storages:
            for connection in connections:
                key = (connection.topic, connection.msgtype)
                storage_topics.setdefault(key, []).append(connection)
        remarks: list[str] = []
        listed: set[tuple[str, str]] = set()
        for entry in self._reader.connections:
            key = (entry.topic, entry.msgtype)
            listed.add(key)
            stored = storage_topics.get(key)
            if stored is None:
                # A topic without messages may be missing from a storage file; one with
                # messages is lost (a damaged storage file).
                lost = entry.msgcount > 0
                if lost:
                    remarks.append(
                        f"topic {entry.topic!r} ({entry.msgtype}) is listed in metadata.yaml "
                        f"with {entry.msgcount} messages but no storage file holds it"
                    )
                if entry.topic not in topics:
                    topics[entry.topic] = Topic(
                        entry.topic,
                        entry.msgtype,
                        "cdr",
                        0,
                        problem="listed in metadata.yaml but in no storage file of the bag"
                        if lost
                        else None,
                    )
                continue
            if any(_qos_text(c) != _qos_text(entry) for c in stored):
                remarks.append(
                    f"topic {entry.topic!r}: metadata.yaml and the storage file give different "
                    "QoS profiles (topics are matched by name and type)"
                )
            held = sum(c.msgcount for c in stored)
            if held != entry.msgcount:
                remarks.append(
                    f"topic {entry.topic!r}: metadata.yaml lists {entry.msgcount} messages, the "
                    f"storage holds {held}"
                )
        for topic_name, msgtype in sorted(set(storage_topics) - listed):
            remarks.append(f"topic {topic_name!r} ({msgtype}) is not listed in metadata.yaml")
        if remarks:
            self._notes["metadata"] = remarks
        unlisted = unlisted_storage_files(self._file, self._listed)
        if unlisted:
            self._notes["unlisted_files"] = unlisted

    # ------------------------------------------------------------------ reading

    def close(self) -> None:
        """Close the rosbags reader."""
        reader, self._reader = self._reader, None
        self._storages = []
        if reader is None:
            return
        with contextlib.suppress(Exception):  # a reader that failed half-way may fail again
            reader.close()

    def _damaged(self, err: BaseException) -> LogError:
        text = _said(first_line(err))
        if "checksum" in text.lower() or "crc" in text.lower():
            return LogError(f"{self.path}: CRC mismatch: the file is corrupt ({text})")
        if self._directory and "not in timestamp order" in text:
            # A storage file without chunks, its messages in another order than log time
            # (which MCAP allows): rosbags reads such a file only in order; the mcap
            # reader takes it as a file of its own.
            files = sorted(self._file.glob("*.mcap"))
            file = str(files[0]) if len(files) == 1 else "its .mcap files one by one"
            return LogError(
                f"{self.path}: an MCAP storage file of this bag has no chunks and its messages "
                f"are not in log-time order, which rosbags' bag reader cannot read; "
                f"analyse {file}"
            )
        return LogError(f"{self.path}: damaged {self._format} file ({text})")

    def _recover_hint(self, topic: str, found: int) -> str:
        """``--recover`` applies to bare MCAP files only (read then by the mcap library)."""
        return recover_hint(self._file, topic, found) if self._kind == "mcap" else ""

    def _iter_raw(self, topics: set[str]) -> Iterator[tuple[str, int, bytes]]:
        decompress = _zstd_decompress() if self._per_message_zstd else None
        for storage, connections in self._storages:
            chosen = [c for c in connections if c.topic in topics]
            if not chosen:
                continue
            for connection, timestamp, data in storage.messages(chosen):
                yield connection.topic, timestamp, data if decompress is None else decompress(data)


#: Suffixes of the storage files of a ROS 2 bag folder, compressed per file or not.
STORAGE_SUFFIXES = (".db3", ".mcap", ".db3.zstd", ".mcap.zstd")


def unlisted_storage_files(folder: Path, names: list[str] | None) -> list[str]:
    """The storage files in a bag folder that its ``metadata.yaml`` does not list.

    rosbags (and ``ros2 bag``) read only the files of ``relative_file_paths``; another
    ``.db3`` or ``.mcap`` file beside them (a split file copied in, a second recording) is
    passed over without a word, and its messages with it.  Its name is returned so that the
    reading says so.  ``names``: the list (the names of the storage files rosbags opened, or
    :func:`_listed_files` for a bag compressed per file); ``None``, when ``metadata.yaml``
    has no such list rosbags could read (it has refused the bag then), gives none.
    """
    if names is None:
        return []
    listed = set(names)
    return sorted(
        file.name
        for file in folder.iterdir()
        if file.name not in listed
        and file.name.lower().endswith(STORAGE_SUFFIXES)  # as the log's suffix is read
        and file.is_file()
    )


def _metadata_problem(folder: Path, said: str) -> str:
    """What rosbags refused in ``metadata.yaml`` (``said``), naming the key.

    rosbags names a missing key only as ``KeyError('duration')``, and a version that is not
    a number not at all (``'>' not supported between instances of 'str' and 'int'``).
    """
    missing = re.search(r"KeyError\('([^']*)'\)", said)
    if missing is not None:
        return f"the key {missing[1]!r} is missing (rosbags needs it to read the bag)"
    version = _bag_information(folder, "version")
    if version is not None and (isinstance(version, bool) or not isinstance(version, int)):
        return f"rosbag2_bagfile_information.version is {excerpt(str(version))}, not a whole number"
    return f"not metadata rosbags can read ({said})"


def _bag_information(folder: Path, key: str) -> Any:
    """``rosbag2_bagfile_information.<key>`` of the folder's ``metadata.yaml``, as rosbags reads it.

    ``None`` when the file, the table or the key is not there or not readable YAML.
    """
    from ruamel.yaml import YAML
    from ruamel.yaml.error import YAMLError

    try:
        document = YAML(typ="safe").load((folder / "metadata.yaml").read_text(encoding="utf-8"))
        return document["rosbag2_bagfile_information"][key]
    except (OSError, ValueError, YAMLError, LookupError, TypeError, AttributeError):
        return None


def _listed_files(folder: Path) -> list[str] | None:
    """The names of the storage files ``metadata.yaml`` lists, in order, as rosbags takes them.

    ``None`` when it has no such list rosbags could read (rosbags refuses the bag then).
    """
    paths = _bag_information(folder, "relative_file_paths")
    try:
        return None if paths is None else [Path(str(path)).name for path in paths]
    except TypeError:  # not a list
        return None


def _refuse_listed_twice(names: list[str] | None, path: str) -> None:
    """Refuse a bag whose ``metadata.yaml`` lists one storage file more than once.

    rosbags opens the file once per listing and yields its messages as often, so each
    message was read twice: refused as "the same log time as the one before", with
    ``--sort`` (which keeps one of each) offered as the remedy for a fault of the metadata.

    Raises
    ------
    LogError
        Naming ``metadata.yaml``, the file and how often it is listed.
    """
    if names is None:
        return
    for name in dict.fromkeys(names):
        if (times := names.count(name)) > 1:
            raise LogError(
                f"{path}: metadata.yaml lists the storage file {excerpt(name)} {times} times "
                "in relative_file_paths, which would read its messages as often: list it "
                "once"
            )


def _definitions(connections: list[Any]) -> dict[str, int | None]:
    """The different message definitions of a topic's connections, with their counts.

    Told apart by the stored hash (a ROS 1 MD5 sum, a ROS 2 ``RIHS01_`` type hash), else by
    the definition text without comments and blank space (two recorders may lay out the
    same definition differently); labelled by the hash for messages.
    """
    found: dict[str, int | None] = {}
    labels: dict[str, str] = {}
    for connection in connections:
        definition = connection.msgdef
        key = connection.digest or definition_key(
            definition.format.name.lower(), str(definition.data)
        )
        if key not in labels:
            shown = connection.digest or f"definition {len(labels) + 1}"
            labels[key] = excerpt(shown, 24)
        label = labels[key]
        known, count = found.get(label, 0), connection.msgcount
        found[label] = None if known is None or count < 0 else known + count
    return found


def _zstd_decompress() -> Any:
    if sys.version_info >= (3, 14):  # pragma: no cover
        from compression import zstd
    else:
        from backports import zstd
    return zstd.decompress
