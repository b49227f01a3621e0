"""Read one MCAP file (rosbag2's ``mcap`` storage) record by record, every length bounded, every CRC checked.

MCAP (https://mcap.dev/spec) is a sequence of records ``opcode u8, length u64, body`` between two magic
strings; messages sit in *chunks* (optionally zstd or lz4 compressed) with the CRC-32 of their uncompressed
bytes; the *DataEnd* record holds the CRC-32 of the data section (the leading magic and every record before
DataEnd), the *Footer* the CRC-32 of the summary section. A CRC of 0 means "not computed" (allowed by the
format; rosbag2's writer leaves the data-section CRC at 0, and the ``rosbags`` writer every CRC).

:func:`read_mcap` walks the file once from the first byte to the last, so nothing is skipped unchecked:

- every record length must fit in what is left of the file (a flipped length byte is never used to allocate:
  reads are bounded by the file size) and a record is at most :data:`MAX_RECORD_BYTES`;
- a chunk declares its uncompressed size: at most :data:`MAX_CHUNK_BYTES`, and all of a bag's files' at most
  :data:`MAX_INFLATED_BYTES` (checked before each is decompressed), decompressed with an output bound of that
  size, and it must come out exactly that long; its records must tile it exactly; its CRC, the data-section CRC
  and the summary CRC must match when they are not 0;
- a bag's files hold at most :data:`MAX_MESSAGES` messages in all (empty ones are 31 bytes of chunk each);
- messages must reference a channel defined before them, channels a schema, and lie inside their chunk's
  time range; the summary's Statistics must agree with the messages, chunks and time range walked, and its chunk
  indexes (which indexed readers such as ``ros2 bag play`` read instead of the walk) must be one per chunk, each
  with that chunk's offset, length, time range, compression, sizes and message indexes, and its summary offsets
  must each span whole records of their opcode, leaving none of a group out;
- the message indexes after each chunk must list exactly its messages, channel by channel (:mod:`.mcap_index`).

Every violation raises :class:`~gpr_kinematics.bags.errors.BagError` naming the file, the byte offset and
what is wrong. The SHA-256 of the whole file is computed on the way (for the bag's checksums).
"""
from __future__ import annotations

import hashlib
import struct
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import BinaryIO

from .errors import BagError
from .fileio import open_regular
from .mcap_index import MessageIndexes
from .mcap_records import Fields, FormatError, decompress
from .mcap_summary import ChunkFacts, chunk_index_problem, statistics_problem, summary_offset_problem

MAGIC = b'\x89MCAP0\r\n'
#: Largest record accepted (a chunk of a rosbag2 or ``gpr`` recording is about 1 MiB).
MAX_RECORD_BYTES = 256 << 20
#: Largest uncompressed chunk accepted.
MAX_CHUNK_BYTES = 256 << 20
#: Largest sum of the uncompressed chunks of a bag's files (a compressed file of 127 kB held 4 GB of messages; six
#: files of 37 kB, each within a bound per file, 6 GB).
MAX_INFLATED_BYTES = 1 << 30
#: Most messages of a bag's files, every topic's (MCAP and SQLite3 alike): reading one costs some 250 bytes of
#: Python objects however small it is (a 25 kB chunk of 6.6 million empty messages, within the bytes' bound, took
#: 2.15 GB and 23 s to verify), 2 GB at the bound; the sweep's 151,201 messages are 2 % of it.
MAX_MESSAGES = 8_000_000

OP_HEADER, OP_FOOTER, OP_SCHEMA, OP_CHANNEL, OP_MESSAGE, OP_CHUNK = 0x01, 0x02, 0x03, 0x04, 0x05, 0x06
OP_MESSAGE_INDEX, OP_CHUNK_INDEX, OP_STATISTICS = 0x07, 0x08, 0x0B
OP_METADATA, OP_SUMMARY_OFFSET, OP_DATA_END = 0x0C, 0x0E, 0x0F
_FOOTER_LENGTH = 20  # summary_start u64, summary_offset_start u64, summary_crc u32
_RECORD = struct.Struct('<BQ')
_MESSAGE_HEAD = struct.Struct('<HIQQ')  # channel id, sequence, log time, publish time


