"""A crash-safe rosbag2 writer: a split recording whose segments are closed every flush interval.

The ``rosbags`` writers are not safe against a kill: the SQLite3 writer keeps every row in one transaction
until ``close()``, the MCAP writer writes its summary (and the bag's ``metadata.yaml``) only at ``close()``;
a SIGKILLed process leaves nothing that a reader accepts. :class:`SegmentedBagWriter` therefore writes the
bag as a *split recording* (rosbag2's own format for ``ros2 bag record --max-bag-duration``):

- the segment being written lives in ``<bag>/.recording/<name>_<i>/`` (a ``rosbags`` Writer of its own);
- a segment is closed when its oldest message is :data:`ROLL_FRACTION` x ``flush_interval`` old (checked on
  every message and by the caller's timer, see :meth:`SegmentedBagWriter.poll`), when it exceeds
  ``max_bag_size`` bytes or ``max_bag_duration`` seconds, and at :meth:`close`;
- closing a segment: the segment's writer finishes the file (MCAP summary and footer, or the SQLite3
  commit), the file is fsynced and hashed (SHA-256), moved atomically into the bag folder as
  ``<name>_<i>.mcap`` (``.db3``), the folder fsynced, and ``metadata.yaml`` rewritten atomically (temporary
  file + ``os.replace``) listing every closed segment with per-file and per-topic counts (bag format version
  9) and the checksums of :mod:`.metadata` (each file's SHA-256, the metadata's own digest).

The segment files themselves are written by :mod:`.storage_writers` (MCAP with every CRC, or SQLite3).

So at every instant the bag folder is a complete, readable rosbag2 split bag of everything received up to
the last roll; a kill loses at most the open segment: messages younger than about ``flush_interval``.
Tools read the segments as one recording (``ros2 bag info/play``, :func:`~gpr_kinematics.bags.reader.read_bag`).
"""
from __future__ import annotations

import contextlib
import math
import os
import shutil
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from rosbags.rosbag2.errors import WriterError

from ..errors import FileError, brief
from ..inputs.files import writable_folder
from ..inputs.validation import plain_number
from .errors import BagError
from .fileio import path_error, shown
from .metadata import BAG_VERSION, INT_END, file_lines, render_metadata
from .reader import OPEN_SEGMENT_DIR
from .storage_writers import ROS_DISTRO, McapStorage, Sqlite3Storage, StorageWriter, offered_qos
from .typestore import check_known, definition

#: Storage name -> file suffix.
STORAGES: dict[str, str] = {'mcap': '.mcap', 'sqlite3': '.db3'}
COMPRESSIONS = ('none', 'zstd')
#: A segment is closed once its oldest message is this fraction of the flush interval old.
ROLL_FRACTION = 0.8
@dataclass
class _Segment:
    index: int
    storage: StorageWriter
    folder: Path
    opened: float
    first_message: float | None = None
    first_stamp: int | None = None
    min_stamp: int | None = None
    max_stamp: int | None = None
    bytes: int = 0
    counts: dict[str, int] = field(default_factory=dict)


@dataclass
class _ClosedFile:
    path: str
    start: int
    duration: int
    count: int
    sha256: str
    lines: tuple[bytes, bytes, bytes] = field(init=False, repr=False)   # its metadata lines, rendered once

    def __post_init__(self) -> None:
        self.lines = file_lines(self.path, self.start, self.duration, self.count, self.sha256)


def check_output_path(path: Path) -> None:
    """Raise :class:`BagError` if ``path`` exists or cannot be created (nearest existing ancestor not a
    writable folder)."""
    try:
        os.lstat(path)
    except (FileNotFoundError, NotADirectoryError):
        pass   # nothing there: the folder is checked below
    except OSError as exc:   # a name too long (Path.exists raised it), a folder that cannot be searched
        raise BagError(f'output {path_error(path, exc)}') from None
    else:
        raise BagError(f'output {shown(path)} exists already; allowed: a path that does not exist yet (the recorder '
                       f'never overwrites a bag)')
    try:
        writable_folder(path, 'output')
    except FileError as exc:
        raise BagError(str(exc)) from None
    except OSError as exc:
        raise BagError(f'output {path_error(path, exc)}') from None


