"""An MCAP file's message indexes against the chunks they follow (https://mcap.dev/spec, "Message Index").

After each chunk a writer may put one Message Index record per channel that has messages in it: the channel id and
each message's log time [ns] and offset [bytes] from the start of the chunk's uncompressed records. Seeking
readers (Foxglove, the MCAP libraries' indexed views) find messages through them, reached by the summary's chunk
index (``message_index_offsets``, ``message_index_length``): an index that leaves a message out, or places it at
another time or offset, hides or misplaces it for them while a walk of the chunks sees it unchanged.

:class:`MessageIndexes` follows the walk of :mod:`.mcap_file` and names what is wrong (empty when nothing is):
a message index must directly follow its chunk or another index of it, once per channel, and list exactly that
channel's messages in the chunk (in any order); in a file with message indexes every channel's messages in every
chunk are indexed (a file without any passes: the format makes them optional); each chunk's index offsets and
length are kept for its chunk index (:func:`.mcap_summary.chunk_index_problem`).
"""
from __future__ import annotations

import struct

_HEAD = struct.Struct('<HI')     # channel id u16, byte length of the entries u32
_ENTRY = struct.Struct('<QQ')    # log time u64, offset u64
_MESSAGE_HEAD = struct.Struct('<HIQ')  # a message's channel id, sequence, log time


class MessageIndexes:
    """The message indexes of one MCAP file as walked (module docstring)."""

    def __init__(self) -> None:
        self.messages: dict[int, list[tuple[int, int]]] = {}  # of the last chunk: channel -> (log time, offset)
        self.indexed: set[int] = set()     # channels indexed after the last chunk
        self.chunk_start = -1              # the last chunk's file offset (-1: none yet)
        self.follow = -1                   # where a message index of the last chunk may start (-1: none may)
        self.chunk_end = 0
        #: Per chunk walked: its index records' (channel, file offset) pairs, sorted, and their length [bytes].
        self.per_chunk: list[tuple[tuple[tuple[int, int], ...], int]] = []
        self.any = False
        self.unindexed = ''                # the first chunk with a channel's messages in no index

    def chunk(self, start: int, end: int) -> None:
        """A chunk record from file offset ``start`` to ``end``."""
        self._close()
        self.messages, self.indexed = {}, set()
        self.chunk_start, self.follow, self.chunk_end = start, end, end
        self.per_chunk.append(((), 0))

    def message(self, record: memoryview, offset: int) -> None:
        """A message record (its body) at ``offset`` in the current chunk's uncompressed records."""
        cid, _, log_time = _MESSAGE_HEAD.unpack_from(record)
        self.messages.setdefault(cid, []).append((log_time, offset))

    def other(self) -> None:
        """A record that is neither a chunk nor a message index: no index may follow it."""
        self.follow = -1

    def index(self, start: int, end: int, body: memoryview, in_summary: bool) -> str:
        """A Message Index record from file offset ``start`` to ``end`` with ``body``: what is wrong with it."""
        if in_summary or start != self.follow:
            return 'message index that does not follow a chunk or its message indexes (allowed: right after its chunk)'
        if len(body) < _HEAD.size:
            return f'message index of {len(body)} bytes (at least {_HEAD.size})'
        cid, size = _HEAD.unpack_from(body)
        if size != len(body) - _HEAD.size or size % _ENTRY.size:
            return (f'message index entries of {size} bytes in a record with {len(body) - _HEAD.size} after its head '
                    f'(allowed: all of them, {_ENTRY.size} bytes per message)')
        if cid in self.indexed:
            return f'message index of channel {cid} a second time after the chunk at byte {self.chunk_start}'
        listed = sorted(_ENTRY.iter_unpack(body[_HEAD.size:]))
        held = sorted(self.messages.get(cid, []))
        if listed != held:
            first = next((k for k, (a, b) in enumerate(zip(listed, held, strict=False)) if a != b),
                         min(len(listed), len(held)))
            return (f'message index of channel {cid} lists {len(listed)} entries; the chunk at byte {self.chunk_start} '
                    f'holds {len(held)} messages of it (first difference at entry {first} by log time; allowed: each '
                    'message of the channel in the chunk, with its log time and offset)')
        self.indexed.add(cid)
        self.any = True
        self.follow = end
        offsets, _ = self.per_chunk[-1]
        self.per_chunk[-1] = (tuple(sorted((*offsets, (cid, start)))), end - self.chunk_end)
        return ''

    def finish(self) -> str:
        """After the walk: what is wrong with the file's message indexes as a whole."""
        self._close()
        if self.any and self.unindexed:
            return (f'{self.unindexed} is in no message index, while other messages are (allowed: every channel '
                    'of every chunk indexed, or no message index at all)')
        return ''

    def _close(self) -> None:
        missing = sorted(set(self.messages) - self.indexed)
        if missing and not self.unindexed:
            self.unindexed = f'channel {missing[0]} of the chunk at byte {self.chunk_start}'