@dataclass(frozen=True)
class McapChannel:
    """A channel: ``topic``, the message type (its schema's name), the message encoding and the metadata, and its
    schema's encoding and text (the message definition embedded in the file)."""

    id: int
    topic: str
    msgtype: str
    encoding: str
    metadata: tuple[tuple[str, str], ...]
    schema_encoding: str = ''
    schema_text: str = ''

    def meta(self, key: str) -> str:
        return dict(self.metadata).get(key, '')


@dataclass
class McapFile:
    """What :func:`read_mcap` found: channels, the messages (per channel id, in file order), and the checks."""

    path: Path
    size: int
    sha256: str
    profile: str
    channels: dict[int, McapChannel]
    times: dict[int, list[int]] = field(default_factory=dict)
    data: dict[int, list[bytes]] = field(default_factory=dict)
    counts: dict[int, int] = field(default_factory=dict)
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    #: Every ``rosbag2`` metadata record, in file order (rosbag2 writes one per update of the bag's metadata).
    rosbag2: list[dict[str, str]] = field(default_factory=list)
    start: int | None = None
    end: int | None = None
    chunks: int = 0
    chunks_with_crc: int = 0
    data_crc: bool = False
    summary_crc: bool = False
    #: The uncompressed bytes of the chunks, with the bag's files read before (:func:`read_mcap`'s ``inflated``).
    inflated: int = 0
    #: The messages walked, with the bag's files read before (:func:`read_mcap`'s ``messages``).
    messages: int = 0


