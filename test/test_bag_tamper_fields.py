"""Tampered bags that no test wrote before: mutation testing of ``gpr verify``'s checks (a comparison flipped, a
condition dropped, a column left out) found each mutant passing every bag test. Each bag here is written by
``bags.synthetic``, edited by the independent ``mcap`` writer with every CRC recomputed and the metadata re-signed
(:mod:`mcap_tamper`, as in ``test_bag_tamper.py``), and fails naming the check and the sample."""
from __future__ import annotations

import dataclasses
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from bag_support import MARKERS, example_robot_bag, small_sweep, write_bag
from gpr_kinematics.bags.columns import quaternion_angle
from gpr_kinematics.bags.reader import read_bag
from gpr_kinematics.bags.synthetic import sweep_messages
from gpr_kinematics.bags.typestore import GEOMETRY_TOPIC, GPR_TOPICS, PROGRAM_TOPIC
from gpr_kinematics.bags.verify import verify_bag
from mcap_tamper import edited, tampered

STATE, POSE, JOINTS = '/gpr/platform_state', '/gpr/platform_pose', '/joint_states'


def _failed(result: Any) -> dict[str, set[int | None]]:
    out: dict[str, set[int | None]] = {}
    for f in result.failures:
        out.setdefault(f.check, set()).add(f.sample)
    return out


def _types(msgs: list[tuple[str, int, bytes]]) -> dict[str, str]:
    return {t: GPR_TOPICS[t] for t in dict.fromkeys(m[0] for m in msgs)}


@pytest.fixture(scope='module')
def sweep(tmp_path_factory: pytest.TempPathFactory) -> Path:
    msgs = small_sweep()
    bag = write_bag(tmp_path_factory.mktemp('fields') / 'sweep', msgs, _types(msgs))
    assert verify_bag(bag).passed
    return bag


def _at(topic: str, index: int, change: Any) -> Any:
    """A message edit: ``change(message)`` of the ``index``-th message of ``topic``."""
    def edit(t: str, i: int, raw: bytes) -> bytes:
        return edited(GPR_TOPICS[t], raw, change) if (t, i) == (topic, index) else raw
    return edit


def _all(*edits: Any) -> Any:
    def edit(t: str, i: int, raw: bytes) -> bytes:
        for e in edits:
            raw = e(t, i, raw)
        return raw
    return edit


def _turned(q: Any, by: float = 1e-6) -> Any:
    """A quaternion message scaled by ``1 + by``: the same rotation, its norm ``by`` off 1."""
    return dataclasses.replace(q, x=q.x * (1 + by), y=q.y * (1 + by), z=q.z * (1 + by), w=q.w * (1 + by))


def _pose_orientation(m: Any, change: Any) -> Any:
    return dataclasses.replace(m, pose=dataclasses.replace(m.pose, orientation=change(m.pose.orientation)))


# -- state.* ------------------------------------------------------------------------------------------------------

@pytest.mark.parametrize('name, edit, fails', [
    # the stored closure residual (only the recomputed one was compared)
    ('residual', _at(STATE, 8, lambda m: dataclasses.replace(m, residual=1e-6)), {'state.residual': {8}}),
    # the commanded tilt 0.1 % larger, its sign kept (only a sign flip moved the azimuth the check compared)
    ('commanded', _at(STATE, 8, lambda m: dataclasses.replace(m, commanded_tilt=m.commanded_tilt * 1.001)),
     {'state.commanded': {8}, 'stream.program': {8}}),
    # an infinite commanded azimuth at an untilted sample (sample 2: tilt 0)
    ('azimuth', _at(STATE, 2, lambda m: dataclasses.replace(m, commanded_azimuth=math.inf)),
     {'state.commanded': {2}, 'stream.program': {2}}),
    # the virtual joints renamed, as many as the model's
    ('names', _at(STATE, 8, lambda m: dataclasses.replace(m, virtual_joint_names=['x1', 'x2', 'x3'])),
     {'state.virtual_joints': {8}, 'topic.virtual_joints': {8}}),
    # one virtual joint more at one sample: only that sample fails (it failed stream.jump at every sample: the
    # columns padded with NaN for it)
    ('extra', _at(STATE, 8, lambda m: dataclasses.replace(m, virtual_joint_names=[*m.virtual_joint_names, 'x4'],
                                                          virtual_joints=np.append(m.virtual_joints, 0.0))),
     {'state.virtual_joints': {8}, 'topic.virtual_joints': {8}}),
    # the orientation's norm 1e-6 off 1 (the same rotation), in the state and its pose topic
    ('norm', _all(_at(STATE, 8, lambda m: _pose_orientation(m, _turned)),
                  _at(POSE, 8, lambda m: _pose_orientation(m, _turned))), {'state.pose_orientation': {8}}),
    # the third rod moved by 1 um (only its first two were compared with the recorded program)
    ('rod3', _at(STATE, 8, lambda m: dataclasses.replace(m, q=m.q + np.array([0.0, 0.0, 1e-6]))),
     {'state.pose_position': {8}, 'state.pose_orientation': {8}, 'state.nominal_position': {8},
      'state.nominal_orientation': {8}, 'state.centre_shift': {8}, 'state.virtual_joints': {8},
      'state.side_lengths': {8}, 'state.tilt': {8}, 'state.joint_displacement': {8}, 'state.commanded': {8},
      'topic.joint_states': {8}, 'topic.markers': {8}, 'stream.program': {8}})])
