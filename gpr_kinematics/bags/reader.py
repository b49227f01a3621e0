"""Read a rosbag2 bag (MCAP or SQLite3, one file or a split recording) into per-topic message lists.

A bag is a folder with ``metadata.yaml`` naming its storage files (``relative_file_paths``), in order; a
recording split into segments (as the recorder writes it) is read as one. A single ``.mcap`` or ``.db3``
file is accepted too. Every failure to read becomes a :class:`~gpr_kinematics.bags.errors.BagError` with a
one-line message naming the path and the reason (missing, not a bag, no metadata, truncated or corrupt
file), which ``gpr verify`` reports with exit status 2.
"""
from __future__ import annotations

import sqlite3
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from numpy.typing import NDArray
from rosbags.rosbag2 import Reader
from rosbags.rosbag2.errors import ReaderError

from .cdr import Columns, decode_columns
from .errors import BagError
from .typestore import normalize_type

#: Folder inside a bag where the recorder keeps the segment it is writing (not part of the bag until closed).
OPEN_SEGMENT_DIR = '.recording'


@dataclass
class TopicData:
    """Messages of one topic in log-time order: ``log_time`` [ns since the epoch] and the CDR bytes ``raw``."""

    name: str
    msgtype: str
    digest: str
    log_time: NDArray[np.int64]
    raw: list[bytes]
    metadata_count: int | None = None
    _columns: Columns | None = field(default=None, repr=False)

    def __len__(self) -> int:
        return len(self.raw)

    def columns(self) -> Columns:
        """All fields decoded into numpy columns (cached); see :func:`~gpr_kinematics.bags.cdr.decode_columns`."""
        if self._columns is None:
            self._columns = decode_columns(self.msgtype, self.raw)
        return self._columns


@dataclass
class Bag:
    """A bag read into memory."""

    path: Path
    storage: str
    version: int | None
    files: list[str]
    compression: str
    topics: dict[str, TopicData]
    metadata: dict[str, Any]
    unfinished: list[str]

    @property
    def message_count(self) -> int:
        return sum(len(t) for t in self.topics.values())

    def topic(self, name: str) -> TopicData | None:
        """The topic ``name`` (with or without the leading slash)."""
        if name in self.topics:
            return self.topics[name]
        alt = name[1:] if name.startswith('/') else '/' + name
        return self.topics.get(alt)


def _fail(path: Path, reason: str) -> BagError:
    return BagError(f'{path}: {reason}')


def read_metadata(path: str | Path) -> dict[str, Any]:
    """``rosbag2_bagfile_information`` of a bag folder's ``metadata.yaml``; :class:`BagError` if absent/bad."""
    path = Path(path)
    meta = path / 'metadata.yaml'
    if not path.exists():
        raise _fail(path, 'does not exist')
    if not path.is_dir():
        raise _fail(path, 'is not a bag folder')
    if not meta.is_file():
        raise _fail(path, 'no metadata.yaml: not a rosbag2 bag folder (or a recording whose first segment was '
                          'never closed)')
    try:
        data = yaml.safe_load(meta.read_text())
        info = data['rosbag2_bagfile_information']
        if not isinstance(info, dict):
            raise TypeError('not a mapping')
    except (OSError, yaml.YAMLError, KeyError, TypeError) as exc:
        raise _fail(meta, f'not a rosbag2 metadata file ({type(exc).__name__}: {exc})'.replace('\n', ' ')) from None
    return info


