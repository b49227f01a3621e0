"""The bounded MCAP reader against the ``mcap`` library (CRC validation, messages), its limits, foreign files
(the ``rosbags`` writer, CRCs left 0; lz4 chunks), and files that are not regular files (a FIFO never blocks)."""
from __future__ import annotations

import os
import re
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest
from bag_support import REFERENCE, small_sweep, write_bag
from gpr_kinematics.bags import mcap_file
from gpr_kinematics.bags.errors import BagError
from gpr_kinematics.bags.mcap_file import read_mcap
from gpr_kinematics.bags.reader import read_bag
from gpr_kinematics.bags.typestore import GPR_TOPICS, definition


@pytest.fixture(scope='module')
def messages() -> list[tuple[str, int, bytes]]:
    return small_sweep()


def _types(messages: list[tuple[str, int, bytes]]) -> dict[str, str]:
    return {t: GPR_TOPICS[t] for t in dict.fromkeys(m[0] for m in messages)}


@pytest.mark.parametrize('compression', ['none', 'zstd'])
def test_written_files_carry_every_crc_and_the_mcap_library_agrees(tmp_path: Path, messages: list,
                                                                   compression: str) -> None:
    from mcap.reader import make_reader
    from mcap.stream_reader import StreamReader

    bag = write_bag(tmp_path / 'b', messages, _types(messages), compression=compression, max_bag_size=20000)
    files = sorted(bag.glob('*.mcap'))
    assert len(files) >= 3  # split by size (20 kB each)
    ours, theirs = [], []
    for f in files:
        m = read_mcap(f)
        assert m.chunks >= 1 and m.chunks_with_crc == m.chunks and m.data_crc and m.summary_crc
        names = {c.id: c.topic for c in m.channels.values()}
        ours += sorted((t, names[cid], d) for cid in m.times for t, d in zip(m.times[cid], m.data[cid], strict=True))
        with f.open('rb') as fh:  # the library's own validation of chunk and data-section CRCs
            assert sum(1 for _ in StreamReader(fh, validate_crcs=True).records) > 10
        with f.open('rb') as fh:
            theirs += sorted((msg.log_time, ch.topic, msg.data) for _, ch, msg in make_reader(fh).iter_messages())
        assert {c.topic: c.meta('topic_type_hash') for c in m.channels.values()} == {
            t: definition(GPR_TOPICS[t])[1] for t in names.values()}
    assert sorted(ours) == sorted(theirs) == sorted((t, topic, d) for topic, t, d in messages)


def test_a_file_of_the_rosbags_writer_reads_without_crcs(tmp_path: Path, messages: list) -> None:
    from rosbags.rosbag2 import StoragePlugin, Writer

    with Writer(tmp_path / 'r', version=9, storage_plugin=StoragePlugin.MCAP) as w:
        conns = {t: w.add_connection(t, ty, msgdef=definition(ty)[0], rihs01=definition(ty)[1])
                 for t, ty in _types(messages).items()}
        for topic, t, data in messages:
            w.write(conns[topic], t, data)
    m = read_mcap(tmp_path / 'r' / 'r.mcap')
    assert m.chunks == 1 and m.chunks_with_crc == 0 and not m.data_crc and not m.summary_crc
    assert sum(m.counts.values()) == len(messages)
    assert read_bag(tmp_path / 'r').message_count == len(messages)


def test_lz4_chunks(tmp_path: Path, messages: list) -> None:
    from mcap.writer import CompressionType, Writer

    path = tmp_path / 'lz4.mcap'
    with path.open('wb') as fh:
        w = Writer(fh, compression=CompressionType.LZ4, chunk_size=4096)
        w.start(profile='ros2', library='test')
        schema = w.register_schema('gpr_interfaces/msg/PlatformState', 'ros2msg',
                                   definition('gpr_interfaces/msg/PlatformState')[0].encode())
        ch = w.register_channel('/gpr/platform_state', 'cdr', schema)
        states = [m for m in messages if m[0] == '/gpr/platform_state']
        for _, t, data in states:
            w.add_message(ch, log_time=t, data=data, publish_time=t)
        w.finish()
    m = read_mcap(path)
    assert m.chunks > 3 and m.chunks_with_crc == m.chunks
    assert m.data[ch] == [d for _, _, d in states]
    bag = read_bag(path)
    assert bag.metadata is None and len(bag.topic('/gpr/platform_state')) == len(states)