def test_a_state_field_edited_fails_its_check(sweep: Path, tmp_path: Path, name: str, edit: Any,
                                             fails: dict[str, set[int]]) -> None:
    assert _failed(verify_bag(tampered(sweep, tmp_path / name, edit))) == fails


def test_a_tilt_azimuth_edited_at_a_small_tilt_fails(tmp_path: Path) -> None:
    """The tilt azimuth is compared by the tilt vectors (its difference times the tilt): an azimuth turned by 0.1 rad
    at a tilt of 5e-5 rad moves the tilt vector by 5e-6 rad, far beyond 1e-9 (the sweep's samples tilt 0, 5e-5 and
    1e-4 rad)."""
    msgs = sweep_messages(max_tilt=1e-4, tilt_step=5e-5, azimuth_step=math.radians(60.0))
    bag = write_bag(tmp_path / 'small', msgs, _types(msgs))
    assert verify_bag(bag).passed
    result = verify_bag(tampered(bag, tmp_path / 'azimuth', _at(STATE, 1, lambda m: dataclasses.replace(
        m, tilt_azimuth=m.tilt_azimuth + 0.1))))
    assert _failed(result) == {'state.tilt': {1}}
    assert result.failures[0].value == pytest.approx(0.1 * 5e-5, rel=1e-6)


def _geometry(old: str, new: str) -> Any:
    """The recorded geometry's line ``old`` (a regular expression) replaced by ``new``."""
    def edit(t: str, i: int, raw: bytes) -> bytes:
        if t != GEOMETRY_TOPIC:
            return raw
        return edited(GPR_TOPICS[t], raw, lambda m: dataclasses.replace(m, data=re.sub(old, new, m.data, count=1,
                                                                                       flags=re.M)))
    return edit


@pytest.mark.parametrize('line, samples, worst', [
    # 1.72 deg: the sweep's 2 deg samples (0.0349 rad) are beyond it
    ('tilt_limit: 0.03', [0, 4, 5, 9, 10, 14, 15, 19, 20, 24, 25, 29], math.radians(2.0) - 0.03 - 1e-9),
    # 5 nrad beyond it: more than forward kinematics' tilt slack of 1e-9 (the value: by how much beyond the slack)
    (f'tilt_limit: {math.radians(2.0) - 5e-9!r}', [0, 4, 5, 9, 10, 14, 15, 19, 20, 24, 25, 29], 4e-9),
    # the stroke's lower end above the shortest rod (the stroke's slack: 1e-12 m)
    ('stroke_min: 0.4999', None, 0.0027191242510815 - 1e-12)])
def test_a_recording_beyond_its_recorded_limits_fails_state_limits(sweep: Path, tmp_path: Path, line: str,
                                                                   samples: list[int] | None, worst: float) -> None:
    """The recorded geometry's tilt limit lowered, or its stroke's lower end raised, beyond the recorded states
    (the record cannot be planned again then either)."""
    key = line.split(':')[0]
    result = verify_bag(tampered(sweep, tmp_path / 'geometry', _geometry(f'^{key}: .*$', line)))
    assert set(_failed(result)) == {'state.limits', 'topic.program', 'stream.program'}
    limits = next(c for c in result.checks if c.name == 'state.limits')
    assert limits.worst == pytest.approx(worst, abs=1e-12)
    if samples is not None:
        assert limits.failed == len(samples) and [f.sample for f in limits.failures] == samples


