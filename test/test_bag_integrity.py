"""Tamper evidence beyond the checksums: copies written again through the writer (valid checksums) with one
change each; the content checks (markers, companion topics, metadata totals, types) name it. And the
checksums themselves: each kind of change is named, a bag without them fails unless allowed."""
from __future__ import annotations

import json
import math
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from bag_support import (
    MARKERS,
    REFERENCE,
    STATE,
    copy_bag,
    messages_of,
    resign_metadata,
    rewritten,
    small_sweep,
    write_bag,
)
from gpr_kinematics.bags.errors import BagError
from gpr_kinematics.bags.metadata import METADATA_DIGEST_KEY, digest_line
from gpr_kinematics.bags.reader import read_bag
from gpr_kinematics.bags.results import format_table
from gpr_kinematics.bags.typestore import GPR_TOPICS, typestore
from gpr_kinematics.bags.verify import verify_bag
from gpr_kinematics.cli import main as cli


@pytest.fixture(scope='module')
def src(tmp_path_factory: pytest.TempPathFactory) -> Path:
    msgs = small_sweep()
    return write_bag(tmp_path_factory.mktemp('src') / 'src', msgs, {t: GPR_TOPICS[t] for t in GPR_TOPICS})


def _failed(path: Path, **kw: Any) -> list[tuple[str, int | None, str]]:
    return [(f.check, f.sample, f.detail) for f in verify_bag(path, **kw).failures]


def _marker_edit(sample_stamp: int, change: Any) -> Any:
    def edit(topic: str, msg: Any) -> Any:
        if topic == MARKERS and msg.markers[0].header.stamp.sec * 10**9 + msg.markers[0].header.stamp.nanosec \
                == sample_stamp:
            return change(msg)
        return msg
    return edit


def test_markers_are_checked_against_the_state(tmp_path: Path, src: Path) -> None:
    assert verify_bag(src).passed
    t7 = int(read_bag(src).topic(STATE).log_time[7])

    def far(m: Any) -> Any:  # what one flipped exponent bit did in the issue: z = -5.3e135 m
        m.markers[1].points[3].z = -5.3e135
        return m

    def tiny(m: Any) -> Any:
        m.markers[2].points[0].x += 1e-9
        return m

    def renamed(m: Any) -> Any:
        m.markers[3].ns = 'nominal'
        return m

    def moved(m: Any) -> Any:
        m.markers[0].pose.position.z = 0.01
        return m

    def dropped(m: Any) -> Any:
        m.markers = m.markers[:3]
        return m

    for name, change in (('far', far), ('tiny', tiny), ('renamed', renamed), ('moved', moved), ('dropped', dropped)):
        failed = _failed(rewritten(src, tmp_path / name, _marker_edit(t7, change)))
        assert [(c, s) for c, s, _ in failed] == [('topic.markers', 7)], (name, failed)
    result = verify_bag(tmp_path / 'far')
    worst = next(c for c in result.checks if c.name == 'topic.markers').worst
    assert worst == pytest.approx(5.3e135)
    assert next(c for c in verify_bag(tmp_path / 'tiny').checks if c.name == 'topic.markers').worst == \
        pytest.approx(1e-9, rel=1e-6)