def test_a_flipped_message_byte_fails_the_chunk_crc(tmp_path: Path, messages: list) -> None:
    bag = write_bag(tmp_path / 'b', messages, _types(messages))
    f = bag / 'b_0.mcap'
    data = bytearray(f.read_bytes())
    i = data.index(b'gpr_base', len(data) // 3)  # a frame id inside a message of the (uncompressed) chunk
    data[i] ^= 0x20
    f.write_bytes(bytes(data))
    with pytest.raises(BagError, match=r'b_0\.mcap: corrupt MCAP file: record 0x06 at byte \d+: chunk CRC mismatch'):
        read_mcap(f)



def _summary_edited(path: Path, opcode: int, field: int, value: int, group: int | None = None) -> None:
    """Set the u64 at byte ``field`` of the first ``opcode`` record of the summary section (a summary offset: the
    one of the ``group`` opcode) to ``value`` (same size, so no offset moves) and recompute the summary CRC: an
    editor who knows the format's checksums."""
    import struct
    import zlib
    data = bytearray(path.read_bytes())
    footer = len(data) - 8 - 20
    summary_start = struct.unpack_from('<Q', data, footer)[0]
    pos = summary_start
    while data[pos] != opcode or (group is not None and data[pos + 9] != group):
        pos += 9 + struct.unpack_from('<Q', data, pos + 1)[0]
    struct.pack_into('<Q', data, pos + 9 + field, value)
    struct.pack_into('<I', data, footer + 16, zlib.crc32(bytes(data[summary_start:footer + 16])))
    path.write_bytes(bytes(data))


@pytest.mark.parametrize('opcode, field, value, refusal', [
    # chunk index: message end time (an indexed reader reading up to 10 ms skips the chunk's later messages)
    (0x08, 8, 1_700_000_000_010_000_000, 'chunk index 0 says message end time 1700000000010000000; the chunk at byte '
     r'\d+ has 1700000000029000000 \(allowed: the chunk index of a chunk names its own values\)'),
    (0x08, 16, 8, r'chunk index 0 says start offset 8; the chunk at byte \d+ has \d+'),   # points elsewhere
    # chunk index: a message index offset pointing at the file's header (a seeking reader finds no index there)
    (0x08, 38, 8, r'chunk index 0 says message index offsets \(\(\d+, 8\), .*; the chunk at byte \d+ has '
     r'\(\(\d+, \d+\), '),
    # statistics: message end time 10 ms earlier
    (0x0B, 34, 1_700_000_000_019_000_000, 'statistics record says 1 chunks and messages from 1700000000000000000 '
     'to 1700000000019000000 ns; the file holds 1 chunks and messages from 1700000000000000000 to '
     '1700000000029000000 ns')])
def test_a_summary_that_disagrees_with_the_chunks_is_refused(tmp_path: Path, messages: list, opcode: int, field: int,
                                                            value: int, refusal: str) -> None:
    """The summary's chunk indexes and statistics were not compared with the chunks walked (only the message
    counts were): an index that names another offset or a narrower time range than its chunk (what an indexed
    reader, such as ros2 bag play, reads by) passed with its CRC recomputed."""
    from mcap.reader import make_reader

    bag = write_bag(tmp_path / 'b', messages, _types(messages))
    f = bag / 'b_0.mcap'
    read_mcap(f)
    _summary_edited(f, opcode, field, value)
    with f.open('rb') as fh:
        assert make_reader(fh).get_summary() is not None   # the library reads the edited summary
    with pytest.raises(BagError, match=r'b_0\.mcap: corrupt MCAP file: ' + refusal):
        read_mcap(f)



@pytest.mark.parametrize('field, value, refusal', [
    (9, 0, r'summary offsets leave out the record of opcode 0x08 at byte (\d+) \(allowed: every record of a group '
     'they name\\)'),                                                  # the chunk indexes' group made empty
    (1, 8, r'summary offset of opcode 0x08 spans bytes 8 to \d+, not whole records of that opcode')])
def test_summary_offsets_that_hide_a_group_are_refused(tmp_path: Path, messages: list, field: int, value: int,
                                                      refusal: str) -> None:
    """A summary offset is where a seeking reader finds a group of the summary (the chunk indexes): one that leaves a
    chunk index out, or points at other bytes, was not read (only the CRC covered it) and passed recomputed."""
    bag = write_bag(tmp_path / 'b', messages, _types(messages))
    f = bag / 'b_0.mcap'
    _summary_edited(f, 0x0E, field, value, group=0x08)
    with pytest.raises(BagError, match=r'b_0\.mcap: corrupt MCAP file: ' + refusal):
        read_mcap(f)


def _data_edited(path: Path, opcode: int, which: int, field: int | None, value: int) -> None:
    """Set the u64 at byte ``field`` of the ``which``-th ``opcode`` record of the data section to ``value`` (None:
    set that record's opcode to ``value``) and recompute the data-section CRC (the DataEnd record's)."""
    import struct
    import zlib
    data = bytearray(path.read_bytes())
    pos, seen = 8, -1
    while data[pos] != 0x0F:
        seen += data[pos] == opcode
        if data[pos] == opcode and seen == which:
            if field is None:
                data[pos] = value
            else:
                struct.pack_into('<Q', data, pos + 9 + field, value)
        pos += 9 + struct.unpack_from('<Q', data, pos + 1)[0]
    struct.pack_into('<I', data, pos + 9, zlib.crc32(bytes(data[:pos])))
    path.write_bytes(bytes(data))


def _message_indexes(path: Path) -> int:
    from mcap.records import MessageIndex
    from mcap.stream_reader import StreamReader

    with path.open('rb') as fh:
        return sum(isinstance(r, MessageIndex) for r in StreamReader(fh).records)


@pytest.mark.parametrize('field, value, refusal', [
    (6, 1_700_000_000_029_000_000, r'record 0x07 at byte \d+: message index of channel \d+ lists \d+ entries; the '
     r'chunk at byte \d+ holds \d+ messages of it \(first difference at entry 0 by log time; allowed: each message '
     r'of the channel in the chunk, with its log time and offset\)'),  # the first message seemingly at the chunk's end
    (14, 8, r'record 0x07 at byte \d+: message index of channel \d+ lists \d+ entries; the chunk at byte \d+ '
     'holds'),                                                          # the first message's offset
    (None, 0x80, r'channel \d+ of the chunk at byte \d+ is in no message index, while other messages are \(allowed: '
     r'every channel of every chunk indexed, or no message index at all\)')])      # the last index made a custom record
def test_message_indexes_that_misplace_or_hide_messages_are_refused(tmp_path: Path, messages: list,
                                                                    field: int | None, value: int,
                                                                    refusal: str) -> None:
    """Message indexes were not compared with their chunk (only the data-section CRC covered them): a seeking
    reader finds messages through them, so an entry moved to another time or offset, or a channel's index taken
    away, passed with the CRC recomputed."""
    bag = write_bag(tmp_path / 'b', messages, _types(messages))
    f = bag / 'b_0.mcap'
    read_mcap(f)
    _data_edited(f, 0x07, 0 if field is not None else _message_indexes(f) - 1, field, value)
    with pytest.raises(BagError, match=r'b_0\.mcap: corrupt MCAP file: ' + refusal):
        read_mcap(f)


def test_a_chunk_beyond_the_size_limit_is_refused(tmp_path: Path, messages: list,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    bag = write_bag(tmp_path / 'b', messages, _types(messages))
    monkeypatch.setattr(mcap_file, 'MAX_CHUNK_BYTES', 1000)
    with pytest.raises(BagError, match='uncompressed bytes; allowed: at most 1000'):
        read_mcap(bag / 'b_0.mcap')
    monkeypatch.setattr(mcap_file, 'MAX_RECORD_BYTES', 500)
    with pytest.raises(BagError, match='allowed: at most 500'):
        read_mcap(bag / 'b_0.mcap')


def test_chunks_beyond_the_files_uncompressed_bound_are_refused_before_decompression(
        tmp_path: Path, messages: list, monkeypatch: pytest.MonkeyPatch) -> None:
    """A 127 kB file of zstd chunks held 4 GB of messages (each chunk under the chunk bound): the sum of a file's
    uncompressed chunks is bounded too, checked before each chunk is decompressed."""
    from gpr_kinematics.bags import storage_writers
    from mcap.records import Chunk
    from mcap.stream_reader import StreamReader

    monkeypatch.setattr(storage_writers, 'MCAP_CHUNK_BYTES', 4000)
    bag = write_bag(tmp_path / 'b', messages, _types(messages), compression='zstd')
    f = bag / 'b_0.mcap'
    with f.open('rb') as fh:
        sizes = [r.uncompressed_size for r in StreamReader(fh, emit_chunks=True).records if isinstance(r, Chunk)]
    assert len(sizes) >= 3
    monkeypatch.setattr(mcap_file, 'MAX_INFLATED_BYTES', sum(sizes))
    assert read_mcap(f).chunks == len(sizes)
    monkeypatch.setattr(mcap_file, 'MAX_INFLATED_BYTES', sum(sizes) - 1)
    with pytest.raises(BagError, match=rf'more than {sum(sizes) - 1} uncompressed bytes in all; allowed: at most'):
        read_mcap(f)


def test_the_uncompressed_bound_holds_for_the_whole_bag(tmp_path: Path, messages: list,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """Six MCAP files of 37 kB, each within the bound per file, held 6 GB of zstd chunks in all (224 kB of bag, 46 s
    and 6.4 GB to read): the bound is the bag's, counted over its files."""
    bag = write_bag(tmp_path / 'b', messages, _types(messages), compression='zstd', max_bag_size=20_000)
    files = sorted(bag.glob('*.mcap'))
    assert len(files) >= 3
    sizes, inflated = [], 0
    for f in files:
        inflated = read_mcap(f, inflated=inflated).inflated
        sizes.append(inflated)
    monkeypatch.setattr(mcap_file, 'MAX_INFLATED_BYTES', sizes[-1])
    assert len(read_bag(bag).topics) > 0
    monkeypatch.setattr(mcap_file, 'MAX_INFLATED_BYTES', sizes[-1] - 1)   # each file alone is well within
    assert all(read_mcap(f).inflated < sizes[-1] - 1 for f in files)
    with pytest.raises(BagError, match=rf"{files[-1].name}: corrupt MCAP file: record 0x06 at byte \d+: chunks of "
                                       rf"more than {sizes[-1] - 1} uncompressed bytes in all \(this file's and the "
                                       rf"{sizes[-2]} of the bag's files before it\); allowed: at most {sizes[-1] - 1} "
                                       'per bag$'):
        read_bag(bag)


@pytest.mark.parametrize('storage', ['mcap', 'sqlite3'])
def test_the_messages_of_a_bag_are_bounded_in_number_over_its_files(tmp_path: Path, messages: list,
                                                                    monkeypatch: pytest.MonkeyPatch,
                                                                    storage: str) -> None:
    """A 25 kB MCAP chunk of 6.6 million empty messages (within the bytes' bound) took 2.15 GB and 23 s to read: a
    bag's messages are bounded in number, every topic's (one topic asked for reads them all), over its files; an
    SQLite3 file's rows are counted before any is read."""
    from gpr_kinematics.bags import sqlite_file

    bag = write_bag(tmp_path / 'b', messages, _types(messages), storage=storage, max_bag_size=20_000)
    files = sorted(bag.glob('*.mcap' if storage == 'mcap' else '*.db3'))
    assert len(files) >= 3
    n, topic = len(messages), messages[0][0]
    for module in (mcap_file, sqlite_file):
        monkeypatch.setattr(module, 'MAX_MESSAGES', n)
    assert sum(len(t.raw) for t in read_bag(bag).topics.values()) == n
    for module in (mcap_file, sqlite_file):
        monkeypatch.setattr(module, 'MAX_MESSAGES', n - 1)
    said = f'more than {n - 1}' if storage == 'mcap' else str(n)   # MCAP stops at the message beyond, SQLite3 before
    for topics in (None, [topic]):
        with pytest.raises(BagError, match=rf"{files[-1].name}: .*{said} messages in all \(this file's and the \d+ "
                                           rf"of the bag's files before it\); allowed: at most {n - 1} per bag$"):
            read_bag(bag, topics)


@pytest.mark.slow
def test_a_message_costs_some_250_bytes_so_the_bound_holds_the_memory(tmp_path: Path) -> None:
    """The bound on messages is a bound on memory: 30,000 messages of two bytes in one zstd chunk (a file of 1 byte
    a message) take at most 300 bytes each to read, so :data:`MAX_MESSAGES` of them stay within 2.4 GB."""
    import tracemalloc

    from mcap.writer import CompressionType, IndexType, Writer

    n = 30_000
    f = tmp_path / 'small.mcap'
    with f.open('wb') as fh:
        w = Writer(fh, chunk_size=1 << 26, compression=CompressionType.ZSTD, index_types=IndexType.NONE)
        w.start(profile='ros2', library='test')
        cid = w.register_channel('/e', 'cdr', w.register_schema('std_msgs/msg/Empty', 'ros2msg', b''))
        for i in range(n):   # two bytes and a time of their own: no object Python shares between them
            w.add_message(cid, log_time=10**18 + i, data=b'\0\0', publish_time=0)
        w.finish()
    assert f.stat().st_size < 2 * n
    tracemalloc.start()
    try:
        read = read_bag(f)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert len(read.topics['/e'].raw) == n
    assert peak / n <= 300, peak / n
    assert mcap_file.MAX_MESSAGES * 300 <= 2.4e9


def test_a_bag_beyond_the_memory_is_refused_in_one_line(tmp_path: Path, messages: list,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    """An allocation that fails while a file is read (a chunk decompressed beyond the process's memory: a 33 kB file
    of 200 MiB chunks under the tests' 768 MiB address space) is named, not a traceback of MemoryError."""
    bag = write_bag(tmp_path / 'b', messages, _types(messages), compression='zstd')

    def no_memory(*args: object) -> bytes:
        raise MemoryError('Unable to allocate output buffer')

    monkeypatch.setattr(mcap_file, 'decompress', no_memory)
    with pytest.raises(BagError, match=r'b_0\.mcap: not enough memory to read its messages \(a bag is read into '
                                       r"memory\); allowed: a bag whose messages fit in this process's memory$"):
        read_bag(bag)


def test_reference_file_holds_what_its_metadata_lists() -> None:
    bag = read_bag(REFERENCE)
    (f,) = bag.storage_files
    assert f.chunks_with_crc == f.chunks and f.data_crc and f.summary_crc
    # 756 samples x 6 topics, the geometry and the robot description once.
    assert f.message_count == bag.metadata.message_count == 756 * 6 + 2


_READ = 'import sys; from gpr_kinematics.bags.reader import read_bag; read_bag(sys.argv[1])'


def _fifo_cases(tmp_path: Path, messages: list) -> list[tuple[Path, str]]:
    cases = []
    for what in ('storage', 'metadata'):
        bag = write_bag(tmp_path / what, messages, _types(messages))
        victim = bag / (f'{what}_0.mcap' if what == 'storage' else 'metadata.yaml')
        victim.unlink()
        os.mkfifo(victim)
        cases.append((bag, victim.name))
    single = tmp_path / 'single.mcap'
    os.mkfifo(single)
    cases.append((single, 'single.mcap'))
    return cases


@pytest.mark.slow
def test_a_fifo_is_refused_without_blocking(tmp_path: Path, messages: list) -> None:
    """verify and the reader that replay_node uses: exit 2 / BagError naming the FIFO, within seconds."""
    for path, name in _fifo_cases(tmp_path, messages):
        proc = subprocess.run([sys.executable, '-m', 'gpr_kinematics.cli.main', 'verify', str(path)], text=True,
                              capture_output=True, timeout=60)
        assert proc.returncode == 2 and 'is a FIFO; allowed: a regular file' in proc.stderr, proc.stderr
        assert name in proc.stderr and proc.stderr.count('\n') == 1
        proc = subprocess.run([sys.executable, '-c', _READ, str(path)], text=True, capture_output=True, timeout=60)
        assert proc.returncode == 1 and 'BagError' in proc.stderr and 'is a FIFO' in proc.stderr


def _mcap(tmp_path: Path, messages: list) -> Path:
    bag = write_bag(tmp_path / 'b', messages, _types(messages))
    read_mcap(bag / 'b_0.mcap')
    return bag / 'b_0.mcap'


def _replaced(path: Path, old: bytes, new: bytes, after: int = 0) -> None:
    """The first ``old`` from byte ``after`` on replaced by ``new`` (as long): a flip no CRC was recomputed for."""
    data = path.read_bytes()
    i = data.index(old, after)
    path.write_bytes(data[:i] + new + data[i + len(old):])


def test_a_flipped_byte_outside_the_chunks_fails_the_data_or_summary_crc(tmp_path: Path, messages: list) -> None:
    """A single MCAP file has no SHA-256 beside it: the data section's CRC covers its metadata record (ROS_DISTRO
    jazzy), the summary's its metadata index, which nothing else reads."""
    import re
    f = _mcap(tmp_path, messages)
    data = f.read_bytes()
    _replaced(f, b'jazzy', b'jazzz')
    with pytest.raises(BagError, match=r'corrupt MCAP file: data section CRC mismatch \(stored 0x[0-9a-f]{8}, '
                                       r'computed 0x[0-9a-f]{8}\)$'):
        read_mcap(f)
    f.write_bytes(data)
    _replaced(f, b'\x07\x00\x00\x00rosbag2', b'\x07\x00\x00\x00rosbag3', data.index(b'\x0f\x04\x00\x00'))
    with pytest.raises(BagError, match=re.escape('corrupt MCAP file: summary CRC mismatch (stored')):
        read_mcap(f)


def test_record_edits_with_their_crcs_recomputed_are_refused(tmp_path: Path, messages: list) -> None:
    """Each edit below passed a mutant of the reader (its check dropped) with every CRC recomputed."""
    import struct
    f = _mcap(tmp_path, messages)
    original = f.read_bytes()
    start = 1_700_000_000_000_000_000
    cases = [
        # the chunk and its index say its messages end at 10 ms: the messages after it lie outside the chunk
        (lambda: (_data_edited(f, 0x06, 0, 8, start + 10_000_000), _summary_edited(f, 0x08, 8, start + 10_000_000)),
         r'record 0x06 at byte \d+: message log time 1700000000011000000 outside its chunk '
         r'\[1700000000000000000, 1700000000010000000\]$'),
        # the file's first record made an unknown one
        (lambda: _data_edited(f, 0x01, 0, None, 0x80), 'first record has opcode 0x80, not the header$'),
        # the metadata record before the chunk made a message index
        (lambda: _data_edited(f, 0x0C, 0, None, 0x07), r'record 0x07 at byte 55: message index that does not follow '
         r'a chunk or its message indexes \(allowed: right after its chunk\)$'),
        # the footer's summary offsets pointing at the file's first record (the summary CRC covers them)
        (lambda: _footer_edited(f, 8, 8), r'footer offsets \(summary at \d+, offsets at 8\) do not match the file '
         r'\(summary at \d+\)$'),
        # the chunk indexes' summary offset widened back over the statistics record before them
        (lambda: (_summary_edited(f, 0x0E, 1, _summary_start(original, 0x0B), group=0x08),
                  _summary_edited(f, 0x0E, 9, _summary_start(original, 0x0D) - _summary_start(original, 0x0B),
                                  group=0x08)),
         r'summary offset of opcode 0x08 spans bytes \d+ to \d+, not whole records of that opcode'),
        # bytes after the footer, the file still ending in the magic
        (lambda: f.write_bytes(original + b'junk' + mcap_file.MAGIC), r'footer at byte \d+ of 20 bytes, 20 bytes '
         r'before the end \(a footer is 20 bytes followed by the end magic\)$')]
    for edit, refusal in cases:
        f.write_bytes(original)
        edit()
        with pytest.raises(BagError, match=r'b_0\.mcap: corrupt MCAP file: ' + refusal):
            read_mcap(f)
    # the statistics' per-channel counts: one moved from a channel to another, the total kept
    f.write_bytes(original)
    body = _summary_start(original, 0x0B) + 9                         # the statistics record's body
    assert struct.unpack_from('<I', original, body + 42)[0] == 80   # its channel counts: (u16 id, u64 count) each
    (c1, n1), (c2, n2) = (struct.unpack_from('<HQ', original, body + 46 + 10 * k) for k in range(2))
    _summary_edited(f, 0x0B, 48, n1 + 1)
    _summary_edited(f, 0x0B, 58, n2 - 1)
    with pytest.raises(BagError, match=f'statistics record counts {n1 + 1} messages of channel {c1}, the chunks hold '
                                       f'{n1}$'):
        read_mcap(f)


def _footer_edited(path: Path, field: int, value: int) -> None:
    """Set the footer's u64 at ``field`` (0: the summary's start, 8: the summary offsets' start) and recompute the
    summary CRC, which covers them."""
    import struct
    import zlib
    data = bytearray(path.read_bytes())
    footer = len(data) - 8 - 20
    struct.pack_into('<Q', data, footer + field, value)
    summary_start = struct.unpack_from('<Q', data, footer)[0]
    struct.pack_into('<I', data, footer + 16, zlib.crc32(bytes(data[summary_start:footer + 16])))
    path.write_bytes(bytes(data))


def _summary_start(data: bytes, opcode: int) -> int:
    """Where the summary's first ``opcode`` record starts."""
    import struct
    pos = struct.unpack_from('<Q', data, len(data) - 28)[0]   # the footer's summary start
    while data[pos] != opcode:
        pos += 9 + struct.unpack_from('<Q', data, pos + 1)[0]
    return pos


def _chunk_edited(path: Path, edit: Callable[[bytearray, list[tuple[int, int, int]]], None]) -> None:
    """Edit the records of the data section's first chunk (uncompressed) in place, their length kept:
    ``edit(records, table)`` with ``table`` each record's ``(start, opcode, length)``; the chunk's CRC and the
    data section's computed anew (the offsets of its message and chunk indexes stay right)."""
    import struct
    import zlib
    data = bytearray(path.read_bytes())
    pos = 8
    while data[pos] != 0x06:
        pos += 9 + struct.unpack_from('<Q', data, pos + 1)[0]
    body = pos + 9
    (name_length,) = struct.unpack_from('<I', data, body + 28)
    assert bytes(data[body + 32:body + 32 + name_length]) == b''          # uncompressed
    at = body + 32 + name_length
    (length,) = struct.unpack_from('<Q', data, at)
    records = data[at + 8:at + 8 + length]
    table, i = [], 0
    while i < len(records):
        op, n = struct.unpack_from('<BQ', records, i)
        table.append((i, op, n))
        i += 9 + n
    edit(records, table)
    assert len(records) == length
    data[at + 8:at + 8 + length] = records
    struct.pack_into('<I', data, body + 24, zlib.crc32(bytes(records)))
    end = pos
    while data[end] != 0x0F:
        end += 9 + struct.unpack_from('<Q', data, end + 1)[0]
    struct.pack_into('<I', data, end + 9, zlib.crc32(bytes(data[:end])))
    path.write_bytes(bytes(data))


def test_chunk_records_edited_with_every_crc_recomputed_are_refused(tmp_path: Path, messages: list) -> None:
    """Edits inside a chunk and in the summary, each with the chunk's, the data section's and the summary's CRCs
    computed anew, that mutants of the reader passed (its check loosened or dropped): the chunk's last record one
    byte longer than what is left (a reader that slices past the end reads it short), a message record made another
    opcode (a metadata record inside a chunk), and the summary's first record made a message."""
    import struct

    def longer(records: bytearray, table: list[tuple[int, int, int]]) -> None:
        start, _, n = table[-1]
        struct.pack_into('<Q', records, start + 1, n + 1)

    def another_opcode(records: bytearray, table: list[tuple[int, int, int]]) -> None:
        start = next(s for s, op, _ in table if op == 0x05)
        records[start] = 0x0C

    def message_in_summary() -> None:
        data = bytearray(f.read_bytes())
        summary = struct.unpack_from('<Q', data, len(data) - 28)[0]
        assert data[summary] != 0x05
        data[summary] = 0x05
        f.write_bytes(bytes(data))
        _footer_edited(f, 0, summary)                        # the summary CRC computed anew

    bag = write_bag(tmp_path / 'b', messages, _types(messages), compression='none')
    f = bag / 'b_0.mcap'
    original = f.read_bytes()
    read_mcap(f)
    for edit, refusal in [
            (lambda: _chunk_edited(f, longer), r'record 0x06 at byte \d+: record of (\d+) bytes inside a chunk with '
                                               r'(\d+) bytes left$'),
            (lambda: _chunk_edited(f, another_opcode), r'record 0x06 at byte \d+: record opcode 0x0c inside a chunk '
                                                       r'\(allowed: schema, channel, message\)$'),
            (message_in_summary, r'record 0x05 at byte \d+: message data in the summary section$')]:
        f.write_bytes(original)
        edit()
        with pytest.raises(BagError, match=r'b_0\.mcap: corrupt MCAP file: ' + refusal) as caught:
            read_mcap(f)
        m = re.search(r'record of (\d+) bytes inside a chunk with (\d+) bytes left', str(caught.value))
        assert m is None or int(m[1]) == int(m[2]) + 1                 # one byte too long
