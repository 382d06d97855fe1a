"""ROS 1 and ROS 2 bags through ``rosbags.highlevel.AnyReader``.

Reads ROS 1 ``.bag`` files, ROS 2 bag directories (``metadata.yaml`` with sqlite3 or MCAP
storage), bare ROS 2 ``.db3`` files and bare MCAP files of the ``ros2`` profile.  Message
definitions come from the bag itself; types it does not define are taken, in this order, from
``--msg-dir`` folders (:func:`types_from_msg_dirs`) and from rosbags' standard ROS 1 (Noetic) or
ROS 2 (latest LTS) type store.  Messages are read raw and reduced by
:class:`~hybridlog.io.messages.MessageSource`; rosbags' deserialiser is the fallback.
"""

from __future__ import annotations

import sqlite3
import struct
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from hybridlog.errors import LogError
from hybridlog.io.message_paths import Typedefs
from hybridlog.io.messages import MessageSource, Topic, first_line
from hybridlog.io.source import ReadSettings

SCHEMALESS = "__schemaless__"


def _library_errors() -> tuple[type[BaseException], ...]:
    from rosbags.highlevel import AnyReaderError
    from rosbags.rosbag1 import ReaderError as Ros1Error
    from rosbags.rosbag2 import ReaderError as Ros2Error
    from rosbags.serde import SerdeError
    from rosbags.typesys import TypesysError

    errors: list[type[BaseException]] = [
        AnyReaderError,
        Ros1Error,
        Ros2Error,
        SerdeError,
        TypesysError,
        sqlite3.Error,
        struct.error,
        OSError,
        EOFError,
        ValueError,
        KeyError,
        IndexError,
        RuntimeError,  # lz4 reports corrupt frames this way
    ]
    try:
        from backports.zstd import ZstdError

        errors.append(ZstdError)
    except ImportError:  # pragma: no cover - Python >= 3.14 has compression.zstd
        pass
    return tuple(errors)


def types_from_msg_dirs(folders: tuple[str, ...]) -> dict[str, Any]:
    """Message types defined by the ``.msg`` files under ``folders``.

    A file ``<pkg>/msg/<Name>.msg`` (or ``<pkg>/<Name>.msg``) defines ``<pkg>/msg/<Name>``.

    Raises
    ------
    LogError
        For a folder that does not exist or a ``.msg`` file rosbags cannot parse (naming it).
    """
    from rosbags.typesys import TypesysError, get_types_from_msg

    types: dict[str, Any] = {}
    for folder in folders:
        root = Path(folder)
        if not root.is_dir():
            raise LogError(f"--msg-dir {folder}: no such folder")
        for file in sorted(root.rglob("*.msg")):
            parent = file.parent
            package = parent.parent.name if parent.name == "msg" else parent.name
            name = f"{package}/msg/{file.stem}"
            try:
                types.update(get_types_from_msg(file.read_text(encoding="utf-8"), name))
            except (TypesysError, UnicodeDecodeError, OSError) as err:
                raise LogError(
                    f"{file}: not a readable message definition ({first_line(err)})"
                ) from err
    return types


def standard_types(ros1: bool) -> Typedefs:
    """Rosbags' standard message definitions (ROS 1 Noetic, or the latest ROS 2 LTS)."""
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.LATEST)
    fielddefs: Typedefs = store.fielddefs
    return fielddefs


def complete_typestore(store: Any, needed: set[str], extra: dict[str, Any], ros1: bool) -> None:
    """Register into ``store`` the ``needed`` types it lacks (and what they use).

    Taken from ``extra`` (``--msg-dir``) first, then from the standard definitions.
    """
    missing = {name for name in needed if name not in store.fielddefs}
    if not missing:
        return
    pool: dict[str, Any] = {**standard_types(ros1), **extra}
    chosen: dict[str, Any] = {}

    def add(name: str) -> None:
        if name in chosen or name in store.fielddefs or name not in pool:
            return
        chosen[name] = pool[name]
        for _, desc in pool[name][1]:
            node = int(desc[0])
            if node == 2:
                add(desc[1])
            elif node in (3, 4) and int(desc[1][0][0]) == 2:
                add(desc[1][0][1])

    for name in sorted(missing):
        add(name)
    if chosen:
        store.register(chosen)


