"""Bags without DDS: writer/reader round trips (MCAP, SQLite3, split, compressed), the vectorised decoder
against ``rosbags``, independent readers (``mcap`` + ``mcap_ros2``, ``sqlite3``), ``gpr verify`` on the committed
reference bag, tampering, unreadable bags (exit 2), the report, and SIGKILL of a writing process."""
from __future__ import annotations

import json
import math
import os
import re
import shutil
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from gpr_kinematics.bags import cdr
from gpr_kinematics.bags.cdr import decode_columns
from gpr_kinematics.bags.errors import BagError
from gpr_kinematics.bags.reader import read_bag
from gpr_kinematics.bags.synthetic import sweep_messages, write_messages
from gpr_kinematics.bags.typestore import (
    GEOMETRY_TOPIC,
    GPR_TOPICS,
    PLATFORM_STREAM_TOPICS,
    definition,
    legacy_joint_states,
    typestore,
)
from gpr_kinematics.bags.verify import verify_bag
from gpr_kinematics.bags.writer import SegmentedBagWriter
from gpr_kinematics.cli import main as cli

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / 'bags' / 'reference_sweep'
STATE = '/gpr/platform_state'


@pytest.fixture(scope='module')
def messages() -> list[tuple[str, int, bytes]]:
    # A short sweep: 1 deg steps, 60 deg azimuth: 6 rows x 5 tilts; the geometry once, then 5 topics a sample.
    return sweep_messages(tilt_step=math.radians(1.0), azimuth_step=math.radians(60.0))


