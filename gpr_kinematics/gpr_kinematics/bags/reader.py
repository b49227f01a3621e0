"""Read a rosbag2 bag (MCAP or SQLite3, one file or a split recording) into per-topic message lists.

Reading is done in three steps, each with its own errors:

1. **locate** (:func:`locate`): a bag folder with ``metadata.yaml`` naming its storage files
   (``relative_file_paths``, in order; a recording split into segments is read as one), or a single ``.mcap``
   / ``.db3`` file; the recorder's unfinished segment (``.recording/``) and storage files the metadata does not
   list are noted, not read;
2. **validate**: the metadata's fields and types (:mod:`.metadata`), every storage file a regular file (a FIFO
   is refused without being opened for reading, so nothing blocks);
3. **decode**: each file with a bounded reader, :func:`.mcap_file.read_mcap` (every length and CRC checked; the
   channels of one topic alike, :func:`_one_channel_per_topic`) or
   :func:`.sqlite_file.read_sqlite` (``PRAGMA quick_check`` first), computing each file's SHA-256 on the way.

Every failure is a :class:`~gpr_kinematics.bags.errors.BagError` whose one-line message names the file and
what is wrong; ``gpr verify`` reports it as "unreadable" with exit status 2. Only what a corrupt file raises is
caught (``sqlite3.Error`` and the decoders' own errors); anything else is a bug and propagates.
"""
from __future__ import annotations

import functools
import itertools
import os
import stat
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..errors import brief
from .cdr import Columns, decode_columns
from .errors import BagError
from .fileio import require_regular, shown, status_of
from .mcap_file import McapChannel, read_mcap
from .metadata import INT_END, Metadata, read_metadata, record_distros
from .sqlite_file import read_sqlite
from .storage_file import Contents, StorageFile
from .typestore import (
    JOINT_STATES_TOPIC,
    KNOWN_TOPICS,
    LEGACY_JOINT_STATES_TOPIC,
    PLATFORM_STATE_TOPIC,
    legacy_joint_states,
    normalize_type,
    suite_topic,
    topics_namespace,
)

#: Folder inside a bag where the recorder keeps the segment it is writing (not part of the bag until closed).
OPEN_SEGMENT_DIR = '.recording'
#: The unfinished segments' storage files named at most (a killed recorder leaves one).
MAX_UNFINISHED = 100
SUFFIXES = {'.mcap': 'mcap', '.db3': 'sqlite3'}


@dataclass
class TopicData:
    """Messages of one topic in log-time order: ``log_time`` [ns since the epoch] and the CDR bytes ``raw``;
    ``metadata_count``/``metadata_type`` as ``metadata.yaml`` lists them (None: not listed, or a single file)."""

    name: str
    msgtype: str
    digest: str
    log_time: NDArray[np.int64]
    raw: list[bytes]
    metadata_count: int | None = None
    metadata_type: str | None = None
    _columns: Columns | None = field(default=None, repr=False)

    def __len__(self) -> int:
        return len(self.raw)

    def columns(self) -> Columns:
        """All fields decoded into numpy columns (cached); see :func:`~gpr_kinematics.bags.cdr.decode_columns`."""
        if self._columns is None:
            try:
                self._columns = decode_columns(self.msgtype, self.raw)
            except BagError as exc:   # which topic: several carry one type (three PoseStamped topics)
                raise BagError(f'{self.name}: {exc}') from None
        return self._columns


