"""``bag.*`` checks: the bag as a file set, against what was read from it.

- ``bag.topic_types``: every recorded topic has a type of the typestore (so its messages were decoded), and a
  topic of the node suite has the type the suite publishes (:data:`.typestore.GPR_TOPICS`);
- ``bag.type_hash``: the stored type hash of every topic equals the current definition's (a changed
  ``PlatformState.msg`` is named);
- ``bag.message_count``: the per-topic counts of ``metadata.yaml`` equal the messages read;
- ``bag.metadata``: the rest of ``metadata.yaml`` against the files: the format version (9 for a bag of this
  suite's recorder, which carries its checksums; 1 to 9 for others), the file list
  (``relative_file_paths`` = ``files``), per file its message count, start and duration, the totals
  (``message_count``, ``starting_time``, ``duration``), each topic's type, type hash and serialization format as
  the files store them, its ``offered_qos_profiles`` too where the file stores them (MCAP channels, an SQLite3
  database's ``topics`` table where it holds a profile: an edit of the latched topics' durability would change what
  a replay latches), and the storage description: no file-level
  compression claimed (``compression_format`` and ``compression_mode`` empty: each file was read as it is, so a
  claim of ``zstd`` is false); an SQLite3 database's own metadata against the files (:mod:`.checks_embedded`; a
  single ``.db3`` file's against itself);
- ``bag.schemas``: the message definition each file embeds (MCAP schemas; SQLite3's ``message_definitions``) is the
  package's definition of its type (:func:`.typestore.definition`), by text (comments and blank lines aside: an
  edited ``float64 residual`` -> ``float32 residual`` would make an independent decoder misread every message,
  while this reader, which decodes with the package's definitions, would not notice) and by type hash (RIHS01);
- ``bag.checksums``: the metadata's own digest and each storage file's SHA-256 (:mod:`.metadata`) as recorded.
  A bag without them (written by another recorder) fails unless ``allow_missing_checksums``; a single MCAP
  file passes when every one of its CRCs was present (they were checked while reading).
"""
from __future__ import annotations

from ..errors import brief
from .checks_embedded import embedded_problems, qos_data
from .metadata import BAG_VERSION, FILE_DIGEST_PREFIX, METADATA_DIGEST_KEY, digest_line
from .reader import Bag
from .results import Check, bag_check, skipped
from .typestore import KNOWN_TOPICS, definition, typestore

Problem = tuple[str, float, float, str]


def _differs(problems: list[Problem], where: str, what: str, listed: object, read: object) -> None:
    if listed != read:
        problems.append((where, 1.0, 0.0, f'{what}: metadata.yaml says {listed!r}, the files hold {read!r}'))


def _topic_problems(bag: Bag, problems: list[Problem]) -> None:
    """Each topic of ``metadata.yaml`` against the files: type, type hash, serialization format."""
    assert bag.metadata is not None  # callers check
    for t in bag.metadata.topics:
        for f in bag.storage_files:
            if t.name in f.types:
                _differs(problems, t.name, f'type in {f.name}', t.type, f.types[t.name])
                if t.type_description_hash and f.digests.get(t.name):
                    _differs(problems, t.name, f'type hash in {f.name}', t.type_description_hash, f.digests[t.name])
                if t.name in f.formats:
                    _differs(problems, t.name, f'serialization_format in {f.name}', t.serialization_format,
                             f.formats[t.name])
                if t.name in f.qos and t.offered_qos is not None:
                    _differs(problems, t.name, f'offered_qos_profiles in {f.name}', qos_data(t.offered_qos, t.name),
                             qos_data(f.qos[t.name], t.name))


def _distro_problems(bag: Bag, problems: list[Problem]) -> None:
    """The ROS distribution each MCAP file's ``rosbag2`` records state against ``metadata.yaml``'s (a file whose
    record a crash cut off states none; a bag whose metadata names none is older than the field)."""
    assert bag.metadata is not None  # callers check
    for f in bag.storage_files:
        for where, distro in f.distros:
            if distro is None:
                problems.append((f.name, 1.0, 0.0, f'{where} in {f.name}'))
            elif bag.metadata.ros_distro != distro and bag.metadata.ros_distro:   # the record's value shown briefly
                problems.append((f.name, 1.0, 0.0, f'ros_distro ({where} in {f.name}): metadata.yaml says '
                                                   f'{bag.metadata.ros_distro!r}, the files hold {brief(distro, 64)}'))