class BagSource(MessageSource):
    """A bag read through rosbags' ``AnyReader`` (see the module docstring).

    Parameters
    ----------
    path:
        A ``.bag`` file, a ROS 2 bag directory, a ``.db3`` file or a ``ros2``-profile ``.mcap``.
    kind:
        ``"ros1"``, ``"ros2"`` (directory), ``"db3"`` or ``"mcap"``: what the content says.
    settings:
        Reading settings (``--msg-dir`` is used here).

    Raises
    ------
    LogError
        When rosbags cannot open the bag (naming why in one line).
    """

    def __init__(self, path: str | Path, kind: str, settings: ReadSettings | None = None) -> None:
        super().__init__(path, settings)
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore

        self._kind = kind
        self._ros1 = kind == "ros1"
        self.format = {
            "ros1": "ros1-bag",
            "ros2": "ros2-bag",
            "db3": "ros2-db3",
            "mcap": "mcap",
        }[kind]
        default = get_typestore(Stores.ROS1_NOETIC if self._ros1 else Stores.LATEST)
        self._reader: Any = None
        try:
            reader = AnyReader([self._file], default_typestore=default)
            reader.open()
        except FileNotFoundError as err:
            raise LogError(self._open_problem(err)) from None
        except _library_errors() as err:
            raise LogError(self._open_problem(err)) from None
        self._reader = reader
        if kind == "ros2":
            storage = getattr(reader.readers[0], "storage", None)
            plugin = type(getattr(storage, "storages", [None])[0]).__name__
            self.format += " (mcap)" if "Mcap" in plugin else " (sqlite3)"
        self._store = reader.typestore
        if kind == "mcap":
            self._details["profile"] = "ros2"
        try:
            extra = types_from_msg_dirs(self.settings.msg_dirs) if self.settings.msg_dirs else {}
            complete_typestore(
                self._store, {c.msgtype for c in reader.connections}, extra, self._ros1
            )
        except LogError:
            self.close()
            raise
        except _library_errors() as err:
            self.close()
            raise LogError(
                f"{self.path}: message definitions conflict ({first_line(err)})"
            ) from err
        self._topics = self._make_topics()

    def _open_problem(self, err: BaseException) -> str:
        text = first_line(err)
        if isinstance(err, FileNotFoundError) and "metadata" in text:
            inside = sorted(p.name for p in self._file.glob("*") if p.suffix in (".db3", ".mcap"))
            hint = f"; open the file inside it directly: {inside[0]}" if inside else ""
            return (
                f"{self.path}: a ROS 2 bag directory needs metadata.yaml, which this one lacks "
                f"(the recorder did not finish?){hint}"
            )
        if "Profile is not ros2" in text:
            return (
                f"{self.path}: holds an MCAP file whose profile is not 'ros2', so it is not a "
                "ROS 2 bag; open the .mcap file itself (read with the mcap library)"
            )
        if "index looks damaged" in text:
            return (
                f"{self.path}: damaged ROS 1 bag: its index cannot be read (the file is cut off "
                "or corrupt; `rosbag reindex` may rebuild it)"
            )
        if "not indexed" in text:
            return (
                f"{self.path}: the ROS 1 bag is not indexed (its recording did not finish); "
                "run `rosbag reindex` on it"
            )
        if "Cannot open database" in text or isinstance(err, sqlite3.Error):
            return f"{self.path}: not a readable ROS 2 bag database ({text})"
        if "File end magic is invalid" in text and self._kind == "ros2":
            return (
                f"{self.path}: its MCAP storage file is unfinished (no footer: the recorder was "
                "killed?); analyse the .mcap file inside it with --recover"
            )
        if "File magic is invalid" in text:
            return f"{self.path}: not a {self.format} file (wrong magic bytes)"
        if "seems to be empty" in text:
            return f"{self.path}: empty file"
        if "no type definitions" in text:
            return f"{self.path}: the bag has no message definitions; pass --msg-dir DIR"
        return f"{self.path}: cannot open the {self.format} file ({text})"

    def _make_topics(self) -> dict[str, Topic]:
        store = self._store
        topics: dict[str, Topic] = {}
        grouped: dict[str, list[Any]] = {}
        for connection in self._reader.connections:
            grouped.setdefault(connection.topic, []).append(connection)
        for name, connections in grouped.items():
            msgtypes = {c.msgtype for c in connections}
            msgtype = connections[0].msgtype
            encoding = "ros1" if self._ros1 else "cdr"
            formats = {getattr(c.ext, "serialization_format", "ros1") for c in connections}
            counts = [c.msgcount for c in connections]
            count = sum(counts) if all(c >= 0 for c in counts) else None
            topic = Topic(name, msgtype, encoding, count)
            if len(msgtypes) > 1:
                topic.problem = f"has several message types ({', '.join(sorted(msgtypes))})"
            elif msgtype == SCHEMALESS:
                topic.msgtype = ""
                topic.problem = "schemaless channel: its messages cannot be decoded"
            elif not self._ros1 and formats != {"cdr"}:
                topic.problem = (
                    f"message encoding {', '.join(sorted(formats))!r} is not CDR, which a "
                    "ROS 2 bag requires"
                )
            elif msgtype not in store.fielddefs:
                topic.problem = (
                    f"type {msgtype!r} has no definition in the log or the standard types; "
                    f"pass --msg-dir DIR with {msgtype}.msg in it"
                )
            else:
                topic.typedefs = store.fielddefs
                topic.decode = self._decoder(msgtype)
            topics[name] = topic
        return topics

    def _decoder(self, msgtype: str) -> Any:
        store = self._store
        if self._ros1:
            return lambda data: store.deserialize_ros1(data, msgtype)
        return lambda data: store.deserialize_cdr(data, msgtype)

    def close(self) -> None:
        """Close the rosbags reader."""
        reader, self._reader = self._reader, None
        if reader is not None and reader.stack is not None:
            reader.close()

    def _read_errors(self) -> tuple[type[BaseException], ...]:
        return _library_errors()

    def _damaged(self, err: BaseException) -> LogError:
        text = first_line(err)
        if "checksum" in text.lower() or "crc" in text.lower():
            return LogError(f"{self.path}: CRC mismatch: the file is corrupt ({text})")
        return LogError(f"{self.path}: damaged {self.format} file ({text})")

    def _iter_raw(self, topics: set[str]) -> Iterator[tuple[str, int, bytes]]:
        connections = [c for c in self._reader.connections if c.topic in topics]
        if not connections:
            return
        for connection, timestamp, data in self._reader.messages(connections=connections):
            yield connection.topic, timestamp, data
