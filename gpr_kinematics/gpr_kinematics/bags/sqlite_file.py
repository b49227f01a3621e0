"""Read one rosbag2 SQLite3 storage file (``sqlite3`` storage, schema versions 2-4) with every row checked.

``PRAGMA quick_check`` first; the ``topics``, ``messages``, ``message_definitions`` and ``metadata`` (the database's
own copy of the bag's metadata, kept for ``bag.metadata``) tables must be stored tables of stored columns
(:func:`_stored_tables`: a view, a virtual table or a generated column computes what is read), one row per topic
(:func:`_topics_table`) and per type (:func:`_definitions`), the messages counted before any is read. Every failure
is a :class:`~gpr_kinematics.bags.errors.BagError` naming the file; the SHA-256 of the file is computed on the way.
"""
from __future__ import annotations

import sqlite3
import urllib.parse
from pathlib import Path

from .errors import BagError
from .fileio import check_sqlite_pages, read_head, sha256_file
from .mcap_file import MAX_MESSAGES
from .metadata import MAX_METADATA_BYTES
from .storage_file import Contents, StorageFile
from .typestore import normalize_type


def read_sqlite(path: Path, topics: set[str] | None = None, messages: int = 0) -> Contents:
    """Read a rosbag2 SQLite3 storage file (schema versions 2-4: ``topics`` and ``messages`` tables; a view of
    those names is refused, so every row read is stored in the file). The bag's files before it held ``messages``
    messages; its rows are counted before any is read (:data:`~.mcap_file.MAX_MESSAGES` bounds all) and only those
    of ``topics`` (all if None) are kept."""
    head, size = read_head(path, 'SQLite3 file', 100)
    if head[:16] != b'SQLite format 3\x00':
        raise BagError(f'{path}: not an SQLite3 database')
    check_sqlite_pages(path, head, size)   # before the digest: 50 GB of zeros after it were hashed for minutes
    sha = sha256_file(path, 'SQLite3 file')
    uri = f'file:{urllib.parse.quote(str(path.resolve()))}?mode=ro&immutable=1'
    try:
        con = sqlite3.connect(uri, uri=True)
        con.text_factory = bytes  # text of a corrupt file need not be UTF-8: decoded and checked below
        try:
            row = con.execute('PRAGMA quick_check').fetchone()
            if row is None or row[0] != b'ok':
                answer = row[0].decode('utf-8', errors='replace') if row else 'no answer'
                raise BagError(f'{path}: corrupt SQLite3 database (quick_check: {answer})')
            _stored_tables(con, path)
            columns = {r[1] for r in con.execute('PRAGMA table_info(topics)')}
            hashes = 'type_description_hash' if b'type_description_hash' in columns else "''"
            profiles = 'offered_qos_profiles' if b'offered_qos_profiles' in columns else "''"
            rows = con.execute(f'SELECT id, name, type, serialization_format, {hashes}, {profiles} '
                               'FROM topics').fetchall()
            tables = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
            definitions = con.execute('SELECT id, topic_type, encoding, encoded_message_definition FROM '
                                      'message_definitions ORDER BY id').fetchall() \
                if b'message_definitions' in tables else []
            embedded = _embedded_metadata(con, path) if b'metadata' in tables else ()
            names, types, digests, formats, qos = _topics_table(rows, path)
            # the table's rows, not an index's: a detached index counted 77 of 8.5 million rows read (quick_check
            # does not compare indexes with tables), and rosbag2 plays in the index's order
            stored = con.execute('SELECT count(*) FROM messages NOT INDEXED').fetchone()[0]
            indexed = con.execute('SELECT count(*) FROM messages').fetchone()[0]
            if indexed != stored:
                raise BagError(f'{path}: corrupt SQLite3 database (its messages table has {stored} rows, an index of '
                               f'it {indexed}); allowed: indexes that match their tables, as rosbag2 writes them')
            total = messages + stored
            if total > MAX_MESSAGES:
                before = f" (this file's and the {messages} of the bag's files before it)" if messages else ''
                raise BagError(f'{path}: {total} messages in all{before}; allowed: at most {MAX_MESSAGES} per bag')
            counts = dict.fromkeys(types, 0)
            keep = [n for n in types if topics is None or n in topics]
            times: dict[str, list[int]] = {n: [] for n in keep}
            data: dict[str, list[bytes]] = {n: [] for n in keep}
            first = last = None
            for tid, stamp, blob in con.execute('SELECT topic_id, timestamp, data FROM messages ORDER BY id'):
                name = names.get(tid) if isinstance(tid, int) else None
                if name is None or not isinstance(stamp, int) or not isinstance(blob, bytes):
                    raise BagError(f'{path}: corrupt messages table (topic id {tid!r}, timestamp '
                                   f'{type(stamp).__name__}, data {type(blob).__name__})')
                counts[name] += 1
                first = stamp if first is None or stamp < first else first
                last = stamp if last is None or stamp > last else last
                if name in times:
                    times[name].append(stamp)
                    data[name].append(blob)
        finally:
            con.close()
    except sqlite3.Error as exc:
        raise BagError(f'{path}: corrupt SQLite3 database ({exc})') from None
    except UnicodeDecodeError:  # Python cannot make a str of SQLite's error message that quotes corrupt bytes
        raise BagError(f'{path}: corrupt SQLite3 database (an error about bytes that are not UTF-8)') from None
    defined = _definitions(definitions, path)
    schemas = {name: defined[ty] for name, ty in types.items() if ty in defined}
    info = StorageFile(path.name, size, sha, counts, types, digests, first, last, schemas=schemas, formats=formats,
                       qos=qos, embedded=embedded)
    return Contents(info, times, data, messages=total)