class _Walker:
    def __init__(self, f: BinaryIO, size: int, path: Path, topics: set[str] | None, inflated: int,
                 messages: int) -> None:
        self.f = f
        self.size = size
        self.pos = 0
        self.sha = hashlib.sha256()
        self.topics = topics
        self.schemas: dict[int, tuple[str, str, str]] = {}   # id -> (name, encoding, text)
        self.out = McapFile(path, size, '', '', {})
        self.summary_start = 0
        self.inflated = self.before = inflated
        self.out.messages = self.messages_before = messages
        self.record_start = 0
        self.chunk_facts: list[tuple[int, int, int, int, str, int, int]] = []   # per chunk walked (with its indexes':
        self.indexes = MessageIndexes()                                            # as a chunk index must name it)
        self.chunk_indexes: list[ChunkFacts] = []   # the chunk indexes of the summary
        self.stats_times: tuple[int, int, int] | None = None   # chunk count, message start, message end
        self.summary_records: list[tuple[int, int]] = []   # (start offset, opcode) of each summary record
        self.summary_offsets: list[tuple[int, int, int]] = []   # (opcode, group start, group length)

    def read(self, n: int) -> memoryview:
        data = self.f.read(n)
        if len(data) != n:
            raise FormatError(f'file ended after {self.pos + len(data)} of {self.size} bytes (changed while read?)')
        self.sha.update(data)
        self.pos += n
        return memoryview(data)

    # -- definitions ------------------------------------------------------------------------------------------
    def schema(self, body: memoryview) -> None:
        r = Fields(body)
        sid = r.u16()
        name = r.string('schema name')
        encoding = r.string('schema encoding')
        text = bytes(r.take(r.u32(), 'schema data')).decode('utf-8', errors='replace')
        if sid == 0:
            raise FormatError('schema id 0 (reserved)')
        if self.schemas.setdefault(sid, (name, encoding, text)) != (name, encoding, text):
            raise FormatError(f'schema {sid} redefined as {name!r} (was {self.schemas[sid][0]!r})')

    def channel(self, body: memoryview) -> None:
        r = Fields(body)
        cid, sid = r.u16(), r.u16()
        topic = r.string('channel topic')
        encoding = r.string('channel message encoding')
        meta = r.string_map('channel metadata')
        if sid not in self.schemas:
            raise FormatError(f'channel {cid} ({topic!r}) refers to schema {sid}, which is not defined before it')
        name, schema_encoding, text = self.schemas[sid]
        ch = McapChannel(cid, topic, name, encoding, meta, schema_encoding, text)
        if self.out.channels.setdefault(cid, ch) != ch:
            raise FormatError(f'channel {cid} redefined ({topic!r})')
        self.out.counts.setdefault(cid, 0)
        if self.topics is None or topic in self.topics:
            self.out.times.setdefault(cid, [])
            self.out.data.setdefault(cid, [])

    def message(self, body: memoryview, lo: int = 0, hi: int = 2**64 - 1) -> None:
        if len(body) < _MESSAGE_HEAD.size:
            raise FormatError(f'message record of {len(body)} bytes (at least {_MESSAGE_HEAD.size})')
        cid, _seq, log_time, _pub = _MESSAGE_HEAD.unpack_from(body)
        if cid not in self.out.channels:
            raise FormatError(f'message on channel {cid}, which is not defined before it')
        if not lo <= log_time <= hi:
            raise FormatError(f'message log time {log_time} outside its chunk [{lo}, {hi}]')
        self.out.counts[cid] += 1
        self.out.messages += 1
        if self.out.messages > MAX_MESSAGES:
            before = (f" (this file's and the {self.messages_before} of the bag's files before it)"
                      if self.messages_before else '')
            raise FormatError(f'more than {MAX_MESSAGES} messages in all{before}; allowed: at most {MAX_MESSAGES} '
                              'per bag')
        if self.out.start is None or log_time < self.out.start:
            self.out.start = log_time
        if self.out.end is None or log_time > self.out.end:
            self.out.end = log_time
        times = self.out.times.get(cid)
        if times is not None:
            times.append(log_time)
            self.out.data[cid].append(bytes(body[_MESSAGE_HEAD.size:]))

    # -- chunks -------------------------------------------------------------------------------------------------
    def chunk(self, body: memoryview) -> None:
        r = Fields(body)
        lo, hi, size, crc = r.u64(), r.u64(), r.u64(), r.u32()
        compression = r.string('chunk compression')
        payload = r.take(r.u64(), 'chunk records')
        if size > MAX_CHUNK_BYTES:
            raise FormatError(f'chunk of {size} uncompressed bytes; allowed: at most {MAX_CHUNK_BYTES}')
        self.inflated += size
        if self.inflated > MAX_INFLATED_BYTES:
            before = f" (this file's and the {self.before} of the bag's files before it)" if self.before else ''
            raise FormatError(f'chunks of more than {MAX_INFLATED_BYTES} uncompressed bytes in all{before}; '
                               f'allowed: at most {MAX_INFLATED_BYTES} per bag')
        raw = decompress(payload, compression, size)
        self.out.chunks += 1
        self.chunk_facts.append((self.record_start, _RECORD.size + len(body), lo, hi, compression, len(payload), size))
        self.indexes.chunk(self.record_start, self.record_start + _RECORD.size + len(body))
        if crc:
            if zlib.crc32(raw) != crc:
                raise FormatError(f'chunk CRC mismatch (stored {crc:#010x}, computed {zlib.crc32(raw):#010x})')
            self.out.chunks_with_crc += 1
        view, pos = memoryview(raw), 0
        while pos < len(view):
            if len(view) - pos < _RECORD.size:
                raise FormatError(f'chunk ends inside a record header ({len(view) - pos} bytes left)')
            op, length = _RECORD.unpack_from(view, pos)
            start, pos = pos, pos + _RECORD.size
            if length > len(view) - pos:
                raise FormatError(f'record of {length} bytes inside a chunk with {len(view) - pos} bytes left')
            rec = view[pos:pos + length]
            pos += length
            if op == OP_MESSAGE:
                self.message(rec, lo, hi)
                self.indexes.message(rec, start)
            elif op == OP_SCHEMA:
                self.schema(rec)
            elif op == OP_CHANNEL:
                self.channel(rec)
            else:
                raise FormatError(f'record opcode {op:#04x} inside a chunk (allowed: schema, channel, message)')

    # -- the file -------------------------------------------------------------------------------------------
    def walk(self) -> McapFile:
        if self.read(8) != MAGIC:
            raise FormatError('not an MCAP file (bad magic)')
        data_crc = zlib.crc32(MAGIC)
        summary_crc = 0
        in_summary = False
        stats: tuple[int, dict[int, int]] | None = None
        first = True
        while True:
            start = self.pos
            head, op, body = self.next_record(first)
            if op == OP_FOOTER:
                self.footer(body, start, in_summary, zlib.crc32(body[:16], zlib.crc32(head, summary_crc)))
                break
            if op == OP_DATA_END:
                self.data_end(body, start, in_summary, data_crc)
                in_summary = True
                continue
            if in_summary:
                summary_crc = zlib.crc32(body, zlib.crc32(head, summary_crc))
                self.summary_records.append((start, op))
            else:
                data_crc = zlib.crc32(body, zlib.crc32(head, data_crc))
            self.record_start = start
            try:
                stats = self.record(op, body, first, in_summary) or stats
            except FormatError as exc:
                raise FormatError(f'record {op:#04x} at byte {start}: {exc}') from None
            first = False
        if self.read(8) != MAGIC:
            raise FormatError('bad end magic')
        if stats is not None:
            self.check_statistics(*stats)
        self.check_summary()
        self.out.sha256 = self.sha.hexdigest()
        self.out.inflated = self.inflated
        return self.out

    def next_record(self, first: bool) -> tuple[memoryview, int, memoryview]:
        """The next record's header bytes, opcode and body; its length bounded by what is left of the file."""
        start = self.pos
        if self.size - start < _RECORD.size + 8:
            raise FormatError(f'no footer before the end of the file (record at byte {start})')
        head = self.read(_RECORD.size)
        op, length = _RECORD.unpack(head)
        if length > self.size - self.pos - 8:
            raise FormatError(f'record {op:#04x} at byte {start} claims {length} bytes; '
                               f'{self.size - self.pos - 8} are left before the end magic')
        if length > MAX_RECORD_BYTES:
            raise FormatError(f'record {op:#04x} at byte {start} of {length} bytes; allowed: at most '
                               f'{MAX_RECORD_BYTES}')
        if first and op != OP_HEADER:
            raise FormatError(f'first record has opcode {op:#04x}, not the header')
        return head, op, self.read(length)

    def data_end(self, body: memoryview, start: int, in_summary: bool, data_crc: int) -> None:
        """The DataEnd record: the data section's CRC (checked when not 0); the summary section starts."""
        if in_summary:
            raise FormatError(f'second data end record at byte {start}')
        stored = Fields(body).u32()
        if stored:
            if stored != data_crc:
                raise FormatError(f'data section CRC mismatch (stored {stored:#010x}, computed {data_crc:#010x})')
            self.out.data_crc = True
        self.summary_start = self.pos

    def check_statistics(self, count: int, per_channel: dict[int, int]) -> None:
        """The Statistics record's message counts (total and per channel) against the messages walked."""
        if count != sum(self.out.counts.values()):
            raise FormatError(f'statistics record counts {count} messages, the chunks hold '
                               f'{sum(self.out.counts.values())}')
        for c, n in self.out.counts.items():
            if per_channel.get(c, 0) != n:   # the same total, counts moved between channels
                raise FormatError(f'statistics record counts {per_channel.get(c, 0)} messages of channel {c}, the '
                                   f'chunks hold {n}')

    def check_summary(self) -> None:
        """The summary's statistics, offsets and chunk indexes against the walk (:mod:`.mcap_summary`)."""
        end = self.size - len(MAGIC) - _FOOTER_LENGTH - _RECORD.size   # the footer record's start
        problem = (statistics_problem(self.stats_times, (self.out.chunks, self.out.start or 0, self.out.end or 0))
                   or summary_offset_problem(self.summary_records, self.summary_offsets, end)
                   or self.indexes.finish()
                   or chunk_index_problem(self.chunk_indexes, [
                       c + i for c, i in zip(self.chunk_facts, self.indexes.per_chunk, strict=True)]))
        if problem:
            raise FormatError(problem)

    def record(self, op: int, body: memoryview, first: bool, in_summary: bool) -> tuple[int, dict[int, int]] | None:
        self.message_index(op, body, in_summary)
        if op == OP_HEADER:
            if not first:
                raise FormatError('a second header record')
            self.out.profile = Fields(body).string('profile')
        elif op == OP_SCHEMA:
            self.schema(body)
        elif op == OP_CHANNEL:
            self.channel(body)
        elif op in (OP_MESSAGE, OP_CHUNK) and in_summary:
            raise FormatError('message data in the summary section')
        elif op == OP_MESSAGE:
            self.message(body)
        elif op == OP_CHUNK:
            self.chunk(body)
        elif op == OP_METADATA:
            r = Fields(body)
            name = r.string('metadata name')
            self.out.metadata[name] = dict(r.string_map('metadata'))
            if name == 'rosbag2':
                self.out.rosbag2.append(self.out.metadata[name])
        elif op in (OP_STATISTICS, OP_SUMMARY_OFFSET, OP_CHUNK_INDEX):
            return self.summary_record(op, body, in_summary)
        return None  # attachments: covered by the CRCs and the walk itself

    def message_index(self, op: int, body: memoryview, in_summary: bool) -> None:
        """A message index checked against its chunk (:mod:`.mcap_index`); any other record but a chunk ends them."""
        if op == OP_MESSAGE_INDEX:
            problem = self.indexes.index(self.record_start, self.pos, body, in_summary)
            if problem:
                raise FormatError(problem)
        elif op != OP_CHUNK:
            self.indexes.other()

    def summary_record(self, op: int, body: memoryview, in_summary: bool) -> tuple[int, dict[int, int]] | None:
        """A Statistics record (its counts returned, its chunk count and times kept), a summary offset or a chunk
        index (kept, for the checks after the walk)."""
        r = Fields(body)
        if op == OP_STATISTICS:
            count = r.u64()
            r.take(2 + 4 * 3, 'statistics counts')
            self.stats_times = (r.u32(), r.u64(), r.u64())
            per = Fields(r.take(r.u32(), 'channel message counts'))
            per_channel: dict[int, int] = {}
            while per.pos < len(per.b):
                cid = per.u16()
                per_channel[cid] = per.u64()
            return count, per_channel
        if op == OP_SUMMARY_OFFSET and in_summary:
            self.summary_offsets.append((int(r.take(1, 'summary offset opcode')[0]), r.u64(), r.u64()))
        elif op == OP_CHUNK_INDEX and in_summary:
            lo, hi, start, length = r.u64(), r.u64(), r.u64(), r.u64()
            pairs = r.take(r.u32(), 'chunk index message index offsets')
            if len(pairs) % 10:
                raise FormatError(f'chunk index message index offsets of {len(pairs)} bytes (allowed: 10 per channel)')
            offsets = tuple(sorted(struct.iter_unpack('<HQ', pairs)))
            index_length = r.u64()
            compression = r.string('chunk index compression')
            self.chunk_indexes.append((start, length, lo, hi, compression, r.u64(), r.u64(), offsets, index_length))
        return None

    def footer(self, body: memoryview, start: int, in_summary: bool, crc: int) -> None:
        if len(body) != _FOOTER_LENGTH or self.pos != self.size - 8:
            raise FormatError(f'footer at byte {start} of {len(body)} bytes, {self.size - self.pos} bytes before the '
                           f'end (a footer is {_FOOTER_LENGTH} bytes followed by the end magic)')
        if not in_summary:
            raise FormatError('no data end record before the footer')
        r = Fields(body)
        summary_start, summary_offset, stored = r.u64(), r.u64(), r.u32()
        has_summary = start > self.summary_start
        if summary_start != (self.summary_start if has_summary else 0) or not (
                summary_offset == 0 or self.summary_start <= summary_offset <= start):
            raise FormatError(f'footer offsets (summary at {summary_start}, offsets at {summary_offset}) do not '
                               f'match the file (summary at {self.summary_start})')
        if stored:
            if stored != crc:
                raise FormatError(f'summary CRC mismatch (stored {stored:#010x}, computed {crc:#010x})')
            self.out.summary_crc = True


def read_mcap(path: Path, topics: set[str] | None = None, inflated: int = 0, messages: int = 0) -> McapFile:
    """Walk the MCAP file ``path`` (see the module docstring); keep the messages of ``topics`` (all if None). The
    bag's files read before it uncompressed ``inflated`` bytes of chunks and held ``messages`` messages
    (:data:`MAX_INFLATED_BYTES` and :data:`MAX_MESSAGES` bound all).

    Raises:
        BagError: not a regular file, not MCAP, truncated (no footer: the writer did not close it) or corrupt.
    """
    f, size = open_regular(path, 'MCAP file')
    with f:
        try:
            if size < 16 or f.read(8) != MAGIC:
                raise BagError(f'{path}: not an MCAP file (bad magic)')
            f.seek(size - 8)
            if f.read(8) != MAGIC:
                raise BagError(f'{path}: truncated MCAP file ({size} bytes, no footer magic): the writer did not '
                               f'close it')
            f.seek(0)
            return _Walker(f, size, path, topics, inflated, messages).walk()
        except FormatError as exc:
            raise BagError(f'{path}: corrupt MCAP file: {exc}') from None
        except OSError as exc:
            raise BagError(f'{path}: cannot be read: {exc.strerror or exc}') from None
