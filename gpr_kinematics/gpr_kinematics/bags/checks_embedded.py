"""The SQLite3 database's own metadata against the bag (part of ``bag.metadata``).

rosbag2's sqlite3 plugin stores the bag's metadata in each database's ``metadata`` table (schema version 3 and
later; YAML, the mapping under ``rosbag2_bagfile_information``), a row at each update: when a file is opened, before
a split and at the end of the recording, the last row the one it reads back. This package's recorder writes each
segment with the ``rosbags`` writer, which stores that segment's own metadata (itself as the only file). An edit of
it (the latched topics made volatile, a count of 54 made 5400) passed re-signed, since nothing read it. Each row is
read with the package's bounded YAML reader and compared with what ``bag.metadata`` compares ``metadata.yaml``
with:

- ``metadata_version`` and ``version`` as ``metadata.yaml``'s (the plugin reads the topics' QoS by it),
  ``storage_identifier`` ``sqlite3``;
- ``relative_file_paths``: this file alone, or the bag's files from the first up to this one (rosbag2 lists the
  files so far), by name;
- each topic it lists: held by the file's ``topics`` table, with its type, serialization format, type hash and
  offered QoS (the table's, else ``metadata.yaml``'s), and its count the messages of the files the row lists;
- the totals and each file entry: a row that lists topics (complete: the end of a recording, a segment of this
  recorder) counts exactly the messages of the files it lists, spans their log times; one without (rosbag2's rows
  written while recording, whose counts lag) counts no more than they hold.
"""
from __future__ import annotations

from pathlib import PurePosixPath
from typing import Any

from ..errors import GprError, brief
from ..inputs import safe_yaml
from .metadata import MAX_METADATA_BYTES, MAX_METADATA_NODES, Metadata
from .storage_file import StorageFile

Problem = tuple[str, float, float, str]

#: The ``ros_distro`` the ``rosbags`` writer stores in a database's own metadata (its name, not a distribution: this
#: package's recorder writes its SQLite3 segments with it), compared with nothing.
ROSBAGS_DISTRO = 'rosbags'


def qos_data(value: object, topic: str) -> object:
    """``offered_qos_profiles`` as data: YAML text (a file's, or metadata before version 9) read by the package's
    bounded reader; empty text or none is no profile."""
    if isinstance(value, str):
        try:
            value = safe_yaml.load_text(value, f'{topic} offered_qos_profiles') if value.strip() else []
        except GprError as exc:
            return f'unreadable: {exc}'
    return [] if value is None else value


def _name(path: object) -> str | None:
    return PurePosixPath(path.replace('\\', '/')).name if isinstance(path, str) else None


def _get(data: object, *keys: str) -> object:
    for key in keys:
        data = data.get(key) if isinstance(data, dict) else None
    return data


def _first_difference(what: str, says: object, want: object) -> tuple[str, object, object]:
    """Where two profile lists of the same length first differ (``offered_qos_profiles[0].durability of /t``), with
    both values; the whole lists otherwise."""
    if isinstance(says, list) and isinstance(want, list) and len(says) == len(want):
        for i, (a, b) in enumerate(zip(says, want, strict=True)):
            if isinstance(a, dict) and isinstance(b, dict) and a != b:
                key = next(k for k in sorted({*a, *b}, key=str) if a.get(k) != b.get(k))
                head, _, tail = what.partition(' of ')
                return f'{head}[{i}].{key} of {tail}', a.get(key), b.get(key)
    return what, says, want


class _Row:
    """One row of one file's ``metadata`` table, its problems collected."""

    def __init__(self, f: StorageFile, rid: int, problems: list[Problem]) -> None:
        self.f, self.where, self.problems = f, f"{f.name}'s own metadata (its metadata table, row {rid})", problems

    def differs(self, what: str, says: object, ref: str, want: object) -> None:
        if says != want:
            self.problems.append((self.f.name, 1.0, 0.0, f'{self.where}: {what}: it says {brief(says, 80)}, {ref} '
                                                         f'{brief(want, 80)}'))

    def most(self, what: str, says: object, want: int) -> None:
        if not isinstance(says, int) or isinstance(says, bool) or not 0 <= says <= want:
            self.problems.append((self.f.name, 1.0, 0.0, f'{self.where}: {what}: it says {brief(says, 80)}; allowed: '
                                                         f'0 to {want}, the messages of the files it lists'))


def _files_listed(row: _Row, info: dict[str, Any], meta: Metadata | None, index: int,
                  read: dict[str, StorageFile]) -> list[StorageFile] | None:
    """The files the row lists, as read (None: a list not allowed, or files not in this reading: a single file of a
    split bag)."""
    raw = info.get('relative_file_paths')
    names = [_name(p) for p in raw] if isinstance(raw, list) else raw
    upto = [_name(p) for p in meta.relative_file_paths[:index + 1]] if meta else None
    alone = [row.f.name]
    if names != alone and names != upto and (upto is not None or not isinstance(names, list) or names[-1:] != alone):
        allowed = f'{alone!r}' + (f' or {upto!r}' if upto is not None and upto != alone else '')
        row.problems.append((row.f.name, 1.0, 0.0, f'{row.where}: relative_file_paths: it says {brief(raw, 80)}; '
                             f'allowed: {allowed} (this file alone, or the files up to it)'))
        return None
    files = [read.get(n) for n in names if n is not None] if isinstance(names, list) else [None]
    return [f for f in files if f is not None] if None not in files else None