def _topics_table(rows: list[tuple[object, ...]], path: Path) -> tuple[dict[int, str], dict[str, str], dict[str, str],
                                                                    dict[str, str], dict[str, str]]:
    """The ``topics`` table's rows (id, name, type, serialization format, type hash, offered profiles) as the topic
    names by id and, by name, the types, type hashes, formats and the offered profiles where one is stored (the
    package's writer before 2026-12-03 stored ``[]``: none)."""
    names: dict[int, str] = {}
    types: dict[str, str] = {}
    digests: dict[str, str] = {}
    formats: dict[str, str] = {}
    qos: dict[str, str] = {}
    for tid, *texts in rows:
        try:
            name, msgtype, fmt, digest, profiles = (v.decode('utf-8') if isinstance(v, bytes) else v for v in texts)
        except UnicodeDecodeError:
            raise BagError(f'{path}: corrupt topics table (row {tid!r}: text that is not UTF-8)') from None
        if not (isinstance(tid, int) and isinstance(name, str) and isinstance(msgtype, str) and isinstance(fmt, str)
                and isinstance(digest, str) and isinstance(profiles, str)):
            raise BagError(f'{path}: corrupt topics table (row {tid!r})')
        if fmt != 'cdr':
            raise BagError(f'{path}: topic {name!r} has serialization format {fmt!r}; allowed: cdr')
        if name in types:   # rosbag2 writes one row per topic: a second (another type) read its messages as that
            first = next(i for i, n in names.items() if n == name)
            raise BagError(f'{path}: topic {name!r} is listed twice in the topics table (ids {first} and {tid}, types '
                           f'{types[name]} and {normalize_type(msgtype)}); allowed: one row per topic')
        if profiles.strip() not in ('', '[]'):
            qos[name] = profiles
        formats[name] = fmt
        names[tid] = name
        types[name] = normalize_type(msgtype)
        digests[name] = digest
    return names, types, digests, formats, qos


def _embedded_metadata(con: sqlite3.Connection, path: Path) -> tuple[tuple[int, object, str], ...]:
    """The rows of the database's own ``metadata`` table (rosbag2's sqlite3 plugin stores the bag's metadata YAML there,
    one row at each update, and reads the last back), at most :data:`~.metadata.MAX_METADATA_BYTES` in all: they are
    checked against the bag (``bag.metadata``), not trusted."""
    count, size = con.execute('SELECT count(*), coalesce(sum(length(CAST(metadata AS BLOB))), 0) FROM metadata'
                              ).fetchone()
    if size > MAX_METADATA_BYTES:
        raise BagError(f'{path}: metadata table of {count} rows, {size} bytes; allowed: at most {MAX_METADATA_BYTES} '
                       'bytes (rosbag2 stores a few kB at each update)')
    rows = con.execute('SELECT id, metadata_version, metadata FROM metadata ORDER BY id').fetchall()
    return tuple((rid, version, _text(text)) for rid, version, text in rows)


def _definitions(rows: list[tuple[object, ...]], path: Path) -> dict[str, tuple[str, str]]:
    """The ``message_definitions`` table's rows (id, type, encoding, text) as (encoding, text) by type, one row per
    type: rosbag2 (and ``rosbags``) write one per type, and the reader checks one definition per type, so a second row
    had the last one checked while a reader that takes the first decoded by the other (a row swapping ``pose`` and
    ``nominal_pose`` passed beside the package's definition appended)."""
    defined: dict[str, tuple[str, str]] = {}
    ids: dict[str, object] = {}
    for did, t, e, d in rows:
        name, entry = _text(t), (_text(e), _text(d))
        if name in defined:
            alike = 'the same definition' if defined[name] == entry else 'different definitions'
            raise BagError(f'{path}: type {name} is defined twice in the message_definitions table (ids {ids[name]} '
                           f'and {did}: {alike}); allowed: one row per type (rosbag2 writes one)')
        defined[name], ids[name] = entry, did
    return defined


def _stored_tables(con: sqlite3.Connection, path: Path) -> None:
    """:class:`BagError` if ``topics``, ``messages``, ``message_definitions`` or ``metadata`` is not a stored table or
    has a column that is not stored: a view computes its rows (an endless recursive one never ends), a virtual table
    its module's, and a generated column its expression at every read (a 20 kB file of four rows whose ``data`` was
    ``zeroblob(500000000)`` took 2.5 GB, another 1 s of CPU per row), so only stored values are read."""
    allowed = "allowed: rosbag2's stored tables topics, messages, message_definitions and metadata"
    for name, kind, sql in con.execute("SELECT name, type, sql FROM sqlite_master WHERE name IN ('topics', "
                                       "'messages', 'message_definitions', 'metadata') ORDER BY name"):
        if kind != b'table':
            raise BagError(f'{path}: {_text(name)} is a {_text(kind)}, not a table; {allowed}')
        if isinstance(sql, bytes) and sql.lstrip().upper().startswith(b'CREATE VIRTUAL'):
            raise BagError(f'{path}: {_text(name)} is a virtual table; {allowed}')
        # table_xinfo's hidden: 0 a stored column, 1 a virtual table's hidden one, 2 and 3 generated ones
        computed = [_text(r[1]) for r in con.execute(f"PRAGMA table_xinfo('{_text(name)}')") if r[6] != 0]
        if computed:
            raise BagError(f'{path}: column {computed[0]} of {_text(name)} is generated (computed when read), not '
                           f'stored; {allowed}')


def _text(value: object) -> str:
    """A text cell of a corrupt-proof SQLite3 read (bytes that are not UTF-8 kept as replacement characters)."""
    return value.decode('utf-8', errors='replace') if isinstance(value, bytes) else str(value)
