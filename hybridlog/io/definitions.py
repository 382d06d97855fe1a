"""Message definitions: from the log, from ``--msg-dir`` folders, from rosbags' standard types.

Every distinct definition a log stores (an MCAP schema, a bag connection's ``msgdef``) gets a
rosbags type store of its own (:func:`typestore_for`).  One definition rosbags cannot parse --
a ROS 2 Jazzy service-event schema holding a ``.srv`` text with ``---``, a placeholder, a
typo -- therefore makes only the topics that use it undecodable, never the whole file.

Types a definition references but does not define, and types the log stores no definition
for at all (ROS 2 bags recorded before Iron), are taken from ``--msg-dir`` folders first and
then from rosbags' standard ROS 1 (Noetic) or ROS 2 (latest LTS) definitions.
"""

from __future__ import annotations

import re
import weakref
from collections import OrderedDict
from pathlib import Path
from typing import Any

from hybridlog.errors import LogError, excerpt
from hybridlog.io.message_paths import Typedefs
from hybridlog.io.options import msg_dir_problem

_IDL_SEPARATOR = "=" * 80 + "\n"

STORE_CACHE_SIZE = 64
"""How many type stores :func:`typestore_for` keeps, the least recently used dropped first."""
_stores: OrderedDict[tuple[str, str, str, bool, str], Any] = OrderedDict()


class DefinitionError(Exception):
    """A stored definition that cannot be used (message without the file, one line)."""


def first_line(err: BaseException) -> str:
    """The first line of an exception's message, or its class name."""
    text = str(err).strip()
    return text.splitlines()[0] if text else type(err).__name__


def library_reason(err: BaseException) -> str:
    """A reading library's error, for the parentheses of a message: its first line, quoted.

    Bytes that are not UTF-8 where a library expects text (a topic or schema name) are
    said so: Python's own text, quoted, read ``(''utf-8' codec can't decode byte 0xff ...')``.
    """
    if isinstance(err, UnicodeDecodeError):
        byte = err.object[err.start : err.start + 1].hex()
        return f"text in it is not UTF-8: byte 0x{byte}"
    return excerpt(first_line(err))


def normal_type(name: str) -> str:
    """``std_msgs/Float64`` (ROS 1 style) → ``std_msgs/msg/Float64``."""
    parts = name.split("/")
    if len(parts) == 2:
        return f"{parts[0]}/msg/{parts[1]}"
    return name


def definition_key(encoding: str, text: str) -> str:
    """What tells two stored definitions apart, comments and layout aside.

    A ``.msg`` text without its comments and blank space (two recorders may lay out one
    definition differently); any other as it is.  ``encoding``: the schema's (``ros2msg``,
    ``ros1msg``, ``ros2idl`` ...) or ``"msg"``.
    """
    if encoding not in ("msg", "ros1msg", "ros2msg"):
        return text
    return " ".join(word for line in text.splitlines() for word in line.partition("#")[0].split())


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
        why = msg_dir_problem(folder)
        if why is not None:
            raise LogError(f"--msg-dir {folder}: {why}")
        for file in sorted(root.rglob("*.msg")):
            parent = file.parent
            package = parent.parent.name if parent.name == "msg" else parent.name
            name = f"{package}/msg/{file.stem}"
            try:
                # utf-8-sig: a byte-order mark (Windows Notepad writes one) is no text of it
                types.update(get_types_from_msg(file.read_text(encoding="utf-8-sig"), name))
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


def referenced_types(types: Typedefs) -> set[str]:
    """The types of ``types`` and every message type their fields use."""
    names = set(types)
    for _, fields in types.values():
        for _, desc in fields:
            inner = _message_type(desc)
            if inner is not None:
                names.add(inner)
    return names


def complete_typestore(store: Any, needed: set[str], extra: Typedefs, ros1: bool) -> None:
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
            inner = _message_type(desc)
            if inner is not None:
                add(inner)

    for name in sorted(missing):
        add(name)
    if chosen:
        store.register(chosen)


def parse_definition(msgtype: str, encoding: str, text: str) -> dict[str, Any]:
    """Parse one stored definition into rosbags field definitions.

    Parameters
    ----------
    msgtype:
        The type it defines (``pkg/msg/Name``).
    encoding:
        ``"msg"`` (``.msg`` text, ROS 1 or ROS 2, with ``MSG:`` sections for the types it
        uses) or ``"idl"`` (ROS 2 IDL, possibly several ``IDL:`` sections).
    text:
        The definition.

    Raises
    ------
    DefinitionError
        When rosbags cannot parse it.
    """
    from rosbags.typesys import TypesysError, get_types_from_idl, get_types_from_msg

    types: dict[str, Any] = {}
    # Lines as a text-mode read gives them (as --msg-dir files are read): a .msg file saved
    # with Windows line ends is stored so by ROS's recorders, and rosbags parses none of it.
    text = text.replace("\r\n", "\n").replace("\r", "\n")
    try:
        if encoding == "msg":
            types.update(get_types_from_msg(text, msgtype))
        else:
            parts = text.split(_IDL_SEPARATOR)[1:] if text.startswith(_IDL_SEPARATOR) else [text]
            for part in parts:
                idl = part.split("\n", 1)[1] if part.startswith("IDL: ") else part
                types.update(get_types_from_idl(_without_directives(idl)))
    except (TypesysError, ValueError, KeyError, IndexError, AttributeError, TypeError) as err:
        raise DefinitionError(
            f"its stored message definition cannot be parsed ({library_reason(err)})"
        ) from err
    return types


