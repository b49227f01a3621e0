"""An MCAP file's summary against what the walk of :mod:`.mcap_file` found: the statistics, the chunk indexes and
the summary offsets, by which indexed and seeking readers (``ros2 bag play``, the ``mcap`` library) read a file
instead of walking it. Each function returns what is wrong (empty when nothing is); the reader raises it."""
from __future__ import annotations

#: A chunk as its index names it: (start offset, record length, message start time, message end time [ns],
#: compression, compressed size, uncompressed size [bytes], its message indexes' (channel, offset) pairs sorted and
#: their length [bytes]).
ChunkFacts = tuple[int, int, int, int, str, int, int, tuple[tuple[int, int], ...], int]

_NAMES = ('start offset', 'length', 'message start time', 'message end time', 'compression', 'compressed size',
          'uncompressed size', 'message index offsets', 'message index length')


def statistics_problem(said: tuple[int, int, int] | None, walked: tuple[int, int, int]) -> str:
    """The Statistics record's chunk count and first and last log time [ns] (None: no record) against the walk's
    (its message counts are compared while reading)."""
    if said is None or said == walked:
        return ''
    return (f'statistics record says {said[0]} chunks and messages from {said[1]} to {said[2]} ns; the file holds '
            f'{walked[0]} chunks and messages from {walked[1]} to {walked[2]} ns')


def chunk_index_problem(indexes: list[ChunkFacts], chunks: list[ChunkFacts]) -> str:
    """The summary's chunk indexes (if any) against the chunks walked: one per chunk, in order, each naming that
    chunk's values (an indexed reader reads through them: a chunk left out, or a time range narrowed, hides its
    messages from it but not from the walk)."""
    if not indexes or indexes == chunks:
        return ''
    if len(indexes) != len(chunks):
        return (f'the summary indexes {len(indexes)} chunks; the file holds {len(chunks)} (allowed: one chunk index '
                'per chunk, or none)')
    k, (index, chunk) = next((k, ic) for k, ic in enumerate(zip(indexes, chunks, strict=True)) if ic[0] != ic[1])
    f = next(j for j in range(len(_NAMES)) if index[j] != chunk[j])
    return (f'chunk index {k} says {_NAMES[f]} {index[f]!r}; the chunk at byte {chunk[0]} has {chunk[f]!r} '
            '(allowed: the chunk index of a chunk names its own values)')


def summary_offset_problem(records: list[tuple[int, int]], offsets: list[tuple[int, int, int]], end: int) -> str:
    """Each summary offset ``(opcode, group start, group length)`` against the summary's ``records`` ``(start,
    opcode)`` (``end``: where the last one ends, the footer): it must span whole records of its opcode, and the
    offsets every record of an opcode they name (a seeking reader finds a group through them: an offset that
    leaves out a chunk index hides that chunk from it)."""
    if not offsets:
        return ''
    ends = [s for s, _ in records[1:]] + [end]
    spans = {s: (op, e) for (s, op), e in zip(records, ends, strict=True)}
    named: set[int] = set()
    for op, start, length in offsets:
        pos = start
        while pos < start + length and pos in spans and spans[pos][0] == op:
            named.add(pos)
            pos = spans[pos][1]
        if pos != start + length:
            return (f'summary offset of opcode {op:#04x} spans bytes {start} to {start + length}, not whole records '
                    'of that opcode (allowed: a group of the summary section)')
    grouped = {op for op, _, _ in offsets}
    left = sorted(s for s, o in records if s not in named and o in grouped)
    if left:
        return (f'summary offsets leave out the record of opcode {spans[left[0]][0]:#04x} at byte {left[0]} '
                '(allowed: every record of a group they name)')
    return ''
