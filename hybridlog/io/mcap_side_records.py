"""What an MCAP file holds beside its messages: attachments and metadata records.

The MCAP specification's Attachment records (a calibration file, a URDF, a video) and
Metadata records (string pairs under a name: a robot's serial number, a run's settings) are
not messages and no estimator reads them, but a user inspecting a log wants to know they are
there.  ``hybridlog inspect`` lists them (:func:`describe_side_records`); ``analyze`` passes
over them.  A finished file's data section is walked record by record for them
(:meth:`SideRecords.walk`); a file read sequentially (unfinished, ``--recover``, or a summary
that disagrees with its data section) has them collected as its records go by
(:meth:`SideRecords.add`).
"""

from __future__ import annotations

import io
import os
import struct
from dataclasses import dataclass, field
from typing import IO, Any

from hybridlog.io.definitions import library_reason
from hybridlog.io.formats import MCAP_MAGIC
from hybridlog.io.source import seconds_of


@dataclass
class SideRecords:
    """The attachments and metadata records of one MCAP file, as ``inspect`` gives them.

    ``attachments``: per record ``name``, ``media_type``, ``bytes`` (the data's size) and
    ``log_time`` (seconds, as the topics' times).  ``metadata``: per record ``name`` and
    ``entries`` (its key-value pairs, in the record's order).  ``problem``: where the
    records could not be walked, if they could not.
    """

    attachments: list[dict[str, Any]] = field(default_factory=list)
    metadata: list[dict[str, Any]] = field(default_factory=list)
    problem: str | None = None

    def add(self, record: Any) -> None:
        """Keep ``record`` if it is an Attachment or a Metadata record (a sequential read)."""
        from mcap.records import Attachment, Metadata

        if isinstance(record, Attachment):
            self.attachments.append(
                _attachment(record.name, record.media_type, len(record.data), record.log_time)
            )
        elif isinstance(record, Metadata):
            self.metadata.append({"name": record.name, "entries": dict(record.metadata)})

    @classmethod
    def walk(cls, handle: IO[bytes]) -> SideRecords:
        """The attachments and metadata records of a finished file's data section.

        The section's top-level records are walked by their opcode and length, every other
        record (a chunk, a message, an index) skipped by a seek, and an attachment's data
        too: only its header is read.  A summary's ``AttachmentIndex`` and ``MetadataIndex``
        records are optional (a file may carry attachments and index none: the conformance
        suite's ``OneAttachment-st-sum.mcap``), so they are not what is listed.  A record
        whose length runs past the file's end, or that cannot be parsed, ends the walk with
        a ``problem``: the messages, read through the summary's indexes, are not affected.
        """
        from mcap.data_stream import ReadDataStream
        from mcap.opcode import Opcode
        from mcap.records import Metadata

        side = cls()
        size = handle.seek(0, os.SEEK_END)
        position = len(MCAP_MAGIC)
        try:
            while position + _RECORD_HEAD.size <= size:
                handle.seek(position)
                opcode, length = _RECORD_HEAD.unpack(handle.read(_RECORD_HEAD.size))
                content = position + _RECORD_HEAD.size
                if opcode in (Opcode.DATA_END, Opcode.FOOTER):
                    break
                if content + length > size:
                    side.problem = (
                        f"the record at byte {position} runs past the file's end: attachments "
                        "and metadata records after it are not listed"
                    )
                    break
                if opcode == Opcode.ATTACHMENT:
                    stream = ReadDataStream(handle)
                    log_time = stream.read8()
                    stream.read8()  # create time
                    name = stream.read_prefixed_string()
                    media_type = stream.read_prefixed_string()
                    side.attachments.append(_attachment(name, media_type, stream.read8(), log_time))
                elif opcode == Opcode.METADATA:
                    record = Metadata.read(ReadDataStream(io.BytesIO(handle.read(length))))
                    side.metadata.append({"name": record.name, "entries": dict(record.metadata)})
                position = content + length
        except Exception as err:  # bytes the mcap library's parsers refuse
            side.problem = (
                f"the record at byte {position} cannot be read ({library_reason(err)}): "
                "attachments and metadata records after it are not listed"
            )
        return side

    def describe(self) -> dict[str, Any]:
        """The keys ``inspect`` adds to an MCAP file's description."""
        return {"attachments": self.attachments, "metadata_records": self.metadata}


# a record's opcode (one byte) and the length of its content (uint64, little-endian)
_RECORD_HEAD = struct.Struct("<BQ")


def _attachment(name: str, media_type: str, size: int, log_time: int) -> dict[str, Any]:
    return {
        "name": name,
        "media_type": media_type,
        "bytes": size,
        "log_time": seconds_of(log_time),
    }