_DIRECTIVE = re.compile(r"^[ \t]*#[^\n]*", re.MULTILINE)
"""A preprocessor line of an IDL file: ``#include "std_msgs/msg/Header.idl"``, ``#pragma``."""


def _without_directives(idl: str) -> str:
    """An IDL text with its preprocessor lines blanked, for rosbags' parser, which has none.

    Every ``.idl`` file rosidl generates includes those of the types it uses
    (``#include "builtin_interfaces/msg/Time.idl"``), and rosbag2 stores the files as they
    are: rosbags refused each such definition as one it "could not parse", so a bag or MCAP
    file of IDL-defined types was undecodable.  The included types are sections of the same
    definition (or standard types), so the lines say nothing the reading needs.  Blanked,
    not removed, so that a parse error's position still counts the file's lines.
    """
    return _DIRECTIVE.sub("", idl)


def typestore_for(msgtype: str, encoding: str, text: str, *, ros1: bool, extra: Typedefs) -> Any:
    """A rosbags type store that defines ``msgtype``, built from its stored definition.

    Built once for the same arguments and shared (the last :data:`STORE_CACHE_SIZE` kept):
    read and decode with it, never register into it.

    Parameters
    ----------
    msgtype:
        The topic's type (``pkg/msg/Name``).
    encoding:
        ``"msg"``, ``"idl"``, or ``""`` when the log stores no definition (then ``--msg-dir``
        types and the standard types define it).
    text:
        The stored definition.
    ros1:
        Whether the messages are ROS 1 serialised (for the standard types to complete with).
    extra:
        Types from ``--msg-dir`` folders.

    Raises
    ------
    DefinitionError
        When the stored definition cannot be parsed, conflicts with itself, or the type is
        defined nowhere.
    """
    # The logs of a batch store the same definitions over and over: parsing one and building
    # its store (rosbags generates a class per type) cost some 1-2 ms a definition, a tenth of
    # a small log's reading.  Kept by everything the store is built from -- the type, the
    # definition's text, ROS 1 or 2 and the --msg-dir types -- never by a file's name; a store
    # is not changed once built (its users read and decode with it only).
    key = (msgtype, encoding, text, ros1, repr(sorted(extra.items())) if extra else "")
    store = _stores.get(key)
    if store is not None:
        _stores.move_to_end(key)
        return store
    store = _build_typestore(msgtype, encoding, text, ros1=ros1, extra=extra)
    _stores[key] = store
    if len(_stores) > STORE_CACHE_SIZE:
        _stores.popitem(last=False)
    return store


def _build_typestore(msgtype: str, encoding: str, text: str, *, ros1: bool, extra: Typedefs) -> Any:
    """:func:`typestore_for`, without its cache."""
    from rosbags.typesys import Stores, TypesysError, get_typestore

    types = parse_definition(msgtype, encoding, text) if encoding and text.strip() else {}
    store = get_typestore(Stores.EMPTY)
    try:
        if types:
            store.register(types)
        complete_typestore(store, referenced_types(types) | {msgtype}, extra, ros1)
    except (TypesysError, ValueError, KeyError, TypeError, SyntaxError) as err:
        raise DefinitionError(
            f"its message definition cannot be used ({library_reason(err)})"
        ) from err
    if msgtype not in store.fielddefs and types:
        # rosbags names what it parses package/msg/Name: a schema named Float64 defines
        # msg/Float64, and the log does hold a definition.
        raise DefinitionError(
            f"its stored definition defines {next(iter(types))!r}, not its type "
            f"{msgtype!r}: a ROS type is named package/msg/Name"
        )
    if msgtype not in store.fielddefs:
        raise DefinitionError(
            f"type {msgtype!r} has no definition in the log or the standard types; "
            f"pass --msg-dir DIR with {msgtype}.msg in it"
        )
    problem = structure_problem(store.fielddefs, msgtype)
    if problem is not None:
        raise DefinitionError(problem)
    return _decoded_as_ros(store, ros1=ros1)


_WRITTEN: weakref.WeakKeyDictionary[Any, Any] = weakref.WeakKeyDictionary()
"""The store of each :func:`_decoded_as_ros` store's definitions as written."""

_ROS1_TIMES = {
    "builtin_interfaces/msg/Time": {"sec": "uint32"},
    "builtin_interfaces/msg/Duration": {"nanosec": "int32"},
}
"""The fields of ROS 1's ``time`` and ``duration`` that rosbags decodes as ROS 2's, with
ROS 1's types (``ros::Time``'s ``uint32_t sec``, ``ros::Duration``'s ``int32_t nsec``)."""