def read_bag(path: str | Path, topics: list[str] | None = None) -> Bag:
    """Read every message (or those of ``topics``) of the bag at ``path``.

    Raises:
        BagError: the path is missing, not a bag, its metadata is missing or bad, a storage file is missing,
            truncated or corrupt, or a message's serialization is not CDR.
    """
    path = Path(path)
    if not path.exists():
        raise _fail(path, 'does not exist')
    info: dict[str, Any] = {}
    unfinished: list[str] = []
    if path.is_dir():
        info = read_metadata(path)
        open_dir = path / OPEN_SEGMENT_DIR
        if open_dir.is_dir():
            unfinished = sorted(str(p.relative_to(path)) for p in open_dir.rglob('*') if p.is_file()
                                and p.suffix in ('.mcap', '.db3'))
    elif path.suffix not in ('.mcap', '.db3'):
        raise _fail(path, 'not a bag: expected a rosbag2 folder (with metadata.yaml), a .mcap or a .db3 file')
    try:
        if path.is_file():
            _check_file(path)
        else:
            for rel in info.get('relative_file_paths', []) or []:
                f = path / Path(str(rel)).name
                if f.is_file():
                    _check_file(f)
        wanted = {t if t.startswith('/') else '/' + t for t in topics} if topics else None
        raw: dict[str, list[bytes]] = {}
        times: dict[str, list[int]] = {}
        conns: dict[str, tuple[str, str, int | None]] = {}
        with Reader(path) as reader:
            selected = [c for c in reader.connections if wanted is None or c.topic in wanted]
            for c in selected:
                raw.setdefault(c.topic, [])
                times.setdefault(c.topic, [])
                prev = conns.get(c.topic)
                count = c.msgcount if path.is_dir() else None
                if prev is not None and prev[2] is not None and count is not None:
                    count += prev[2]
                conns[c.topic] = (normalize_type(c.msgtype), c.digest or '', count)
            if selected:
                for conn, t, data in reader.messages(connections=selected):
                    raw[conn.topic].append(bytes(data))
                    times[conn.topic].append(t)
            storage = info.get('storage_identifier') or ('mcap' if path.suffix == '.mcap' else 'sqlite3')
    except BagError:
        raise
    except FileNotFoundError as exc:
        raise _fail(path, str(exc)) from None
    except (ReaderError, sqlite3.Error, OSError, struct.error, ValueError, KeyError, IndexError,
            EOFError, TypeError, AssertionError) as exc:
        msg = str(exc).replace('\n', ' ') or type(exc).__name__
        raise _fail(path, f'cannot be read ({type(exc).__name__}: {msg}); truncated or corrupt file?') from None
    out: dict[str, TopicData] = {}
    for topic in sorted(raw):
        t = np.asarray(times[topic], dtype=np.int64)
        order = np.argsort(t, kind='stable')
        data = raw[topic]
        if np.any(order != np.arange(order.size)):
            data = [data[i] for i in order]
            t = t[order]
        msgtype, digest, count = conns[topic]
        out[topic] = TopicData(topic, msgtype, digest, t, data, count)
    files = [str(f) for f in info.get('relative_file_paths', [])] if info else [path.name]
    return Bag(path=path, storage=str(storage), version=info.get('version') if info else None, files=files,
               compression=str(info.get('compression_format') or '') if info else '', topics=out,
               metadata=info, unfinished=unfinished)


_MCAP_MAGIC = b'\x89MCAP0\r\n'


def _check_file(path: Path) -> None:
    """Cheap structural check of one storage file: MCAP magic at both ends, SQLite header and integrity."""
    size = path.stat().st_size
    if path.suffix == '.mcap':
        with path.open('rb') as f:
            head = f.read(8)
            if head != _MCAP_MAGIC:
                raise _fail(path, 'not an MCAP file (bad magic)')
            f.seek(max(0, size - 8))
            tail = f.read(8)
        if size < 16 or tail != _MCAP_MAGIC:
            raise _fail(path, f'truncated MCAP file ({size} bytes, no footer magic): the writer did not close it')
    elif path.suffix == '.db3':
        with path.open('rb') as f:
            head = f.read(16)
        if head != b'SQLite format 3\x00':
            raise _fail(path, 'not an SQLite3 database')
        try:
            con = sqlite3.connect(f'file:{path}?mode=ro', uri=True)
            try:
                row = con.execute('PRAGMA quick_check').fetchone()
            finally:
                con.close()
        except sqlite3.Error as exc:
            raise _fail(path, f'corrupt SQLite3 database ({exc})') from None
        if row is None or row[0] != 'ok':
            raise _fail(path, f'corrupt SQLite3 database (quick_check: {row[0] if row else "no answer"})')
