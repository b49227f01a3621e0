"""``metadata.yaml`` of a rosbag2 bag (format version 9): read and validated, or written with its checksums.

rosbag2 keeps ``rosbag2_bagfile_information``: the storage, the file list with per-file start, duration and
message count, the topics with their types, type hashes and counts, the totals, and ``custom_data`` (string
pairs that rosbag2 carries along). The recorder stores the integrity data there:

- ``gpr_sha256/<file>``: the SHA-256 of each closed storage file (SQLite3 has no checksums of its own; MCAP
  has CRC-32s, which this covers as well);
- ``gpr_metadata_sha256``: the SHA-256 of the ``metadata.yaml`` bytes without that one line, so any change
  to the metadata, down to a bit, is seen (a parsed-and-compared digest would miss changes that parse alike);
  the line itself must read exactly :func:`digest_line` of the value it holds.

These are checksums, not signatures: they catch corruption and edits by anyone who does not recompute them.
"""
from __future__ import annotations

import hashlib
import re
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final, Literal

import yaml

from ..errors import PATH_LENGTH, ConfigError, GprError, brief, kind_of
from ..inputs import safe_yaml
from .errors import BagError
from .fileio import read_bounded, require_regular, status_of

BAG_VERSION: Final[Literal[9]] = 9
STORAGES = ('mcap', 'sqlite3')
#: The end of rosbag2's integers (int64 nanoseconds, counts): every one lies in ``[0, INT_END)``.
INT_END = 2**63
#: ``custom_data`` key prefix of a storage file's SHA-256, and the key of the metadata's own digest.
FILE_DIGEST_PREFIX = 'gpr_sha256/'
METADATA_DIGEST_KEY = 'gpr_metadata_sha256'
#: Largest ``metadata.yaml`` read: about 280 bytes per storage file, so 16 MiB hold 16 hours of 1 s segments.
MAX_METADATA_BYTES = 16 << 20
#: Most YAML values in it: about 15 a storage file of some 280 bytes (the package's YAML bound, 200,000 values and
#: 10 MiB, refused a recording of 3.6 hours at the default flush_interval that the recorder had written).
MAX_METADATA_NODES = MAX_METADATA_BYTES // 12
_DIGEST_LINE = re.compile(rb'^[ \t]*' + METADATA_DIGEST_KEY.encode() + rb':[^\n]*(\n|\Z)', re.MULTILINE)
_PLACEHOLDER = '0' * 64
#: A ``ros_distro`` (``jazzy``), or none: older rosbag2 versions wrote no such field.
_DISTRO = re.compile(r'[a-z0-9_]{0,64}')
_INDENT = ' ' * 4  # rosbag2_bagfile_information > custom_data > key, as PyYAML indents


@dataclass(frozen=True)
class FileEntry:
    """One storage file as ``metadata.yaml`` lists it (times in ns since the epoch / ns)."""

    path: str
    starting_time: int
    duration: int
    message_count: int


@dataclass(frozen=True)
class TopicEntry:
    """One topic as ``metadata.yaml`` lists it."""

    name: str
    type: str
    serialization_format: str
    type_description_hash: str
    message_count: int
    #: ``offered_qos_profiles`` as listed: a list (version 9) or the YAML text of one (earlier versions), None absent.
    offered_qos: Any = None


@dataclass(frozen=True)
class Metadata:
    """The validated ``rosbag2_bagfile_information`` and the digest of the file it came from."""

    version: int
    storage: str
    starting_time: int
    duration: int
    message_count: int
    relative_file_paths: tuple[str, ...]
    files: tuple[FileEntry, ...]
    topics: tuple[TopicEntry, ...]
    compression_format: str
    compression_mode: str
    custom_data: Mapping[str, str]
    info: Mapping[str, Any]
    #: SHA-256 of the file without the digest line, how many digest lines it has (1 when written here) and the
    #: line (when there is exactly one).
    computed_digest: str
    digest_lines: int
    digest_line: bytes
    #: The ROS distribution the recorder says it ran on ('' where the metadata names none).
    ros_distro: str = ''