@dataclass
class Bag:
    """A bag read into memory."""

    path: Path
    storage: str
    files: list[str]
    topics: dict[str, TopicData]
    metadata: Metadata | None
    storage_files: list[StorageFile]
    unfinished: list[str] = field(default_factory=list)
    unlisted: list[str] = field(default_factory=list)

    @functools.cached_property
    def suites(self) -> list[str]:
        """The namespaces of the node suites recorded: the prefix of each ``gpr/platform_state`` topic (``''`` at the
        root, ``/r1`` for ``/r1/gpr/platform_state``), sorted."""
        return sorted(n[:-len(PLATFORM_STATE_TOPIC)] for n in self.topics if n.endswith(PLATFORM_STATE_TOPIC))

    @functools.cached_property
    def namespace(self) -> str:
        """The namespace the node suite's topics were recorded in: where its ``gpr/platform_state`` is (one suite;
        ``''`` with several, :attr:`suites`); without one, the one namespace of every suite topic
        (:func:`.typestore.topics_namespace`: ``/r1/gpr/joint_states`` is ``/r1``'s legacy topic; ``''`` for a
        suite topic at the root, or ``/r1/gpr/platform_pose`` beside ``/r1/arm_controller/joint_states``)."""
        if self.suites:
            return self.suites[0] if len(self.suites) == 1 else ''
        return topics_namespace(self.topics)

    def unread(self) -> list[str]:
        """What of the folder is not read, in words: the unfinished segments, the storage files not listed."""
        return ([f'unfinished segment(s) (a recording still running, or a recorder killed): '
                 f'{", ".join(self.unfinished)}'] if self.unfinished else []) + (
            [f'storage file(s) that metadata.yaml does not list: {", ".join(self.unlisted)}'] if self.unlisted else [])

    def outside(self) -> list[str]:
        """Topics named like a suite topic (:data:`.typestore.KNOWN_TOPICS`) but not in the bag's :attr:`namespace`:
        not verified (another suite's, or another node's such as ``/r1/arm_controller/joint_states``)."""
        inside = {self.namespace + k for k in KNOWN_TOPICS}
        return sorted(n for n in self.topics if n not in inside and any(n.endswith(k) for k in KNOWN_TOPICS))

    def relative(self, name: str) -> str:
        """``name`` without the bag's :attr:`namespace` (as the node suite names its topics)."""
        ns = self.namespace
        return name[len(ns):] if ns and name.startswith(ns + '/') else name

    @property
    def version(self) -> int | None:
        return self.metadata.version if self.metadata else None

    @property
    def message_count(self) -> int:
        return sum(len(t) for t in self.topics.values())

    def topic(self, name: str) -> TopicData | None:
        """The topic ``name`` (with or without the leading slash), a suite topic in the bag's :attr:`namespace`
        only: a root topic of the same name is not the suite's (a decoy ``/joint_states`` beside a tampered
        ``/r1/joint_states`` was verified in its place)."""
        return self.topics.get(suite_topic(self.namespace, name))

    def joint_states_topic(self) -> str:
        """The suite's joint states: ``/joint_states``, ``/gpr/joint_states`` in bags recorded before it moved."""
        legacy = legacy_joint_states(self.topics, self.namespace) is not None
        return LEGACY_JOINT_STATES_TOPIC if legacy else JOINT_STATES_TOPIC


@dataclass(frozen=True)
class Layout:
    """Where a bag's pieces are: its storage files in order, the metadata, what is there but not read."""

    path: Path
    storage: str
    files: tuple[Path, ...]
    metadata: Metadata | None
    unfinished: tuple[str, ...]
    unlisted: tuple[str, ...]


def locate(path: str | Path) -> Layout:
    """Find and validate the parts of the bag at ``path`` (a folder with ``metadata.yaml``, or one file)."""
    path = Path(path)
    info = status_of(path)
    if info is None:
        raise BagError(f'{shown(path)}: does not exist')
    if not stat.S_ISDIR(info.st_mode):
        storage = SUFFIXES.get(path.suffix)
        if storage is None:
            raise BagError(f'{shown(path)}: not a bag: expected a rosbag2 folder (with metadata.yaml), a .mcap or a '
                           '.db3 file')
        require_regular(path, 'storage file')
        return Layout(path, storage, (path,), None, (), ())
    meta = read_metadata(path)
    suffix = next(s for s, name in SUFFIXES.items() if name == meta.storage)
    files = []
    for rel in meta.relative_file_paths:
        name = Path(rel).name
        other = SUFFIXES.get(Path(name).suffix, meta.storage)
        if other != meta.storage:
            raise BagError(f'{path}: metadata.yaml says storage_identifier {meta.storage} but lists {rel!r}, an '
                           f'{other} file name; allowed: the identifier of its files ({meta.storage} files end in '
                           f'{suffix})')
        if not name or name != rel.replace('\\', '/').rsplit('/', 1)[-1] or Path(name).suffix != suffix:
            raise BagError(f'{path}: metadata.yaml lists {rel!r}; allowed: {meta.storage} file names ending in '
                           f'{suffix}')
        f = path / name
        if status_of(f, 'storage file') is None:
            raise BagError(f'{shown(f)}: listed in metadata.yaml but missing')
        require_regular(f, 'storage file')
        files.append(f)
    listed = {f.name for f in files}
    unlisted = sorted(p.name for p in path.iterdir() if p.suffix in SUFFIXES and p.name not in listed)
    return Layout(path, meta.storage, tuple(files), meta, tuple(_unfinished(path)), tuple(unlisted))