def _metadata_problems(bag: Bag) -> tuple[list[Problem], int]:
    meta = bag.metadata
    assert meta is not None  # callers check
    problems: list[Problem] = []
    signed = METADATA_DIGEST_KEY in meta.custom_data
    if (meta.version != BAG_VERSION) if signed else not 1 <= meta.version <= BAG_VERSION:
        allowed = f'{BAG_VERSION}, the format the recorder writes' if signed else f'1 to {BAG_VERSION}'
        problems.append(('bag', 1.0, 0.0, f'version {meta.version}; allowed: {allowed}'))
    _differs(problems, 'bag', 'file list (relative_file_paths vs files)', list(meta.relative_file_paths),
             [f.path for f in meta.files])
    read = {f.name: f for f in bag.storage_files}
    for entry in meta.files:
        f = read.get(entry.path)
        if f is None:
            problems.append((entry.path, 1.0, 0.0, 'listed in files but not in relative_file_paths'))
            continue
        _differs(problems, entry.path, 'message_count', entry.message_count, f.message_count)
        if f.start is not None and f.end is not None:
            _differs(problems, entry.path, 'starting_time', entry.starting_time, f.start)
            _differs(problems, entry.path, 'duration', entry.duration, f.end - f.start)
    _differs(problems, 'bag', 'message_count', meta.message_count, sum(f.message_count for f in bag.storage_files))
    starts = [f.start for f in bag.storage_files if f.start is not None]
    ends = [f.end for f in bag.storage_files if f.end is not None]
    if starts and ends:
        _differs(problems, 'bag', 'starting_time', meta.starting_time, min(starts))
        _differs(problems, 'bag', 'duration', meta.duration, max(ends) - min(starts))
    _topic_problems(bag, problems)
    if meta.compression_format.lower() not in ('', 'none') or meta.compression_mode.lower() not in ('', 'none'):
        problems.append(('bag', 1.0, 0.0, f'compression_format {meta.compression_format!r:.40}, compression_mode '
                         f'{meta.compression_mode!r:.40}: the files are not compressed (each was read as a '
                         f'{meta.storage} file as it is); allowed: empty (no file-level compression)'))
    listed = {t.name for t in meta.topics}
    for f in bag.storage_files:
        for name in sorted(set(f.types) - listed):
            problems.append((name, 1.0, 0.0, f'in {f.name} but not in metadata.yaml'))
    _distro_problems(bag, problems)
    embedded, rows = embedded_problems(bag.storage_files, meta)
    return problems + embedded, 5 + 3 * len(meta.files) + 3 * len(meta.topics) + rows


def _normal(text: str) -> list[str]:
    """A message definition's lines without comments, trailing blanks and empty lines."""
    lines = (line.split('#', 1)[0].rstrip() for line in text.splitlines())
    return [line for line in lines if line]


def _first_difference(got: list[str], want: list[str]) -> str:
    """Where two definitions' lines first differ, both lines quoted briefly."""
    k = next((i for i, (a, b) in enumerate(zip(got, want, strict=False)) if a != b), min(len(got), len(want)))
    mine, theirs = (brief(lines[k] if k < len(lines) else '(no line)', 50) for lines in (got, want))
    return f'line {k + 1} is {mine}, the package\'s {theirs}'


def _schema_problems(bag: Bag) -> tuple[list[Problem], int]:
    """``bag.schemas`` (module docstring): each embedded definition against the package's."""
    known = typestore().fielddefs
    problems: list[Problem] = []
    checked = 0
    for f in bag.storage_files:
        for topic in sorted(set(f.schemas) | set(f.digests)):
            msgtype = f.types.get(topic, '')
            if msgtype not in known:
                continue  # bag.topic_types names it
            checked += 1
            text, digest = definition(msgtype)
            encoding, embedded = f.schemas.get(topic, ('ros2msg', text))
            if encoding != 'ros2msg':
                problems.append((topic, 1.0, 0.0, f'the definition of {msgtype} in {f.name} is encoded '
                                 f'{encoding!r:.40}; allowed: ros2msg'))
            elif _normal(embedded) != _normal(text):
                problems.append((topic, 1.0, 0.0, f'the definition of {msgtype} embedded in {f.name} differs from the '
                                 f"package's: {_first_difference(_normal(embedded), _normal(text))}"))
            if f.digests.get(topic) and f.digests[topic] != digest:
                problems.append((topic, 1.0, 0.0, f'type hash of {msgtype} in {f.name} is not the package\'s '
                                 f'({digest})'))
    return problems, checked


