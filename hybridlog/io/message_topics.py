"""A topic of a message log, the fields its definition has, and how their paths are spelled.

:class:`Topic` is what a reader of messages says of each topic (its type, encoding, count,
definition and decoder).  Its fields are listed as message paths after the topic name; where
nested topics (``/a`` and ``/a.b``) make one path alike, or where another topic would read it
first, the path is spelled with its topic quoted (:func:`shared_paths`, :func:`spelt_path`).
"""

from __future__ import annotations

import bisect
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from hybridlog.io.json_schemas import json_leaves
from hybridlog.io.message_leaves import deep_leaves
from hybridlog.io.message_paths import FLOAT_TYPES, MessagePath, PathError, Typedefs, split_paths


@dataclass
class Topic:
    """One topic of a message log.

    Attributes
    ----------
    name:
        The topic name, e.g. ``/y1``.
    msgtype:
        Its message type, e.g. ``std_msgs/msg/Float64`` (``""`` when unknown).
    encoding:
        How its messages are serialised: ``"cdr"``, ``"ros1"``, ``"json"`` or another name.
    count:
        How many messages the file's index or summary lists, or ``None`` when it does not say.
    typedefs:
        rosbags field definitions that hold ``msgtype``, when the type's definition is known.
    decode:
        Decodes one serialised message into an object or ``dict`` (fallback path).
    problem:
        Why the topic's messages cannot be decoded (no schema, unknown encoding, no
        definition), or ``None``.
    json_schema:
        The topic's JSON schema, for JSON messages that have one.
    note:
        What ``inspect`` says of a topic whose messages are read nonetheless (a JSON schema
        passed over), or ``None``.
    """

    name: str
    msgtype: str
    encoding: str
    count: int | None = None
    typedefs: Typedefs | None = None
    decode: Callable[[bytes], object] | None = None
    problem: str | None = None
    json_schema: Mapping[str, Any] | None = None
    note: str | None = None

    @property
    def label(self) -> str:
        """``'/y1' (std_msgs/msg/Float64)`` for messages."""
        return f"{self.name!r} ({self.msgtype or 'no type'})"


def shared_paths(leaves: Mapping[str, Sequence[str]]) -> set[str]:
    """Paths of ``{topic: leaves}`` that must be written with their topic quoted.

    Those two topics make alike (``/a`` + ``.b.v``, ``/a.b`` + ``.v``), and those that
    :func:`split_paths` reads on another topic first, as ``--map`` would: ``/a`` + ``.v``
    where the log also has a topic ``/a.v``, and every path of a topic named ``""``.  A listed
    ``[]`` is read as the index it stands for: ``/imu.covariance[]`` beside a topic
    ``/imu_raw`` was quoted, as if no topic read it.
    """
    counts = Counter(name + leaf for name, found in leaves.items() for leaf in set(found))
    shared = {path for path, count in counts.items() if count > 1}
    ordered = sorted(leaves)
    for name, found in leaves.items():
        longer = _extensions(ordered, name)
        if name and not longer:
            continue  # no other topic starts its paths: each reads on it
        # split_paths reads a path on its longest topic first: the topic itself or one
        # that extends it (or, for a name in quotes, the topic it quotes); comparing with
        # these alone kept 20,000 topics from taking 50 s
        near = [name, *longer]
        if name.startswith('"'):
            near.extend(t for t in ordered if name.startswith(f'"{t}"'))
        for leaf in found:
            try:  # as --map takes it: a listed `[]` stands for an index
                first = split_paths(name + leaf.replace("[]", "[0]"), near)[0].topic
            except PathError:
                first = None
            if first != name:
                shared.add(name + leaf)
    return shared


def _extensions(ordered: Sequence[str], name: str) -> list[str]:
    """The topics of sorted ``ordered`` other than ``name`` that start with ``name``."""
    found = []
    at = bisect.bisect_left(ordered, name)
    while at < len(ordered) and ordered[at].startswith(name):
        if ordered[at] != name:
            found.append(ordered[at])
        at += 1
    return found


def spelt_path(topic: str, leaf: str, shared: set[str]) -> str:
    """``topic + leaf``, with the topic quoted (``"/a".b.v``) where another topic makes it too."""
    return f'"{topic}"{leaf}' if topic + leaf in shared else topic + leaf


def foxglove_form(path: MessagePath) -> bool:
    """Whether ``path`` follows its topic with ``.field`` or ``[index]`` (not the ``/`` alias)."""
    text = path.text.strip()
    quoted = f'"{path.topic}"'
    rest = text[len(quoted) :] if text.startswith(quoted) else text[len(path.topic) :]
    return not rest.startswith("/")


def topic_fields(topic: Topic) -> list[str]:
    """The paths (after the topic name) of the numeric and text leaves its definition has."""
    if topic.typedefs is not None and topic.msgtype in topic.typedefs:
        return [leaf.text for leaf in deep_leaves(topic.typedefs, topic.msgtype)]
    if topic.json_schema is not None:
        return json_leaves(topic.json_schema).leaves
    return []


def field_hint(topic: Topic) -> str:
    """How to name a field of ``topic``: an example it has, else why none can be given."""
    fields = topic_fields(topic)
    if topic.typedefs is not None and topic.msgtype in topic.typedefs:
        found = deep_leaves(topic.typedefs, topic.msgtype)
        fields = [leaf.text for leaf in found if leaf.leaf.type_name in FLOAT_TYPES] or fields
    if fields:
        example = topic.name + fields[0].replace("[]", "[0]")
        more = f" ({len(fields)} fields; hybridlog inspect lists them)" if len(fields) > 1 else ""
        return f"add a field, e.g. {example}{more}"
    if topic.encoding == "json":
        return (
            "add a field of its JSON messages (the topic has no JSON schema listing them; "
            "hybridlog inspect lists the fields found in the messages)"
        )
    return f"its type {topic.msgtype or '(unknown)'} has no numeric or text field to map"
