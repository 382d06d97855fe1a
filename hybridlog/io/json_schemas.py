"""What a JSON message's schema says: the type of a path, its leaves, its required keys.

MCAP's ``json`` encoding may carry a JSON schema per topic (:func:`parse_json_schema`); a
mapped path is checked against it before reading (:func:`json_kind`), its fields are listed
for ``inspect`` (:func:`json_leaves`, no deeper than :data:`MAX_JSON_DEPTH`), and a message
without a key it lists as ``required`` is refused (:func:`json_required`).  A key an object's
``properties`` do not list is the messages' to say, unless the object is closed
(``"additionalProperties": false``), as JSON Schema has it.  A local ``$ref`` is followed
where a path is checked (``#/definitions/Pose``, ``#/$defs/Pose``), not where the fields are
listed.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from hybridlog.io.message_paths import PathError, Step, format_steps, no_field, spell_field

MAX_JSON_DEPTH = 256
"""Nesting of a JSON message or schema (objects and arrays) that ``inspect`` walks; deeper
is reported as a problem of the topic, never cut silently.  Real documents are a few levels
deep; this guards the walk (Python's recursion) against a pathological one."""


def json_required(schema: Mapping[str, Any], steps: Sequence[Step]) -> bool:
    """Whether a JSON schema lists the last key of ``steps`` as ``required`` in its object."""
    node: Any = schema
    for depth, step in enumerate(steps):
        node = _resolved(schema, node)
        if not isinstance(node, Mapping):
            return False
        if isinstance(step, int):
            node = node.get("items")
            continue
        required = node.get("required")
        if depth == len(steps) - 1:
            return isinstance(required, list) and step in required
        properties = node.get("properties")
        node = properties.get(step) if isinstance(properties, Mapping) else None
    return False


MAX_REFS = 32
"""``$ref`` hops followed from one node: a schema whose references loop is not followed."""


def _resolved(schema: Mapping[str, Any], node: object) -> object:
    """``node`` with its local ``$ref`` (``#/definitions/Pose``, ``#/$defs/Pose``) followed.

    The keys beside ``$ref`` are kept over the target's.  A reference into another document,
    one that names nothing, or a loop leaves the node as it is (the schema then says nothing
    of what lies below it, and the messages decide).
    """
    for _ in range(MAX_REFS):
        if not isinstance(node, Mapping) or not isinstance(node.get("$ref"), str):
            return node
        target: object = schema
        reference: str = node["$ref"]
        if not reference.startswith("#"):
            return node
        for part in reference[1:].split("/")[1:]:
            key = part.replace("~1", "/").replace("~0", "~")
            target = target.get(key) if isinstance(target, Mapping) else None
        if not isinstance(target, Mapping):
            return node
        node = {**target, **{k: v for k, v in node.items() if k != "$ref"}}
    return node


def parse_json_schema(data: bytes) -> Mapping[str, Any] | None:
    """A JSON schema as a dict, or ``None`` when it is empty or not JSON."""
    try:
        schema = json.loads(data) if data else None
    except (ValueError, UnicodeDecodeError):
        return None
    return schema if isinstance(schema, dict) else None


def unread_schema(data: bytes) -> str | None:
    """Why a topic's JSON schema is passed over (not JSON, nor a schema), or ``None``.

    An empty schema says nothing, nor does ``true`` or ``false`` (JSON Schema's own), an
    object is read (:func:`parse_json_schema`); anything else was passed over in silence,
    its ``required`` keys with it.
    """
    try:
        schema = json.loads(data) if data else None
    except (ValueError, UnicodeDecodeError) as err:
        return f"its JSON schema is not JSON ({err})"
    if schema is None or isinstance(schema, dict | bool):
        return None
    kind = (
        "array" if isinstance(schema, list) else "string" if isinstance(schema, str) else "number"
    )
    return f"its JSON schema is a JSON {kind}, not an object"


def json_kind(schema: Mapping[str, Any], steps: Sequence[Step]) -> str | None:
    """What ``steps`` name in a JSON schema, or ``None`` where the schema does not say."""
    return {
        "number": "number",
        "integer": "number",
        "boolean": "number",
        "string": "string",
        "object": "message",
        "array": "array",
    }.get(str(json_type(schema, steps)))


def json_type(schema: Mapping[str, Any], steps: Sequence[Step]) -> str | None:
    """The JSON type a schema gives ``steps`` (``"integer"``, ...), or ``None`` if none.

    Raises
    ------
    PathError
        Where ``steps`` index what is no array, or name a key a closed object (its
        ``additionalProperties`` false) does not list.
    """
    node: Any = schema
    done: list[Step] = []
    for step in steps:
        node = _resolved(schema, node)
        if not isinstance(node, Mapping):
            return None
        if isinstance(step, int):
            if node.get("type") not in ("array", None) and "items" not in node:
                raise PathError(f"{format_steps(done) or 'the message'} is not an array")
            node = node.get("items")
        else:
            properties = node.get("properties")
            if not isinstance(properties, Mapping):
                return None
            if step not in properties:
                if node.get("additionalProperties", True) is not False:
                    return None  # the messages may hold keys the schema does not list
                names = [spell_field(str(k)) for k in properties]
                raise no_field(format_steps(done) or "the message", step, names)
            node = properties[step]
        done.append(step)
    node = _resolved(schema, node)
    if not isinstance(node, Mapping):
        return None
    kind = node.get("type")
    if isinstance(kind, list):
        kind = next((k for k in kind if k != "null"), None)
    return None if kind is None else str(kind)


@dataclass(frozen=True)
class _JsonLeaves:
    """The leaves a JSON schema lists, and where it nests too deep to follow (or ``None``)."""

    leaves: list[str]
    too_deep: str | None


def json_leaves(schema: Mapping[str, Any]) -> _JsonLeaves:
    """The numeric and text leaves of a JSON schema's objects, at any depth.

    Arrays of numbers, booleans or text are leaves (``.name[]``), as a single one is; the
    leaves of arrays of objects are listed
    with ``[]`` where a path takes an index (``.poses[].x``), as for ROS messages.  Objects
    nested deeper than :data:`MAX_JSON_DEPTH` are not followed, and the first such path is
    returned.  A ``$ref`` is not followed (a recursive schema would list without end): the
    fields below one are those found in the messages.
    """
    out: list[str] = []
    too_deep: str | None = None

    def walk(node: Mapping[str, Any], prefix: str, depth: int) -> None:
        nonlocal too_deep
        properties = node.get("properties")
        if not isinstance(properties, Mapping):
            return
        if depth > MAX_JSON_DEPTH:
            too_deep = too_deep or prefix or "the message"
            return
        for name, child in properties.items():
            if not isinstance(child, Mapping):
                continue
            kind = child.get("type")
            if kind in ("number", "integer", "boolean", "string"):
                out.append(f"{prefix}.{spell_field(name)}")
            elif kind == "object":
                walk(child, f"{prefix}.{spell_field(name)}", depth + 1)
            elif kind == "array":
                items = child.get("items")
                if not isinstance(items, Mapping):
                    continue
                if items.get("type") in ("number", "integer", "boolean", "string"):
                    out.append(f"{prefix}.{spell_field(name)}[]")
                elif items.get("type") == "object":
                    walk(items, f"{prefix}.{spell_field(name)}[]", depth + 1)

    walk(schema, "", 0)
    return _JsonLeaves(out, too_deep)
