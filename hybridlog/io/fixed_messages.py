"""Messages of one ``float64`` field (``std_msgs/Float64``) read a batch at a time with NumPy.

A log of ``std_msgs/Float64`` topics (what ``simulate`` writes, and many recorders) spent
about a third of its reading in rosbags' deserialiser, called once per message to build an
object that only gave its one number back.  Such a message has a fixed layout: in CDR a
4-byte encapsulation header and the little- or big-endian ``float64`` (12 bytes, the header
saying which); in ROS 1 the 8 bytes of the number.  :func:`single_floats` reads a batch as
one NumPy array when every message has that layout exactly, and returns ``None`` otherwise
(another length, a big-endian header, a definition with other fields): the batch is then
decoded message by message, as before, which names the message that is wrong.  The numbers
are the same bits as rosbags' (``struct``'s ``<d`` and NumPy's ``<f8`` read the same
bytes).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from hybridlog.io.message_paths import BASE, Step, Typedefs
from hybridlog.signals import FloatArray

_SIZES = {"cdr": 12, "ros1": 8}
"""The bytes of a message of one ``float64`` field, per encoding."""

_CDR_LITTLE_ENDIAN = (0, 1)
"""The first two bytes of a little-endian CDR message (rosbags reads ``00 00`` big-endian)."""


def float_field(typedefs: Typedefs | None, msgtype: str) -> str | None:
    """The name of the one field of ``msgtype`` when it is a ``float64``; else ``None``.

    Constants are not serialised, so a definition with constants beside the field counts.
    """
    if typedefs is None or msgtype not in typedefs:
        return None
    fields: Any = typedefs[msgtype][1]
    if len(fields) != 1:
        return None
    name, (node, detail) = fields[0]
    if int(node) != BASE or tuple(detail) != ("float64", 0):
        return None
    return str(name)


def single_floats(
    encoding: str,
    typedefs: Typedefs | None,
    msgtype: str,
    steps: Sequence[Sequence[Step]],
    datas: Sequence[bytes],
) -> FloatArray | None:
    """The numbers of ``datas`` when each of ``steps`` is the one ``float64`` field; or ``None``.

    ``None`` unless ``encoding`` is ``cdr`` (little-endian) or ``ros1``, the definition of
    ``msgtype`` is one ``float64`` field, every path in ``steps`` names that field alone,
    and every message has exactly the layout's bytes: any other batch is decoded message by
    message, where a message that is wrong is named.
    """
    size = _SIZES.get(encoding)
    field = float_field(typedefs, msgtype)
    if size is None or field is None or not steps or any(tuple(s) != (field,) for s in steps):
        return None
    count = len(datas)
    lengths = np.fromiter(map(len, datas), dtype=np.int64, count=count)
    if not bool((lengths == size).all()):
        return None
    block = np.frombuffer(b"".join(datas), dtype=np.uint8).reshape(count, size)
    if encoding == "cdr" and not (
        bool((block[:, 0] == _CDR_LITTLE_ENDIAN[0]).all())
        and bool((block[:, 1] == _CDR_LITTLE_ENDIAN[1]).all())
    ):
        return None
    values: FloatArray = np.ascontiguousarray(block[:, size - 8 :]).view("<f8").reshape(count)
    return values.astype(np.float64)