def _fsync_path(path: Path, directory: bool = False) -> None:
    flags = os.O_RDONLY | (os.O_DIRECTORY if directory else 0)
    fd = os.open(path, flags)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def check_format(storage: str, compression: str) -> None:
    """Refuse a storage or compression the writer does not write, or compression without MCAP (:class:`BagError`)."""
    if storage not in STORAGES:
        raise BagError(f'storage = {storage!r} is invalid; allowed: {" or ".join(STORAGES)}')
    if compression not in COMPRESSIONS:
        raise BagError(f'compression = {compression!r} is invalid; allowed: {" or ".join(COMPRESSIONS)}')
    if compression != 'none' and storage != 'mcap':
        raise BagError(f'compression = {compression!r} needs storage mcap (MCAP chunk compression); '
                       f'storage is {storage!r}')


class SegmentedBagWriter:
    """Crash-safe rosbag2 writer (see the module docstring).

    Args:
        path: bag folder to create (must not exist).
        topics: topic name -> message type (``pkg/msg/Type``), every type in the typestore.
        storage: ``mcap`` (default) or ``sqlite3``.
        flush_interval: seconds; a message is in a closed, readable file at most about this long after it
            was written. ``0`` disables the periodic roll (then only splits and :meth:`close` persist data).
        max_bag_size: bytes of message data per segment, 0 = no limit (``ros2 bag record --max-bag-size``).
        max_bag_duration: seconds per segment, 0 = no limit.
        compression: ``none`` or ``zstd`` (MCAP chunk compression; MCAP only).
        fsync: fsync each closed segment and the folder (survives power loss, not just a killed process).
        custom_data: string pairs stored in ``metadata.yaml`` (``custom_data``; the checksums are added).

    Raises:
        BagError: bad arguments, unknown type, output exists or is not writable.
    """

    def __init__(self, path: str | Path, topics: dict[str, str], storage: str = 'mcap',
                 flush_interval: float = 1.0, max_bag_size: int = 0, max_bag_duration: float = 0.0,
                 compression: str = 'none', fsync: bool = True,
                 custom_data: dict[str, str] | None = None) -> None:
        self.path = Path(path)
        check_format(storage, compression)
        for name, value in (('flush_interval', flush_interval), ('max_bag_size', max_bag_size),
                            ('max_bag_duration', max_bag_duration)):
            number = plain_number(value)   # numpy scalars as their numbers; truth values and text NaN
            if not 0.0 <= number < math.inf or name == 'max_bag_size' and number != int(number):
                whole = 'a whole number of bytes' if name == 'max_bag_size' else 'a finite number'
                raise BagError(f'{name} = {brief(value)} is invalid; allowed: {whole} >= 0 (0 = off)')
        if not isinstance(topics, Mapping) or not topics or not all(
                isinstance(t, str) and isinstance(ty, str) for t, ty in topics.items()):
            raise BagError(f'topics = {brief(topics)}; allowed: a mapping of one or more topic names to their message '
                           "types ({'/gpr/platform_state': 'gpr_interfaces/msg/PlatformState'})")
        if custom_data is not None and (not isinstance(custom_data, Mapping) or not all(
                isinstance(k, str) and isinstance(v, str) for k, v in custom_data.items())):
            raise BagError(f'custom_data = {brief(custom_data)}; allowed: a mapping of strings to strings (as '
                           'metadata.yaml stores it)')
        self.topics = {self._topic(t): check_known(ty, t) for t, ty in topics.items()}
        self.storage = storage
        self.suffix = STORAGES[storage]
        self.flush_interval = float(flush_interval)
        self.max_bag_size = int(max_bag_size)
        self.max_bag_duration = float(max_bag_duration)
        self.compression = compression
        self.fsync = bool(fsync)
        self.custom_data = dict(custom_data or {})
        self.defs = {t: definition(ty) for t, ty in self.topics.items()}
        self.counts: dict[str, int] = dict.fromkeys(self.topics, 0)
        self.files: list[_ClosedFile] = []
        self.segment: _Segment | None = None
        self.next_index = 0
        self.rolls = 0
        self.max_close_time = 0.0
        self._opened = False
        self._closed = False

    @staticmethod
    def _topic(name: str) -> str:
        name = name.strip()
        return name if name.startswith('/') else '/' + name

    # -- life cycle -----------------------------------------------------------------------------------------
    def open(self) -> None:
        """Create the bag folder and the first segment; :class:`BagError` (nothing left behind) on failure."""
        check_output_path(self.path)
        try:
            self.path.mkdir(parents=True)
        except OSError as exc:
            raise BagError(f'output {self.path} cannot be created: {exc.strerror or exc}; allowed: a new folder in a '
                           'writable place (missing parents are created)') from None
        self._opened = True
        try:
            self._open_segment()
        except BaseException:
            self.abort(remove=True)
            raise

    @property
    def name(self) -> str:
        return self.path.name

    def _open_segment(self) -> None:
        i = self.next_index
        self.next_index += 1
        folder = self.path / OPEN_SEGMENT_DIR / f'{self.name}_{i}'
        try:
            storage: StorageWriter = (McapStorage(folder, self.topics, self.defs, self.compression)
                                      if self.storage == 'mcap' else Sqlite3Storage(folder, self.topics, self.defs))
        except (WriterError, OSError) as exc:
            raise BagError(f'cannot open segment {folder}: {exc}') from None
        self.segment = _Segment(i, storage, folder, time.monotonic(), counts=dict.fromkeys(self.topics, 0))

    def write(self, topic: str, timestamp: int, data: bytes) -> None:
        """Append one serialized message (CDR bytes, stored unchanged) with its log time [ns], an integer from 0 to
        2^63 - 1 (refused before anything is written: a bad one had broken the open segment and lost the bag)."""
        if isinstance(timestamp, (bool, np.bool_)) or not isinstance(timestamp, (int, np.integer)) or \
                not 0 <= timestamp < INT_END:
            raise BagError(f'log time = {brief(timestamp)}; allowed: an integer from 0 to 2^63 - 1 [ns]')
        timestamp = int(timestamp)
        seg = self.segment
        if seg is None:
            raise BagError('the bag writer is not open')
        if (self.max_bag_duration and seg.first_stamp is not None
                and timestamp - seg.first_stamp >= self.max_bag_duration * 1e9):
            self.roll()  # a segment spans less than max_bag_duration of log time
            seg = self.segment
            if seg is None:
                raise BagError('the bag writer is not open')
        if topic not in self.topics:
            raise BagError(f'topic {topic!r} is not recorded; recorded topics: {", ".join(self.topics)}')
        try:
            seg.storage.write(topic, int(timestamp), data)
        except OSError as exc:
            raise BagError(f'cannot write to {seg.storage.file}: {exc.strerror or exc}') from None
        seg.counts[topic] += 1
        self.counts[topic] += 1
        seg.bytes += len(data)
        if seg.first_message is None:
            seg.first_message = time.monotonic()
            seg.first_stamp = int(timestamp)
        # The file's start and duration in metadata.yaml span its earliest to its latest log time (a wall
        # clock may step back between two messages).
        seg.min_stamp = int(timestamp) if seg.min_stamp is None else min(seg.min_stamp, int(timestamp))
        seg.max_stamp = int(timestamp) if seg.max_stamp is None else max(seg.max_stamp, int(timestamp))
        full = bool(self.max_bag_size) and seg.bytes >= self.max_bag_size
        due = bool(self.flush_interval) and time.monotonic() - seg.first_message >= ROLL_FRACTION * self.flush_interval
        if full or due:
            self.roll()

    def poll(self) -> bool:
        """Close the open segment if its oldest message is due (call every ~``flush_interval / 20``)."""
        seg = self.segment
        if seg is None or seg.first_message is None or not self.flush_interval:
            return False
        if time.monotonic() - seg.first_message >= ROLL_FRACTION * self.flush_interval:
            self.roll()
            return True
        return False

    def roll(self) -> None:
        """Close the open segment (if it holds messages) and open the next."""
        seg = self.segment
        if seg is None or seg.first_message is None:
            return
        self._close_segment()
        self._open_segment()
        self.rolls += 1

    def _close_segment(self) -> None:
        seg = self.segment
        if seg is None:
            return
        self.segment = None
        t0 = time.monotonic()
        try:
            seg.storage.close()
        except (WriterError, OSError) as exc:
            raise BagError(f'cannot close segment {seg.folder}: {exc}') from None
        src = seg.storage.file
        dst = self.path / src.name
        if self.fsync:
            _fsync_path(src)
        count = sum(seg.counts.values())
        start = seg.min_stamp if seg.min_stamp is not None else 0
        end = seg.max_stamp if seg.max_stamp is not None else start
        self.files.append(_ClosedFile(dst.name, start, max(0, end - start), count, seg.storage.sha256()))
        # Prepare the metadata that lists it, then two renames back to back (a kill between them leaves a
        # complete file that the metadata does not list yet: the window is two system calls). If either fails (a
        # full disk, a file size limit), the segment is not kept: the bag is what its metadata.yaml lists.
        try:
            tmp = self._prepare_metadata()
            os.replace(src, dst)
        except BaseException:
            self.files.pop()
            (self.path / 'metadata.yaml.tmp').unlink(missing_ok=True)
            raise
        os.replace(tmp, self.path / 'metadata.yaml')
        if self.fsync:
            _fsync_path(self.path, directory=True)
        shutil.rmtree(seg.folder, ignore_errors=True)
        self.max_close_time = max(self.max_close_time, time.monotonic() - t0)

    def _write_metadata(self) -> None:
        os.replace(self._prepare_metadata(), self.path / 'metadata.yaml')

    def _prepare_metadata(self) -> Path:
        """Write ``metadata.yaml.tmp`` (fsynced if ``fsync``) listing the closed files; return its path."""
        files = list(self.files)
        with_msgs = [f for f in files if f.count]
        start = min((f.start for f in with_msgs), default=0)
        end = max((f.start + f.duration for f in with_msgs), default=0)
        closed_counts = dict.fromkeys(self.topics, 0)
        for topic in self.topics:
            closed_counts[topic] = self._closed_counts.get(topic, 0)
        info = {
            'version': BAG_VERSION,
            'storage_identifier': self.storage,
            'duration': {'nanoseconds': max(0, end - start)},
            'starting_time': {'nanoseconds_since_epoch': start},
            'message_count': sum(f.count for f in files),
            'topics_with_message_count': [
                {'topic_metadata': {'name': topic, 'type': msgtype, 'serialization_format': 'cdr',
                                    'offered_qos_profiles': offered_qos(topic),
                                    'type_description_hash': self.defs[topic][1]},
                 'message_count': closed_counts[topic]}
                for topic, msgtype in self.topics.items()],
            'compression_format': '',
            'compression_mode': '',
            'relative_file_paths': [],   # the files' own lines, spliced in (render_metadata)
            'files': [],
            'custom_data': self.custom_data,
            'ros_distro': ROS_DISTRO,
        }
        text = render_metadata(info, [f.lines for f in files])
        tmp = self.path / 'metadata.yaml.tmp'
        with tmp.open('wb') as f:
            f.write(text)
            f.flush()
            if self.fsync:
                os.fsync(f.fileno())
        return tmp

    @property
    def _closed_counts(self) -> dict[str, int]:
        out = dict(self.counts)
        if self.segment is not None:
            for topic, n in self.segment.counts.items():
                out[topic] -= n
        return out

    @property
    def closed_message_count(self) -> int:
        """Messages already in closed segments (what a kill cannot lose)."""
        return sum(f.count for f in self.files)

    def close(self) -> None:
        """Close the open segment and write the final ``metadata.yaml``. A segment without messages is
        dropped unless the bag would otherwise have no file at all."""
        if self._closed or not self._opened:
            return
        seg = self.segment
        if seg is not None and seg.first_message is None and self.files:
            self.segment = None
            seg.storage.abort()
            shutil.rmtree(seg.folder, ignore_errors=True)
        elif seg is not None:
            self._close_segment()
        open_dir = self.path / OPEN_SEGMENT_DIR
        if open_dir.is_dir() and not any(open_dir.iterdir()):
            open_dir.rmdir()
        self._write_metadata()
        self._closed = True

    def abort(self, remove: bool = False) -> None:
        """Give up: drop the open segment; with ``remove`` delete the whole bag folder."""
        seg, self.segment = self.segment, None
        if seg is not None:
            # Giving up anyway: the folder may be gone or the disk full.
            with contextlib.suppress(WriterError, OSError):
                seg.storage.abort()
        if remove and self._opened:
            shutil.rmtree(self.path, ignore_errors=True)
        self._closed = True

    def __enter__(self) -> SegmentedBagWriter:
        self.open()
        return self

    def __exit__(self, exc_type: object, exc: object, tb: object) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()