class _Schema:
    """Typed access to one mapping of the metadata; a wrong type names the field and what is allowed."""

    def __init__(self, source: str, data: Any, where: str) -> None:
        if not isinstance(data, Mapping):
            raise BagError(f'{source}: {where or "rosbag2_bagfile_information"} is {kind_of(data)}; allowed: a '
                           f'mapping')
        self.source, self.data, self.where = source, data, where

    def _fail(self, key: str, value: Any, allowed: str) -> BagError:
        text = repr(value)
        text = text if len(text) <= 60 else text[:57] + '...'
        return BagError(f'{self.source}: {self.where}{key} = {text} is invalid; allowed: {allowed}')

    def get(self, key: str, default: Any = None) -> Any:
        if key not in self.data:
            if default is None:
                raise BagError(f'{self.source}: missing {self.where}{key}')
            return default
        return self.data[key]

    def integer(self, key: str, *path: str) -> int:
        value = self.get(key)
        for p in path:
            value = _Schema(self.source, value, f'{self.where}{key}.').get(p)
            key = f'{key}.{p}'
        if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value < INT_END:
            raise self._fail(key, value, 'an integer from 0 to 2^63 - 1')
        return value

    def text(self, key: str, default: str | None = None) -> str:
        value = self.get(key, default)
        if value is None:
            value = ''
        if not isinstance(value, str):
            raise self._fail(key, value, 'a string')
        return value

    def items(self, key: str) -> list[_Schema]:
        value = self.get(key, [])
        if not isinstance(value, list):
            raise self._fail(key, value, 'a list')
        return [_Schema(self.source, v, f'{self.where}{key}[{i}].') for i, v in enumerate(value)]


def _digest_without_line(text: bytes) -> tuple[str, int, bytes]:
    lines = list(_DIGEST_LINE.finditer(text))
    rest = _DIGEST_LINE.sub(b'', text, count=1) if lines else text
    return hashlib.sha256(rest).hexdigest(), len(lines), lines[0].group(0) if len(lines) == 1 else b''


def digest_line(value: str) -> bytes:
    """The one form of the digest line: ``custom_data``'s indentation, the key, the value in single quotes."""
    return f"{_INDENT}{METADATA_DIGEST_KEY}: '{value}'\n".encode()


def _outside(rel: str) -> bool:
    """Whether a listed storage file lies outside the bag folder: an absolute path or one with ``..``."""
    parts = rel.replace('\\', '/').split('/')
    return rel.startswith(('/', '\\')) or '..' in parts or (len(parts) > 1 and parts[0].endswith(':'))


