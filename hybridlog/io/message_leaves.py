"""The numeric and text leaves of ROS messages, inside arrays of messages too, and their values.

:func:`~hybridlog.io.message_paths.leaves` stops at an array of messages; ``inspect`` lists and
counts the leaves of its elements as well (``/tf.transforms[].transform.translation.x``):
:func:`deep_leaves` finds them in a definition, :func:`array_elements` and
:func:`message_leaf_values` read them from decoded messages, :func:`first_unheld` finds an
integer a float64 does not hold.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from hybridlog.io.exact import inexact
from hybridlog.io.message_paths import (
    ARRAY,
    NAME,
    SEQUENCE,
    Leaf,
    PathError,
    Typedefs,
    accessor,
    as_float_array,
    evaluate,
    format_steps,
    leaf_value,
    leaves,
)
from hybridlog.signals import FloatArray

WIDE_INTEGER_TYPES = frozenset(("int64", "uint64"))
"""ROS integer types whose values may lie beyond 2^53, which a ``float64`` does not hold."""


def first_unheld(messages: list[object], leaf: DeepLeaf) -> tuple[int, str] | None:
    """The first of ``messages`` whose ``leaf`` holds an integer a float64 does not hold.

    Its row and why (:func:`~hybridlog.io.exact.inexact`); ``None`` when there is none.
    """
    for row, message in enumerate(messages):
        for element in array_elements([message], leaf.arrays):
            value = evaluate(element, leaf.leaf.steps)  # as decoded: ints, not floats
            items = np.ravel(np.asarray(value)).tolist() if leaf.leaf.array else [value]
            for item in items:
                reason = inexact(item)
                if reason is not None:
                    return row, reason
    return None


def message_leaf_values(messages: list[object], leaf: Leaf) -> FloatArray:
    """The numbers of ``leaf`` in decoded messages, arrays concatenated, as ``float64``."""
    get = accessor(leaf.steps)
    try:
        if not leaf.array:
            return np.fromiter(map(get, messages), dtype=np.float64, count=len(messages))
        parts = [as_float_array(get(message)) for message in messages]
    except (AttributeError, IndexError, KeyError, TypeError, ValueError, PathError):
        # the careful path: renamed fields (``from_``) and containers of other decoders
        parts = [np.asarray(leaf_value(m, leaf.steps), dtype=np.float64) for m in messages]
    return np.concatenate([np.ravel(part) for part in parts]) if parts else np.zeros(0)


@dataclass(frozen=True)
class DeepLeaf:
    """A numeric or text leaf of a ROS message, possibly inside arrays of messages.

    ``arrays``: the steps to each array of messages on the way to it (from the message, then
    from an element of the array before), every element followed; ``leaf``: the leaf in the
    innermost element (in the message itself when ``arrays`` is empty).
    """

    arrays: tuple[tuple[str, ...], ...]
    leaf: Leaf

    @property
    def text(self) -> str:
        """The path after the topic, e.g. ``.transforms[].transform.translation.x``."""
        return "".join(format_steps(steps) + "[]" for steps in self.arrays) + self.leaf.text


def deep_leaves(typedefs: Typedefs, msgtype: str) -> list[DeepLeaf]:
    """The numeric and text leaves of ``msgtype``, inside arrays of messages too.

    :func:`~hybridlog.io.message_paths.leaves` stops at an array of messages (a path into one
    takes an index); the leaves of its elements are fields all the same (listed with ``[]``,
    ``/tf.transforms[].transform.translation.x``) and ``inspect`` counts their values.  An
    element type already on the way is not followed into itself.
    """
    out: list[DeepLeaf] = []

    def walk(type_name: str, arrays: tuple[tuple[str, ...], ...], within: frozenset[str]) -> None:
        out.extend(DeepLeaf(arrays, leaf) for leaf in leaves(typedefs, type_name))
        for steps, element in _message_arrays(typedefs, type_name):
            if element not in within:
                walk(element, (*arrays, steps), within | {element})

    walk(msgtype, (), frozenset({msgtype}))
    return out


def _message_arrays(typedefs: Typedefs, msgtype: str) -> list[tuple[tuple[str, ...], str]]:
    """Steps to, and element type of, every array of messages in ``msgtype`` (not in arrays)."""
    out: list[tuple[tuple[str, ...], str]] = []

    def walk(type_name: str, prefix: tuple[str, ...], within: frozenset[str]) -> None:
        if type_name in within or type_name not in typedefs:
            return
        within = within | {type_name}
        for name, desc in typedefs[type_name][1]:
            node = int(desc[0])
            if node == NAME:
                walk(desc[1], (*prefix, name), within)
            elif node in (ARRAY, SEQUENCE) and int(desc[1][0][0]) == NAME:
                out.append(((*prefix, name), str(desc[1][0][1])))

    walk(msgtype, (), frozenset())
    return out


def array_elements(messages: list[object], arrays: tuple[tuple[str, ...], ...]) -> list[object]:
    """Every element of the arrays of messages ``arrays`` lead to in ``messages``, in order."""
    items = messages
    for steps in arrays:
        found: list[object] = []
        for item in items:
            value = evaluate(item, steps)
            if not isinstance(value, Sequence) or isinstance(value, str):
                raise PathError(f"{format_steps(steps)} is not an array of messages")
            found.extend(value)
        items = found
    return items
