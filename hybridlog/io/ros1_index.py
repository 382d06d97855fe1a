"""ROS 1 bags through rosbags' reader, indexing only the topics that are read.

rosbags' ``rosbag1.Reader`` reads, when it opens a bag, the index entry of every message in
it (a named tuple of three Python integers, about 170 bytes a message), whichever topics are
then read: a 3.8 GB bag of 4.4·10^6 messages -- camera images, point clouds, ``tf`` and
twenty more topics beside the eight a model maps -- took 7.4 s and 761 MB to open.
:class:`Ros1Reader` opens with the chunks' message counts alone (the bag's chunk-info
records), and reads the entries of the connections :meth:`Ros1Reader.messages` is asked for
into NumPy arrays (20 bytes a message), from which rosbags' entries are made as it reads.
The messages come in rosbags' own order: each connection's entries stably sorted by time,
in the order they are stored, and merged by time.
"""

from __future__ import annotations

import os
from collections import Counter
from collections.abc import Collection, Generator, Iterator
from typing import cast

import numpy as np
from rosbags.interfaces import Connection
from rosbags.rosbag1 import Reader, ReaderError
from rosbags.rosbag1.reader import Header, IndexData, RecordType, read_bytes, read_uint32

from hybridlog.signals import IntArray

ENTRIES_AT_ONCE = 4096
"""Index entries turned into Python objects at a time, as rosbags reads the messages."""
_ENTRY = np.dtype([("sec", "<u4"), ("nsec", "<u4"), ("offset", "<u4")])


class Ros1Reader(Reader):
    """rosbags' ROS 1 bag reader, reading the index of the connections read only.

    A connection's ``msgcount`` is the sum of the chunks' counts of it (what ``rosbag info``
    shows); the entries found when its messages are read are checked against it by
    :class:`~hybridlog.io.messages.MessageSource`.
    """

    def open(self) -> None:
        """Open the bag: connections and chunks, no index entry (see :meth:`read_index_data`)."""
        super().open()
        counts: Counter[int] = Counter()
        for info in self.chunk_infos:
            counts.update(info.connection_counts)
        self.connections = [c._replace(msgcount=counts[c.id]) for c in self.connections]

    def read_index_data(self, pos: int, indexes: dict[int, list[IndexData]]) -> None:
        """Read nothing: rosbags' ``open`` calls this for every index record of every chunk.

        rosbags seeks to each chunk before reading its index records, so leaving them unread
        leaves its reading of the bag's structure as it was; :meth:`messages` reads them.
        """

    def messages(
        self,
        connections: Collection[Connection] = (),
        start: int | None = None,
        stop: int | None = None,
    ) -> Generator[tuple[Connection, int, bytes], None, None]:
        """The messages of ``connections`` as rosbags reads them, their index read first."""
        chosen = list(connections) or list(self.connections)
        entries = self._index({c.id for c in chosen})
        # rosbags only merges the entries (heapq.merge), which an iterator serves as a list
        self.indexes = {c.id: cast("list[IndexData]", entries[c.id]) for c in chosen}
        return super().messages(chosen, start, stop)

    def _index(self, wanted: set[int]) -> dict[int, Iterator[IndexData]]:
        """Each wanted connection's index entries, in time order (stable), made lazily.

        Raises
        ------
        ReaderError
            For an index record that is cut off or does not hold what its header says.
        """
        assert self.bio is not None
        parts: dict[int, list[tuple[IntArray, int, IntArray]]] = {c: [] for c in wanted}
        for info in self.chunk_infos:
            chunk = self.chunks[info.pos]
            self.bio.seek(chunk.datapos + chunk.datasize)
            for _ in info.connection_counts:
                header = Header.read(self.bio, RecordType.IDXDATA)
                conn, count = header.get_uint32("conn"), header.get_uint32("count")
                size = read_uint32(self.bio)
                if conn not in parts:
                    self.bio.seek(size, os.SEEK_CUR)
                    continue
                if header.get_uint32("ver") != 1 or size != 12 * count:
                    msg = f"index record of the chunk at byte {info.pos} is malformed"
                    raise ReaderError(msg)
                found = np.frombuffer(read_bytes(self.bio, size), dtype=_ENTRY)
                times = found["sec"].astype(np.int64) * 10**9 + found["nsec"]
                parts[conn].append((times, info.pos, found["offset"].astype(np.int64)))
        return {conn: _in_time_order(found) for conn, found in parts.items()}


def _in_time_order(parts: list[tuple[IntArray, int, IntArray]]) -> Iterator[IndexData]:
    """One connection's entries as rosbags sorts them: stably by time, made lazily."""
    if not parts:
        return iter(())
    times = np.concatenate([p[0] for p in parts])
    chunks = np.concatenate([np.full(p[0].size, p[1], dtype=np.int64) for p in parts])
    offsets = np.concatenate([p[2] for p in parts])
    order = np.argsort(times, kind="stable")
    return _made(times[order], chunks[order], offsets[order])


def _made(times: IntArray, chunks: IntArray, offsets: IntArray) -> Iterator[IndexData]:
    """The entries as rosbags' tuples, :data:`ENTRIES_AT_ONCE` converted at a time."""
    for begin in range(0, times.size, ENTRIES_AT_ONCE):
        end = begin + ENTRIES_AT_ONCE
        for entry in zip(
            times[begin:end].tolist(),
            chunks[begin:end].tolist(),
            offsets[begin:end].tolist(),
            strict=True,
        ):
            yield IndexData(*entry)