def _unfinished(path: Path) -> list[str]:
    """The storage files of the recorder's unfinished segments, as it makes them: ``.recording/<segment>/<file>``
    (noted, never read). Real folders only, two levels, at most :data:`MAX_UNFINISHED` names: a ``.recording``
    linked to ``/`` walked the whole file system into a traceback, 1,200 nested folders into a RecursionError."""
    top = path / OPEN_SEGMENT_DIR
    if top.is_symlink():
        return [f'{OPEN_SEGMENT_DIR} (a symbolic link, not the recorder\'s: not listed)']
    if not top.is_dir():
        return []
    out: list[str] = []
    try:
        with os.scandir(top) as segments:
            for seg in itertools.islice(segments, MAX_UNFINISHED):
                names = [seg.name] if seg.is_file(follow_symlinks=False) else []
                if seg.is_dir(follow_symlinks=False):
                    with os.scandir(seg.path) as inner:
                        names = [f'{seg.name}/{e.name}' for e in itertools.islice(inner, MAX_UNFINISHED)
                                 if e.is_file(follow_symlinks=False)]
                out += [f'{OPEN_SEGMENT_DIR}/{n}' for n in names if Path(n).suffix in SUFFIXES]
    except OSError as exc:
        out.append(f'{OPEN_SEGMENT_DIR} (cannot be listed: {exc.strerror or exc})')
    return sorted(out)[:MAX_UNFINISHED]


def _read_mcap_file(path: Path, topics: set[str] | None, inflated: int = 0, messages: int = 0) -> Contents:
    m = read_mcap(path, topics, inflated, messages)
    if m.profile != 'ros2':
        raise BagError(f'{path}: MCAP profile {m.profile!r}; allowed: ros2 (rosbag2)')
    bad = sorted({c.encoding for c in m.channels.values()} - {'cdr'})
    if bad:
        raise BagError(f'{path}: message encoding {", ".join(bad)}; allowed: cdr')
    _one_channel_per_topic(path, m.channels, m.counts)
    schemas = {ch.topic: (ch.schema_encoding, ch.schema_text) for ch in m.channels.values()}
    formats = {ch.topic: ch.encoding for ch in m.channels.values()}
    qos = {ch.topic: ch.meta('offered_qos_profiles') for ch in m.channels.values()
           if 'offered_qos_profiles' in dict(ch.metadata)}
    counts: dict[str, int] = {}
    times: dict[str, list[int]] = {}
    data: dict[str, list[bytes]] = {}
    types: dict[str, str] = {}
    digests: dict[str, str] = {}
    for cid, ch in m.channels.items():
        counts[ch.topic] = counts.get(ch.topic, 0) + m.counts.get(cid, 0)
        types[ch.topic] = normalize_type(ch.msgtype)
        digests[ch.topic] = ch.meta('topic_type_hash')
        if cid in m.times:
            times.setdefault(ch.topic, []).extend(m.times[cid])
            data.setdefault(ch.topic, []).extend(m.data[cid])
    info = StorageFile(path.name, m.size, m.sha256, counts, types, digests, m.start, m.end, m.chunks,
                       m.chunks_with_crc, m.data_crc, m.summary_crc, schemas, formats, qos,
                       distros=record_distros(m.rosbag2, str(path)))
    return Contents(info, times, data, m.inflated, m.messages)