def _decoded_as_ros(store: Any, *, ros1: bool) -> Any:
    """A store that decodes the few primitive types rosbags reads otherwise than ROS does.

    - ROS 2's ``byte`` is an octet, 0 to 255 (``unsigned char`` in C++, ``bytes`` in
      Python), where ROS 1's is a deprecated ``int8``; rosbags decodes both as ``int8``, so
      a ``std_msgs/msg/Byte`` of 200 read as -56, silently.
    - ROS 1's ``time`` holds its seconds in a ``uint32`` and ``duration`` its nanoseconds in
      an ``int32``; rosbags reads them as ROS 2's ``Time`` and ``Duration`` (``int32``
      seconds, ``uint32`` nanoseconds), so ``ros::TIME_MAX``'s seconds, or a stamp past
      2038, read negative and a duration's -5 ns as 4294967291 ns.

    Such fields are registered with ROS's types in a store of their own (``store`` itself
    when it has none); the type hash (RIHS01 or MD5) the log's is compared with stays that
    of the definition as written (:data:`_WRITTEN`, :func:`digest_problem`).
    """
    from rosbags.typesys.store import Typestore

    def as_ros(name: str, field: str, desc: Any) -> Any:
        if not ros1:
            return _unsigned(desc)
        kind = _ROS1_TIMES.get(name, {}).get(field)
        return desc if kind is None else (desc[0], (kind, *desc[1][1:]))

    types = {
        name: (constants, [(field, as_ros(name, field, desc)) for field, desc in defined])
        for name, (constants, defined) in store.fielddefs.items()
    }
    if all(types[name][1] == list(defined) for name, (_, defined) in store.fielddefs.items()):
        return store
    decoding = Typestore()  # not get_typestore(Stores.EMPTY): it holds ROS 2's Time
    decoding.register(types)
    _WRITTEN[decoding] = store
    return decoding


def _unsigned(desc: Any) -> Any:
    """A field's description with ``byte`` elements made ``uint8`` (:func:`_decoded_as_ros`)."""
    node = int(desc[0])
    if node == 1 and desc[1][0] == "byte":
        return (desc[0], ("uint8", *desc[1][1:]))
    if node in (3, 4):
        return (desc[0], (_unsigned(desc[1][0]), *desc[1][1:]))
    return desc


def _message_type(desc: Any) -> str | None:
    """The message type a field holds (itself, or as array elements), or ``None``."""
    node = int(desc[0])
    if node == 2:
        return str(desc[1])
    if node in (3, 4) and int(desc[1][0][0]) == 2:
        return str(desc[1][0][1])
    return None


def structure_problem(typedefs: Typedefs, msgtype: str) -> str | None:
    """Why ``msgtype``'s messages cannot be decoded with ``typedefs``, or ``None``.

    A field of a type defined nowhere (a stored definition or a ``--msg-dir`` file that
    uses a type it does not define, which rosbags registers all the same) made the topic
    list no fields and count no values, and naming such a field ended in a ``KeyError``; a
    type that contains itself, even through an array, sends rosbags' decoder into endless
    recursion.  Named with the field path from ``msgtype``.
    """
    done: set[str] = set()

    def walk(name: str, path: str, within: tuple[str, ...]) -> str | None:
        if name in within:
            return f"type {name!r} contains itself (field {path}), which cannot be decoded"
        if name in done:
            return None
        if name not in typedefs:
            return (
                f"field {path} has type {name!r}, which has no definition in the log or the "
                f"standard types; pass --msg-dir DIR with {name}.msg in it"
            )
        for field, desc in typedefs[name][1]:
            inner = _message_type(desc)
            if inner is not None:
                found = walk(inner, f"{path}.{field}" if path else field, (*within, name))
                if found is not None:
                    return found
        done.add(name)
        return None

    return walk(msgtype, "", ())


def digest_problem(
    store: Any, msgtype: str, digest: str, *, ros1: bool, stored: bool = True
) -> str | None:
    """Why a stored type hash does not fit the definition used, or ``None``.

    ROS 1 bags store each definition's MD5 sum, ROS 2 bags (Iron and later) a ``RIHS01_``
    type hash; a mismatch means the definition is not the one the messages were written with.
    ``stored``: the definition is the log's own; else it came from ``--msg-dir`` or the
    standard types (the log stores only the hash), and the message says so.
    """
    if not digest or (not ros1 and not digest.startswith("RIHS01_")):
        return None
    try:
        written = _WRITTEN.get(store, store)
        have = written.generate_msgdef(msgtype)[1] if ros1 else written.hash_rihs01(msgtype)
    except Exception:  # a hash rosbags cannot compute is no evidence either way
        return None
    if have == digest:
        return None
    if stored:
        return (
            f"its stored message definition does not match its type hash "
            f"({excerpt(digest, 24)}); the messages were written with another definition"
        )
    return (
        f"the log stores no message definition, and the one from --msg-dir or the standard "
        f"types does not match its type hash ({excerpt(digest, 24)}); pass --msg-dir DIR with "
        f"the {msgtype}.msg the messages were written with"
    )