def run_cli(*argv: str, capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    status = cli.main(list(argv))
    out = capsys.readouterr()
    return status, out.out, out.err


# -- reference bag ------------------------------------------------------------------------------------------
def test_reference_bag_verifies_against_the_current_core(capsys: pytest.CaptureFixture[str]) -> None:
    status, out, err = run_cli('verify', str(REFERENCE), capsys=capsys)
    assert status == 0, out + err
    assert 'verification PASSED' in out
    from gpr_kinematics.bags.typestore import (
        JOINT_STATES_TOPIC,
        LEGACY_JOINT_STATES_TOPIC,
        PROGRAM_TOPIC,
        ROBOT_STATE_TOPIC,
        ROBOT_TOPIC,
        WAFER_POSE_TOPIC,
    )

    bag = read_bag(REFERENCE)
    # The default sweep: 36 azimuths x 21 tilts; every topic of a platform stream one message per sample, the
    # latched geometry and robot description once, the robot program's own topics listed and empty (a sweep). It was
    # recorded when the joint states were on /gpr/joint_states: verify still reads them there.
    old = {t: LEGACY_JOINT_STATES_TOPIC if t == JOINT_STATES_TOPIC else t for t in GPR_TOPICS}
    stream = dict.fromkeys((old[t] for t in PLATFORM_STREAM_TOPICS), 756)
    assert {k: len(t) for k, t in bag.topics.items()} == {**stream, GEOMETRY_TOPIC: 1, ROBOT_TOPIC: 1,
                                                          ROBOT_STATE_TOPIC: 0, WAFER_POSE_TOPIC: 0}
    assert set(bag.topics) == set(old.values()) - {PROGRAM_TOPIC}   # recorded before the node published gpr/program
    assert legacy_joint_states(bag.topics, bag.namespace) == LEGACY_JOINT_STATES_TOPIC   # the replay warns
    assert 'topic.joint_states' in {c.name for c in verify_bag(REFERENCE).checks if not c.skipped}
    assert 'note: verified against the geometry recorded on /gpr/geometry' in out
    assert 'robot example_dual_arm recorded on /gpr/robot; no robot states' in out
    assert bag.storage == 'mcap' and bag.version == 9
    assert sum(f.stat().st_size for f in REFERENCE.iterdir()) < 2_000_000
    c = bag.topic(STATE).columns()
    assert np.array_equal(c['sample'], np.arange(756))
    # alpha = 0 once per azimuth row: 36 singular crossings, q1 = q2 = q3 = 0.5 m there.
    zero = np.flatnonzero(c['commanded_tilt'] == 0.0)
    assert zero.size == 36
    assert np.allclose(c['q'][zero], 0.5, atol=1e-12)
    # The paper's figure 6 value: at singularity l1 = l2 = l3 = R = 93.218 mm.
    assert np.allclose(c['virtual_joints'][zero], 0.093218, atol=1e-12)


def test_with_both_joint_states_topics_the_current_one_is_verified(tmp_path: Path, messages: list) -> None:
    """``/joint_states`` is where the suite publishes; ``/gpr/joint_states`` is read only in bags recorded before the
    move (``/joint_states`` absent). A bag with both, the legacy one an honest copy and ``/joint_states`` with rod 2
    of sample 7 moved 1 um: the moved one is verified, and fails there."""
    import dataclasses

    from bag_support import rewritten, write_bag
    from gpr_kinematics.bags.typestore import JOINT_STATES_TOPIC, KNOWN_TOPICS, LEGACY_JOINT_STATES_TOPIC

    out = []
    for topic, t, raw in messages:
        out.append((topic, t, raw))
        if topic == JOINT_STATES_TOPIC:
            out.append((LEGACY_JOINT_STATES_TOPIC, t, raw))
    types = {**GPR_TOPICS, LEGACY_JOINT_STATES_TOPIC: KNOWN_TOPICS[LEGACY_JOINT_STATES_TOPIC]}
    both = write_bag(tmp_path / 'both', out, types)
    assert read_bag(both).joint_states_topic() == JOINT_STATES_TOPIC
    assert verify_bag(both).passed
    stamp = (1_700_000_000, 7_000_000)   # sample 7, 1 ms a sample

    def moved(topic, msg):
        if topic == JOINT_STATES_TOPIC and (msg.header.stamp.sec, msg.header.stamp.nanosec) == stamp:
            position = np.array(msg.position)
            position[1] += 1e-6
            return dataclasses.replace(msg, position=position)
        return msg

    result = verify_bag(rewritten(both, tmp_path / 'moved', moved))
    assert [(f.check, f.topic, f.sample) for f in result.failures] == [('topic.joint_states', JOINT_STATES_TOPIC, 7)]
    assert result.failures[0].value == pytest.approx(1e-6, rel=1e-6)
    assert "/gpr/joint_states recorded beside /joint_states: the legacy topic of older recordings, not verified" in \
        " ".join(result.notes)
    assert legacy_joint_states(read_bag(both).topics, '') is None   # the replay's warning: not for this bag


@pytest.mark.parametrize('topics, namespace, legacy', [
    ({'/gpr/joint_states', '/gpr/platform_state'}, '', '/gpr/joint_states'),   # recorded before the move
    ({'/gpr/joint_states', '/joint_states'}, '', None),   # both: the joint states are on /joint_states
    ({'/joint_states'}, '', None),
    ({'/gpr/platform_state'}, '', None),
    ({'/r1/gpr/joint_states'}, '/r1', '/r1/gpr/joint_states'),
    ({'/r1/gpr/joint_states', '/r1/joint_states'}, '/r1', None),
    ({'/r1/gpr/joint_states', '/joint_states'}, '/r1', '/r1/gpr/joint_states'),   # a root one is not the suite's
])
def test_the_replays_legacy_joint_states_warning_is_for_a_bag_without_joint_states(topics, namespace, legacy):
    """replay_node warns that a recorder's default topics miss the joint states of a bag that carries them on the
    legacy /gpr/joint_states only (``typestore.legacy_joint_states``): a bag with /joint_states beside it has them
    there (a mutation audit: a warning for every bag with the legacy topic passed every test)."""
    assert legacy_joint_states(topics, namespace) == legacy


@pytest.mark.parametrize('topics, namespace, legacy', [
    (['/r1/joint_states', '/r1/gpr/joint_states'], '/r1', None),   # both: the suite's in /r1
    (['/r1/gpr/joint_states', '/r1/joint_states'], '/r1', None),   # in either order
    (['/r1/gpr/joint_states'], '/r1', '/r1/gpr/joint_states'),   # alone: /r1's legacy topic
    (['/r1/gpr/joint_states', '/r1/gpr/platform_pose'], '/r1', '/r1/gpr/joint_states'),
    (['/r1/gpr/gpr/joint_states', '/r1/gpr/joint_states'], '/r1/gpr', None),   # both in /r1/gpr
    (['/gpr/joint_states', '/gpr/gpr/platform_pose'], '/gpr', None),   # /gpr's joint_states, not the root's legacy
    (['/gpr/joint_states', '/joint_states'], '', None),
    (['/gpr/joint_states'], '', '/gpr/joint_states'),
    (['/r1/gpr/joint_states', '/joint_states'], '', None),   # a root topic: no shared namespace
    (['/r1/gpr/platform_pose', '/r1/arm_controller/joint_states'], '', None),
])
def test_a_bag_without_a_platform_state_is_in_the_namespace_its_legacy_joint_states_are_in(
        tmp_path: Path, messages: list, topics: list[str], namespace: str, legacy: str | None) -> None:
    """Without a gpr/platform_state the bag's namespace is the one every suite topic is in, ``X/gpr/joint_states``
    read as X's legacy joint states (``typestore.topics_namespace``, as ``legacy_joint_states`` reads it): a bag
    recorded in /r1 with /r1/joint_states and /r1/gpr/joint_states was in /r1 or /r1/gpr, so in neither (''), and
    its replay published nothing in the replay's namespace."""
    from bag_support import write_bag
    from gpr_kinematics.bags.typestore import JOINT_STATES_TOPIC, LEGACY_JOINT_STATES_TOPIC, topics_namespace

    raw = {t: r for t, _, r in messages}
    like = {t: '/joint_states' if t.endswith('/joint_states') else '/gpr/platform_pose' for t in topics}
    timed = [(t, 1_700_000_000_000_000_000 + i, raw[like[t]]) for i, t in enumerate(topics)]
    bag = read_bag(write_bag(tmp_path / 'bag', timed, {t: GPR_TOPICS[like[t]] for t in topics}))
    assert topics_namespace(topics) == bag.namespace == namespace
    assert legacy_joint_states(bag.topics, bag.namespace) == legacy
    if namespace:   # the suite's names as the replay publishes them in its own namespace
        assert {bag.relative(t) for t in topics} == {t[len(namespace):] for t in topics}
        assert bag.joint_states_topic() == (LEGACY_JOINT_STATES_TOPIC if legacy else JOINT_STATES_TOPIC)
        assert bag.topic(bag.joint_states_topic()) is bag.topics[namespace + bag.joint_states_topic()]
        assert bag.outside() == []


@pytest.mark.slow
def test_reference_bag_json_and_report(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    status, out, _ = run_cli('verify', str(REFERENCE), '--json', '--report', str(tmp_path / 'rep'), capsys=capsys)
    assert status == 0
    data = json.loads(out)
    assert data['passed'] is True and data['counts'][STATE] == 756
    assert data['singular_crossings'] == 36
    names = {c['name'] for c in data['checks']}
    assert {'state.pose_position', 'stream.counter', 'stream.jump', 'topic.joint_states'} <= names
    pngs = sorted(p.name for p in (tmp_path / 'rep').glob('*.png'))
    assert pngs == sorted(['fig05_rod_lengths.png', 'fig06_polar_linear_virtual_joints.png',
                           'fig07_polar_angular_virtual_joints.png', 'fig08_side_lengths.png',
                           'fig09_offset_linear_virtual_joints.png', 'fig10_offset_angular_virtual_joints.png',
                           'radial_virtual_joints.png', 'centre_shift_vs_tilt.png'])
    for p in (tmp_path / 'rep').glob('*.png'):
        assert p.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n' and p.stat().st_size > 10_000
    assert json.loads((tmp_path / 'rep' / 'verify.json').read_text())['passed'] is True


@pytest.mark.slow
def test_a_report_into_an_earlier_reports_folder_leaves_no_figure_of_the_other_bag(tmp_path: Path,
                                                                                    capsys: pytest.CaptureFixture[str]
                                                                                    ) -> None:
    """A compliant bag's report written where a radial bag's was left its radial_virtual_joints.png (another bag's
    figure beside this one's verify.json), a bag without states all eight: the figures this report does not draw
    are removed (put back if the command fails: test_core_files)."""
    from gpr_kinematics.bags.report import FIGURES
    from gpr_kinematics.core.config import load_config

    rep = tmp_path / 'rep'
    assert run_cli('verify', str(REFERENCE), '--report', str(rep), capsys=capsys)[0] == 0
    assert (rep / 'radial_virtual_joints.png').is_file()
    assert {p.name for p in rep.iterdir()} - {'verify.json', 'verify.txt'} <= set(FIGURES)
    comp = tmp_path / 'comp'
    write_messages(comp, sweep_messages(config=load_config(overrides={'model': 'compliant'})))
    assert run_cli('verify', str(comp), '--report', str(rep), capsys=capsys)[0] == 0
    pngs = sorted(p.name for p in rep.glob('*.png'))
    assert 'radial_virtual_joints.png' not in pngs and 'compliant_virtual_joints.png' in pngs
    assert sorted(p.name for p in rep.iterdir() if p.name.startswith('.')) == []


def test_the_report_figures_name_their_bag_and_quantities_and_mark_r_and_the_largest_shift() -> None:
    """The figures' y axes read 'mm' and 'deg' (which quantity?), their legends lay on the curves' right ends, no
    title named the bag, Fig. 6's l = R at the singular configurations had no line, and the centre shift's largest
    value (the docs' 28.4 um at 2 deg) no mark: each names the bag and its quantity, the legend stands beside the
    axes, R is a line in Fig. 6 and the radial figure, the largest shift is marked and named."""
    import matplotlib.pyplot as plt
    from gpr_kinematics.bags.report import report_figures
    result = verify_bag(REFERENCE)
    figures = dict(report_figures(result))
    try:
        assert list(figures) == ['fig05_rod_lengths.png', 'fig08_side_lengths.png',
                                 'fig06_polar_linear_virtual_joints.png', 'fig07_polar_angular_virtual_joints.png',
                                 'fig09_offset_linear_virtual_joints.png', 'fig10_offset_angular_virtual_joints.png',
                                 'radial_virtual_joints.png', 'centre_shift_vs_tilt.png']
        ylabels = {name: fig.axes[0].get_ylabel() for name, fig in figures.items()}
        assert list(ylabels.values()) == ['q [mm]', 'L [mm]', 'l [mm]', 'phi [deg]', 'dr [mm]', 'dphi [deg]', 'l [mm]',
                                          'centre shift vs naive model [um]']
        for name, fig in figures.items():
            assert fig.axes[0].get_title().endswith('bag reference_sweep'), name
        fig6 = figures['fig06_polar_linear_virtual_joints.png']
        assert fig6.axes[0].get_title().startswith('Fig. 6: polar model, linear virtual joints (computed from the '
                                                   'recorded q of a radial bag)')
        for fig in (fig6, figures['radial_virtual_joints.png']):
            (line,) = [ln for ln in fig.axes[0].lines if ln.get_label().startswith('R = ')]
            assert line.get_ydata()[0] == pytest.approx(93.218, abs=5e-4) and line.get_label().startswith('R = 93.218')
            fig.canvas.draw()
            ax = fig.axes[0]
            assert ax.get_legend().get_window_extent().x0 > ax.get_window_extent().x1
        shift = figures['centre_shift_vs_tilt.png'].axes[0]
        (mark,) = [ln for ln in shift.lines if ln.get_label().startswith('largest')]
        s = result.series
        largest = np.linalg.norm(s.centre_shift[:, :2], axis=1).max() * 1e6
        assert mark.get_ydata()[0] == largest and mark.get_xdata()[0] == pytest.approx(2.0, abs=1e-9)
        assert mark.get_label().startswith('largest 28.4 um at tilt 2.00 deg (sample ')
    finally:
        for fig in figures.values():
            plt.close(fig)


def test_a_measured_machines_report_draws_no_r_line() -> None:
    """l = R at a singular configuration holds for the drawing's machine only: a bag verified against a machine
    whose rods stand at measured positions had its figures draw the drawing's R as if it held there."""
    import dataclasses

    import matplotlib.pyplot as plt
    from gpr_kinematics.bags.report import report_figures
    from gpr_kinematics.core.config import GprConfig, nominal_points
    result = verify_bag(REFERENCE)
    cfg = GprConfig.from_mapping(result.config, source='test')
    measured = [[x + 1e-4 * k, y] for k, (x, y) in enumerate(nominal_points(cfg))]
    figures = dict(report_figures(dataclasses.replace(result, config={**result.config, 'rod_positions': measured})))
    try:
        for name in ('fig06_polar_linear_virtual_joints.png', 'radial_virtual_joints.png'):
            labels = [str(ln.get_label()) for ln in figures[name].axes[0].lines]
            assert [lab for lab in labels if not lab.startswith('_')] == ['l1', 'l2', 'l3'], (name, labels)
    finally:
        for fig in figures.values():
            plt.close(fig)


def test_mcap_reader_with_ros2_decoder_gives_the_same_messages() -> None:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    bag = read_bag(REFERENCE)
    ours = bag.topic(STATE)
    c = ours.columns()
    files = [REFERENCE / f for f in bag.files]
    got_raw, got = [], []
    for f in files:
        with f.open('rb') as fh:
            reader = make_reader(fh, decoder_factories=[DecoderFactory()])
            for schema, _channel, message, decoded in reader.iter_decoded_messages(topics=[STATE]):
                assert schema.name == 'gpr_interfaces/msg/PlatformState'
                got_raw.append(message.data)
                got.append((decoded.sample, decoded.q, decoded.pose.position.x, decoded.pose.orientation.w,
                            decoded.virtual_joints, decoded.model, message.log_time))
    assert got_raw == ours.raw
    assert [g[0] for g in got] == c['sample'].tolist()
    assert np.array_equal(np.array([g[1] for g in got]), c['q'])
    assert np.array_equal(np.array([g[2] for g in got]), c['pose.position.x'])
    assert np.array_equal(np.array([g[3] for g in got]), c['pose.orientation.w'])
    assert np.array_equal(np.array([g[4] for g in got]), c['virtual_joints'])
    assert {g[5] for g in got} == {'radial'}
    assert [g[6] for g in got] == ours.log_time.tolist()


# -- decoder and round trips -------------------------------------------------------------------------------
def test_vectorised_decoder_equals_rosbags_deserialisation() -> None:
    bag = read_bag(REFERENCE)
    store = typestore()
    for topic in bag.topics.values():
        if len(topic) == 0:      # the robot program's topics in a sweep
            assert topic.name in ('/gpr/robot_state', '/gpr/wafer_pose')
            continue
        c = topic.columns()
        if topic.msgtype == 'std_msgs/msg/String':     # the geometry and the robot: one latched text each
            assert c['data'][0] == store.deserialize_cdr(topic.raw[0], topic.msgtype).data
            continue
        assert c.fallback == 0 and c.layouts <= 2
        for i in (0, 1, len(topic) // 2, len(topic) - 1):
            msg = store.deserialize_cdr(topic.raw[i], topic.msgtype)
            if topic.name == '/gpr/markers':
                # base, rods, platform, nominal platform; the rods' upper ends are the joint centres (z = q).
                assert c['markers[1].header.stamp.sec'][i] == msg.markers[1].header.stamp.sec
                assert c['markers[1].ns'][i] == msg.markers[1].ns == 'rods'
                assert c['markers[1].points[5].z'][i] == msg.markers[1].points[5].z
                continue
            assert c['header.stamp.sec'][i] == msg.header.stamp.sec
            assert c['header.stamp.nanosec'][i] == msg.header.stamp.nanosec
            assert c['header.frame_id'][i] == msg.header.frame_id
            if topic.name == STATE:
                assert c['sample'][i] == msg.sample and c['iterations'][i] == msg.iterations
                assert np.array_equal(c['q'][i], msg.q)
                assert np.array_equal(c['virtual_joints'][i], msg.virtual_joints)
                assert c['virtual_joint_names'][i] == tuple(msg.virtual_joint_names)
                assert c['residual'][i] == msg.residual and bool(c['within_budget'][i]) == msg.within_budget
            if topic.name == '/gpr/joint_states':
                assert c['name'][i] == tuple(msg.name) and np.array_equal(c['position'][i], msg.position)


def test_decoder_handles_changing_layouts(monkeypatch: pytest.MonkeyPatch) -> None:
    store = typestore()
    T = store.types
    js = T['sensor_msgs/msg/JointState']
    hdr = T['std_msgs/msg/Header']
    stamp = T['builtin_interfaces/msg/Time']
    msgs = []
    for i in range(40):
        k = 1 + i % 3  # three layouts: 1, 2, 3 joints
        names = [f'j{j}' for j in range(k)] if i != 7 else ['a_longer_name'] * k
        m = js(header=hdr(stamp=stamp(sec=i, nanosec=i), frame_id='f' * (i % 2 + 1)), name=names,
               position=np.arange(k) + 0.5 * i, velocity=np.zeros(0), effort=np.zeros(0))
        msgs.append(bytes(store.serialize_cdr(m, 'sensor_msgs/msg/JointState')))
    c = decode_columns('sensor_msgs/msg/JointState', msgs)
    assert c.layouts >= 6 and c.fallback == 0
    # With one template only, the rest goes through rosbags' deserialisation: same columns.
    monkeypatch.setattr(cdr, 'MAX_LAYOUTS', 1)
    f = decode_columns('sensor_msgs/msg/JointState', msgs)
    assert f.layouts == 1 and f.fallback > 30
    for col in (c, f):
        for i in range(40):
            k = 1 + i % 3
            assert col['header.stamp.sec'][i] == i and col['header.stamp.nanosec'][i] == i
            assert col['header.frame_id'][i] == 'f' * (i % 2 + 1)
            assert np.array_equal(np.asarray(col['position'][i]), np.arange(k) + 0.5 * i)
            assert len(col['name'][i]) == k and (i == 7 or col['name'][i][-1] == f'j{k - 1}')


@pytest.mark.parametrize('storage,compression', [('mcap', 'none'), ('mcap', 'zstd'), ('sqlite3', 'none')])
def test_round_trip_split_recording(tmp_path: Path, messages: list, storage: str, compression: str) -> None:
    bag_path = tmp_path / 'bag'
    topics = {t: GPR_TOPICS[t] for t in dict.fromkeys(m[0] for m in messages)}
    with SegmentedBagWriter(bag_path, topics, storage=storage, compression=compression, flush_interval=0,
                            max_bag_size=5000, fsync=False) as w:
        for topic, t, data in messages:
            w.write(topic, t, data)
    suffix = '.mcap' if storage == 'mcap' else '.db3'
    files = sorted(bag_path.glob('*' + suffix))
    assert len(files) > 3  # split by size
    assert not (bag_path / '.recording').exists()
    bag = read_bag(bag_path)
    assert bag.files == [f'bag_{i}{suffix}' for i in range(len(files))]
    for topic in topics:
        want = [(t, d) for tp, t, d in messages if tp == topic]
        got = bag.topic(topic)
        assert got.raw == [d for _, d in want]
        assert got.log_time.tolist() == [t for t, _ in want]
        assert got.metadata_count == len(want)
        assert got.digest == definition(topics[topic])[1]
    assert verify_bag(bag).passed


def test_split_by_duration(tmp_path: Path, messages: list) -> None:
    # The synthetic stream is 1 ms per sample (6 messages: state, two poses, joint states, virtual joints, markers;
    # the geometry and the record of the sweep before the first): 30 samples split every 5 ms of log time.
    topics = {t: GPR_TOPICS[t] for t in dict.fromkeys(m[0] for m in messages)}
    with SegmentedBagWriter(tmp_path / 'd', topics, flush_interval=0, max_bag_duration=0.005, fsync=False) as w:
        for topic, t, data in messages:
            w.write(topic, t, data)
    bag = read_bag(tmp_path / 'd')
    assert len(bag.files) == 6
    spans = [f['duration']['nanoseconds'] for f in bag.metadata.info['files']]
    assert max(spans) < 5_000_000
    assert [f['message_count'] for f in bag.metadata.info['files']] == [32] + [30] * 5
    assert verify_bag(bag).passed
    # metadata.yaml as rosbag2 (version 9) writes it: totals agree with the per-file and per-topic entries.
    meta = bag.metadata.info
    assert meta['version'] == 9 and meta['storage_identifier'] == 'mcap'
    assert meta['relative_file_paths'] == [f['path'] for f in meta['files']]
    assert meta['message_count'] == sum(f['message_count'] for f in meta['files']) == len(messages)
    assert sum(t['message_count'] for t in meta['topics_with_message_count']) == len(messages)
    assert meta['starting_time']['nanoseconds_since_epoch'] == messages[0][1]
    assert meta['duration']['nanoseconds'] == messages[-1][1] - messages[0][1]
    for t in meta['topics_with_message_count']:
        assert t['topic_metadata']['serialization_format'] == 'cdr'
        assert t['topic_metadata']['type_description_hash'].startswith('RIHS01_')


def test_sqlite3_read_directly_gives_the_same_messages(tmp_path: Path, messages: list) -> None:
    write_messages(tmp_path / 'b', messages, storage='sqlite3')
    db = tmp_path / 'b' / 'b_0.db3'
    con = sqlite3.connect(db)
    rows = con.execute('SELECT topics.name, topics.type, messages.timestamp, messages.data FROM messages '
                       'JOIN topics ON messages.topic_id = topics.id ORDER BY messages.id').fetchall()
    schema = con.execute('SELECT schema_version FROM schema').fetchone()[0]
    con.close()
    assert schema >= 3
    assert [(r[0], r[2], bytes(r[3])) for r in rows] == messages
    assert {r[1] for r in rows if r[0] == STATE} == {'gpr_interfaces/msg/PlatformState'}
    bag = read_bag(tmp_path / 'b')
    assert sum(len(t) for t in bag.topics.values()) == len(rows)


def _schema_edited(tmp_path: Path, messages: list, script: str) -> Path:
    """A fresh SQLite3 bag's file with ``script`` run on it (SQL)."""
    write_messages(tmp_path / 'b', messages, storage='sqlite3')
    db = tmp_path / 'b' / 'b_0.db3'
    con = sqlite3.connect(db)
    try:
        con.executescript(script)
    finally:
        con.close()
    return db


def _refused_at_once(db: Path, pattern: str) -> None:
    t0 = time.monotonic()
    with pytest.raises(BagError, match=pattern):
        read_bag(db)
    assert time.monotonic() - t0 < 10


@pytest.mark.parametrize('table', ['messages', 'topics', 'metadata'])
def test_a_view_in_place_of_a_rosbag2_table_is_refused_at_once(tmp_path: Path, messages: list, table: str) -> None:
    """A view computes its rows: an endless recursive ``messages`` view never finished reading (and filled the temp
    folder), an endless ``topics`` view filled the memory. Only stored rows are read (the database's own metadata
    too, which is read since it is checked)."""
    endless = {'messages': "SELECT x AS id, 1 AS topic_id, x AS timestamp, x'00010000' AS data FROM c",
               'topics': "SELECT x AS id, '/t' || x AS name, 'std_msgs/msg/String' AS type, 'cdr' AS "
                         "serialization_format, '' AS offered_qos_profiles, '' AS type_description_hash FROM c",
               'metadata': "SELECT x AS id, 9 AS metadata_version, 'version: 9' AS metadata FROM c"}[table]
    db = _schema_edited(tmp_path, messages, f'DROP TABLE {table}; CREATE VIEW {table} AS WITH RECURSIVE c(x) AS '
                                            f'(SELECT 1 UNION ALL SELECT x + 1 FROM c) {endless};')
    _refused_at_once(db, rf"b_0\.db3: {table} is a view, not a table; allowed: rosbag2's stored tables topics, "
                         'messages, message_definitions and metadata$')


@pytest.mark.parametrize('kind', ['VIRTUAL', 'STORED'])
def test_a_generated_column_in_a_rosbag2_table_is_refused_at_once(tmp_path: Path, messages: list, kind: str) -> None:
    """A generated column is computed from its expression: a 20 kB file of four rows whose ``data`` was
    ``zeroblob(500000000)`` (the expression swapped in through ``writable_schema``) took 2.5 GB to read, another 1 s
    of CPU per row. Only stored columns are read (a stored generated one too is refused: rosbag2 writes none)."""
    db = _schema_edited(tmp_path, messages, 'ALTER TABLE messages RENAME TO old; CREATE TABLE messages (id INTEGER '
                        'PRIMARY KEY, topic_id INTEGER NOT NULL, timestamp INTEGER NOT NULL, data BLOB GENERATED '
                        f'ALWAYS AS (zeroblob(10)) {kind}); INSERT INTO messages (id, topic_id, timestamp) SELECT id, '
                        'topic_id, timestamp FROM old; DROP TABLE old;')
    _refused_at_once(db, r'b_0\.db3: column data of messages is generated \(computed when read\), not stored; '
                         "allowed: rosbag2's stored tables")


def test_rows_an_index_does_not_list_are_refused_before_any_is_read(tmp_path: Path, messages: list) -> None:
    """The message bound counted the rows of the covering index timestamp_idx: rows inserted with the index detached
    (writable_schema), then the index put back, were 8.5 million read past the bound of 8 million (1.3 GB) where
    count(*) said 77, and quick_check does not compare an index with its table. The table's rows are counted, and an
    index that lists fewer (rosbag2 plays in its order) is a corrupt database."""
    write_messages(tmp_path / 'b', messages, storage='sqlite3')
    db = tmp_path / 'b' / 'b_0.db3'
    con = sqlite3.connect(db)
    try:
        index = con.execute("SELECT type, name, tbl_name, rootpage, sql FROM sqlite_master WHERE name = "
                            "'timestamp_idx'").fetchone()
        assert index is not None
        listed = con.execute('SELECT count(*) FROM messages').fetchone()[0]
        con.execute('PRAGMA writable_schema = ON')
        con.execute("DELETE FROM sqlite_master WHERE name = 'timestamp_idx'")
        con.commit()
    finally:
        con.close()
    con = sqlite3.connect(db)
    try:
        con.executemany('INSERT INTO messages (topic_id, timestamp, data) VALUES (1, 0, ?)',
                        [(b'\x00\x01\x00\x00',)] * 7)
        con.commit()
        con.execute('PRAGMA writable_schema = ON')
        con.execute('INSERT INTO sqlite_master VALUES (?, ?, ?, ?, ?)', index)
        con.commit()
    finally:
        con.close()
    con = sqlite3.connect(db)
    try:   # the forgery as the trial made it: the index's count, quick_check ok
        assert con.execute('SELECT count(*) FROM messages').fetchone()[0] == listed
        assert con.execute('PRAGMA quick_check').fetchone()[0] == 'ok'
    finally:
        con.close()
    _refused_at_once(db, rf'b_0\.db3: corrupt SQLite3 database \(its messages table has {listed + 7} rows, an index '
                         rf'of it {listed}\); allowed: indexes that match their tables, as rosbag2 writes them$')


def test_a_virtual_table_in_place_of_a_rosbag2_table_is_refused(tmp_path: Path, messages: list) -> None:
    """A virtual table's rows come from its module (here the FTS index's, where the build has it)."""
    try:
        db = _schema_edited(tmp_path, messages, 'DROP TABLE message_definitions; CREATE VIRTUAL TABLE '
                            'message_definitions USING fts4(topic_type, encoding, encoded_message_definition, '
                            'type_description_hash);')
    except sqlite3.OperationalError as exc:
        pytest.skip(f'no FTS4 in this SQLite build ({exc})')
    _refused_at_once(db, r'b_0\.db3: message_definitions is a virtual table; allowed: rosbag2')


# -- verification failures ---------------------------------------------------------------------------------
def _tampered_copy(src: Path, dst: Path, sample: int, field: str, delta: float) -> None:
    bag = read_bag(src)
    store = typestore()
    msgs = []
    for topic in bag.topics.values():
        for t, raw in zip(topic.log_time.tolist(), topic.raw, strict=True):
            msgs.append((topic.name, t, raw))
    msgs.sort(key=lambda m: m[1])
    out = []
    for topic, t, raw in msgs:
        if topic == STATE:
            msg = store.deserialize_cdr(raw, 'gpr_interfaces/msg/PlatformState')
            if msg.sample == sample:
                obj = msg
                *path, last = field.split('.')
                for p in path:
                    obj = getattr(obj, p)
                setattr(obj, last, getattr(obj, last) + delta)
                raw = bytes(store.serialize_cdr(msg, 'gpr_interfaces/msg/PlatformState'))
        out.append((topic, t, raw))
    topics = {name: bag.topics[name].msgtype for name in bag.topics}
    with SegmentedBagWriter(dst, topics, flush_interval=0, fsync=False) as w:
        for topic, t, raw in out:
            w.write(topic, t, raw)


def test_tampered_pose_fails_naming_the_sample(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    _tampered_copy(REFERENCE, tmp_path / 't', 417, 'pose.position.x', 2e-9)
    status, out, _ = run_cli('verify', str(tmp_path / 't'), capsys=capsys)
    assert status == 1
    assert 'FAIL state.pose_position on /gpr/platform_state at sample 417: value 2e-09' in out
    # The PoseStamped of that sample now disagrees with the PlatformState as well; nothing else fails.
    assert 'FAIL topic.platform_pose on /gpr/platform_pose at sample 417' in out
    fails = [line for line in out.splitlines() if line.startswith('FAIL')]
    assert len(fails) == 2, fails
    status, out, _ = run_cli('verify', str(tmp_path / 't'), '--json', capsys=capsys)
    data = json.loads(out)
    failed = [(f['check'], f['sample']) for c in data['checks'] for f in c['failures']]
    assert failed == [('state.pose_position', 417), ('topic.platform_pose', 417)]
    # A tolerance above the change lets the state check pass (the companion topic still differs).
    status, out, _ = run_cli('verify', str(tmp_path / 't'), '--tolerance', 'position=5e-9', capsys=capsys)
    assert 'state.pose_position' not in ''.join(line for line in out.splitlines() if line.startswith('FAIL'))


def test_tampered_virtual_joint_and_lost_sample(tmp_path: Path, messages: list,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    src = write_messages(tmp_path / 'src', messages)
    _tampered_copy(src, tmp_path / 't', 9, 'tilt', 1e-6)
    result = verify_bag(tmp_path / 't')
    assert [(f.check, f.sample) for f in result.failures] == [('state.tilt', 9)]
    # Drop one sample of every topic: the counter check names the sample after the gap.
    t12 = [t for topic, t, _ in messages if topic == STATE][12]
    lost = [m for m in messages if m[1] != t12]
    write_messages(tmp_path / 'gap', lost)
    result = verify_bag(tmp_path / 'gap')
    assert [(f.check, f.sample, f.value) for f in result.failures] == [('stream.counter', 13, 1.0)]


@pytest.mark.parametrize('storage', ['mcap', 'sqlite3'])
def test_truncated_file_gives_exit_2(tmp_path: Path, messages: list, storage: str,
                                     capsys: pytest.CaptureFixture[str]) -> None:
    path = write_messages(tmp_path / 'b', messages, storage=storage)
    f = next(p for p in path.iterdir() if p.suffix in ('.mcap', '.db3'))
    data = f.read_bytes()
    f.write_bytes(data[:len(data) // 2])
    status, out, err = run_cli('verify', str(path), capsys=capsys)
    assert status == 2 and out == ''
    assert err.count('\n') == 1 and 'Traceback' not in err
    assert str(f) in err or str(path) in err
    assert 'truncated' in err or 'corrupt' in err


def test_unreadable_bags_give_exit_2(tmp_path: Path, messages: list, capsys: pytest.CaptureFixture[str]) -> None:
    path = write_messages(tmp_path / 'b', messages)
    (path / 'metadata.yaml').unlink()
    cases = {
        str(path): 'no metadata.yaml',
        str(tmp_path / 'missing'): 'does not exist',
    }
    (tmp_path / 'notes.txt').write_text('hello')
    cases[str(tmp_path / 'notes.txt')] = 'not a bag'
    (tmp_path / 'bad').mkdir()
    (tmp_path / 'bad' / 'metadata.yaml').write_text('just: [text')
    cases[str(tmp_path / 'bad')] = 'not a rosbag2 metadata file'
    for arg, words in cases.items():
        status, out, err = run_cli('verify', arg, capsys=capsys)
        assert status == 2, arg
        assert err.startswith('gpr verify: error: ') and words in err and err.count('\n') == 1
    status, _, err = run_cli('verify', str(REFERENCE), '--tolerance', 'speed=3', capsys=capsys)
    assert status == 2 and 'unknown name' in err
    status, _, err = run_cli('verify', str(REFERENCE), '--tolerance', '-1', capsys=capsys)
    assert status == 2 and 'allowed: a number from 0 to 0.001' in err   # the whole range (it said '>= 0')
    # 1e308 passed every recording; an empty name was the global tolerance; a repeated name kept the last value
    for argv, words in ((['1e308'], "tolerance position = 1e+308 is invalid; allowed: a number from 0 to 0.001"),
                        (['jump_pos=1e308'], 'tolerance jump_pos = 1e+308 is invalid; allowed: a number from 0 to 10'),
                        (['=1e-9'], 'the name before = is empty'),
                        (['angle=1e-9', 'angle=1e-8'], "--tolerance 'angle=1e-8': angle is given twice")):
        status, out, err = run_cli('verify', str(REFERENCE), *[a for v in argv for a in ('--tolerance', v)],
                                   capsys=capsys)
        assert status == 2 and out == '' and words in err and err.count('\n') == 1, err


def test_bag_without_states_fails_with_a_named_check(tmp_path: Path, messages: list) -> None:
    path = write_messages(tmp_path / 'b', [m for m in messages if m[0] != STATE])
    result = verify_bag(path)
    assert not result.passed and result.failures[0].check == 'state.present'
    # its line reads true: one thing missing where none may be ('value 0 > limit 1' before)
    assert result.failures[0].line().startswith('FAIL state.present on /gpr/platform_state at bag: value 1 > limit 0')


# -- writer safety -----------------------------------------------------------------------------------------
def test_writer_refuses_existing_unwritable_and_unknown(tmp_path: Path) -> None:
    topics = {STATE: GPR_TOPICS[STATE]}
    (tmp_path / 'exists').mkdir()
    with pytest.raises(BagError, match='exists already'):
        SegmentedBagWriter(tmp_path / 'exists', topics).open()
    (tmp_path / 'file').write_text('x')
    with pytest.raises(BagError, match='not a folder'):
        SegmentedBagWriter(tmp_path / 'file' / 'bag', topics).open()
    with pytest.raises(BagError, match='cannot be created: .*; allowed: a new folder in a writable place|not writable'):
        SegmentedBagWriter('/proc/gpr_bag_test/bag', topics).open()
    assert not Path('/proc/gpr_bag_test').exists()
    with pytest.raises(BagError, match="type 'nonexistent_msgs/msg/Thing'.*not in the typestore"):
        SegmentedBagWriter(tmp_path / 'new', {'/x': 'nonexistent_msgs/msg/Thing'})
    with pytest.raises(BagError, match='compression'):
        SegmentedBagWriter(tmp_path / 'new', topics, storage='sqlite3', compression='zstd')
    assert not (tmp_path / 'new').exists()


LONG = 'x' * 300    # beyond a file name's 255 bytes: Path.exists raised ENAMETOOLONG (an OSError, not a BagError)
NAME_TOO_LONG = 'name too long; allowed: a path whose names have at most 255 bytes each, 4096 in all'


def _long_storage_name(tmp_path: Path) -> Path:
    """A copy of the reference bag whose metadata.yaml lists a storage file of 300 characters (no digests)."""
    bag = tmp_path / 'long_name'
    shutil.copytree(REFERENCE, bag)
    meta = bag / 'metadata.yaml'
    text = ''.join(line for line in meta.read_text().splitlines(keepends=True) if 'sha256' not in line)
    meta.write_text(text.replace('reference_sweep_0.mcap', f'{LONG}.mcap'))
    return bag


def test_a_name_too_long_is_refused_naming_the_path_cut(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A bag path, a storage file listed in metadata.yaml, a recorder output: each too long for the file system is a
    BagError naming the path cut and what is allowed, and gpr verify calls it unreadable (exit 2)."""
    for path, what in ((tmp_path / LONG, ''), (_long_storage_name(tmp_path) / f'{LONG}.mcap', 'storage file ')):
        with pytest.raises(BagError) as info:
            read_bag(path.parent if what else path)
        assert str(info.value).endswith(f'... ({len(str(path))} characters): {what}{NAME_TOO_LONG}')
        assert str(path) not in str(info.value)
    status, out, err = run_cli('verify', LONG, capsys=capsys)
    assert (status, out) == (2, '') and err == f"gpr verify: error: unreadable: '{LONG[:119]}... (300 characters): " \
                                               f'{NAME_TOO_LONG}\n'
    for output in (tmp_path / LONG, tmp_path / LONG / 'bag'):
        with pytest.raises(BagError, match=f'^output .*\\.\\.\\. \\({len(str(output))} characters\\): {NAME_TOO_LONG}'):
            SegmentedBagWriter(output, {STATE: GPR_TOPICS[STATE]}).open()


@pytest.mark.parametrize('listed', ['../reference_sweep/reference_sweep_0.mcap', '/tmp/reference_sweep_0.mcap',
                                    '..\\reference_sweep_0.mcap', 'reference_sweep/reference_sweep_0.mcap'])
def test_a_storage_file_listed_outside_the_bag_folder_is_refused_by_name(tmp_path: Path, listed: str,
                                                                         capsys: pytest.CaptureFixture[str]) -> None:
    """``../base/base_0.db3`` in both lists was read as the ``base_0.db3`` inside the bag and failed as "listed in files
    but not in relative_file_paths" (it was in both); ``<bag folder>/<name>``, as the first rosbag2 versions wrote,
    reads the name."""
    bag = tmp_path / 'copy'
    shutil.copytree(REFERENCE, bag)
    meta = bag / 'metadata.yaml'
    meta.write_text(meta.read_text().replace('- reference_sweep_0.mcap', f"- '{listed}'")
                    .replace('path: reference_sweep_0.mcap', f"path: '{listed}'"))
    if not listed.startswith('reference_sweep/'):
        with pytest.raises(BagError, match=f'^{re.escape(str(meta))}: relative_file_paths lists '
                                           f"{re.escape(repr(listed))}, a storage file outside the bag folder; "
                                           'allowed: a file in the bag folder, by its name'):
            read_bag(bag)
        status, _, err = run_cli('verify', str(bag), capsys=capsys)
        assert status == 2 and 'unreadable' in err and 'outside the bag folder' in err
    else:
        assert read_bag(bag).files == ['reference_sweep_0.mcap']


_KILL_WRITER = r'''
import sys, time
sys.path.insert(0, sys.argv[3])
from gpr_kinematics.bags.synthetic import sweep_messages
from gpr_kinematics.bags.writer import SegmentedBagWriter
from gpr_kinematics.bags.typestore import GPR_TOPICS
msgs = [m for m in sweep_messages() if m[0] == '/gpr/platform_state']
w = SegmentedBagWriter(sys.argv[1], {'/gpr/platform_state': GPR_TOPICS['/gpr/platform_state']},
                       storage=sys.argv[2], flush_interval=0.3)
w.open()
print('open', flush=True)
for i, (topic, _, data) in enumerate(msgs):
    w.write(topic, time.time_ns(), data)
    w.poll()
    time.sleep(0.002)
time.sleep(60)
'''


@pytest.mark.parametrize('storage', ['mcap', 'sqlite3'])
@pytest.mark.slow
def test_sigkill_of_a_writing_process_loses_nothing_older_than_the_flush_interval(tmp_path: Path,
                                                                                  storage: str) -> None:
    script = tmp_path / 'writer.py'
    script.write_text(_KILL_WRITER)
    bag = tmp_path / 'bag'
    proc = subprocess.Popen([sys.executable, str(script), str(bag), storage, str(ROOT)], stdout=subprocess.PIPE,
                            env={**os.environ, 'PYTHONUNBUFFERED': '1'})
    assert proc.stdout is not None and proc.stdout.readline().strip() == b'open'
    time.sleep(1.2)
    kill_ns = time.time_ns()
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=10)
    assert proc.returncode == -signal.SIGKILL
    assert (bag / '.recording').is_dir()  # where the segment being written lived
    result = verify_bag(bag)  # counters gapless from 0, every state reproduced by the core
    assert result.passed, [f.line() for f in result.failures]
    topic = read_bag(bag).topic(STATE)
    assert len(topic) > 100
    # Everything written more than flush_interval (0.3 s) before the kill is in the bag; the newest message
    # in the bag is younger than 0.3 s + a scheduling margin of 0.2 s.
    assert topic.log_time[-1] >= kill_ns - int(0.5e9)
    assert np.array_equal(topic.columns()['sample'], np.arange(len(topic)))
    if storage == 'mcap':
        from mcap.reader import make_reader

        n = 0
        for f in read_bag(bag).files:
            with (bag / f).open('rb') as fh:
                n += sum(1 for _ in make_reader(fh).iter_messages())
        assert n == len(topic)
    shutil.rmtree(bag)


def test_garbage_q_fails_checks_without_crashing(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    store = typestore()
    msgs = sweep_messages(tilt_step=math.radians(1.0), azimuth_step=math.radians(60.0), topics=(STATE,))
    out = []
    for i, (topic, t, raw) in enumerate(msgs):
        if i in (3, 7):
            msg = store.deserialize_cdr(raw, 'gpr_interfaces/msg/PlatformState')
            q = msg.q.copy()
            q[0] = math.nan if i == 3 else 5.0  # 5 m: far beyond the 0.508 m stroke
            msg.q = q
            raw = bytes(store.serialize_cdr(msg, 'gpr_interfaces/msg/PlatformState'))
        out.append((topic, t, raw))
    write_messages(tmp_path / 'g', out)
    status, text, err = run_cli('verify', str(tmp_path / 'g'), capsys=capsys)
    assert status == 1 and err == ''
    assert 'FAIL state.forward on /gpr/platform_state at sample 3' in text
    assert 'FAIL state.limits on /gpr/platform_state at sample 7: value 4.492' in text
    assert 'FAIL state.pose_position on /gpr/platform_state at sample 7' in text
    failed_samples = {int(s) for s in re.findall(r'at sample (\d+)', text)}
    assert failed_samples == {3, 4, 7}  # 4: the step from the NaN sample (stream.jump)


def test_a_different_machine_geometry_fails_the_reference_bag(tmp_path: Path,
                                                              capsys: pytest.CaptureFixture[str]) -> None:
    """The check is against the model: 0.1 mm more radius moves the recorded poses beyond 1e-9 m."""
    cfg = tmp_path / 'gpr.yaml'
    cfg.write_text('radius: 0.093318\n')
    status, out, _ = run_cli('verify', str(REFERENCE), '--config', str(cfg), '--json', capsys=capsys)
    assert status == 1
    data = json.loads(out)
    failed = {c['name'] for c in data['checks'] if c['status'] == 'FAIL'}
    assert {'state.side_lengths', 'state.virtual_joints'} <= failed
    assert data['config']['radius'] == 0.093318
    status, _, err = run_cli('verify', str(REFERENCE), '--config', str(tmp_path / 'none.yaml'), capsys=capsys)
    assert status == 2 and 'none.yaml' in err


def test_a_segment_whose_metadata_cannot_be_written_is_not_counted_as_kept(tmp_path: Path, messages: list) -> None:
    """A file size limit hit by metadata.yaml.tmp: the recorder logged 'kept the 279 messages of the 56 segments'
    while the bag listed 55 and 274, and left the partial metadata.yaml.tmp behind. The segment whose listing
    failed is not kept: what the writer says it kept is what metadata.yaml lists."""
    import yaml
    from gpr_kinematics.bags.writer import SegmentedBagWriter

    types = {t: GPR_TOPICS[t] for t in dict.fromkeys(m[0] for m in messages)}
    w = SegmentedBagWriter(tmp_path / 'b', types, flush_interval=0, fsync=False, max_bag_size=20000)
    w.open()
    real, calls = w._prepare_metadata, []

    def failing() -> Path:
        calls.append(1)
        if len(calls) == 3:
            (tmp_path / 'b' / 'metadata.yaml.tmp').write_bytes(b'partial')
            raise OSError(27, 'File too large')
        return real()

    w._prepare_metadata = failing    # type: ignore[method-assign]
    with pytest.raises(Exception, match='File too large'):
        for topic, t, raw in messages:
            w.write(topic, t, raw)
    w.abort()
    meta = yaml.safe_load((tmp_path / 'b' / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert len(w.files) == len(meta['relative_file_paths']) == 2
    assert w.closed_message_count == meta['message_count'] > 0
    assert not (tmp_path / 'b' / 'metadata.yaml.tmp').exists()


def test_a_calibrated_machine_inside_its_drawing_verifies_clean(tmp_path: Path) -> None:
    """A calibrated geometry keeps the drawing's ``radius`` and puts the rods and joints where they are: 1.8 mm
    inside, the plane turns faster per rod change than ``sqrt(2/3)/R`` allows, and every sample of the package's own
    recording failed ``stream.jump`` (1.010 x bound). The bound takes the rods' and joints' own triangles now
    (``slope_gain``); the drawing's gain is the nominal one."""
    from gpr_kinematics.bags.verify import verify_bag
    from gpr_kinematics.core.config import GprConfig
    from gpr_kinematics.core.machine import slope_gain

    nominal = GprConfig()
    assert slope_gain(nominal) == pytest.approx(math.sqrt(2.0 / 3.0) / nominal.radius, rel=1e-14)
    inner = nominal.radius - 1.8e-3
    points = [[inner * math.cos(t), inner * math.sin(t)] for t in nominal.rod_azimuths]
    cfg = nominal.replace(rod_positions=points, platform_joints=points)
    assert slope_gain(cfg) == pytest.approx(math.sqrt(2.0 / 3.0) / inner, rel=1e-14)
    bag = write_messages(tmp_path / 'inner', sweep_messages(config=cfg, tilt_step=math.radians(0.2),
                                                            azimuth_step=math.radians(5.0)))
    result = verify_bag(bag)
    jump = next(c for c in result.checks if c.name == 'stream.jump')
    assert result.passed and 0.9 < jump.worst <= 1.0, jump


def test_a_calibrated_machine_with_leaning_rods_verifies_clean(tmp_path: Path) -> None:
    """Rods leaning 2-3 mrad (a calibrated machine's): the joint centres' triangle shrinks with the rods, the plane
    turns up to 1.1 % faster per rod change at 0.5 m than the base points' triangle says, and 108 samples of a
    recorded sweep failed ``stream.jump`` (1.002 x bound). The gain takes the joint centres at the stroke's corners."""
    from gpr_kinematics.bags.verify import verify_bag
    from gpr_kinematics.core.config import GprConfig
    from gpr_kinematics.core.machine import slope_gain

    cfg = GprConfig().replace(rod_directions=[[0.003, 0.0], [0.0, -0.002], [-0.0025, 0.0015]],
                              imperfection_budget=0.005)
    upright = cfg.replace(rod_directions=[[0.0, 0.0]] * 3)
    assert 1.005 < slope_gain(cfg) / slope_gain(upright) < 1.02
    bag = write_messages(tmp_path / 'lean', sweep_messages(config=cfg))
    result = verify_bag(bag, config=cfg)
    jump = next(c for c in result.checks if c.name == 'stream.jump')
    assert result.passed and 0.95 < jump.worst <= 1.0, jump


def test_a_negative_log_time_in_an_sqlite3_bag_is_named(tmp_path: Path, messages: list) -> None:
    """The first platform state stored with timestamp -5 (SQLite takes any integer): refused naming the topic and the
    negative value (not the topic's largest, which is in range)."""
    assert sum(m[0] == STATE for m in messages) > 1
    db = _schema_edited(tmp_path, messages, 'UPDATE messages SET timestamp = -5 WHERE id = (SELECT min(messages.id) '
                        f"FROM messages JOIN topics ON messages.topic_id = topics.id WHERE topics.name = '{STATE}');")
    with pytest.raises(BagError) as e:
        read_bag(db)
    assert str(e.value) == (f'{db}: topic {STATE} has a log time of -5 ns; allowed: 0 to 2^63 - 1 ns (a rosbag2 time '
                            'stamp)')


def test_a_compliant_bags_report_plots_its_recorded_virtual_joints(tmp_path: Path) -> None:
    """docs/bags.md: the virtual joints of the model a bag was recorded with are plotted from its messages; a compliant
    bag's dr and dt were in no figure (only the polar and offset models computed from its q)."""
    import matplotlib.pyplot as plt
    from gpr_kinematics.bags.report import report_figures
    from gpr_kinematics.bags.synthetic import sweep_messages, write_messages
    from gpr_kinematics.core.config import load_config

    bag = tmp_path / 'comp'
    write_messages(bag, sweep_messages(config=load_config(overrides={'model': 'compliant'})))
    result = verify_bag(bag)
    figures = dict(report_figures(result))
    try:
        fig = figures['compliant_virtual_joints.png']
        lines = [ln for ln in fig.axes[0].lines if ln.get_label() in ('dr1', 'dt3')]
        assert [ln.get_label() for ln in lines] == ['dr1', 'dt3']
        X = result.series.virtual_joints
        np.testing.assert_array_equal(lines[0].get_ydata(), X[:, 0] * 1e3)
        np.testing.assert_array_equal(lines[1].get_ydata(), X[:, 5] * 1e3)
        assert 'radial_virtual_joints.png' not in figures
    finally:
        for fig in figures.values():
            plt.close(fig)


def test_a_platform_states_frame_is_a_frame_after_the_records_prefix_not_the_world() -> None:
    """`state.frame`: a re-signed bag with every header's frame set to '', 'world' or 'evil' beside a record's
    frame_prefix passed gpr verify (the other topics' frames were only matched to the states' own). The frame is a tf
    frame name after the records' prefix, not the robot's world frame; without records (an older node's) any tf frame
    name but the world frame."""
    from gpr_kinematics.bags.checks_state import frame_check
    frames = ['r1/gpr_base', 'r1/cell/gpr_base', 'gpr_base', 'r1/', '', 'r1/world', 'r1//x', 'evil/gpr_base']
    c = {'header.frame_id': np.array(frames, dtype=object)}
    samples = np.arange(len(frames))
    failed = {f.sample for f in frame_check(c, samples, STATE, 'r1/', 'world').failures}
    assert failed == {2, 3, 4, 5, 6, 7}
    failed = {f.sample for f in frame_check(c, samples, STATE, None, 'world').failures}
    assert failed == {3, 4, 6}   # no prefix recorded: any tf frame name ('r1/world' may be a base_frame's)
    failed = {f.sample for f in frame_check(c, samples, STATE, '', 'gpr_base').failures}
    assert failed == {2, 3, 4, 6}


def test_a_platform_state_with_an_empty_frame_fails_verification(tmp_path: Path,
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    bag = read_bag(REFERENCE)
    store = typestore()
    out = []
    for topic in bag.topics.values():
        for t, raw in zip(topic.log_time.tolist(), topic.raw, strict=True):
            if topic.name == STATE:
                msg = store.deserialize_cdr(raw, 'gpr_interfaces/msg/PlatformState')
                msg.header.frame_id = ''
                raw = bytes(store.serialize_cdr(msg, 'gpr_interfaces/msg/PlatformState'))
            out.append((topic.name, t, raw))
    out.sort(key=lambda m: m[1])
    with SegmentedBagWriter(tmp_path / 't', {n: bag.topics[n].msgtype for n in bag.topics}, flush_interval=0,
                            fsync=False) as w:
        for topic, t, raw in out:
            w.write(topic, t, raw)
    status, text, _ = run_cli('verify', str(tmp_path / 't'), capsys=capsys)
    assert status == 1 and "FAIL state.frame on /gpr/platform_state at sample 0: value 1 > limit 0 (header.frame_id " \
        "is not a tf frame name, other than the robot's world frame 'world' (trajectory_node's base_frame))" in text, \
        text[-2000:]