def test_one_joint_beyond_the_imperfection_budget_fails(sweep: Path, tmp_path: Path) -> None:
    """The budget lowered to 35 um, between the largest joint displacements of the 1 deg and 2 deg samples (14.2 and
    56.8 um; the others' of the 2 deg samples are 28.4 um): a sample fails by its largest, as the flag says."""
    disp = np.stack(read_bag(sweep).topics[STATE].columns()['joint_displacement'])
    over = np.flatnonzero(disp.max(axis=1) > 3.5e-5)
    assert over.tolist() == [0, 4, 5, 9, 10, 14, 15, 19, 20, 24, 25, 29] and np.all(disp.min(axis=1)[over] < 3.5e-5)
    result = verify_bag(tampered(sweep, tmp_path / 'budget', _geometry('^imperfection_budget: .*$',
                                                                       'imperfection_budget: 3.5e-05')))
    assert _failed(result) == dict.fromkeys(('state.within_budget', 'state.imperfection_budget'), set(over.tolist()))
    check = next(c for c in result.checks if c.name == 'state.imperfection_budget')
    assert check.worst == pytest.approx(disp.max(), abs=1e-15) and check.limit == 3.5e-5


# -- stream.* -----------------------------------------------------------------------------------------------------

def _states_only(tmp_path: Path, edit: Any) -> Any:
    """A sweep of the state topic alone, without a record (as the reference bag: stream.* alone sees its order)."""
    msgs = small_sweep(topics=(STATE, GEOMETRY_TOPIC))
    bag = write_bag(tmp_path / 'states', msgs, _types(msgs))
    assert verify_bag(bag).passed
    return verify_bag(tampered(bag, tmp_path / 'edited', edit))


def test_a_repeated_sample_counter_fails_at_it_and_after_it(tmp_path: Path) -> None:
    """Sample 10's counter edited to 9: a repeated counter (step 0) and the step of 2 after it."""
    result = _states_only(tmp_path, _at(STATE, 10, lambda m: dataclasses.replace(m, sample=9)))
    assert [(f.check, f.sample, f.value) for f in result.failures] == [('stream.counter', 9, 1.0),
                                                                      ('stream.counter', 11, 1.0)]


def test_a_stamp_equal_to_the_previous_one_fails(tmp_path: Path) -> None:
    def earlier(m: Any) -> Any:   # 1 ms earlier: the previous sample's stamp
        stamp = dataclasses.replace(m.header.stamp, nanosec=m.header.stamp.nanosec - 1_000_000)
        return dataclasses.replace(m, header=dataclasses.replace(m.header, stamp=stamp))

    result = _states_only(tmp_path, _at(STATE, 10, earlier))
    assert [(f.check, f.sample, f.value) for f in result.failures] == [('stream.stamps', 10, 1.0)]


def test_the_crossing_ratio_is_the_rotation_over_its_bound(sweep: Path) -> None:
    """At the singular crossings (commanded tilt 0 or changing sign) the jump ratio is the rotation's:
    ``rot / (1.01 sqrt(2/3) / R |dq| + 1e-12)``, computed here from the states; it reaches 0.99 of the bound."""
    result = verify_bag(sweep)
    c = read_bag(sweep).topics[STATE].columns()
    q = np.stack(c['q'])
    quat = np.stack([np.asarray(c[f'pose.orientation.{k}'], float) for k in 'xyzw'], axis=1)
    ratio = quaternion_angle(quat[:-1], quat[1:]) / (
        1.01 * math.sqrt(2 / 3) / 0.093218 * np.linalg.norm(np.diff(q, axis=0), axis=1) + 1e-12)
    tilt = np.asarray(c['commanded_tilt'], float)
    cross = np.flatnonzero((tilt == 0) | np.r_[False, np.sign(tilt[1:]) * np.sign(tilt[:-1]) < 0])
    assert result.crossings == cross.size == 6     # alpha = 0 once per azimuth row
    assert result.crossing_ratio == pytest.approx(ratio[cross[cross >= 1] - 1].max(), rel=1e-12)
    assert 0.98 < result.crossing_ratio < 1.0