def _topics(row: _Row, info: dict[str, Any], meta: Metadata | None, files: list[StorageFile] | None) -> bool:
    """Each topic the row lists against the file's topics table (and metadata.yaml's QoS); True if it lists any."""
    topics = info.get('topics_with_message_count') or []
    if not isinstance(topics, list):
        row.problems.append((row.f.name, 1.0, 0.0, f'{row.where}: topics_with_message_count is {brief(topics, 80)}; '
                                                   'allowed: a list'))
        return False
    f, listed = row.f, {t.name: t for t in meta.topics} if meta else {}
    for entry in topics:
        t = _get(entry, 'topic_metadata')
        name = _get(t, 'name')
        if not isinstance(name, str) or name not in f.types:
            row.problems.append((f.name, 1.0, 0.0, f'{row.where}: lists the topic {brief(name, 80)}, which the '
                                                   "file's topics table does not hold"))
            continue
        assert isinstance(t, dict)
        row.differs(f'type of {name}', t.get('type'), 'the topics table', f.types[name])
        row.differs(f'serialization_format of {name}', t.get('serialization_format'), 'the topics table',
                    f.formats.get(name))
        if f.digests.get(name) and t.get('type_description_hash'):
            row.differs(f'type hash of {name}', t.get('type_description_hash'), 'the topics table', f.digests[name])
        stored = f.qos.get(name)
        want = stored if stored is not None else listed[name].offered_qos if name in listed else None
        if want is not None and 'offered_qos_profiles' in t:
            says, want = qos_data(t['offered_qos_profiles'], name), qos_data(want, name)
            what, says, want = _first_difference(f'offered_qos_profiles of {name}', says, want)
            row.differs(what, says, 'the topics table' if stored is not None else 'metadata.yaml', want)
        if files is not None:
            row.differs(f'message_count of {name}', _get(entry, 'message_count'), 'the files hold',
                        sum(g.counts.get(name, 0) for g in files))
    return bool(topics)


def _totals(row: _Row, info: dict[str, Any], files: list[StorageFile], complete: bool) -> None:
    """The row's totals and file entries against the files it lists: exact where ``complete``, else at most."""
    total = sum(g.message_count for g in files)
    starts = [g.start for g in files if g.start is not None]
    ends = [g.end for g in files if g.end is not None]
    if complete:
        row.differs('message_count', info.get('message_count'), 'the files hold', total)
        if starts and ends:
            row.differs('starting_time', _get(info, 'starting_time', 'nanoseconds_since_epoch'), 'the files hold',
                        min(starts))
            row.differs('duration', _get(info, 'duration', 'nanoseconds'), 'the files hold', max(ends) - min(starts))
    else:
        row.most('message_count', info.get('message_count'), total)
    by_name = {g.name: g for g in files}
    entries = info.get('files') or []
    for entry in entries if isinstance(entries, list) else [entries]:
        name = _name(_get(entry, 'path'))
        g = by_name.get(name) if name is not None else None
        if g is None:
            row.problems.append((row.f.name, 1.0, 0.0, f'{row.where}: files lists {brief(_get(entry, "path"), 80)}, '
                                                       'not a file of its relative_file_paths'))
        elif complete:
            row.differs(f'message_count of {g.name}', _get(entry, 'message_count'), 'the file holds', g.message_count)
            if g.start is not None and g.end is not None:
                row.differs(f'starting_time of {g.name}', _get(entry, 'starting_time', 'nanoseconds_since_epoch'),
                            'the file holds', g.start)
                row.differs(f'duration of {g.name}', _get(entry, 'duration', 'nanoseconds'), 'the file holds',
                            g.end - g.start)
        else:
            row.most(f'message_count of {g.name}', _get(entry, 'message_count'), g.message_count)


def embedded_problems(files: list[StorageFile], meta: Metadata | None) -> tuple[list[Problem], int]:
    """Every row of every SQLite3 file's ``metadata`` table against the bag (module docstring): the problems, and
    the rows checked."""
    problems: list[Problem] = []
    read = {f.name: f for f in files}
    checked = 0
    for index, f in enumerate(files):
        for rid, version, text in f.embedded:
            checked += 1
            row = _Row(f, rid, problems)
            try:
                info = safe_yaml.load_text(text, row.where, max_nodes=MAX_METADATA_NODES,
                                           max_chars=MAX_METADATA_BYTES)
            except GprError as exc:
                problems.append((f.name, 1.0, 0.0, f'{row.where}: not YAML ({exc})'))
                continue
            info = info.get('rosbag2_bagfile_information', info) if isinstance(info, dict) else info
            if not isinstance(info, dict):
                problems.append((f.name, 1.0, 0.0, f'{row.where}: {brief(info, 80)}; allowed: a mapping, rosbag2 '
                                                   'metadata'))
                continue
            row.differs('metadata_version', version, 'its version', info.get('version'))
            if meta is not None:
                row.differs('version', info.get('version'), 'metadata.yaml says', meta.version)
                if meta.ros_distro and info.get('ros_distro') not in (None, ROSBAGS_DISTRO):   # older rows: none
                    row.differs('ros_distro', info.get('ros_distro'), 'metadata.yaml says', meta.ros_distro)
            row.differs('storage_identifier', info.get('storage_identifier', 'sqlite3'), 'the file is', 'sqlite3')
            listed = _files_listed(row, info, meta, index, read)
            complete = _topics(row, info, meta, listed)
            if listed is not None:
                _totals(row, info, listed, complete)
    return problems, checked