def test_markers_without_a_state_and_undecodable_markers(tmp_path: Path, src: Path,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    t7 = int(read_bag(src).topic(STATE).log_time[7])

    def shifted(m: Any) -> Any:  # a marker array whose stamp no state has
        for mk in m.markers:
            mk.header.stamp.nanosec += 1
        return m

    failed = _failed(rewritten(src, tmp_path / 'extra', _marker_edit(t7, shifted)))
    assert ('topic.markers_extra', None, 'messages without a PlatformState of the same stamp') in failed
    # A MarkerArray that does not decode at all: the bag is unreadable (exit 2), whatever the checksums say.
    cut = rewritten(src, tmp_path / 'cut', _marker_edit(t7, lambda m: b'\x00\x01\x00\x00\x07\x00\x00\x00'))
    assert cli.main(['verify', str(cut)]) == 2
    err = capsys.readouterr().err
    assert err.startswith('gpr verify: error: unreadable: ') and 'MarkerArray cannot be decoded' in err


def test_companion_topics_with_a_wrong_type_or_an_unknown_topic(tmp_path: Path, src: Path) -> None:
    msgs = messages_of(src)
    types = {t: GPR_TOPICS[t] for t in GPR_TOPICS}
    geometry = [m for m in msgs if m[0] == '/gpr/geometry']  # a std_msgs/String message
    # An extra topic of a known type decodes and is counted; it does not make the bag fail.
    ok = write_bag(tmp_path / 'ok', msgs + [('/chatter', msgs[-1][1], geometry[0][2])],
                   {**types, '/chatter': 'std_msgs/msg/String'})
    result = verify_bag(ok)
    assert result.passed and result.counts['/chatter'] == 1
    # A topic of the suite recorded with another type: named, and its companion check skipped.
    joint = '/joint_states'
    wrong = write_bag(tmp_path / 'wrong', [m for m in msgs if m[0] != joint] + [(joint, msgs[-1][1], geometry[0][2])],
                      {**types, joint: 'std_msgs/msg/String'})
    result = verify_bag(wrong)
    assert [(f.check, f.topic) for f in result.failures] == [('bag.topic_types', joint)]
    assert next(c for c in result.checks if c.name == 'topic.joint_states').skipped


@pytest.mark.parametrize('field,value,words', [
    (('message_count',), 1, 'message_count: metadata.yaml says'),
    (('duration', 'nanoseconds'), 1, 'duration: metadata.yaml says'),
    (('starting_time', 'nanoseconds_since_epoch'), -1, 'starting_time: metadata.yaml says'),
    (('files', 0, 'message_count'), 1, 'message_count: metadata.yaml says'),
    (('version',), -1, 'version 8; allowed: 9'),
])
def test_resigned_metadata_edits_are_named(tmp_path: Path, src: Path, field: tuple[Any, ...], value: int,
                                           words: str) -> None:
    bag = copy_bag(src, tmp_path / 'b')

    def edit(info: dict[str, Any]) -> None:
        obj: Any = info
        for k in field[:-1]:
            obj = obj[k]
        obj[field[-1]] += value

    resign_metadata(bag, edit)
    failed = _failed(bag)
    assert [c for c, _, _ in failed] == ['bag.metadata'] and words in failed[0][2], failed


def test_checksum_failures_name_the_file(tmp_path: Path, src: Path) -> None:
    # A storage file changed where its own format does not notice (SQLite3 has no checksums): the file named.
    db = write_bag(tmp_path / 'db', messages_of(src), {t: GPR_TOPICS[t] for t in GPR_TOPICS}, storage='sqlite3')
    f = db / 'db_0.db3'
    data = bytearray(f.read_bytes())
    data[data.rindex(b'weighting: characteristic') + 11] ^= 0x20  # 'Characteristic' in the geometry text
    f.write_bytes(bytes(data))
    failures = verify_bag(db).failures
    assert ('bag.checksums', 'db_0.db3', 'SHA-256 differs from the recorded one: the file changed') in [
        (x.check, x.topic, x.detail) for x in failures]
    # metadata.yaml changed where it still parses alike (a comment): the digest sees it.
    bag = copy_bag(src, tmp_path / 'meta')
    (bag / 'metadata.yaml').write_text((bag / 'metadata.yaml').read_text() + '# reviewed\n')
    assert _failed(bag) == [('bag.checksums', None, 'SHA-256 differs from the recorded one: metadata.yaml changed')]
    # The digest line in another form that YAML reads alike (double quotes).
    bag = copy_bag(src, tmp_path / 'quotes')
    text = (bag / 'metadata.yaml').read_bytes()
    stored = yaml.safe_load(text)['rosbag2_bagfile_information']['custom_data'][METADATA_DIGEST_KEY]
    (bag / 'metadata.yaml').write_bytes(text.replace(digest_line(stored), digest_line(stored).replace(b"'", b'"')))
    assert _failed(bag) == [('bag.checksums', None, f'the {METADATA_DIGEST_KEY} line is not in its one form')]


def test_a_bag_without_checksums_fails_unless_allowed(tmp_path: Path, src: Path,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    bag = copy_bag(src, tmp_path / 'foreign')
    info = yaml.safe_load((bag / 'metadata.yaml').read_text())
    info['rosbag2_bagfile_information']['custom_data'] = {'recorder': 'somebody else'}
    (bag / 'metadata.yaml').write_text(yaml.safe_dump(info, sort_keys=False))
    failed = _failed(bag)
    assert {c for c, _, _ in failed} == {'bag.checksums'} and len(failed) == 2
    assert cli.main(['verify', str(bag), '--allow-missing-checksums', '--json']) == 0
    data = json.loads(capsys.readouterr().out)
    check = next(c for c in data['checks'] if c['name'] == 'bag.checksums')
    assert check['status'] == 'skip' and 'allowed by the caller' in check['skipped']
    # A single MCAP file of the writer: every CRC present, nothing else needed.
    single = bag / 'src_0.mcap'
    result = verify_bag(single)
    assert result.passed and 'CRCs were all present' in next(c for c in result.checks
                                                            if c.name == 'bag.checksums').skipped


def test_unlisted_and_unfinished_files_are_noted_not_read(tmp_path: Path, src: Path) -> None:
    bag = copy_bag(src, tmp_path / 'b')
    shutil.copy(bag / 'src_0.mcap', bag / 'src_9.mcap')
    (bag / '.recording' / 'src_10').mkdir(parents=True)
    (bag / '.recording' / 'src_10' / 'src_10.mcap').write_bytes(b'\x89MCAP0\r\n')
    result = verify_bag(bag)
    assert result.passed and result.unfinished == ['.recording/src_10/src_10.mcap']
    assert any('src_9.mcap' in n and 'not read' in n for n in result.notes)
    # a bag still being recorded has one too: the note does not say the recorder was killed
    assert ('note: unfinished segment(s) not read (a recording still running, or a recorder killed): '
            ".recording/src_10/src_10.mcap") in format_table(result).splitlines()


def test_a_hostile_unfinished_segment_folder_is_noted_not_walked(tmp_path: Path, src: Path) -> None:
    """``.recording`` linked to ``/`` walked the whole file system into a traceback, 1,200 nested folders into a
    RecursionError (exit 1, "verification failed"): the recorder's layout only (two levels, real folders, a bounded
    count) is listed, a linked folder is noted as such; the bag itself verifies."""
    import os

    from gpr_kinematics.bags import reader

    bag = copy_bag(src, tmp_path / 'b')
    (bag / '.recording').symlink_to('/')
    result = verify_bag(bag)
    assert result.passed and result.unfinished == ['.recording (a symbolic link, not the recorder\'s: not listed)']
    (bag / '.recording').unlink()
    deep = bag / '.recording' / 'src_10'
    deep.mkdir(parents=True)
    (deep / 'src_10.mcap').write_bytes(b'\x89MCAP0\r\n')
    os.symlink('/usr/bin', deep / 'bin.mcap')    # a link to a folder named like a segment's file: not one
    (deep / 'linked.mcap').symlink_to(deep / 'src_10.mcap')
    here = Path.cwd()
    try:
        os.chdir(deep)
        for _ in range(1_200):
            os.mkdir('a')
            os.chdir('a')
        Path('x.mcap').write_bytes(b'')
    finally:
        os.chdir(here)
    try:
        result = verify_bag(bag)
        assert result.passed and result.unfinished == ['.recording/src_10/src_10.mcap'], result.unfinished
        for i in range(reader.MAX_UNFINISHED + 5):
            (bag / '.recording' / f'{i:03d}.db3').write_bytes(b'')
        result = verify_bag(bag)
        assert result.passed and len(result.unfinished) == reader.MAX_UNFINISHED
    finally:   # from the deepest folder up: a recursive removal (pytest's, os.walk) overflows the stack as rglob did
        (deep / ('a/' * 1_200) / 'x.mcap').unlink()
        for k in range(1_200, 0, -1):
            (deep / ('a/' * k)).rmdir()


def test_the_unfinished_listing_reads_a_bounded_number_of_entries(tmp_path: Path, src: Path,
                                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """A .recording of a million entries (or a segment's) is not read whole to name 100: each listing stops after
    MAX_UNFINISHED entries; links in it are not the recorder's (a link named like a storage file is not listed)."""
    import os

    from gpr_kinematics.bags import reader

    bag = copy_bag(src, tmp_path / 'b')
    top = bag / '.recording'
    (top / 'seg').mkdir(parents=True)
    for i in range(40):
        (top / f'{i:02d}.db3').write_bytes(b'')
        (top / 'seg' / f'{i:02d}.mcap').write_bytes(b'')
    (top / 'zz.mcap').symlink_to(top / '00.db3')
    seen = []
    real = os.scandir

    class Counted:
        def __init__(self, path: str) -> None:
            self.it = real(path)

        def __enter__(self) -> Counted:
            return self

        def __exit__(self, *exc: object) -> None:
            self.it.close()

        def __iter__(self) -> Counted:
            return self

        def __next__(self) -> os.DirEntry[str]:
            entry = next(self.it)
            seen.append(entry.name)
            return entry

    monkeypatch.setattr(reader, 'MAX_UNFINISHED', 5)
    monkeypatch.setattr(reader.os, 'scandir', Counted)
    listed = reader._unfinished(bag)
    assert len(listed) == 5 and len(seen) <= 5 + 5, seen      # five at the top, at most five in a segment
    assert not any(u.endswith('zz.mcap') for u in listed)


def test_reference_bag_checksums_and_metadata() -> None:
    result = verify_bag(REFERENCE)
    checks = {c.name: c for c in result.checks}
    assert checks['bag.checksums'].passed and checks['bag.checksums'].checked == 2
    assert checks['bag.metadata'].passed and checks['topic.markers'].checked == 756
    assert checks['topic.markers'].worst < 1e-15
    # Recorded by the trajectory node: rod k's top (point 2k+1 of the rods' line list) is the joint centre
    # (R cos theta_k, R sin theta_k, q_k), R = 93.218 mm, theta_k = 0, 120, 240 deg.
    bag = read_bag(REFERENCE)
    mc, q = bag.topic(MARKERS).columns(), bag.topic(STATE).columns()['q']
    for k in range(3):
        theta = math.radians(120 * k)
        top = np.stack([mc[f'markers[1].points[{2 * k + 1}].{a}'] for a in 'xyz'], axis=1)
        assert np.allclose(top[:, :2], [0.093218 * math.cos(theta), 0.093218 * math.sin(theta)], rtol=0, atol=1e-15)
        assert np.array_equal(top[:, 2], q[:, k])


def test_tolerances_beyond_any_meaningful_check_are_refused_in_python_too():
    import pytest
    from gpr_kinematics.bags.tolerances import Tolerances
    from gpr_kinematics.errors import InputError

    with pytest.raises(InputError, match=r'tolerance position = 1e\+308 is invalid; allowed: a number from 0 to 0.001'):
        Tolerances(position=1e308)
    with pytest.raises(InputError, match=r'tolerance jump_x = nan is invalid'):
        Tolerances().replace(jump_x=float('nan'))
    assert Tolerances().replace(position=1e-3).position == 1e-3


@pytest.mark.parametrize('tail', [b'\x01\x02\x03\x04', b'\x00' * 8, b'\x00' * 64, b'\x00\x00\x01', b'\x00\x00\x00'],
                         ids=['junk', 'zeros', 'many', 'padding-not-zero', 'padding'])
def test_bytes_after_a_messages_last_field_make_the_bag_unreadable(tmp_path: Path, src: Path, tail: bytes,
                                                                    capsys: pytest.CaptureFixture[str]) -> None:
    """A state message with bytes appended after its last field verified (exit 0): the serializer pads the end to
    4 bytes with at most 3 zeros (rmw's messages in the reference bag), anything else after the last field is
    refused, naming the message."""
    store = typestore()
    t7 = int(read_bag(src).topic(STATE).log_time[7])

    def edit(topic: str, msg: Any) -> Any:
        if topic == STATE and msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec == t7:
            return bytes(store.serialize_cdr(msg, 'gpr_interfaces/msg/PlatformState')) + tail
        return msg

    bad = rewritten(src, tmp_path / 'tail', edit)
    if tail == b'\x00\x00\x00':
        assert verify_bag(bad).passed
        return
    assert cli.main(['verify', str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.count('\n') == 1 and 'PlatformState cannot be decoded' in err, err
    assert 'after its last field; allowed: at most 3 zero bytes of padding' in err, err


@pytest.mark.parametrize('change', ['terminator', 'not-utf8'])
def test_a_string_that_is_not_nul_terminated_text_makes_the_bag_unreadable(tmp_path: Path, src: Path, change: str,
                                                                            capsys: pytest.CaptureFixture[str]) -> None:
    """A marker's frame id with its terminating NUL set to 'X', or a frame id of bytes that are not UTF-8,
    verified (the decoder stripped NULs and replaced bad bytes)."""
    store = typestore()
    t7 = int(read_bag(src).topic(STATE).log_time[7])

    def edit(m: Any) -> bytes:
        raw = bytearray(store.serialize_cdr(m, 'visualization_msgs/msg/MarkerArray'))
        if change == 'terminator':
            i = raw.index(b'gpr_base\x00') + len(b'gpr_base')
            raw[i] = ord('X')
        else:
            i = raw.index(b'gpr_base')
            raw[i:i + 3] = b'\xff\xfe\xfd'
        return bytes(raw)

    bad = rewritten(src, tmp_path / 'str', _marker_edit(t7, edit))
    assert cli.main(['verify', str(bad)]) == 2
    err = capsys.readouterr().err
    assert 'MarkerArray cannot be decoded' in err and err.count('\n') == 1, err


def test_a_bag_recorded_in_a_namespace_verifies_as_such(tmp_path: Path, src: Path) -> None:
    """A recorder and a trajectory node in /r1 (offline_loop.launch.py namespace:=/r1) record /r1/gpr/...: verify
    found no /gpr/platform_state and failed 'nothing to verify'. The suite's topics are looked up in the one
    namespace they share; the result names it; a second namespace in the same bag is no namespace."""
    msgs = messages_of(src)
    types = {t.name: t.msgtype for t in read_bag(src).topics.values()}
    ns = write_bag(tmp_path / 'ns', [('/r1' + t, s, raw) for t, s, raw in msgs],
                   {'/r1' + k: v for k, v in types.items()})
    bag = read_bag(ns)
    assert bag.namespace == '/r1' and bag.topic(STATE) is bag.topics['/r1' + STATE]
    listed = {t['topic_metadata']['name']: t['topic_metadata']['offered_qos_profiles'] for t in yaml.safe_load(
        (ns / 'metadata.yaml').read_text())['rosbag2_bagfile_information']['topics_with_message_count']}
    assert 'transient_local' in str(listed['/r1/gpr/geometry']).lower() and not listed['/r1' + STATE]
    res = verify_bag(ns)
    assert res.passed, [(c.name, c.status) for c in res.checks if c.status == 'FAIL']
    assert "the node suite's topics were recorded in the namespace /r1 (verified as such)" in res.notes
    assert [c.name for c in res.checks] == [c.name for c in verify_bag(src).checks]
    two = write_bag(tmp_path / 'two', [('/r1' + t, s, raw) for t, s, raw in msgs] +
                    [('/r2' + t, s, raw) for t, s, raw in msgs if t == STATE],
                    {**{'/r1' + k: v for k, v in types.items()}, '/r2' + STATE: types[STATE]})
    assert read_bag(two).namespace == '' and not verify_bag(two).passed


@pytest.mark.parametrize('ns', ['/gpr', '/g'])
def test_a_bag_recorded_in_a_namespace_that_begins_like_the_suite_s_names_verifies(tmp_path: Path, src: Path,
                                                                                   ns: str) -> None:
    """suite_topic kept a name already starting with namespace + '/': in /gpr every suite topic does, so
    /gpr/platform_state (absent) was looked up instead of /gpr/gpr/platform_state (30 messages) and verify failed
    'nothing to verify'. A suite topic in a namespace is always namespace + name (also in /g)."""
    from gpr_kinematics.bags.typestore import JOINT_STATES_TOPIC, LEGACY_JOINT_STATES_TOPIC, suite_topic

    assert suite_topic(ns, STATE) == ns + '/gpr/platform_state' and suite_topic('', 'gpr/robot') == '/gpr/robot'
    msgs = messages_of(src)
    types = {t.name: t.msgtype for t in read_bag(src).topics.values()}
    path = write_bag(tmp_path / 'ns', [(ns + t, s, raw) for t, s, raw in msgs], {ns + k: v for k, v in types.items()})
    bag = read_bag(path)
    assert bag.namespace == ns and bag.topic(STATE) is bag.topics[ns + STATE] and len(bag.topic(STATE)) == 30
    assert bag.joint_states_topic() == JOINT_STATES_TOPIC and bag.topic(LEGACY_JOINT_STATES_TOPIC) is None
    res = verify_bag(path)
    assert res.passed, [f.line() for f in res.failures]
    assert res.notes[-1] == f"the node suite's topics were recorded in the namespace {ns} (verified as such)"
    assert [c.name for c in res.checks] == [c.name for c in verify_bag(src).checks]


def test_the_namespace_is_where_the_platform_state_is_and_several_suites_fail_naming_them(tmp_path: Path,
                                                                                         src: Path) -> None:
    """The namespace was the one prefix of every topic named like a suite topic: the suite in /r1 beside an ordinary
    /r1/arm_controller/joint_states gave two prefixes and failed 'nothing to verify'; two suites (/r1, /r2) failed
    so, saying nothing of why; and the suite at the root beside a /r1/gpr/platform_state of garbage (tilt 5 rad)
    passed, that topic unverified and unnamed. The namespace is where gpr/platform_state is: another node's topic is
    named in a note as not verified, several suites fail naming them."""
    store = typestore()
    msgs = messages_of(src)
    types = {t.name: t.msgtype for t in read_bag(src).topics.values()}
    r1 = [('/r1' + t, s, raw) for t, s, raw in msgs]
    joints = [('/r1/arm_controller/joint_states', s, raw) for t, s, raw in msgs if t == '/joint_states'][:5]
    ns = write_bag(tmp_path / 'ns', sorted(r1 + joints, key=lambda m: m[1]), {
        **{'/r1' + k: v for k, v in types.items()}, '/r1/arm_controller/joint_states': types['/joint_states']})
    res = verify_bag(ns)
    assert res.passed and read_bag(ns).namespace == '/r1', [f.line() for f in res.failures]
    assert res.notes[-1] == ("topics named like the node suite's outside its namespace /r1, not verified: "
                             '/r1/arm_controller/joint_states')
    garbage = []
    for t, s, raw in msgs:
        if t == STATE:
            m = store.deserialize_cdr(raw, types[t])
            m.tilt = 5.0
            garbage.append(('/r1' + t, s, bytes(store.serialize_cdr(m, types[t]))))
    two = write_bag(tmp_path / 'two', sorted(msgs + garbage, key=lambda m: m[1]),
                    {**types, '/r1' + STATE: types[STATE]})
    res = verify_bag(two)
    assert [f.line() for f in res.failures] == [
        'FAIL state.present on /gpr/platform_state at bag: value 2 > limit 1 (2 node suites recorded (/, /r1: a '
        'gpr/platform_state in each): verify checks the one suite of a bag and cannot choose; nothing verified '
        '(record each suite in its own bag))']


def test_latched_topics_are_known_in_a_namespace() -> None:
    from gpr_kinematics.nodes.qos import is_latched

    assert is_latched('/gpr/geometry') and is_latched('/r1/gpr/geometry') and is_latched('/r1/robot_description')
    assert is_latched('/tf_static') and not is_latched('/r1/tf_static') and not is_latched('/r1/gpr/platform_state')
    assert not is_latched('/foo_gpr/robot')


def test_an_sqlite_bag_stores_the_offered_profiles_in_its_database(tmp_path: Path, src: Path) -> None:
    """rosbag2's sqlite3 plugin reads a topic's offered QoS from the database's topics table: the writer stored '[]'
    there for every topic while metadata.yaml listed the latched profile, so a player would offer /gpr/geometry
    volatile and a late subscriber would never get it. The database now carries what metadata.yaml lists."""
    import sqlite3

    msgs = messages_of(src)
    types = {t.name: t.msgtype for t in read_bag(src).topics.values()}
    bag = write_bag(tmp_path / 'db', msgs, types, storage='sqlite3')
    listed = {t['topic_metadata']['name']: t['topic_metadata']['offered_qos_profiles'] for t in yaml.safe_load(
        (bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']['topics_with_message_count']}
    (db,) = bag.glob('*.db3')
    with sqlite3.connect(db) as conn:
        rows = conn.execute('SELECT name, offered_qos_profiles FROM topics').fetchall()
    stored = {name: yaml.safe_load(qos) for name, qos in rows}
    assert stored == listed and 'transient_local' in str(stored['/gpr/geometry']).lower() and stored[STATE] == []
    assert verify_bag(bag).passed


def test_an_sqlite_database_profile_edited_against_metadata_fails(tmp_path: Path, src: Path) -> None:
    """The database's profiles were not compared with metadata.yaml: /gpr/geometry edited to volatile there (the
    metadata re-signed) passed, and a player reading the database would not latch it. '[]' (the writer's before
    2026-12-03) stores no profile and is not compared."""
    import sqlite3

    from mcap_tamper import resign

    msgs = messages_of(src)
    types = {t.name: t.msgtype for t in read_bag(src).topics.values()}
    bag = write_bag(tmp_path / 'db', msgs, types, storage='sqlite3')
    (db,) = bag.glob('*.db3')
    old = tmp_path / 'old'
    shutil.copytree(bag, old)
    with sqlite3.connect(db) as conn:
        (text,) = conn.execute("SELECT offered_qos_profiles FROM topics WHERE name = '/gpr/geometry'").fetchone()
        assert 'transient_local' in text
        conn.execute("UPDATE topics SET offered_qos_profiles = ? WHERE name = '/gpr/geometry'",
                     (text.replace('transient_local', 'volatile'),))
    conn.close()
    resign(bag)
    result = verify_bag(bag)
    assert {f.check for f in result.failures} == {'bag.metadata'}
    detail, own = [f.detail for f in result.failures]
    assert detail.startswith('offered_qos_profiles in db_0.db3: metadata.yaml says [{')
    assert "'durability': 'volatile'" in detail.split('the files hold')[1]
    assert own == ("db_0.db3's own metadata (its metadata table, row 1): offered_qos_profiles[0].durability of "
                   "/gpr/geometry: it says 'transient_local', the topics table 'volatile'")
    with sqlite3.connect(old / 'db_0.db3') as conn:
        conn.execute("UPDATE topics SET offered_qos_profiles = '[]'")
    conn.close()
    resign(old)
    assert verify_bag(old).passed


def test_an_sqlite_topic_listed_twice_is_named(tmp_path: Path, src: Path) -> None:
    """A second row of /gpr/platform_state in the topics table, typed std_msgs/msg/String, half the state's messages
    moved to it (re-signed): the bag failed as 'message 0 of type std_msgs/msg/String cannot be decoded', not saying
    where the fault is; the table's two rows are named now."""
    import sqlite3

    msgs = messages_of(src)
    types = {t.name: t.msgtype for t in read_bag(src).topics.values()}
    bag = write_bag(tmp_path / 'db', msgs, types, storage='sqlite3')
    (db,) = bag.glob('*.db3')
    with sqlite3.connect(db) as conn:
        (tid,) = conn.execute("SELECT id FROM topics WHERE name = '/gpr/platform_state'").fetchone()
        conn.execute("INSERT INTO topics (id, name, type, serialization_format, offered_qos_profiles, "
                     "type_description_hash) SELECT 99, name, 'std_msgs/msg/String', serialization_format, "
                     "offered_qos_profiles, type_description_hash FROM topics WHERE id = ?", (tid,))
        conn.execute('UPDATE messages SET topic_id = 99 WHERE id % 2 = 0 AND topic_id = ?', (tid,))
    conn.close()
    with pytest.raises(BagError) as info:   # the reader's own refusal (no re-signing: it reads no such table)
        read_bag(bag)
    assert str(info.value) == (f"{db}: topic '/gpr/platform_state' is listed twice in the topics table (ids {tid} and "
                               '99, types gpr_interfaces/msg/PlatformState and std_msgs/msg/String); allowed: one row '
                               'per topic')


@pytest.mark.parametrize('swapped', [True, False])
def test_an_sqlite_type_defined_twice_is_refused(tmp_path: Path, src: Path, swapped: bool) -> None:
    """PlatformState's row of message_definitions edited to swap pose and nominal_pose, the package's definition
    appended as a second row of the type (re-signed): the reader kept the last row of a type, checked it and passed,
    while a reader taking the first decodes every state's pose as its nominal pose. rosbag2 writes one row per type:
    a second is refused, both named (the same text appended is refused too)."""
    import sqlite3

    from mcap_tamper import resign, swapped_poses

    msgs = messages_of(src)
    types = {t.name: t.msgtype for t in read_bag(src).topics.values()}
    bag = write_bag(tmp_path / 'db', msgs, types, storage='sqlite3')
    (db,) = bag.glob('*.db3')
    with sqlite3.connect(db) as conn:
        did, name, encoding, text, digest = conn.execute(
            "SELECT * FROM message_definitions WHERE topic_type = 'gpr_interfaces/msg/PlatformState'").fetchone()
        if swapped:
            conn.execute('UPDATE message_definitions SET encoded_message_definition = ? WHERE id = ?',
                         (swapped_poses(name, text), did))
        conn.execute('INSERT INTO message_definitions (topic_type, encoding, encoded_message_definition, '
                     'type_description_hash) VALUES (?, ?, ?, ?)', (name, encoding, text, digest))
        (last,) = conn.execute('SELECT max(id) FROM message_definitions').fetchone()
    conn.close()
    resign(bag)
    with pytest.raises(BagError) as info:
        verify_bag(bag)
    assert str(info.value) == (f'{db}: type gpr_interfaces/msg/PlatformState is defined twice in the '
                               f'message_definitions table (ids {did} and {last}: '
                               f"{'different definitions' if swapped else 'the same definition'}); allowed: one row "
                               'per type (rosbag2 writes one)')

def _own_metadata(db: Path, edit: Any) -> None:
    """Every row of the database's own metadata table (YAML) through ``edit(rows)`` -> rows (text)."""
    import sqlite3

    with sqlite3.connect(db) as conn:
        rows = conn.execute('SELECT metadata_version, metadata FROM metadata ORDER BY id').fetchall()
        conn.execute('DELETE FROM metadata')
        conn.executemany('INSERT INTO metadata (metadata_version, metadata) VALUES (?, ?)', edit(rows))
    conn.close()


def test_an_sqlite_databases_own_metadata_is_checked(tmp_path: Path, src: Path) -> None:
    """rosbag2's sqlite3 plugin keeps the bag's metadata in the database's metadata table (and reads it back); nothing
    read it: the latched topics edited to volatile there and every count of 30 to 3000 (re-signed) passed, as a single
    file too. It is compared with the files as bag.metadata compares metadata.yaml, each difference named."""
    from mcap_tamper import resign

    msgs = messages_of(src)
    types = {t.name: t.msgtype for t in read_bag(src).topics.values()}
    bag = write_bag(tmp_path / 'db', msgs, types, storage='sqlite3')
    (db,) = bag.glob('*.db3')
    _own_metadata(db, lambda rows: [(v, text.replace('durability: transient_local', 'durability: volatile')
                                     .replace('message_count: 30\n', 'message_count: 3000\n')) for v, text in rows])
    resign(bag)
    where = "db_0.db3's own metadata (its metadata table, row 1): "
    want = [where + f"offered_qos_profiles[0].durability of {t}: it says 'volatile', the topics table "
            "'transient_local'" for t in ('/gpr/geometry', '/gpr/program', '/gpr/robot')] + [
            where + f'message_count of {t}: it says 3000, the files hold 30' for t in
            ('/gpr/platform_state', '/gpr/platform_pose', '/gpr/nominal_pose', '/joint_states', '/gpr/virtual_joints',
             '/gpr/markers')]
    for path, kw in ((bag, {}), (db, {'allow_missing_checksums': True})):
        result = verify_bag(path, **kw)
        assert {f.check for f in result.failures} == {'bag.metadata'}
        assert sorted(f.detail for f in result.failures) == sorted(want)


def test_an_sqlite_databases_own_metadata_is_read_within_the_metadata_bound(tmp_path: Path, src: Path) -> None:
    """The metadata table is read to be checked: more than metadata.yaml's 16 MiB of it is refused before it is read
    (rosbag2 stores a few kB at each update)."""
    from gpr_kinematics.bags.metadata import MAX_METADATA_BYTES

    msgs = messages_of(src)
    types = {t.name: t.msgtype for t in read_bag(src).topics.values()}
    bag = write_bag(tmp_path / 'db', msgs, types, storage='sqlite3')
    (db,) = bag.glob('*.db3')
    _own_metadata(db, lambda rows: rows + [(9, 'x' * MAX_METADATA_BYTES)])
    with pytest.raises(BagError) as info:
        read_bag(bag)
    assert str(info.value) == (f'{db}: metadata table of 2 rows, {MAX_METADATA_BYTES + len(_own_rows(db)[0][1])} '
                               f'bytes; allowed: at most {MAX_METADATA_BYTES} bytes (rosbag2 stores a few kB at each '
                               'update)')


def _own_rows(db: Path) -> list[tuple[int, str]]:
    import sqlite3

    with sqlite3.connect(db) as conn:
        rows = conn.execute('SELECT metadata_version, metadata FROM metadata ORDER BY id').fetchall()
    conn.close()
    return rows

def test_the_own_metadata_of_rosbag2s_split_sqlite_files_passes_and_is_checked(tmp_path: Path, src: Path) -> None:
    """rosbag2 writes a row when a file opens (the files so far, no topics: its counts lag while recording), one
    before a split, and at the end one listing every file and topic with the final counts; the last file's last row
    is the one it reads back. Such rows of a split bag pass; the final row's count edited fails, and so does an
    earlier row that claims more messages than its files hold."""
    from mcap_tamper import resign

    msgs = messages_of(src)
    types = {t.name: t.msgtype for t in read_bag(src).topics.values()}
    bag = write_bag(tmp_path / 'db', msgs, types, storage='sqlite3', max_bag_duration=0.01)
    info = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    names = info['relative_file_paths']
    assert len(names) == 3
    final = {k: v for k, v in info.items() if k != 'custom_data'}
    for i, name in enumerate(names):
        opened = {**final, 'relative_file_paths': names[:i + 1], 'files': info['files'][:i + 1],
                  'topics_with_message_count': [], 'message_count': sum(f['message_count'] for f in
                                                                         info['files'][:i])}
        rows = [opened] + ([final] if i == len(names) - 1 else [{**opened, 'message_count': opened['message_count'] +
                                                                 info['files'][i]['message_count']}])
        _own_metadata(bag / name, lambda _, rows=rows: [(9, yaml.safe_dump(r)) for r in rows])
    resign(bag)
    assert verify_bag(bag).passed

    def more(rows: list[tuple[int, str]]) -> list[tuple[int, str]]:
        first = yaml.safe_load(rows[0][1])
        return [(9, yaml.safe_dump({**first, 'message_count': 10 ** 6}))] + rows[1:]

    _own_metadata(bag / names[1], more)
    _own_metadata(bag / names[2], lambda rows: rows[:-1] + [(9, rows[-1][1].replace('message_count: 30\n',
                                                                                    'message_count: 29\n', 1))])
    resign(bag)
    assert [f.detail for f in verify_bag(bag).failures] == [
        f"{names[1]}'s own metadata (its metadata table, row 1): message_count: it says 1000000; allowed: 0 to "
        f"{sum(f['message_count'] for f in info['files'][:2])}, the messages of the files it lists",
        f"{names[2]}'s own metadata (its metadata table, row 2): message_count of /gpr/markers: it says 29, "
        'the files hold 30']

@pytest.mark.slow
def test_the_metadata_of_a_recording_of_hours_reads_back(tmp_path: Path) -> None:
    """13,000 segments (3.6 hours at the default flush_interval of 1 s) made 3.6 MB of metadata.yaml that the reader
    refused ('more than 200000 YAML values': the package's YAML bound, not the metadata's 16 MiB): the recorder kept
    writing a bag no tool could read. It reads back, every segment listed."""
    import copy

    from gpr_kinematics.bags.metadata import MAX_METADATA_BYTES, read_metadata, render_metadata

    info = yaml.safe_load((REFERENCE / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    entry, digest = info['files'][0], next(v for k, v in info['custom_data'].items() if k.startswith('gpr_sha256/'))
    names = [f'reference_sweep_{i}.mcap' for i in range(13_000)]
    info['relative_file_paths'] = names
    info['files'] = [dict(copy.deepcopy(entry), path=name) for name in names]
    info['custom_data'] = {k: v for k, v in info['custom_data'].items() if not k.startswith('gpr_sha256/')} | {
        f'gpr_sha256/{name}': digest for name in names}
    text = render_metadata(info)
    (tmp_path / 'metadata.yaml').write_bytes(text)
    assert 3e6 < len(text) < MAX_METADATA_BYTES
    assert [f.path for f in read_metadata(tmp_path).files] == names


@pytest.mark.parametrize('n', [0, 1, 3, 40])
def test_the_files_lines_rendered_once_are_the_whole_metadata_rendered_at_once(n: int) -> None:
    """The writer renders each closed file's metadata lines once (a close that rendered every file took 0.24 s at
    1,000 files and 3.3 s at 12,000, against the 0.15 s the crash-safety bound allows): spliced in, the bytes equal
    the whole mapping rendered by PyYAML, the digest line included."""
    from gpr_kinematics.bags.metadata import FILE_DIGEST_PREFIX, file_lines, render_metadata

    files = [(f'rec_{i}.mcap', 10 ** 18 + i * 10 ** 9, 999_000_000 + i, 100 + i, f'{i:064x}') for i in range(n)]
    info = yaml.safe_load((REFERENCE / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    custom = {k: v for k, v in info['custom_data'].items() if not k.startswith('gpr_sha256/')}
    custom.pop(METADATA_DIGEST_KEY, None)
    whole = {**info, 'relative_file_paths': [f[0] for f in files],
             'files': [{'path': p, 'starting_time': {'nanoseconds_since_epoch': s}, 'duration': {'nanoseconds': d},
                        'message_count': c} for p, s, d, c, _ in files],
             'custom_data': {**custom, **{FILE_DIGEST_PREFIX + f[0]: f[4] for f in files}}}
    spliced = {**info, 'relative_file_paths': [], 'files': [], 'custom_data': custom}
    assert render_metadata(spliced, [file_lines(*f) for f in files]) == render_metadata(whole)


def _string(text: str = 'x') -> bytes:
    from gpr_kinematics.bags.typestore import message_types  # noqa: F401 - the store knows std_msgs
    store = typestore()
    return bytes(store.serialize_cdr(store.types['std_msgs/msg/String'](data=text), 'std_msgs/msg/String'))


@pytest.mark.parametrize('storage', ['mcap', 'sqlite3'])
def test_the_writer_refuses_a_bad_log_time_and_keeps_the_bag(tmp_path: Path, storage: str) -> None:
    """A log time of -5 or 2**64 raised struct.error and broke the open segment (every later write and the close
    failed: no metadata.yaml, the good messages lost); 2**63 was written and crashed the reader (OverflowError). Now a
    BagError before anything is written, and the bag goes on."""
    from gpr_kinematics.bags.writer import SegmentedBagWriter

    with SegmentedBagWriter(tmp_path / 'b', {'/gpr/program': 'std_msgs/msg/String'}, storage=storage,
                            fsync=False) as w:
        w.write('/gpr/program', 10, _string('a'))
        for bad in (-5, 2**63, 2**64, 1.9, float('nan'), 'x', True):
            with pytest.raises(BagError, match=r'log time = .*; allowed: an integer from 0 to 2\^63 - 1 \[ns\]'):
                w.write('/gpr/program', bad, _string())
        w.write('/gpr/program', np.int64(20), _string('b'))
    bag = read_bag(tmp_path / 'b')
    assert bag.topics['/gpr/program'].log_time.tolist() == [10, 20]


def test_arguments_of_the_bag_api_of_the_wrong_kind_are_named(tmp_path: Path) -> None:
    """AttributeError, TypeError or a bag its own reader refused: now BagError naming the argument and what is
    allowed; a single topic name to read_bag read nothing (a set of its characters)."""
    from gpr_kinematics.bags.errors import BagError
    from gpr_kinematics.bags.writer import SegmentedBagWriter

    for kwargs, words in ((dict(topics=['/gpr/program']), r"topics = \['/gpr/program'\]; allowed: a mapping"),
                          (dict(topics={1: 'std_msgs/msg/String'}), 'topics = '),
                          (dict(custom_data={'a': 1}), r"custom_data = \{'a': 1\}; allowed: a mapping of strings"),
                          (dict(max_bag_size=0.5), r'max_bag_size = 0.5 is invalid; allowed: a whole number of bytes'),
                          (dict(max_bag_size=True), r'max_bag_size = True is invalid')):
        args = {'topics': {'/gpr/program': 'std_msgs/msg/String'}, **kwargs}
        with pytest.raises(BagError, match=words):
            SegmentedBagWriter(tmp_path / 'w', args.pop('topics'), **args)
    SegmentedBagWriter(tmp_path / 'ok', {'/gpr/program': 'std_msgs/msg/String'}, max_bag_size=np.int64(100))
    with SegmentedBagWriter(tmp_path / 'b', {'/gpr/program': 'std_msgs/msg/String'}, fsync=False) as w:
        w.write('/gpr/program', 10, _string())
    for topics in ('/gpr/program', [], [1]):
        with pytest.raises(BagError, match=r'topics = .*; allowed: None \(every topic\) or a list of one or more'):
            read_bag(tmp_path / 'b', topics=topics)   # type: ignore[arg-type]
    assert len(read_bag(tmp_path / 'b', topics=['/gpr/program']).topics['/gpr/program']) == 1
    for kwargs, words in ((dict(bag=5), r'bag = 5; allowed: a bag folder or file path'),
                          (dict(bag=None), 'bag = None'),
                          (dict(bag=''), r"path = ''; allowed: a bag folder or a .mcap or .db3 file"),   # read '.'
                          (dict(config={}), r'config = \{\}; allowed: a GprConfig'),
                          (dict(robot={}), r'robot = \{\}; allowed: a RobotDescription'),
                          (dict(tolerances={}), r'tolerances = \{\}; allowed: Tolerances or None')):
        call = {'bag': tmp_path / 'b', **kwargs}
        with pytest.raises(BagError, match=words):
            verify_bag(call.pop('bag'), **call)


def test_a_log_time_beyond_int64_in_a_file_is_a_bag_error(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A message logged at 2**63 ns (another writer's file: MCAP stores 64 unsigned bits) crashed read_bag, verify_bag
    and `gpr verify` with OverflowError and a traceback; now a BagError, exit 2 and one line."""
    from gpr_kinematics.bags.errors import BagError
    from mcap.writer import Writer

    path = tmp_path / 'late.mcap'
    with open(path, 'wb') as out:
        w = Writer(out)
        w.start(profile='ros2', library='test')
        sid = w.register_schema('std_msgs/msg/String', 'ros2msg', b'string data')
        cid = w.register_channel('/gpr/program', 'cdr', sid)
        w.add_message(cid, 10, _string(), 10)
        w.add_message(cid, 2**63, _string(), 2**63)
        w.finish()
    with pytest.raises(BagError, match=r'topic /gpr/program has a log time of 9223372036854775808 ns; allowed: 0 to '
                       r'2\^63 - 1 ns'):
        read_bag(path)
    status = cli.main(['verify', str(path)])
    out, err = capsys.readouterr()
    assert (status, out) == (2, '') and err.count('\n') == 1 and 'log time of 9223372036854775808 ns' in err


def test_an_sqlite_databases_own_metadata_states_the_metadatas_ros_distribution(tmp_path: Path, src: Path) -> None:
    """Each row of the database's own metadata that names a ROS distribution (rosbag2's rows do; the ``rosbags``
    writer's name the library, ``rosbags``) names metadata.yaml's: another, re-signed, passed (``ros_distro`` was
    left out)."""
    from mcap_tamper import resign

    msgs = messages_of(src)
    types = {t.name: t.msgtype for t in read_bag(src).topics.values()}
    for distro, fails in (('jazzy', []), ('humble', [
            ('bag.metadata', "humble_0.db3's own metadata (its metadata table, row 1): ros_distro: it says 'humble', "
                             "metadata.yaml says 'jazzy'")])):
        bag = write_bag(tmp_path / distro, msgs, types, storage='sqlite3')
        (db,) = bag.glob('*.db3')
        _own_metadata(db, lambda got, d=distro: [(v, text.replace('ros_distro: rosbags', f'ros_distro: {d}'))
                                                 for v, text in got])
        resign(bag)
        assert [(f.check, f.detail) for f in verify_bag(bag).failures] == fails, distro
