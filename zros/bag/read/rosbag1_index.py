"""Indexed ROS 1 bags without their message index in memory.

rosbags' reader keeps the index entry of every message of a bag from the moment it opens it
(about 165 bytes each: 150 MB for a million messages, before a message is read).
:class:`IndexedBag1` reads and checks those entries at opening as rosbags does, then drops
them; a read takes each chunk's entries again when it reaches the chunk
(:func:`~zros.bag.read.rosbag1_scan.indexed_messages`). Imported by the ROS 1 source when it
opens a bag (it imports rosbags).
"""

from __future__ import annotations

from collections import Counter, defaultdict

from rosbags.rosbag1 import Reader
from rosbags.rosbag1.reader import IndexData


class IndexedBag1(Reader):
    """rosbags' reader of an indexed ROS 1 bag that keeps no message index (see the module
    docstring); the connections' message counts come from the chunks' summaries."""

    def open(self) -> None:
        """Open the bag: read its connections and chunk summaries, check its indexes."""
        super().open()
        counts: Counter[int] = Counter()
        for info in self.chunk_infos:
            counts.update(info.connection_counts)
        self.connections = [c._replace(msgcount=counts[c.id]) for c in self.connections]
        self.infos = {info.pos: info for info in self.chunk_infos}  #: chunk summaries by position
        #: the byte offset of the first chunk holding messages of each connection id
        self.first_chunk: dict[int, int] = {}
        for info in sorted(self.chunk_infos, key=lambda info: info.pos):
            for cid in info.connection_counts:
                self.first_chunk.setdefault(cid, info.pos)
        self.position = 0  #: the byte offset of the chunk of the message a read handed on last

    def read_index_data(self, pos: int, indexes: dict[int, list[IndexData]]) -> None:
        """Read (and so check) the index record at the stream's position; keep nothing."""
        super().read_index_data(pos, defaultdict(list))

    def chunk_index(self, position: int) -> dict[int, list[IndexData]]:
        """The index entries of the chunk at byte ``position``, by connection id, in time
        order; they follow the chunk, one record per connection the chunk holds."""
        assert self.bio is not None, 'the bag is not open'
        info = self.infos[position]
        chunk = self.chunks[position]
        self.bio.seek(chunk.datapos + chunk.datasize)
        found: dict[int, list[IndexData]] = defaultdict(list)
        for _ in info.connection_counts:
            super().read_index_data(position, found)
        return {cid: sorted(entries) for cid, entries in found.items()}