def read_metadata(folder: Path) -> Metadata:
    """Read and validate ``folder/metadata.yaml``.

    Raises:
        BagError: missing, not a regular file, larger than :data:`MAX_METADATA_BYTES`, not YAML, or a field of
            the wrong type (named, with what is allowed).
    """
    path = folder / 'metadata.yaml'
    if status_of(path) is None:
        raise BagError(f'{folder}: no metadata.yaml: not a rosbag2 bag folder (or a recording whose first '
                       f'segment was never closed)')
    require_regular(path, 'metadata.yaml')
    text = read_bounded(path, 'metadata.yaml', MAX_METADATA_BYTES)
    try:
        text.decode('utf-8')
    except UnicodeDecodeError as exc:
        raise BagError(f'{path}: not UTF-8 text (byte {exc.start}: {text[exc.start:exc.start + 1]!r}); '
                       f'allowed: a rosbag2 metadata file, UTF-8 YAML') from None
    try:
        data = safe_yaml.load_text(text.decode('utf-8'), str(path), max_nodes=MAX_METADATA_NODES,
                                   max_chars=MAX_METADATA_BYTES)
    except ConfigError as exc:
        raise BagError(f'not a rosbag2 metadata file: {exc}') from None
    if not isinstance(data, Mapping) or 'rosbag2_bagfile_information' not in data:
        raise BagError(f'{path}: not a rosbag2 metadata file (no rosbag2_bagfile_information mapping)')
    info = data['rosbag2_bagfile_information']
    top = _Schema(str(path), info, '')
    version = top.integer('version')
    storage = top.text('storage_identifier')
    if storage not in STORAGES:
        raise top._fail('storage_identifier', storage, ' or '.join(STORAGES))
    paths = top.get('relative_file_paths', [])
    if not isinstance(paths, list) or not all(isinstance(p, str) for p in paths):
        raise top._fail('relative_file_paths', paths, 'a list of file names')
    name, times = Counter(paths).most_common(1)[0] if paths else ('', 1)
    if times > 1:  # a file listed 1000 times was read 1000 times (4 GB): each segment is listed once
        raise BagError(f'{path}: relative_file_paths lists {brief(name)} {times} times; allowed: each segment file '
                       'once')
    outside = next((p for p in paths if _outside(p)), None)
    if outside is not None:  # ../other/x.db3 was read as the x.db3 inside the bag, the failure blamed on the lists
        raise BagError(f'{path}: relative_file_paths lists {brief(outside, PATH_LENGTH)}, a storage file outside the '
                       'bag folder; allowed: a file in the bag folder, by its name (the first rosbag2 versions wrote '
                       '<bag folder>/<name>)')
    files = tuple(FileEntry(f.text('path'), f.integer('starting_time', 'nanoseconds_since_epoch'),
                            f.integer('duration', 'nanoseconds'), f.integer('message_count'))
                  for f in top.items('files'))
    topics = []
    for t in top.items('topics_with_message_count'):
        meta = _Schema(str(path), t.get('topic_metadata'), f'{t.where}topic_metadata.')
        topics.append(TopicEntry(meta.text('name'), meta.text('type'), meta.text('serialization_format'),
                                 meta.text('type_description_hash', ''), t.integer('message_count'),
                                 meta.data.get('offered_qos_profiles')))
    distro = top.text('ros_distro', '')
    if not _DISTRO.fullmatch(distro):   # a list or a NUL in it passed a verification
        raise top._fail('ros_distro', distro, 'a ROS distribution name (lowercase letters, digits, _; rosbag2 writes '
                        'the one it was built for), or none')
    custom = top.get('custom_data', {}) or {}
    if not isinstance(custom, Mapping) or not all(isinstance(k, str) and isinstance(v, str)
                                                  for k, v in custom.items()):
        raise top._fail('custom_data', custom, 'a mapping of strings to strings')
    digest, lines, line = _digest_without_line(text)
    return Metadata(version=version, storage=storage, starting_time=top.integer('starting_time',
                                                                                'nanoseconds_since_epoch'),
                    duration=top.integer('duration', 'nanoseconds'), message_count=top.integer('message_count'),
                    relative_file_paths=tuple(paths), files=files, topics=tuple(topics),
                    compression_format=top.text('compression_format', ''),
                    compression_mode=top.text('compression_mode', ''), custom_data=dict(custom), info=info,
                    computed_digest=digest, digest_lines=lines, digest_line=line, ros_distro=distro)


#: The one entry of each per-file list that :func:`render_metadata` replaces by the files' rendered lines.
_SPLICE = 'gpr-splice'