def test_a_program_reaches_the_singular_configuration_once_per_dwell_and_crosses_it_once(tmp_path: Path) -> None:
    """The example stations' program (load at tilt 0, station_a at 1.5 deg about 45 deg, station_b at 1 deg about
    -135 deg, unload at tilt 0) reaches the singular configuration three times: the load's and the unload's dwells at
    tilt 0 (21 samples each, which counted 42 crossings) and the move from station_a to station_b, whose commanded
    tilt stays positive while the azimuth turns by pi (not counted before). Found here from the commanded tilt
    vectors: a run of zeros once, a reversal once."""
    from gpr_kinematics.bags.synthetic import platform_program_messages
    from gpr_kinematics.inputs.resources import config_path
    from gpr_kinematics.robot.platform_program import load_platform_program

    msgs = platform_program_messages(load_platform_program(config_path('programs/example_stations.yaml')), rate=100.0)
    bag = write_bag(tmp_path / 'stations', msgs, _types(msgs))
    result = verify_bag(bag)
    c = read_bag(bag).topics[STATE].columns()
    tilt, az = np.asarray(c['commanded_tilt'], float), np.asarray(c['commanded_azimuth'], float)
    zero = tilt == 0
    runs = np.flatnonzero(zero & ~np.r_[False, zero[:-1]])
    turn = np.abs(np.angle(np.exp(1j * (az[1:] - az[:-1]))))   # the azimuth's turn between samples, in [0, pi]
    flips = 1 + np.flatnonzero(~zero[1:] & ~zero[:-1] & (np.abs(turn - np.pi) < 1e-9))
    assert runs.size == 2 and flips.size == 1 and np.count_nonzero(zero) == 42
    assert result.passed and result.crossings == 3
    q = np.stack(c['q'])
    quat = np.stack([np.asarray(c[f'pose.orientation.{k}'], float) for k in 'xyzw'], axis=1)
    ratio = quaternion_angle(quat[:-1], quat[1:]) / (
        1.01 * math.sqrt(2 / 3) / 0.093218 * np.linalg.norm(np.diff(q, axis=0), axis=1) + 1e-12)
    at = np.sort(np.r_[runs, flips])
    assert result.crossing_ratio >= ratio[at[at >= 1] - 1].max() * (1 - 1e-9)   # the rotation's ratio, at least


# -- topic.* ------------------------------------------------------------------------------------------------------

def _marker(k: int, change: Any) -> Any:
    """A MarkerArray edit: ``change`` of its ``k``-th marker."""
    return lambda m: dataclasses.replace(m, markers=[change(x) if j == k else x for j, x in enumerate(m.markers)])


@pytest.mark.parametrize('name, edit, fails', [
    # another frame, the stamp kept (only the stamp matched a companion to its state)
    ('frame', _at(POSE, 5, lambda m: dataclasses.replace(m, header=dataclasses.replace(m.header, frame_id='world'))),
     {'topic.platform_pose': {5}, 'topic.platform_pose_extra': {None}}),
    # the pose topic's orientation turned by 2e-6 rad (only its position was compared)
    ('turned', _at(POSE, 5, lambda m: _pose_orientation(m, lambda q: dataclasses.replace(q, x=q.x + 1e-6))),
     {'topic.platform_pose': {5}}),
    # velocities on the stream's joint state (the node publishes positions only)
    ('velocity', _at(JOINTS, 5, lambda m: dataclasses.replace(m, velocity=np.zeros(3))), {'topic.joint_states': {5}}),
    # a fifth marker; a marker's action DELETE; its last point moved; its stamp; a point more
    ('fifth', _at(MARKERS, 5, lambda m: dataclasses.replace(m, markers=[*m.markers, dataclasses.replace(
        m.markers[0], id=4)])), {'topic.markers': {5}}),
    ('delete', _at(MARKERS, 5, _marker(1, lambda x: dataclasses.replace(x, action=2))), {'topic.markers': {5}}),
    ('last_point', _at(MARKERS, 5, _marker(3, lambda x: dataclasses.replace(x, points=[
        *x.points[:-1], dataclasses.replace(x.points[-1], z=x.points[-1].z + 1e-6)]))), {'topic.markers': {5}}),
    ('stamp', _at(MARKERS, 5, _marker(2, lambda x: dataclasses.replace(x, header=dataclasses.replace(
        x.header, stamp=dataclasses.replace(x.header.stamp, nanosec=x.header.stamp.nanosec + 1))))),
     {'topic.markers': {5}}),
    ('point_more', _at(MARKERS, 5, _marker(1, lambda x: dataclasses.replace(x, points=[*x.points, x.points[0]]))),
     {'topic.markers': {5}})])