def checksum_check(bag: Bag, allow_missing: bool) -> Check:
    """``bag.checksums`` (module docstring); ``replay_node`` warns by it too (with ``allow_missing``)."""
    name = 'bag.checksums'
    meta = bag.metadata
    if meta is None:
        f = bag.storage_files[0]
        if f.chunks and f.chunks_with_crc == f.chunks and f.data_crc and f.summary_crc:
            return skipped(name, 'bag', '', 'single MCAP file: its CRCs were all present and checked')
        if allow_missing:
            return skipped(name, 'bag', '', 'single file without checksums (allowed by the caller)')
        return bag_check(name, 'bag', [(f.name, 1.0, 0.0, 'a single file without checksums (no metadata.yaml, '
                                                          'not every MCAP CRC): it cannot be checked')], 1, '')
    custom = meta.custom_data
    digests = {k[len(FILE_DIGEST_PREFIX):]: v for k, v in custom.items() if k.startswith(FILE_DIGEST_PREFIX)}
    if METADATA_DIGEST_KEY not in custom and not digests and allow_missing:
        return skipped(name, 'bag', '', 'no checksums in metadata.yaml (allowed by the caller)')
    problems: list[Problem] = []
    stored = custom.get(METADATA_DIGEST_KEY)
    if stored is None or meta.digest_lines != 1:
        problems.append(('metadata.yaml', 1.0, 0.0, f'no {METADATA_DIGEST_KEY} (written by another recorder, or '
                                                    f'custom_data edited)' if stored is None else
                         f'{meta.digest_lines} lines carry {METADATA_DIGEST_KEY}; expected one'))
    elif stored != meta.computed_digest:
        problems.append(('metadata.yaml', 1.0, 0.0, 'SHA-256 differs from the recorded one: metadata.yaml changed'))
    elif meta.digest_line != digest_line(stored):
        problems.append(('metadata.yaml', 1.0, 0.0, f'the {METADATA_DIGEST_KEY} line is not in its one form'))
    for f in bag.storage_files:
        want = digests.get(f.name)
        if want is None:
            problems.append((f.name, 1.0, 0.0, 'no recorded SHA-256'))
        elif want != f.sha256:
            problems.append((f.name, 1.0, 0.0, 'SHA-256 differs from the recorded one: the file changed'))
    return bag_check(name, 'bag', problems, 1 + len(bag.storage_files), '')


def bag_checks(bag: Bag, allow_missing_checksums: bool = False) -> list[Check]:
    """The ``bag.*`` checks (see the module docstring)."""
    store = typestore()
    topics = list(bag.topics.values())
    types: list[Problem] = [(t.name, 1.0, 0.0, f'type {t.msgtype!r} is not in the typestore') for t in topics
                            if t.msgtype not in store.fielddefs]
    known = {t.name: KNOWN_TOPICS.get(bag.relative(t.name)) for t in topics}
    types += [(t.name, 1.0, 0.0, f'type {t.msgtype!r}; the node suite publishes {known[t.name]}')
              for t in topics if known[t.name] is not None and t.msgtype != known[t.name]]
    hashes: list[Problem] = [(t.name, 1.0, 0.0, 'stored type hash differs from the current message definition')
                             for t in topics if t.msgtype in store.fielddefs and t.digest
                             and t.digest != definition(t.msgtype)[1]]
    counts: list[Problem] = [(t.name, float(abs(t.metadata_count - len(t))), 0.0,
                              f'metadata.yaml counts {t.metadata_count}, the files hold {len(t)}')
                             for t in topics if t.metadata_count is not None and t.metadata_count != len(t)]
    schemas, schemas_checked = _schema_problems(bag)
    out = [bag_check('bag.topic_types', 'bag', types, len(topics), ''),
           bag_check('bag.type_hash', 'bag', hashes, len(topics), ''),
           bag_check('bag.schemas', 'bag', schemas, schemas_checked, ''),
           bag_check('bag.message_count', 'bag', counts, len(topics), 'messages')]
    embedded, rows = embedded_problems(bag.storage_files, None) if bag.metadata is None else ([], 0)
    if bag.metadata is None and rows:   # a single SQLite3 file: its own metadata against itself
        out.append(bag_check('bag.metadata', 'bag', embedded, rows, ''))
    elif bag.metadata is None:
        out.append(skipped('bag.metadata', 'bag', '', 'a single storage file: no metadata.yaml'))
    else:
        problems, checked = _metadata_problems(bag)
        out.append(bag_check('bag.metadata', 'bag', problems, checked, ''))
    out.append(checksum_check(bag, allow_missing_checksums))
    return out