def file_lines(path: str, start: int, duration: int, count: int, digest: str) -> tuple[bytes, bytes, bytes]:
    """A storage file's lines of ``relative_file_paths``, ``files`` and ``custom_data`` (its digest) as
    :func:`render_metadata` writes them, rendered once when the file is closed: a close that rendered every file
    listed took 0.24 s at 1,000 files and 3.3 s at 12,000 (an hour of 1 s segments and more), where the recorder's
    crash-safety bound allows 0.15 s."""
    def lines(key: str, value: Any) -> bytes:   # the lines after 'rosbag2_bagfile_information:' and 'KEY:'
        text = yaml.safe_dump({'rosbag2_bagfile_information': {key: value}}, default_flow_style=False,
                              sort_keys=False).encode('utf-8')
        return text.split(b'\n', 2)[2]
    entry = {'path': path, 'starting_time': {'nanoseconds_since_epoch': start}, 'duration': {'nanoseconds': duration},
             'message_count': count}
    return lines('relative_file_paths', [path]), lines('files', [entry]), lines('custom_data',
                                                                                {FILE_DIGEST_PREFIX + path: digest})


def render_metadata(info: dict[str, Any], files: Sequence[tuple[bytes, bytes, bytes]] | None = None) -> bytes:
    """``metadata.yaml`` bytes of ``info`` (a ``rosbag2_bagfile_information`` mapping) with the metadata digest
    :data:`METADATA_DIGEST_KEY` added to its ``custom_data`` (see the module docstring). ``files``: the storage files'
    lines (:func:`file_lines`, in order) spliced in as its ``relative_file_paths``, ``files`` and the digests after
    its ``custom_data`` (``info`` then lists none): the same bytes as the whole mapping rendered at once."""
    custom = dict(info.get('custom_data') or {})
    if files:
        info = {**info, 'relative_file_paths': [_SPLICE], 'files': [_SPLICE]}
        custom[_SPLICE] = _SPLICE
    custom[METADATA_DIGEST_KEY] = _PLACEHOLDER
    text: bytes = yaml.safe_dump({'rosbag2_bagfile_information': {**info, 'custom_data': custom}},
                                 default_flow_style=False, sort_keys=False).encode('utf-8')
    if files:
        item, entry = f'  - {_SPLICE}\n'.encode(), f'{_INDENT}{_SPLICE}: {_SPLICE}\n'.encode()
        for k, marker in enumerate((item, item, entry)):
            at = text.index(marker)
            text = text[:at] + b''.join(f[k] for f in files) + text[at + len(marker):]
    digest, lines, line = _digest_without_line(text)
    if lines != 1 or not line.startswith(_INDENT.encode() + METADATA_DIGEST_KEY.encode()):
        raise BagError(f'metadata: the {METADATA_DIGEST_KEY} line came out as {line!r} ({lines} such lines)')
    return text.replace(line, digest_line(digest), 1)


def record_distros(records: Sequence[Mapping[str, str]], source: str) -> tuple[tuple[str, str | None], ...]:
    """The ROS distribution each of an MCAP file's ``rosbag2`` metadata records states, with where: its
    ``ROS_DISTRO`` (rosbag2's MCAP plugin until it stored the bag's metadata there), the ``ros_distro`` of its
    ``serialized_metadata`` (the metadata YAML, read by the package's bounded reader; None where it is no such
    YAML, the reason given with it). A record of neither states none."""
    out: list[tuple[str, str | None]] = []
    for k, rec in enumerate(records):
        where = f'rosbag2 metadata record {k + 1}'
        if 'ROS_DISTRO' in rec:
            out.append((f'{where} ROS_DISTRO', rec['ROS_DISTRO']))
        if 'serialized_metadata' in rec:
            try:
                data = safe_yaml.load_text(rec['serialized_metadata'], f'{source} {where}',
                                           max_nodes=MAX_METADATA_NODES, max_chars=MAX_METADATA_BYTES)
            except GprError as exc:
                out.append((f'{where} serialized_metadata: not YAML ({brief(str(exc), 120)})', None))
                continue
            info = data.get('rosbag2_bagfile_information', data) if isinstance(data, Mapping) else None
            if not isinstance(info, Mapping):
                out.append((f'{where} serialized_metadata: {brief(data, 60)}, not a mapping', None))
            elif 'ros_distro' in info:
                out.append((f'{where} serialized_metadata ros_distro', str(info['ros_distro'])))
    return tuple(out)