def test_a_companion_message_edited_fails_its_check(sweep: Path, tmp_path: Path, name: str, edit: Any,
                                                   fails: dict[str, set[int | None]]) -> None:
    assert _failed(verify_bag(tampered(sweep, tmp_path / name, edit))) == fails


def test_a_marker_array_off_the_inferred_cadence_fails(tmp_path: Path) -> None:
    """Without a recorded markers_every, markers at 0, 4, 8, 14, 20, 24, 28: every 4th from the first (the smallest
    step), so 12 and 16 lack theirs and 14's is out of it."""
    msgs = [m for m in small_sweep(markers_every=None)
            if m[0] != MARKERS or (m[1] // 1_000_000) % 1000 in (0, 4, 8, 14, 20, 24, 28)]
    result = verify_bag(write_bag(tmp_path / 'off', msgs, _types(msgs)))
    assert _failed(result) == {'topic.markers_sequence': {12, 14, 16}}


# -- topic.program, stream.program ----------------------------------------------------------------------------------

def test_a_records_length_edited_fails(sweep: Path, tmp_path: Path) -> None:
    """The record's samples: 30 edited to 31 (the recording ends within either)."""
    def edit(t: str, i: int, raw: bytes) -> bytes:
        return edited(GPR_TOPICS[t], raw, lambda m: dataclasses.replace(m, data=m.data.replace(
            'samples: 30\n', 'samples: 31\n', 1))) if t == PROGRAM_TOPIC else raw

    result = verify_bag(tampered(sweep, tmp_path / 'length', edit))
    assert [(f.check, f.detail) for f in result.failures] == [
        ('topic.program', 'the sweep from sample 0 says 31 samples; it recomputes to 30')]



# -- robot.*, topic.robot, topic.wafer_pose ---------------------------------------------------------------------------

ROBOT_STATE, WAFER_POSE = '/gpr/robot_state', '/gpr/wafer_pose'
#: What a RobotState that robot.structure refuses fails besides (its poses are not compared: inf).
REFUSED = ('robot.structure', 'robot.wafer_position', 'robot.wafer_orientation', 'robot.blade',
           'robot.naive_wafer_error')


@pytest.fixture(scope='module')
def robot_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return example_robot_bag(tmp_path_factory.mktemp('fields') / 'robot')


def _below_rest(k: int) -> Any:
    """arm2's hand (at rest while arm1 works) 0.01 rad below its lower limit, -3.05 rad: the RobotState's joint ``k``
    of the arms' joints, the joint state's after the rods."""
    def state(m: Any) -> Any:
        assert (m.arm, m.joint_names[k]) == ('arm1', 'arm2_hand')
        return dataclasses.replace(m, joints=np.where(np.arange(m.joints.size) == k, -3.06, m.joints))

    def joints(m: Any) -> Any:
        assert m.name[3 + k] == 'arm2_hand'
        return dataclasses.replace(m, position=np.where(np.arange(m.position.size) == 3 + k, -3.06, m.position))
    return _all(_at(ROBOT_STATE, 5, state), _at(JOINTS, 5, joints))


def _orientation(field: str, change: Any) -> Any:
    return lambda m: dataclasses.replace(m, **{field: dataclasses.replace(getattr(m, field), orientation=change(
        getattr(m, field).orientation))})


def _x_plus(q: Any) -> Any:
    return dataclasses.replace(q, x=q.x + 1e-6)


@pytest.mark.parametrize('name, edit, fails', [
    # another waypoint held at sample 100 (the aligner, waypoint 6), its name kept
    ('waypoint', _at(ROBOT_STATE, 100, lambda m: dataclasses.replace(m, waypoint=7)), {'stream.program': {100}}),
    # a joint of the arm at rest, its last one, below its lower limit (the upper one alone was tested)
    ('below', _below_rest(6), {'robot.joint_limits': {5}, 'stream.program': {5}}),
    # the blade turned by 2e-6 rad, its position kept
    ('blade', _at(ROBOT_STATE, 9, _orientation('blade', _x_plus)), {'robot.blade': {9}}),
    # the wafer's quaternion 1e-6 off unit norm (the same rotation), in the RobotState and its wafer pose
    ('norm', _all(_at(ROBOT_STATE, 9, _orientation('wafer', _turned)),
                  _at(WAFER_POSE, 9, lambda m: _pose_orientation(m, _turned))), {'robot.wafer_orientation': {9}}),
    # the wafer pose topic's orientation turned (only its position was compared)
    ('wafer_pose', _at(WAFER_POSE, 9, lambda m: _pose_orientation(m, _x_plus)), {'topic.wafer_pose': {9}}),
    # the naive model's wafer error in z (a y edited was tested)
    ('naive', _at(ROBOT_STATE, 9, lambda m: dataclasses.replace(m, naive_wafer_error=dataclasses.replace(
        m.naive_wafer_error, z=m.naive_wafer_error.z + 1e-6))), {'robot.naive_wafer_error': {9}}),
    # a frame that ends in the world frame's name without being it (r1/world is; gpr_world is not)
    ('frame', _at(ROBOT_STATE, 9, lambda m: dataclasses.replace(m, header=dataclasses.replace(
        m.header, frame_id='gpr_world'))), {**dict.fromkeys(REFUSED, {9}), 'topic.wafer_pose': {9},
                                           'topic.wafer_pose_extra': {None}}),
    # a joint value more than the robot's joints
    ('extra', _at(ROBOT_STATE, 9, lambda m: dataclasses.replace(m, joints=np.append(m.joints, 0.0))),
     {**dict.fromkeys(REFUSED, {9}), 'topic.joint_states': {9}, 'stream.program': {9}})])
def test_a_robot_message_edited_fails_its_check(robot_bag: Path, tmp_path: Path, name: str, edit: Any,
                                               fails: dict[str, set[int | None]]) -> None:
    result = verify_bag(tampered(robot_bag, tmp_path / name, edit))
    assert _failed(result) == fails
    if name == 'below':
        assert next(c for c in result.checks if c.name == 'robot.joint_limits').worst == pytest.approx(0.01 - 1e-9)


def test_a_second_robot_description_that_differs_fails(robot_bag: Path, tmp_path: Path) -> None:
    """Another description appended (arm1's branch left): which one governed would be an accident of order."""
    from bag_support import messages_of

    msgs = messages_of(robot_bag)
    text = next(raw for t, _, raw in msgs if t == '/gpr/robot')
    other = edited('std_msgs/msg/String', text, lambda m: dataclasses.replace(m, data=m.data.replace(
        'branch: right', 'branch: left', 1)))
    result = verify_bag(write_bag(tmp_path / 'two', [*msgs, ('/gpr/robot', msgs[-1][1] + 1, other)],
                                  dict(GPR_TOPICS)))
    robot = next(c for c in result.checks if c.name == 'topic.robot')
    assert (robot.failed, robot.worst, robot.failures[0].detail) == (1, 2.0, 'the robot description messages differ')


# -- bag.* ----------------------------------------------------------------------------------------------------------

OTHER_HASH = 'RIHS01_' + '0' * 64


def _listed(name: str, change: Any) -> Any:
    """A metadata edit: ``change(entry)`` of the topic ``name``'s entry of topics_with_message_count."""
    def edit(info: dict[str, Any]) -> None:
        for t in info['topics_with_message_count']:
            if t['topic_metadata']['name'] == name:
                change(t)
    return edit


def _hash(t: dict[str, Any]) -> None:
    t['topic_metadata']['type_description_hash'] = OTHER_HASH


def _fewer(t: dict[str, Any]) -> None:
    t['message_count'] -= 1


def _unlisted(info: dict[str, Any]) -> None:
    info['topics_with_message_count'] = [t for t in info['topics_with_message_count']
                                         if t['topic_metadata']['name'] != MARKERS]


@pytest.mark.parametrize('name, edits, fails', [
    # the metadata's type hash of the states (the files' kept)
    ('metadata_hash', {'metadata': _listed(STATE, _hash)}, [
        ('bag.type_hash', 'stored type hash differs from the current message definition'),
        ('bag.metadata', f"type hash in sweep_0.mcap: metadata.yaml says '{OTHER_HASH}', the files hold "
                         "'RIHS01_728c404de99cdee71b592cdc121c68ee0a2dcfce0bfffc41009d8b93fcd48711'")]),
    # the file's type hash of the states (the metadata's kept)
    ('file_hash', {'channel': lambda topic, meta: {**meta, 'topic_type_hash': OTHER_HASH} if topic == STATE
                   else meta}, [
        ('bag.schemas', "type hash of gpr_interfaces/msg/PlatformState in sweep_0.mcap is not the package's "
                        '(RIHS01_728c404de99cdee71b592cdc121c68ee0a2dcfce0bfffc41009d8b93fcd48711)'),
        ('bag.metadata', "type hash in sweep_0.mcap: metadata.yaml says 'RIHS01_728c404de99cdee71b592cdc121c68ee0a2dcf"
                         f"ce0bfffc41009d8b93fcd48711', the files hold '{OTHER_HASH}'")]),
    # the states' embedded definition said to be another encoding
    ('encoding', {'encoding': lambda name, enc: 'ros2idl' if name.endswith('PlatformState') else enc}, [
        ('bag.schemas', "the definition of gpr_interfaces/msg/PlatformState in sweep_0.mcap is encoded 'ros2idl'; "
                        'allowed: ros2msg')]),
    # a topic of the file left out of the metadata's list
    ('unlisted', {'metadata': _unlisted}, [('bag.metadata', 'in sweep_0.mcap but not in metadata.yaml')]),
    # a topic's count one less than the file holds (one more was tested)
    ('fewer', {'metadata': _listed(MARKERS, _fewer)}, [('bag.message_count', 'metadata.yaml counts 29, the files '
                                                                             'hold 30')])])
def test_metadata_and_embedded_definitions_edited_fail(sweep: Path, tmp_path: Path, name: str, edits: dict[str, Any],
                                                       fails: list[tuple[str, str]]) -> None:
    result = verify_bag(tampered(sweep, tmp_path / name, **edits))
    assert [(f.check, f.detail) for f in result.failures] == fails


def _distro(value: str) -> Any:
    return lambda name, meta: {**meta, 'ROS_DISTRO': value} if name == 'rosbag2' else meta


def _serialized(text: str) -> Any:   # rosbag2's MCAP plugin since it stores the bag's metadata in the file
    return lambda name, meta: {'serialized_metadata': text} if name == 'rosbag2' else meta


RECORD = "ros_distro (rosbag2 metadata record 1 {} in sweep_0.mcap): metadata.yaml says '{}', the files hold '{}'"


@pytest.mark.parametrize('name, edits, fails', [
    # metadata.yaml's distribution re-signed, the file's record kept (it passed)
    ('metadata', {'metadata': lambda info: info.__setitem__('ros_distro', 'humble')},
     [('bag.metadata', RECORD.format('ROS_DISTRO', 'humble', 'jazzy'))]),
    # the record's, metadata.yaml's kept (it passed: the record was never read)
    ('record', {'records': _distro('humble')}, [('bag.metadata', RECORD.format('ROS_DISTRO', 'jazzy', 'humble'))]),
    # a record of the bag's metadata YAML, as rosbag2 writes it now
    ('serialized', {'records': _serialized('rosbag2_bagfile_information: {version: 9, ros_distro: humble}\n')},
     [('bag.metadata', RECORD.format('serialized_metadata ros_distro', 'jazzy', 'humble'))]),
    ('not_yaml', {'records': _serialized('rosbag2_bagfile_information: [')},
     [('bag.metadata', 'rosbag2 metadata record 1 serialized_metadata: not YAML')]),
    # agreeing, or no record (a file a crash cut off before its end has none; older rosbag2 wrote none): no failure
    ('agrees', {'records': _serialized('rosbag2_bagfile_information: {version: 9, ros_distro: jazzy}\n')}, []),
    ('none', {'records': lambda name, meta: None if name == 'rosbag2' else meta}, [])])
def test_the_ros_distribution_of_the_files_is_the_metadatas(sweep: Path, tmp_path: Path, name: str,
                                                            edits: dict[str, Any], fails: list[tuple[str, str]]
                                                            ) -> None:
    """metadata.yaml's ``ros_distro`` against the one each MCAP file's ``rosbag2`` metadata records state (its
    ``ROS_DISTRO``, or the ``ros_distro`` of its ``serialized_metadata``): an edit of either side, re-signed, passed."""
    result = verify_bag(tampered(sweep, tmp_path / name, **edits))
    got = [(f.check, f.detail) for f in result.failures]
    assert len(got) == len(fails) and all(c == want_c and d.startswith(want_d)
                                          for (c, d), (want_c, want_d) in zip(got, fails, strict=True)), got


def _unsigned(src: Path, dst: Path, edit: Any) -> Path:
    """A copy whose metadata.yaml is rewritten with ``edit`` and no digest of its own (another recorder's)."""
    import shutil

    import yaml

    shutil.copytree(src, dst)
    info = yaml.safe_load((dst / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    edit(info)
    (dst / 'metadata.yaml').write_text(yaml.safe_dump({'rosbag2_bagfile_information': info}, sort_keys=False))
    return dst


def test_a_bag_of_another_recorder_needs_a_version_from_1(sweep: Path, tmp_path: Path) -> None:
    def version0(info: dict[str, Any]) -> None:
        info['version'], info['custom_data'] = 0, {}

    result = verify_bag(_unsigned(sweep, tmp_path / 'v0', version0), allow_missing_checksums=True)
    assert [(f.check, f.detail) for f in result.failures] == [('bag.metadata', 'version 0; allowed: 1 to 9')]


def test_allowing_missing_checksums_needs_every_one_gone(sweep: Path, tmp_path: Path) -> None:
    """The files' SHA-256 removed, the metadata's own digest kept (and recomputed): not a bag of another recorder."""
    from bag_support import resign_metadata

    bag = tampered(sweep, tmp_path / 'files')
    resign_metadata(bag, lambda info: info.__setitem__('custom_data', {}))
    result = verify_bag(bag, allow_missing_checksums=True)
    assert [(f.check, f.topic, f.detail) for f in result.failures] == [
        ('bag.checksums', 'sweep_0.mcap', 'no recorded SHA-256')]


def test_a_single_mcap_file_without_its_summary_crc_is_not_checked(sweep: Path, tmp_path: Path) -> None:
    """A single MCAP file passes on its CRCs, all of them: the summary's set to 0 ("not computed") fails."""
    import shutil
    import struct

    f = tmp_path / 'single.mcap'
    shutil.copy(sweep / 'sweep_0.mcap', f)
    data = bytearray(f.read_bytes())
    struct.pack_into('<I', data, len(data) - 8 - 4, 0)    # the footer's summary CRC
    f.write_bytes(bytes(data))
    result = verify_bag(f)
    assert [(f.check, f.detail) for f in result.failures] == [
        ('bag.checksums', 'a single file without checksums (no metadata.yaml, not every MCAP CRC): it cannot be '
                          'checked')]
    assert verify_bag(f, allow_missing_checksums=True).passed


def test_a_message_of_a_topic_no_check_reads_must_decode(sweep: Path, tmp_path: Path) -> None:
    """Every recorded topic is decoded, also one that no check reads (a string that runs beyond its message)."""
    from bag_support import messages_of
    from gpr_kinematics.bags.errors import BagError

    msgs = messages_of(sweep)
    bad = [*msgs, ('/notes', msgs[-1][1] + 1, b'\x00\x01\x00\x00\xff\xff\xff\x7f')]
    bag = write_bag(tmp_path / 'notes', bad, {**_types(msgs), '/notes': 'std_msgs/msg/String'})
    with pytest.raises(BagError, match='^/notes: message 0 of type std_msgs/msg/String cannot be decoded: string '
                                       'beyond the end of the message$'):
        verify_bag(bag)


def test_a_state_topic_of_another_type_fails_without_a_traceback(tmp_path: Path) -> None:
    msgs = [(POSE if t == POSE else t, ts, raw) for t, ts, raw in small_sweep() if t != STATE]
    msgs += [(STATE, ts, raw) for t, ts, raw in small_sweep() if t == POSE]
    msgs.sort(key=lambda m: m[1])
    result = verify_bag(write_bag(tmp_path / 'poses', msgs, {**_types(msgs), STATE: GPR_TOPICS[POSE]}))
    assert [(f.check, f.detail) for f in result.failures] == [
        ('bag.topic_types', "type 'geometry_msgs/msg/PoseStamped'; the node suite publishes "
                            'gpr_interfaces/msg/PlatformState'),
        ('state.present', 'no gpr_interfaces/msg/PlatformState messages on /gpr/platform_state: nothing to verify')]