def _one_channel_per_topic(path: Path, channels: dict[int, McapChannel], counts: dict[int, int]) -> None:
    """:class:`BagError` if two channels of one topic differ in their type, embedded definition (schema), message
    encoding or metadata (offered QoS, type hash): the file's definition and QoS are kept per topic while the messages
    of all its channels are read, so an empty second channel with the package's definition hid a message-carrying one
    whose definition swapped two fields (an independent decoder misread every state, verify passed). rosbag2 writes
    one channel per topic; channels alike in all of these read alike, and pass."""
    first: dict[str, McapChannel] = {}
    for cid, ch in channels.items():
        seen = first.setdefault(ch.topic, ch)
        if seen is ch:
            continue
        differ = [what for what, a, b in (('type', seen.msgtype, ch.msgtype),
                                          ('schema encoding', seen.schema_encoding, ch.schema_encoding),
                                          ('embedded definition', seen.schema_text, ch.schema_text),
                                          ('message encoding', seen.encoding, ch.encoding)) if a != b]
        mine, theirs = dict(seen.metadata), dict(ch.metadata)
        differ += [f'metadata {brief(k, 40)}' for k in sorted(set(mine) | set(theirs)) if mine.get(k) != theirs.get(k)]
        if differ:
            raise BagError(f'{path}: topic {ch.topic!r} has two channels (ids {seen.id} and {cid}, with '
                           f'{counts.get(seen.id, 0)} and {counts.get(cid, 0)} messages) that differ in '
                           f'their {", ".join(differ[:4])}{", ..." if len(differ) > 4 else ""}; allowed: one channel '
                           'per topic (rosbag2 writes one), or channels alike in type, definition, encoding and '
                           'metadata')


def read_bag(path: str | Path, topics: list[str] | None = None) -> Bag:
    """Read every message (or those of ``topics``) of the bag at ``path``; see the module docstring.

    Raises:
        BagError: the path is missing or not a bag, its metadata is missing or bad, a storage file is missing,
            not a regular file, truncated or corrupt.
    """
    if topics is not None and (isinstance(topics, (str, bytes)) or not isinstance(topics, (list, tuple, set))
                               or not topics or not all(isinstance(t, str) and t for t in topics)):
        raise BagError(f'topics = {brief(topics)}; allowed: None (every topic) or a list of one or more topic names '
                       "(['/gpr/platform_state'], not a single name)")
    if not isinstance(path, (str, os.PathLike)) or not os.fspath(path):   # '' read the current folder
        raise BagError(f'path = {brief(path)}; allowed: a bag folder or a .mcap or .db3 file')
    layout = locate(path)
    wanted = {t if t.startswith('/') else '/' + t for t in topics} if topics else None
    contents: list[Contents] = []
    for f in layout.files:
        try:
            inflated, messages = (contents[-1].inflated, contents[-1].messages) if contents else (0, 0)
            contents.append(_read_mcap_file(f, wanted, inflated, messages)
                            if layout.storage == 'mcap' else read_sqlite(f, wanted, messages))
        except MemoryError:  # a failed allocation (a bag beyond the machine's memory), not a corrupt file
            raise BagError(f'{f}: not enough memory to read its messages (a bag is read into memory); allowed: a '
                           "bag whose messages fit in this process's memory") from None
    meta = layout.metadata
    listed = {t.name: t for t in meta.topics} if meta else {}
    names = sorted({n for c in contents for n in c.times} | (set(listed) & wanted if wanted else set(listed)))
    out: dict[str, TopicData] = {}
    for name in names:
        times = [v for c in contents for v in c.times.get(name, [])]
        if times and not 0 <= min(times) <= max(times) < INT_END:   # int64 would overflow (a traceback before)
            bad = min(times) if min(times) < 0 else max(times)
            raise BagError(f'{layout.path}: topic {name} has a log time of {bad} ns; allowed: 0 to 2^63 - 1 ns (a '
                           'rosbag2 time stamp)')
        t = np.asarray(times, dtype=np.int64)
        raw = [v for c in contents for v in c.data.get(name, [])]
        order = np.argsort(t, kind='stable')
        if np.any(order != np.arange(order.size)):
            raw = [raw[i] for i in order]
            t = t[order]
        entry = listed.get(name)
        file_type = next((c.file.types[name] for c in contents if name in c.file.types), '')
        file_digest = next((c.file.digests[name] for c in contents if c.file.digests.get(name)), '')
        out[name] = TopicData(name, file_type or (normalize_type(entry.type) if entry else ''),
                              (entry.type_description_hash if entry else '') or file_digest, t, raw,
                              entry.message_count if entry else None, normalize_type(entry.type) if entry else None)
    return Bag(path=layout.path, storage=layout.storage, files=[f.name for f in layout.files], topics=out,
               metadata=meta, storage_files=[c.file for c in contents], unfinished=list(layout.unfinished),
               unlisted=list(layout.unlisted))
