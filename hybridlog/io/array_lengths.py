"""The arrays a mapped message path indexes: of one length in every message, or refused.

``/joint_states.position[0]`` names one joint only while every message lists the same
joints.  Two publishers on one topic (an arm's three joints and a gripper's one, both on
``/joint_states``) or a set of joints that grows make element 0 one signal in one message and
another in the next: read by index, the two were one series, without a word.  A Parquet list
read by index is held to one length in every row (:mod:`hybridlog.io.table_paths`); a message
array is held to the same by :class:`ArrayLengths`, which names the topic's first message and
the first whose array differs from it.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from hybridlog.io.message_paths import PathError, Step, accessor, evaluate, format_steps
from hybridlog.io.source import format_ns
from hybridlog.signals import IntArray

ABSENT = -1
"""The length recorded for a message without the array (a JSON message leaving it out)."""


class ArrayLengths:
    """The lengths of the arrays a path indexes, each held to the topic's first message's.

    Attributes
    ----------
    arrays:
        The steps to each array the path indexes (``("position",)`` for ``position[2]``).
    getters:
        For each array, a function giving its length in a message (:data:`ABSENT`: none).
    """

    def __init__(self, steps: Sequence[Step]) -> None:
        self.arrays = tuple(tuple(steps[:at]) for at, s in enumerate(steps) if isinstance(s, int))
        self.getters = tuple(_length_of(array) for array in self.arrays)
        self._first: list[tuple[int, int] | None] = [None] * len(self.arrays)

    def of(self, message: object) -> tuple[int, ...]:
        """The length of each array in ``message`` (:data:`ABSENT` where it has none)."""
        return tuple(get(message) for get in self.getters)

    def of_each(self, messages: Sequence[object]) -> IntArray:
        """The lengths of the arrays in each of ``messages``, a row a message."""
        lengths = np.empty((len(messages), len(self.arrays)), dtype=np.int64)
        for row, message in enumerate(messages):
            lengths[row] = self.of(message)
        return lengths

    def check(self, lengths: IntArray, times: Sequence[int]) -> str | None:
        """Why the messages logged at ``times`` cannot be read by index, else ``None``.

        ``lengths`` holds a row a message (:meth:`of_each`), ``times`` their log times; the
        first message with each array, seen in any earlier call, sets that array's length.
        """
        for column, array in enumerate(self.arrays):
            found = lengths[:, column]
            held = np.flatnonzero(found != ABSENT)
            if held.size == 0:
                continue
            first = self._first[column]
            if first is None:
                first = self._first[column] = (int(found[held[0]]), int(times[held[0]]))
            odd = held[found[held] != first[0]]
            if odd.size:
                row = int(odd[0])
                name = format_steps(array)
                return (
                    f"{name} holds {_elements(int(found[row]))} in the message logged at "
                    f"t={format_ns(int(times[row]))} s, but {_elements(first[0])} in the "
                    f"topic's first, logged at t={format_ns(first[1])} s: an index names one "
                    "signal only in arrays of one length in every message (two publishers "
                    "on one topic, or a set of joints that changed?)"
                )
        return None


def _length_of(array: Sequence[Step]) -> Callable[[object], int]:
    get = accessor(array)

    def length(message: object) -> int:
        try:
            return len(get(message))  # type: ignore[arg-type]
        except (AttributeError, IndexError, KeyError, TypeError):
            pass  # a JSON message (a dict), or one without the array
        try:
            return len(evaluate(message, array))  # type: ignore[arg-type]
        except (PathError, TypeError):
            return ABSENT  # the path's reading says what is wrong with such a message

    return length


def _elements(count: int) -> str:
    return f"{count} element{'' if count == 1 else 's'}"
