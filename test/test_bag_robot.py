"""Whole-robot recordings without DDS (the synthetic writer builds the trajectory node's messages): ``gpr verify``
checks every wafer pose against the robot's forward kinematics with the recorded robot description (or a given
one); a changed wafer, blade, naive error, joint, arm, joint state or wafer pose fails the named check; robot
states without a robot description fail; a hostile description text is a failed check, not a crash."""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from bag_support import rewritten, write_bag
from gpr_kinematics.bags.synthetic import robot_program_messages, sweep_messages
from gpr_kinematics.bags.typestore import GPR_TOPICS, ROBOT_STATE_TOPIC, ROBOT_TOPIC, WAFER_POSE_TOPIC
from gpr_kinematics.bags.verify import verify_bag
from gpr_kinematics.cli import main as cli
from gpr_kinematics.core.messages import robot_text
from gpr_kinematics.robot import load_robot, robot_forward
from gpr_kinematics.robot.program import parse_program
from gpr_kinematics.robot.stream import robot_stream
from robot_support import SHORT_PROGRAM

ROBOT = load_robot()
PROGRAM = parse_program(yaml.safe_load(SHORT_PROGRAM), 'test_program')
RATE = 10.0


@pytest.fixture(scope='module')
def robot_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_bag(tmp_path_factory.mktemp('robot') / 'bag', robot_program_messages(ROBOT, PROGRAM, RATE),
                     dict(GPR_TOPICS))


def _failed(result) -> dict[str, set[int | None]]:
    out: dict[str, set[int | None]] = {}
    for f in result.failures:
        out.setdefault(f.check, set()).add(f.sample)
    return out


def test_a_robot_recording_verifies_every_wafer_pose(robot_bag: Path) -> None:
    result = verify_bag(robot_bag)
    assert result.passed, [f.line() for f in result.failures]
    checks = {c.name: c for c in result.checks}
    n = len(robot_stream(ROBOT, PROGRAM, RATE))
    for name in ('robot.structure', 'robot.wafer_position', 'robot.wafer_orientation', 'robot.blade',
                 'robot.naive_wafer_error', 'robot.joint_limits', 'topic.wafer_pose', 'topic.robot'):
        assert not checks[name].skipped, name
    assert checks['robot.wafer_position'].checked == checks['topic.wafer_pose'].checked == n
    assert any('robot example_dual_arm recorded on /gpr/robot' in note for note in result.notes)


def _shift_wafer(sample: int, dx: float):
    def edit(topic, msg):
        if topic == ROBOT_STATE_TOPIC and msg.sample == sample:
            p = dataclasses.replace(msg.wafer.position, x=msg.wafer.position.x + dx)
            return dataclasses.replace(msg, wafer=dataclasses.replace(msg.wafer, position=p))
        return msg
    return edit


def test_a_moved_wafer_fails_at_its_sample_and_its_wafer_pose_no_longer_matches(robot_bag: Path,
                                                                                 tmp_path: Path) -> None:
    bag = rewritten(robot_bag, tmp_path / 'moved', _shift_wafer(17, 2e-9))
    failed = _failed(verify_bag(bag))
    assert failed == {'robot.wafer_position': {17}, 'topic.wafer_pose': {17}}


@pytest.mark.parametrize('what,check', [
    ('blade', 'robot.blade'), ('naive', 'robot.naive_wafer_error'), ('arm', 'robot.structure'),
    ('names', 'robot.structure'), ('frame', 'robot.structure'), ('sample', 'robot.structure'),
])
def test_each_field_of_a_robot_state_is_checked(robot_bag: Path, tmp_path: Path, what: str, check: str) -> None:
    def edit(topic, msg):
        if topic != ROBOT_STATE_TOPIC or msg.sample != 9:
            return msg
        if what == 'blade':
            return dataclasses.replace(msg, blade=dataclasses.replace(msg.blade, position=dataclasses.replace(
                msg.blade.position, z=msg.blade.position.z + 1e-6)))
        if what == 'naive':
            return dataclasses.replace(msg, naive_wafer_error=dataclasses.replace(msg.naive_wafer_error, y=1e-3))
        if what == 'arm':
            return dataclasses.replace(msg, arm='arm3')
        if what == 'names':
            return dataclasses.replace(msg, joint_names=list(reversed(msg.joint_names)))
        if what == 'frame':
            return dataclasses.replace(msg, header=dataclasses.replace(msg.header, frame_id='gpr_base'))
        return dataclasses.replace(msg, sample=msg.sample + 1)

    result = verify_bag(rewritten(robot_bag, tmp_path / what, edit))
    failed = _failed(result)
    assert 9 in failed.pop(check) and set(failed) <= {'robot.wafer_position', 'robot.wafer_orientation',
                                                      'robot.blade', 'robot.naive_wafer_error', 'topic.joint_states',
                                                      'topic.wafer_pose', 'topic.wafer_pose_extra', 'stream.program',
                                                      *(['topic.program'] if what == 'arm' else [])}
    if what == 'arm':   # the arm in use is compared with the recomputed stream's too
        assert [f.detail for f in result.failures if f.check == 'topic.program'] == [
            "the robot_program from sample 0 uses the arm 'arm1'; its RobotStates (arm) name it 'arm3' at sample 9"]


@pytest.mark.parametrize('beyond', [0.01, 5e-10])
def test_a_joint_beyond_its_limit_fails_joint_limits_only(robot_bag: Path, tmp_path: Path, beyond: float) -> None:
    """The elbow of arm1 set beyond its upper limit, with the wafer, blade and naive error it then gives (computed
    here by the robot core) and the joint state: only robot.joint_limits fails; also 5e-10 rad beyond, which the
    core refuses and the check's own slack of 1e-9 passed (the core's 1e-12 now)."""
    limit = ROBOT.arm('arm1').joints[1].upper

    def edit(topic, msg):
        if getattr(msg, 'sample', None) == 5 and topic == ROBOT_STATE_TOPIC:
            joints = np.array(msg.joints)
            joints[1] = limit + beyond
            rods = edit.rods
            fk = robot_forward(ROBOT, [rods], [joints[:3]], 'arm1', check_limits=False)
            wafer = dataclasses.replace(msg.wafer, position=dataclasses.replace(
                msg.wafer.position, **dict(zip('xyz', fk.wafer.position[0].tolist(), strict=True))),
                orientation=dataclasses.replace(msg.wafer.orientation, **dict(zip(
                    'xyzw', fk.wafer.quaternion[0].tolist(), strict=True))))
            blade = dataclasses.replace(msg.blade, position=dataclasses.replace(
                msg.blade.position, **dict(zip('xyz', fk.blade.position[0].tolist(), strict=True))),
                orientation=dataclasses.replace(msg.blade.orientation, **dict(zip(
                    'xyzw', fk.blade.quaternion[0].tolist(), strict=True))))
            naive = dataclasses.replace(msg.naive_wafer_error, **dict(zip(
                'xyz', fk.naive_wafer_error[0].tolist(), strict=True)))
            edit.wafer = wafer
            return dataclasses.replace(msg, joints=joints, wafer=wafer, blade=blade, naive_wafer_error=naive)
        if topic == '/gpr/platform_state' and msg.sample == 5:
            edit.rods = np.array(msg.q)
        if topic == '/joint_states' and msg.header.stamp == edit.stamp:
            position = np.array(msg.position)
            position[4] = limit + beyond
            return dataclasses.replace(msg, position=position)
        if topic == WAFER_POSE_TOPIC and msg.header.stamp == edit.stamp:
            return dataclasses.replace(msg, pose=edit.wafer)
        return msg

    messages = robot_program_messages(ROBOT, PROGRAM, RATE)
    edit.stamp = None
    from gpr_kinematics.bags.typestore import typestore

    state = typestore().deserialize_cdr([m for m in messages if m[0] == '/gpr/platform_state'][5][2],
                                        GPR_TOPICS['/gpr/platform_state'])
    edit.stamp = state.header.stamp
    edit.rods = np.array(state.q)
    bag = rewritten(write_bag(tmp_path / 'src', messages, dict(GPR_TOPICS)), tmp_path / 'limit', edit)
    failed = _failed(verify_bag(bag))
    # ... and the stream recomputed from the recorded program has another elbow there (stream.program)
    assert failed == {'robot.joint_limits': {5}, 'stream.program': {5}}
    worst = next(c for c in verify_bag(bag).checks if c.name == 'robot.joint_limits').worst
    assert worst == pytest.approx(beyond - 1e-12, abs=1e-15)


def test_an_arm_at_rest_beyond_its_limit_fails_joint_limits(robot_bag: Path, tmp_path: Path) -> None:
    """arm2 rests while arm1 works: its shoulder set 0.01 rad beyond the upper limit in the robot state and the
    joint state of sample 5 fails robot.joint_limits there (every arm's joints are checked, not the working one's)."""
    arm2 = ROBOT.arm('arm2')
    limit = arm2.joints[0].upper
    at = 3 + len(ROBOT.arm('arm1').joints)  # arm2's shoulder in the joint state: after the rods and arm1

    def edit(topic, msg):
        if topic == ROBOT_STATE_TOPIC and msg.sample == 5:
            assert msg.arm == 'arm1'
            joints = np.array(msg.joints)
            joints[len(ROBOT.arm('arm1').joints)] = limit + 0.01
            edit.stamp = msg.header.stamp
            return dataclasses.replace(msg, joints=joints)
        return msg

    edit.stamp = None
    bag = rewritten(robot_bag, tmp_path / 'rest', edit)

    def joint_state(topic, msg):
        if topic == '/joint_states' and msg.header.stamp == edit.stamp:
            position = np.array(msg.position)
            assert msg.name[at] == arm2.joints[0].name
            position[at] = limit + 0.01
            return dataclasses.replace(msg, position=position)
        return msg

    result = verify_bag(rewritten(bag, tmp_path / 'rest2', joint_state))
    assert _failed(result) == {'robot.joint_limits': {5}, 'stream.program': {5}}
    worst = next(c for c in result.checks if c.name == 'robot.joint_limits').worst
    assert worst == pytest.approx(0.01 - 1e-12, abs=1e-15)


def test_a_recorded_description_naming_a_geometry_file_is_refused(robot_bag: Path, tmp_path: Path) -> None:
    """A recording carries its geometry inline; a gpr.config path in it (a file verify would open) fails."""
    from gpr_kinematics.bags.typestore import typestore

    text = robot_text(ROBOT)
    assert 'config: null' in text
    text = text.replace('config: null', 'config: /etc/hostname', 1)
    raw = bytes(typestore().serialize_cdr(typestore().types['std_msgs/msg/String'](data=text), 'std_msgs/msg/String'))
    bag = rewritten(robot_bag, tmp_path / 'file', lambda topic, msg: raw if topic == ROBOT_TOPIC else msg)
    result = verify_bag(bag)
    check = next(c for c in result.checks if c.name == 'topic.robot')
    assert check.failed == 1 and 'names a geometry file' in check.failures[0].detail


def test_joint_states_carry_the_arm_joints(robot_bag: Path, tmp_path: Path) -> None:
    def edit(topic, msg):
        stamp = (msg.header.stamp.sec, msg.header.stamp.nanosec) if topic == '/joint_states' else None
        if stamp == (1_700_000_000, 300_000_000):                  # sample 3 at 10 Hz
            return dataclasses.replace(msg, name=msg.name[:3], position=msg.position[:3])
        return msg

    failed = _failed(verify_bag(rewritten(robot_bag, tmp_path / 'js', edit)))
    assert failed == {'topic.joint_states': {3}}


def test_without_a_robot_description_robot_states_fail_and_robot_gives_it(robot_bag: Path, tmp_path: Path) -> None:
    bag = rewritten(robot_bag, tmp_path / 'no_robot', lambda topic, msg: None if topic == ROBOT_TOPIC else msg)
    result = verify_bag(bag)
    assert not result.passed
    failures = {f.check: f for f in result.failures}
    assert set(failures) == {'topic.robot', 'topic.program', 'stream.program'}   # the program needs its robot too
    assert 'give the robot with --robot FILE' in failures['topic.robot'].detail
    assert 'needs the robot description it ran on' in failures['topic.program'].detail
    assert verify_bag(bag, robot=ROBOT, robot_source='example').passed


def test_another_robot_given_fails_the_wafer_poses(robot_bag: Path) -> None:
    """A robot whose first arm has a 1 mm longer upper link: every sample of arm1 misses by up to that."""
    arm = ROBOT.arm('arm1')
    longer = dataclasses.replace(arm, joints=(dataclasses.replace(arm.joints[0], length=arm.joints[0].length + 1e-3),
                                              *arm.joints[1:]))
    other = dataclasses.replace(ROBOT, arms=(longer, ROBOT.arms[1]))
    result = verify_bag(robot_bag, robot=other, robot_source='--robot longer.yaml')
    check = next(c for c in result.checks if c.name == 'robot.wafer_position')
    assert check.failed > 0 and 1e-4 < check.worst <= 1e-3 + 1e-12
    assert 'robot description: --robot longer.yaml (given)' in result.notes   # the same robot's name: no word
    # another robot's file (robot 2's for robot 1's bag) failed the same way without saying the robot differed
    renamed = dataclasses.replace(other, name='example_dual_arm_r2')
    result = verify_bag(robot_bag, robot=renamed, robot_source='--robot r2.yaml')
    assert ('robot description: --robot r2.yaml (given): robot example_dual_arm_r2, but the bag recorded robot '
            'example_dual_arm on /gpr/robot') in result.notes, result.notes


@pytest.mark.parametrize('text,detail', [
    ('- not\n- a mapping', 'not a usable robot description'),
    ('name: [unclosed', 'not a usable robot description'),
    ('a: &x 1\nb: *x\n', 'not a usable robot description'),
    (None, 'differs from the geometry'),
])
def test_a_bad_robot_description_is_a_failed_check(robot_bag: Path, tmp_path: Path, text, detail) -> None:
    from gpr_kinematics.bags.typestore import typestore

    if text is None:  # the description of the same robot on another machine (its gpr section)
        text = robot_text(dataclasses.replace(ROBOT, config=ROBOT.config.replace(radius=0.1)))
    raw = bytes(typestore().serialize_cdr(typestore().types['std_msgs/msg/String'](data=text), 'std_msgs/msg/String'))
    bag = rewritten(robot_bag, tmp_path / 'bad', lambda topic, msg: raw if topic == ROBOT_TOPIC else msg)
    result = verify_bag(bag)
    check = next(c for c in result.checks if c.name == 'topic.robot')
    assert check.failed == 1 and detail in check.failures[0].detail
    assert next(c for c in result.checks if c.name == 'robot.wafer_position').skipped


def test_a_sweep_with_its_robot_recorded_skips_the_robot_checks(tmp_path: Path) -> None:
    from gpr_kinematics.bags.typestore import typestore

    msgs = sweep_messages(tilt_step=math.radians(1.0), azimuth_step=math.radians(120.0))
    raw = bytes(typestore().serialize_cdr(typestore().types['std_msgs/msg/String'](data=robot_text(ROBOT)),
                                          'std_msgs/msg/String'))
    bag = write_bag(tmp_path / 'sweep', [(ROBOT_TOPIC, msgs[0][1], raw), *msgs], dict(GPR_TOPICS))
    result = verify_bag(bag)
    assert result.passed, [f.line() for f in result.failures]
    checks = {c.name: c for c in result.checks}
    assert not checks['topic.robot'].skipped and checks['robot.wafer_position'].skipped == 'no robot states in the bag'
    assert result.notes[-1] == ('robot example_dual_arm recorded on /gpr/robot; no robot states (a platform stream, '
                                'or a recording of fewer topics): no wafer pose verified')


def test_a_recording_without_robot_topics_says_it_has_no_robot_checks(tmp_path: Path) -> None:
    bag = write_bag(tmp_path / 'sweep', sweep_messages(tilt_step=math.radians(1.0),
                                                       azimuth_step=math.radians(120.0)), dict(GPR_TOPICS))
    result = verify_bag(bag)
    assert result.passed and 'no robot topics (a platform recording): no robot checks' in result.notes
    checks = {c.name: c for c in result.checks}
    assert checks['topic.robot'].skipped == 'no robot description recorded'
    assert checks['robot.wafer_position'].skipped == 'no robot states in the bag'
    assert result.robot == {} and result.to_dict()['robot'] == {}


def test_the_json_result_names_the_robot(robot_bag: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import json

    assert cli.main(['verify', str(robot_bag), '--json']) == 0
    data = json.loads(capsys.readouterr().out)
    assert data['robot'] == {'name': ROBOT.name, 'arms': list(ROBOT.arm_names), 'source': 'recorded'}


def test_the_reference_bag_records_its_geometry_and_robot_latched() -> None:
    """The committed reference sweep was recorded with the package geometry and the shipped example robot, both on
    latched topics whose recorded QoS is transient local (``ros2 bag play`` latches them again)."""
    from bag_support import REFERENCE
    from gpr_kinematics.bags.reader import read_bag
    from gpr_kinematics.bags.typestore import GEOMETRY_TOPIC, typestore
    from gpr_kinematics.core.config import load_config

    bag = read_bag(REFERENCE)
    texts = {t: typestore().deserialize_cdr(bag.topic(t).raw[0], 'std_msgs/msg/String').data
             for t in (GEOMETRY_TOPIC, ROBOT_TOPIC)}
    assert yaml.safe_load(texts[GEOMETRY_TOPIC]) == load_config().to_dict()
    # the example robot as it was shipped when the bag was recorded (docs/bags.md): the same robot and geometry,
    # its limits since changed; the recorded description is valid and names the same arms and joints
    from gpr_kinematics.inputs.safe_yaml import load_text
    from gpr_kinematics.robot.description import parse_robot

    recorded = parse_robot(load_text(texts[ROBOT_TOPIC]), ROBOT_TOPIC)
    assert recorded.name == ROBOT.name and recorded.config.to_dict() == load_config().to_dict()
    assert [[j.name for j in a.joints] for a in recorded.arms] == [[j.name for j in a.joints] for a in ROBOT.arms]
    meta = yaml.safe_load((REFERENCE / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    qos = {t['topic_metadata']['name']: t['topic_metadata']['offered_qos_profiles']
           for t in meta['topics_with_message_count']}
    assert all(p['durability'] == 'transient_local' for t in (GEOMETRY_TOPIC, ROBOT_TOPIC) for p in qos[t])


def test_cli_robot_option(robot_bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from gpr_kinematics.inputs.resources import config_path

    assert cli.main(['verify', str(robot_bag), '--robot', str(config_path('robots/example_robot.yaml'))]) == 0
    assert 'robot description: --robot' in capsys.readouterr().out
    assert cli.main(['verify', str(robot_bag), '--robot', '']) == 2
    assert '--robot is empty' in capsys.readouterr().err
    assert cli.main(['verify', str(robot_bag), '--robot', str(tmp_path / 'absent.yaml')]) == 2
    err = capsys.readouterr().err
    assert 'absent.yaml' in err and len(err.strip().splitlines()) == 1


def test_a_recording_with_a_frame_prefix_verifies(robot_bag: Path, tmp_path: Path) -> None:
    """Every header of the recording prefixed r1/ (a trajectory_node with frame_prefix:=r1/): the world frame of the
    robot states is r1/world, and the recording verifies as the unprefixed one does."""
    def prefixed(header):
        return dataclasses.replace(header, frame_id='r1/' + header.frame_id)

    def edit(topic, msg):
        if topic == '/gpr/program':   # the node records its prefix
            return dataclasses.replace(msg, data=msg.data.replace("frame_prefix: ''", 'frame_prefix: r1/'))
        if hasattr(msg, 'markers'):
            return dataclasses.replace(msg, markers=[dataclasses.replace(m, header=prefixed(m.header))
                                                     for m in msg.markers])
        if hasattr(msg, 'header'):
            return dataclasses.replace(msg, header=prefixed(msg.header))
        return msg

    result = verify_bag(rewritten(robot_bag, tmp_path / 'r1', edit))
    assert result.passed, [f.line() for f in result.failures]
    assert next(c for c in result.checks if c.name == 'robot.structure').checked > 0


@pytest.mark.parametrize('prefix', ['', 'r1/'])
def test_robot_states_in_another_prefix_world_fail(robot_bag: Path, tmp_path: Path, prefix: str) -> None:
    """The robot states' world frame carries the node's frame prefix, the one of its PlatformStates' frame: every
    RobotState and wafer pose moved to evil/world (any */world passed) fails robot.structure at every sample."""
    def edit(topic, msg):
        if topic == '/gpr/program' and prefix:   # the node records its prefix
            return dataclasses.replace(msg, data=msg.data.replace("frame_prefix: ''", f'frame_prefix: {prefix}'))
        if not hasattr(msg, 'header'):
            return msg
        frame = msg.header.frame_id
        moved = 'evil/' + frame if topic in (ROBOT_STATE_TOPIC, WAFER_POSE_TOPIC) else prefix + frame
        return dataclasses.replace(msg, header=dataclasses.replace(msg.header, frame_id=moved))

    result = verify_bag(rewritten(robot_bag, tmp_path / 'evil', edit))
    structure = next(c for c in result.checks if c.name == 'robot.structure')
    assert not result.passed and structure.failed == structure.checked == result.counts[ROBOT_STATE_TOPIC]


@pytest.mark.parametrize('dropped, failed', [
    (range(0, 3), set()),                                          # a recorder that subscribed to them last
    (range(4, 6), {'topic.joint_states', 'robot.structure'}),      # lost in the middle (and more checks)
])
def test_robot_states_missing_at_the_start_are_a_late_recorder(robot_bag: Path, tmp_path: Path, dropped: range,
                                                              failed: set[str]) -> None:
    """A recorder joining a running robot program subscribed to the robot states after the joint states: the first
    samples' joint_states carry the arm joints without their RobotState in the bag, and topic.joint_states failed
    an honest bag (it is checked as rods only there, as the last sample's a cut lost). Dropped mid-stream: fails."""
    from bag_support import messages_of

    messages = messages_of(robot_bag)
    states = [k for k, m in enumerate(messages) if m[0] == ROBOT_STATE_TOPIC]
    drop = {states[i] for i in dropped}
    bag = write_bag(tmp_path / 'late', [m for k, m in enumerate(messages) if k not in drop], dict(GPR_TOPICS))
    got = set(_failed(verify_bag(bag)))
    assert got == failed if not failed else failed <= got, got


def _stamp(msg) -> int:
    return msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec


@pytest.mark.parametrize('ends', ['first 7', 'last'])
def test_wafer_poses_without_their_robot_state_at_the_ends_are_recomputed(robot_bag: Path, tmp_path: Path,
                                                                           ends: str) -> None:
    """A wafer pose was checked against the RobotState of its stamp only: with the first 7 RobotStates dropped (a late
    recorder) wafer poses 0-6 moved 5 cm passed, and so did a wafer pose 1 m off between two samples, and with the
    last RobotState dropped (a cut) the last wafer pose moved 5 cm. They are checked against the stream recomputed
    from the record; one at a stamp of no PlatformState inside the states' span is extra."""
    from bag_support import messages_of
    from gpr_kinematics.bags.typestore import typestore

    store = typestore()
    messages = messages_of(robot_bag)
    states = [k for k, m in enumerate(messages) if m[0] == ROBOT_STATE_TOPIC]
    drop = set(states[:7]) if ends == 'first 7' else {states[-1]}
    bag = write_bag(tmp_path / 'ends', [m for k, m in enumerate(messages) if k not in drop], dict(GPR_TOPICS))
    result = verify_bag(bag)
    assert result.passed, [f.line() for f in result.failures]
    assert next(c for c in result.checks if c.name == 'topic.wafer_pose_recomputed').checked == len(drop)
    stamps = sorted(_stamp(store.deserialize_cdr(messages[k][2], GPR_TOPICS[ROBOT_STATE_TOPIC])) for k in drop)
    at = dict(zip(stamps, range(7) if ends == 'first 7' else [len(states) - 1], strict=True))

    def moved(topic, msg):
        if topic == WAFER_POSE_TOPIC and _stamp(msg) in at:
            msg.pose.position.x += 0.05
        return msg

    failed = _failed(verify_bag(rewritten(bag, tmp_path / 'moved', moved)))
    assert failed == {'topic.wafer_pose_recomputed': set(at.values())}, failed
    if ends != 'first 7':
        return
    out = []
    for topic, t, raw in messages_of(bag):
        out.append((topic, t, raw))
        msg = store.deserialize_cdr(raw, GPR_TOPICS[topic]) if topic == WAFER_POSE_TOPIC else None
        if msg is not None and _stamp(msg) == stamps[2]:   # between samples 2 and 3, no PlatformState of its stamp
            msg.header.stamp.nanosec += 50_000_000
            msg.pose.position.x += 1.0
            out.append((topic, t + 1, bytes(store.serialize_cdr(msg, GPR_TOPICS[topic]))))
    extra = verify_bag(write_bag(tmp_path / 'extra', out, dict(GPR_TOPICS)))
    assert {c.name for c in extra.checks if c.failed} == {'topic.wafer_pose_recomputed_extra'}
    assert extra.failures[0].line() == ('FAIL topic.wafer_pose_recomputed_extra on /gpr/wafer_pose at bag: value 1 > '
                                        'limit 0 (messages without a PlatformState of the same stamp)')


def _late_bag(robot_bag: Path, dst: Path, record: bool = True) -> tuple[Path, dict[int, int]]:
    """``robot_bag`` without its first 7 RobotStates (a late recorder; without /gpr/program unless ``record``) and
    the stamps [ns] of the wafer poses 0-6 left without a RobotState, mapped to their samples."""
    from bag_support import messages_of
    from gpr_kinematics.bags.typestore import typestore

    messages = messages_of(robot_bag)
    states = [k for k, m in enumerate(messages) if m[0] == ROBOT_STATE_TOPIC]
    drop = set(states[:7])
    types = {k: v for k, v in GPR_TOPICS.items() if record or k != '/gpr/program'}
    bag = write_bag(dst, [m for k, m in enumerate(messages) if k not in drop and m[0] in types], types)
    msgs = [typestore().deserialize_cdr(messages[k][2], GPR_TOPICS[ROBOT_STATE_TOPIC]) for k in sorted(drop)]
    return bag, {_stamp(m): m.sample for m in msgs}


@pytest.mark.parametrize('scale', [2.0, 0.0])
def test_a_wafer_pose_without_its_robot_state_needs_a_unit_quaternion(robot_bag: Path, tmp_path: Path,
                                                                      scale: float) -> None:
    """The recomputed check adds the quaternion's norm defect to its rotation angle: a wafer pose 0-6 of a late
    recording whose quaternion is scaled by 2 (the same rotation, norm 2) or is all zeros (angle 0 by atan2(0, 0))
    fails at its sample by the defect, 1."""
    bag, at = _late_bag(robot_bag, tmp_path / 'late')
    assert sorted(at.values()) == list(range(7))
    assert verify_bag(bag).passed

    def scaled(topic, msg):
        if topic == WAFER_POSE_TOPIC and _stamp(msg) in at:
            o = msg.pose.orientation
            o.x, o.y, o.z, o.w = o.x * scale, o.y * scale, o.z * scale, o.w * scale
        return msg

    result = verify_bag(rewritten(bag, tmp_path / 'scaled', scaled))
    assert _failed(result) == {'topic.wafer_pose_recomputed': set(range(7))}, _failed(result)
    check = next(c for c in result.checks if c.name == 'topic.wafer_pose_recomputed')
    assert check.failed == 7 and check.worst == pytest.approx(1.0, abs=1e-9)   # |norm - 1|: the angle is 0


@pytest.mark.parametrize('record', [True, False], ids=['recorded', 'no record'])
@pytest.mark.parametrize('frame', ['nowhere', 'evil/world'])
def test_a_wafer_pose_without_its_robot_state_outside_the_world_frame_fails(robot_bag: Path, tmp_path: Path,
                                                                          frame: str, record: bool) -> None:
    """Wafer poses 0-6 of a late recording (no RobotState of their stamp) moved to another frame fail
    topic.wafer_pose_recomputed at their samples, with the record of the stream (values recomputed) and without
    (an older node's recording: the values are not checked, the frame is)."""
    bag, at = _late_bag(robot_bag, tmp_path / 'late', record=record)
    result = verify_bag(bag)
    assert result.passed, [f.line() for f in result.failures]
    assert ('/gpr/program' in result.counts) == record

    def moved(topic, msg):
        if topic == WAFER_POSE_TOPIC and _stamp(msg) in at:
            msg.header.frame_id = frame
        return msg

    result = verify_bag(rewritten(bag, tmp_path / 'moved', moved))
    assert _failed(result) == {'topic.wafer_pose_recomputed': set(range(7))}, _failed(result)
    fails = [f for f in result.failures if f.check == 'topic.wafer_pose_recomputed']
    assert len(fails) == 7 and all(f.value == math.inf for f in fails)
    if not record:
        assert fails[0].detail == ("not in the robot's world frame (values not checked: no record of the stream "
                                   '(gpr/program) to recompute them from: a recording of an older node)')


@pytest.mark.parametrize('kept', [(), (ROBOT_TOPIC,)], ids=['the robot given', 'the robot recorded'])
def test_a_robot_recording_of_fewer_topics_checks_the_rods_of_its_joint_states(robot_bag: Path, tmp_path: Path,
                                                                                kept: tuple[str, ...]) -> None:
    """A recorder given the platform state, joint_states and the geometry (no robot states) of a robot program:
    every joint_states message carries the rods and the arm joints, and topic.joint_states failed every sample of the
    honest bag (inf: the arm joints' RobotState not in the bag). With the robot known (recorded, or given as
    --robot) the rods are checked there, the message carrying that robot's joints after them (as before the first
    RobotState of a late recording); a rod edited by 1 um still fails, and so do joints other than the robot's.
    Without a robot known nothing tells such a message from a platform recording's with joints appended: it fails."""
    from bag_support import messages_of
    from gpr_kinematics.bags.typestore import GEOMETRY_TOPIC, JOINT_STATES_TOPIC

    topics = {'/gpr/platform_state', JOINT_STATES_TOPIC, GEOMETRY_TOPIC, *kept}
    types = {t: GPR_TOPICS[t] for t in topics}
    bag = write_bag(tmp_path / 'few', [m for m in messages_of(robot_bag) if m[0] in topics], types)
    robot = None if kept else ROBOT
    result = verify_bag(bag, robot=robot)
    assert result.passed, [f.line() for f in result.failures]
    check = next(c for c in result.checks if c.name == 'topic.joint_states')
    assert check.checked > 10 and not check.skipped
    if not kept:
        assert 'topic.joint_states' in _failed(verify_bag(bag))

    def edit(change):
        def apply(topic, msg):
            if topic == JOINT_STATES_TOPIC and msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec > 0:
                return change(msg)
            return msg
        return apply

    def rod(msg):
        position = msg.position.copy()
        position[1] += 1e-6
        return dataclasses.replace(msg, position=position)

    def renamed(msg):
        return dataclasses.replace(msg, name=[*msg.name[:-1], 'gripper'])

    for name, change in (('rod', rod), ('renamed', renamed)):
        edited = verify_bag(rewritten(bag, tmp_path / name, edit(change)), robot=robot)
        assert 'topic.joint_states' in _failed(edited), name


def test_a_platform_recordings_joint_states_carry_the_rods_alone(tmp_path: Path) -> None:
    """A sweep's joint_states with a joint appended (1e9 rad) passed once the rods alone were checked wherever no
    robot states are recorded: without a robot known, the whole message is checked again."""
    from gpr_kinematics.bags.typestore import JOINT_STATES_TOPIC

    msgs = sweep_messages(tilt_step=math.radians(1.0), azimuth_step=math.radians(120.0))
    bag = write_bag(tmp_path / 'sweep', msgs, dict(GPR_TOPICS))
    assert verify_bag(bag).passed

    def appended(topic, msg):
        if topic == JOINT_STATES_TOPIC:
            return dataclasses.replace(msg, name=[*msg.name, 'bogus'], position=np.append(msg.position, 1e9))
        return msg

    assert 'topic.joint_states' in _failed(verify_bag(rewritten(bag, tmp_path / 'appended', appended)))


def test_a_sweeps_joint_states_with_the_robots_arm_joints_appended_fail(tmp_path: Path) -> None:
    """The reference sweep records its robot and lists gpr/robot_state without a message: its joint_states with
    the example robot's arm joints appended (1000 rad each) passed, read as a robot recording of fewer topics."""
    from bag_support import REFERENCE

    names = [n for a in ROBOT.arms for n in a.joint_names]

    def appended(topic, msg):
        if topic in ('/joint_states', '/gpr/joint_states'):
            return dataclasses.replace(msg, name=[*msg.name, *names],
                                       position=np.concatenate([msg.position, np.full(len(names), 1e3)]))
        return msg

    assert 'topic.joint_states' in _failed(verify_bag(rewritten(REFERENCE, tmp_path / 'appended', appended)))


def test_a_recorded_sweeps_joint_states_with_arm_joints_fail_without_robot_states_and_with_robot(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A sweep whose record (gpr/program) says a platform stream, gpr/robot_state not recorded at all and the robot
    given (--robot): its joint_states carry the rods alone, so the example robot's arm joints appended (1000 rad each)
    fail at every sample; not read as a robot recording of fewer topics, whose rods alone would be checked."""
    from gpr_kinematics.inputs.resources import config_path

    names = [n for a in ROBOT.arms for n in a.joint_names]
    types = {k: v for k, v in GPR_TOPICS.items() if k != ROBOT_STATE_TOPIC}
    sweep = write_bag(tmp_path / 'sweep', sweep_messages(tilt_step=math.radians(1.0),
                                                         azimuth_step=math.radians(120.0)), types)
    given = config_path('robots/example_robot.yaml')
    assert verify_bag(sweep, robot=ROBOT).passed
    assert cli.main(['verify', str(sweep), '--robot', str(given)]) == 0

    def appended(topic, msg):
        if topic == '/joint_states':
            return dataclasses.replace(msg, name=[*msg.name, *names],
                                       position=np.concatenate([msg.position, np.full(len(names), 1e3)]))
        return msg

    bad = rewritten(sweep, tmp_path / 'appended', appended)
    result = verify_bag(bad, robot=ROBOT, robot_source='--robot example_robot.yaml')
    assert ROBOT_STATE_TOPIC not in result.counts and result.counts['/gpr/program'] == 1
    samples = set(range(result.counts['/gpr/platform_state']))
    assert _failed(result) == {'topic.joint_states': samples}, _failed(result)
    capsys.readouterr()
    assert cli.main(['verify', str(bad), '--robot', str(given)]) == 1
    assert 'FAIL topic.joint_states on /joint_states at sample 0: value inf > limit 1e-12' in capsys.readouterr().out


def _platform_then(robot_bag: Path) -> list[tuple[str, int, bytes]]:
    """A platform program (the example stations at 10 Hz, samples 0 to n - 1) then the robot program of
    ``robot_bag`` from sample n, as an idle node streams two goals."""
    from bag_support import messages_of
    from gpr_kinematics.bags.synthetic import platform_program_messages
    from gpr_kinematics.bags.typestore import GEOMETRY_TOPIC, PLATFORM_STATE_TOPIC, typestore
    from gpr_kinematics.inputs.resources import config_path
    from gpr_kinematics.robot.platform_program import load_platform_program

    store = typestore()
    first = platform_program_messages(load_platform_program(config_path('programs/example_stations.yaml')),
                                      ROBOT.config, 10.0, start_ns=1_600_000_000_000_000_000)
    n = sum(1 for m in first if m[0] == PLATFORM_STATE_TOPIC)
    out = list(first)
    for topic, t, raw in messages_of(robot_bag):
        if topic == GEOMETRY_TOPIC:
            continue
        msg = store.deserialize_cdr(raw, GPR_TOPICS[topic])
        if topic == '/gpr/program':
            msg.data = msg.data.replace('first_sample: 0\n', f'first_sample: {n}\n', 1)
        if hasattr(msg, 'sample'):
            msg.sample += n
        out.append((topic, t, bytes(store.serialize_cdr(msg, GPR_TOPICS[topic]))))
    return out


def test_joint_states_follow_the_records_a_sweeps_the_rods_a_robot_programs_the_arm_joints_too(
        robot_bag: Path, tmp_path: Path) -> None:
    """Every state before the first RobotState was taken as a late recorder's and its joint_states checked by the
    rods: a platform program's joint_states (before a robot program) with the arm joints appended at 0.77 rad
    passed. And with gpr/robot_state not recorded a robot program's joint_states stripped of the arm joints passed (a
    rods-only message matched the rods whole). The records decide: a platform stream's carry the rods alone, a robot
    program's the rods then the robot's joints."""
    from bag_support import messages_of
    from gpr_kinematics.bags.typestore import JOINT_STATES_TOPIC

    names = [n for a in ROBOT.arms for n in a.joint_names]
    both = write_bag(tmp_path / 'both', _platform_then(robot_bag), dict(GPR_TOPICS))
    assert verify_bag(both).passed, [f.line() for f in verify_bag(both).failures]

    def appended(topic, msg):
        if topic == JOINT_STATES_TOPIC and len(msg.name) == 3:
            return dataclasses.replace(msg, name=[*msg.name, *names],
                                       position=np.concatenate([msg.position, np.full(len(names), 0.77)]))
        return msg

    failed = _failed(verify_bag(rewritten(both, tmp_path / 'appended', appended)))
    assert failed == {'topic.joint_states': set(range(20))}, failed
    types = {k: v for k, v in GPR_TOPICS.items() if k != ROBOT_STATE_TOPIC}
    fewer = write_bag(tmp_path / 'fewer', [m for m in messages_of(robot_bag) if m[0] != ROBOT_STATE_TOPIC], types)
    assert verify_bag(fewer).passed
    seen = {'n': 0}

    def stripped(topic, msg):
        if topic == JOINT_STATES_TOPIC:
            seen['n'] += 1
            if 20 <= seen['n'] < 30:
                return dataclasses.replace(msg, name=msg.name[:3], position=msg.position[:3])
        return msg

    failed = _failed(verify_bag(rewritten(fewer, tmp_path / 'stripped', stripped)))
    assert failed == {'topic.joint_states': set(range(19, 29))}, failed


def test_a_late_recorders_first_joint_states_carry_the_robots_joints(robot_bag: Path, tmp_path: Path) -> None:
    """Before the first RobotState of a late recording the rods are checked alone: a joint 'foo' in place of the arm
    joints passed there; the names must be the robot states' own."""
    from bag_support import messages_of
    from gpr_kinematics.bags.typestore import JOINT_STATES_TOPIC

    messages = messages_of(robot_bag)
    states = [k for k, m in enumerate(messages) if m[0] == ROBOT_STATE_TOPIC]
    late = write_bag(tmp_path / 'late', [m for k, m in enumerate(messages) if k not in set(states[:3])],
                     dict(GPR_TOPICS))
    assert verify_bag(late).passed
    seen = {'n': 0}

    def foo(topic, msg):
        if topic == JOINT_STATES_TOPIC and seen['n'] < 2:
            seen['n'] += 1
            return dataclasses.replace(msg, name=[*msg.name[:3], 'foo'], position=np.append(msg.position[:3], 5.0))
        return msg

    assert 'topic.joint_states' in _failed(verify_bag(rewritten(late, tmp_path / 'foo', foo)))


def test_wafer_poses_without_robot_states_fail_in_a_sweep_and_are_recomputed_elsewhere(
        robot_bag: Path, tmp_path: Path) -> None:
    """Wafer poses are checked against the RobotState of their stamp: without robot states they passed unchecked
    (a sweep with 1e6 m wafer poses added, a robot recording of fewer topics with every wafer moved 1 m) under a note
    that said there were none. A sweep's record shows no robot program: they are extra there; elsewhere each is
    checked against the stream recomputed from the record (declared unchecked, and why, without a record)."""
    from bag_support import messages_of
    from gpr_kinematics.bags.typestore import typestore

    store = typestore()
    msgs = sweep_messages(tilt_step=math.radians(1.0), azimuth_step=math.radians(120.0))
    out = []
    for topic, t, raw in msgs:
        out.append((topic, t, raw))
        if topic == '/gpr/platform_state':
            header = store.deserialize_cdr(raw, GPR_TOPICS[topic]).header
            pose = store.types['geometry_msgs/msg/PoseStamped'](header=header, pose=store.types[
                'geometry_msgs/msg/Pose'](position=store.types['geometry_msgs/msg/Point'](x=1e6, y=0.0, z=0.0),
                                          orientation=store.types['geometry_msgs/msg/Quaternion'](x=0.0, y=0.0,
                                                                                                  z=0.0, w=1.0)))
            out.append((WAFER_POSE_TOPIC, t, bytes(store.serialize_cdr(pose, 'geometry_msgs/msg/PoseStamped'))))
    failed = _failed(verify_bag(write_bag(tmp_path / 'sweep', out, dict(GPR_TOPICS))))
    assert 'topic.wafer_pose' in failed, failed
    types = {k: v for k, v in GPR_TOPICS.items() if k != ROBOT_STATE_TOPIC}
    fewer = write_bag(tmp_path / 'fewer', [m for m in messages_of(robot_bag) if m[0] != ROBOT_STATE_TOPIC], types)
    result = verify_bag(fewer)
    check = next(c for c in result.checks if c.name == 'topic.wafer_pose_recomputed')
    assert result.passed and check.checked == result.counts[WAFER_POSE_TOPIC] and not check.skipped, [
        f.line() for f in result.failures]

    states = [store.deserialize_cdr(raw, GPR_TOPICS[topic]) for topic, _, raw in messages_of(fewer)
              if topic == '/gpr/platform_state']

    def moved(topic, msg):
        if topic == WAFER_POSE_TOPIC and _stamp(msg) == _stamp(states[30]):
            msg.pose.position.x += 1.0
        return msg

    failed = _failed(verify_bag(rewritten(fewer, tmp_path / 'moved', moved)))
    assert failed == {'topic.wafer_pose_recomputed': {states[30].sample}}, failed
    types.pop('/gpr/program')
    older = write_bag(tmp_path / 'older', [m for m in messages_of(fewer) if m[0] != '/gpr/program'], types)
    result = verify_bag(older)
    check = next(c for c in result.checks if c.name == 'topic.wafer_pose_recomputed')
    assert check.skipped == (f'{len(states)} wafer poses without their RobotState not checked: no record of the stream '
                             '(gpr/program) to recompute them from: a recording of an older node'), check.skipped
    # without a record nothing says the stream is a platform's: its wafer poses are not extra (it passes, unchecked)
    assert result.passed and not result.failures, [f.line() for f in result.failures]
    assert [c.name for c in result.checks if c.name.startswith('topic.wafer_pose')] == ['topic.wafer_pose_recomputed']
    assert next(c for c in result.checks if c.name == 'robot.wafer_position').skipped == 'no robot states in the bag'


def test_a_sweep_record_after_sample_0_is_another_run_spliced_on() -> None:
    """A node streams a sweep only as its start-up stream (a goal runs a program or stations), from sample 0, and
    it ends the node: a second sweep's record at sample 30 (another run spliced after the first, stamps and counters
    shifted) passed; so did a sweep spliced before or after a robot program."""
    from gpr_kinematics.bags.checks_program import loop_problems
    from gpr_kinematics.bags.program_record import parse_record, record_text
    from gpr_kinematics.inputs.resources import config_path
    from gpr_kinematics.robot.program import load_program

    spec = {'height': 0.25, 'max_tilt': 0.03, 'tilt_step': 0.01, 'azimuth_step': 1.0, 'passes': 1}
    records = [parse_record(record_text('sweep', first, 30, 100.0, False, 2.0, sweep=spec)) for first in (0, 30)]
    samples = np.arange(60)
    owner = np.searchsorted([0, 30], samples, side='right') - 1
    assert not loop_problems(records[:1], samples[:30], owner[:30])
    program = parse_record(record_text('robot_program', 30, 30, 100.0, False, 2.0,
                                       program=load_program(config_path('programs/example_robot_program.yaml'))))
    assert [p[3] for p in loop_problems([records[0], program], samples, owner)] == [
        'the recording has a stream from sample 30 after the sweep from sample 0; a sweep is the node\'s start-up '
        'stream, which ends the node after its last sample']
    program = dataclasses.replace(program, first_sample=0)
    assert [p[3] for p in loop_problems([program, records[1]], samples, owner)] == [
        'the sweep from sample 30 follows the robot_program from sample 0; a node streams a sweep only as its '
        'start-up stream, from sample 0 (a gpr/run_program goal runs a program or stations)']
    assert [p[3] for p in loop_problems(records[1:], samples[30:], owner[30:] - 1)] == [
        'the sweep from sample 30 starts there; a node streams a sweep only as its start-up stream, from sample 0 (a '
        'gpr/run_program goal runs a program or stations)']
    problems = loop_problems(records, samples, owner)
    assert [p[3] for p in problems] == [
        'the recording has a stream from sample 30 after the sweep from sample 0; a sweep is the node\'s start-up '
        'stream, which ends the node after its last sample',
        'the sweep from sample 30 follows the sweep from sample 0; a node streams a sweep only as its start-up stream, '
        'from sample 0 (a gpr/run_program goal runs a program or stations)']


def test_a_recorded_program_with_straight_entries_verifies(tmp_path: Path) -> None:
    """The example cell program (straight entries through two chamber slits) recorded as the node streams it: its
    record dropped the entries, and the honest recording failed topic.program (597 samples recomputed to 399) and
    stream.program from the first entry on."""
    from gpr_kinematics.bags.synthetic import robot_program_messages
    from gpr_kinematics.inputs.resources import config_path
    from gpr_kinematics.robot.program import load_program

    program = load_program(config_path('programs/example_cell_program.yaml'))
    bag = write_bag(tmp_path / 'cell', robot_program_messages(ROBOT, program, 10.0), dict(GPR_TOPICS))
    result = verify_bag(bag)
    assert result.passed and result.counts['/gpr/platform_state'] == 597, [f.line() for f in result.failures]


def _reframed(o, frame):
    """``o`` (a message) with every ``frame_id`` through ``frame``."""
    if dataclasses.is_dataclass(o):
        return dataclasses.replace(o, **{f.name: (frame(v) if f.name == 'frame_id' else _reframed(v, frame))
                                         for f in dataclasses.fields(o) for v in [getattr(o, f.name)]
                                         if f.name == 'frame_id' or dataclasses.is_dataclass(v) or isinstance(v, list)})
    return [_reframed(x, frame) for x in o] if isinstance(o, list) else o


def _in_r1(robot_bag: Path, robot_frame=lambda f: 'r1/' + f if f else f,
           prefix_line: str = 'frame_prefix: r1/\n') -> list[tuple[str, int, bytes]]:
    """The robot bag as a node in /r1 with frame_prefix r1/ records it (the robot topics' frames by ``robot_frame``;
    its records' prefix line ``prefix_line``: '' for an older node's records, without one)."""
    from bag_support import messages_of
    from gpr_kinematics.bags.typestore import typestore

    ts, out = typestore(), []
    for topic, t, raw in messages_of(robot_bag):
        robot = topic in (ROBOT_STATE_TOPIC, WAFER_POSE_TOPIC)
        msg = _reframed(ts.deserialize_cdr(raw, GPR_TOPICS[topic]),
                        robot_frame if robot else (lambda f: 'r1/' + f if f else f))
        if topic == '/gpr/program':   # the node records its prefix
            msg.data = msg.data.replace("frame_prefix: ''\n", prefix_line)
        out.append(('/r1' + topic, t, bytes(ts.serialize_cdr(msg, GPR_TOPICS[topic]))))
    return out


def test_a_namespaced_suite_is_read_in_its_namespace_and_its_world_carries_its_prefix(robot_bag: Path,
                                                                                         tmp_path: Path) -> None:
    """In /r1, a root /joint_states (a copy of the honest one beside a tampered /r1/joint_states, or another node's)
    was read as the suite's: the forgery passed, an honest recording beside a conveyor's joint states failed. And
    RobotStates in `world` beside PlatformStates in `r1/gpr_base` passed (the prefix is every part before the base
    frame's name)."""
    from gpr_kinematics.bags.typestore import JOINT_STATES_TOPIC, typestore

    types = {'/r1' + k: v for k, v in GPR_TOPICS.items()}
    honest = _in_r1(robot_bag)
    assert verify_bag(write_bag(tmp_path / 'honest', honest, types)).passed
    ts, js = typestore(), GPR_TOPICS[JOINT_STATES_TOPIC]
    moved = [(t, s, bytes(ts.serialize_cdr(dataclasses.replace(m, position=m.position + np.r_[0, 0, 0, 0.5, np.zeros(
        len(m.position) - 4)]), js))) if t == '/r1' + JOINT_STATES_TOPIC else (t, s, raw)
             for t, s, raw in honest for m in [ts.deserialize_cdr(raw, js) if t.endswith('joint_states') else None]]
    decoy = [(JOINT_STATES_TOPIC, s, raw) for t, s, raw in honest if t == '/r1' + JOINT_STATES_TOPIC]
    forged = verify_bag(write_bag(tmp_path / 'forged', moved + decoy, {**types, JOINT_STATES_TOPIC: js}))
    assert not forged.passed and 'topic.joint_states' in _failed(forged)
    conveyor = [(JOINT_STATES_TOPIC, s, bytes(ts.serialize_cdr(dataclasses.replace(
        ts.deserialize_cdr(raw, js), name=['conveyor'], position=np.array([0.1]), velocity=np.array([0.2]),
        effort=np.zeros(0)), js))) for t, s, raw in honest if t == '/r1' + JOINT_STATES_TOPIC]
    beside = verify_bag(write_bag(tmp_path / 'beside', honest + conveyor, {**types, JOINT_STATES_TOPIC: js}))
    assert beside.passed, [f.line() for f in beside.failures]
    bare = verify_bag(write_bag(tmp_path / 'bare', _in_r1(robot_bag, lambda f: f), types))
    structure = next(c for c in bare.checks if c.name == 'robot.structure')
    assert not bare.passed and structure.failed == structure.checked > 0


def test_a_namespaced_suite_s_checks_name_its_topics_as_the_bag_has_them(robot_bag: Path, tmp_path: Path) -> None:
    """In /r1 the rows and --json of the companion topics' checks read /gpr/platform_pose, /joint_states,
    /gpr/wafer_pose, /gpr/robot_state, /gpr/geometry (the topics verified were /r1/...), and so did their failures,
    the notes of the recorded geometry and robot, the fields not checked, and a bag without its states."""
    from gpr_kinematics.bags.results import format_table
    from gpr_kinematics.bags.typestore import JOINT_STATES_TOPIC, PLATFORM_STATE_TOPIC, typestore

    types = {'/r1' + k: v for k, v in GPR_TOPICS.items()}
    honest = _in_r1(robot_bag)
    result = verify_bag(write_bag(tmp_path / 'honest', honest, types))
    assert result.passed
    topics = {c.name: c.topic for c in result.checks}
    assert {c.topic for c in result.checks} == {'bag', *types}
    assert [topics[k] for k in ('topic.platform_pose', 'topic.joint_states', 'topic.wafer_pose', 'robot.structure',
                                'topic.geometry', 'topic.robot', 'topic.program', 'topic.markers')] == [
        '/r1/gpr/platform_pose', '/r1/joint_states', '/r1/gpr/wafer_pose', '/r1/gpr/robot_state', '/r1/gpr/geometry',
        '/r1/gpr/robot', '/r1/gpr/program', '/r1/gpr/markers']
    assert 'verified against the geometry recorded on /r1/gpr/geometry' in result.notes
    assert any(n.startswith(f'verified the wafer poses against the robot {ROBOT.name} recorded on /r1/gpr/robot')
               for n in result.notes) and list(result.unchecked) == ['/r1/gpr/markers']
    table = format_table(result)
    assert 'topic.platform_pose          /r1/gpr/platform_pose ' in table and ' /gpr/' not in table.replace(
        '/r1/gpr/', '')
    # a failure names the topic as the bag has it too
    ts, js = typestore(), GPR_TOPICS[JOINT_STATES_TOPIC]
    moved = [(t, s, bytes(ts.serialize_cdr(dataclasses.replace(m, position=m.position + 0.5), js)))
             if t == '/r1' + JOINT_STATES_TOPIC else (t, s, raw)
             for t, s, raw in honest for m in [ts.deserialize_cdr(raw, js) if t.endswith('joint_states') else None]]
    forged = verify_bag(write_bag(tmp_path / 'forged', moved, types))
    assert {f.topic for f in forged.failures} == {'/r1/joint_states'}
    gone = verify_bag(write_bag(tmp_path / 'gone', [m for m in honest if m[0] != '/r1' + PLATFORM_STATE_TOPIC], types))
    (present,) = [c for c in gone.checks if c.name == 'state.present']
    assert present.topic == '/r1/gpr/platform_state' and present.failures[0].detail == (
        'no gpr_interfaces/msg/PlatformState messages on /r1/gpr/platform_state: nothing to verify')


def test_a_namespaced_suite_s_unusable_robot_and_geometry_and_its_robot_note_name_the_namespaced_topics(
        tmp_path: Path) -> None:
    """In /r1 the refusal of an unusable recorded robot or geometry and the note of a robot without states name
    /r1/gpr/robot and /r1/gpr/geometry, the topics read."""
    from gpr_kinematics.bags.typestore import GEOMETRY_TOPIC, typestore

    ts, kind = typestore(), 'std_msgs/msg/String'

    def text(data: str) -> bytes:
        return bytes(ts.serialize_cdr(ts.types[kind](data=data), kind))

    types = {'/r1' + k: v for k, v in GPR_TOPICS.items()}
    msgs = sweep_messages(tilt_step=math.radians(1.0), azimuth_step=math.radians(120.0))
    r1 = [('/r1' + t, s, raw) for t, s, raw in msgs]
    robot = ('/r1' + ROBOT_TOPIC, msgs[0][1], text(robot_text(ROBOT)))
    result = verify_bag(write_bag(tmp_path / 'sweep', [robot, *r1], types))
    assert result.passed and result.notes[1] == (
        f'robot {ROBOT.name} recorded on /r1/gpr/robot; no robot states (a platform stream, or a recording of fewer '
        'topics): no wafer pose verified')
    yaml_error = ("not valid YAML on line 2, column 1: did not find expected ',' or ']' (while parsing a flow "
                  'sequence)')
    for topic, check, what in ((ROBOT_TOPIC, 'topic.robot', 'robot description'),
                               (GEOMETRY_TOPIC, 'topic.geometry', 'geometry')):
        bad = [(t, s, text('name: [unclosed') if t == '/r1' + topic else raw) for t, s, raw in [robot, *r1]]
        result = verify_bag(write_bag(tmp_path / check, bad, types))
        (failure,) = next(c for c in result.checks if c.name == check).failures
        assert failure.detail == f'not a usable {what}: /r1{topic} (recorded {what}): {yaml_error}'


def _framed(robot_bag: Path, frame, prefix_line: str) -> list[tuple[str, int, bytes]]:
    """The robot bag with every frame through ``frame`` and its records' prefix line ``prefix_line``."""
    from bag_support import messages_of
    from gpr_kinematics.bags.typestore import typestore

    ts, out = typestore(), []
    for topic, t, raw in messages_of(robot_bag):
        msg = _reframed(ts.deserialize_cdr(raw, GPR_TOPICS[topic]), frame)
        if topic == '/gpr/program':
            msg.data = msg.data.replace("frame_prefix: ''\n", prefix_line)
        out.append((topic, t, bytes(ts.serialize_cdr(msg, GPR_TOPICS[topic]))))
    return out


@pytest.mark.parametrize('prefix, base', [('r1_', 'gpr_base'), ('', 'gpr/base'), ('r1/', 'tool/gpr_base')])
def test_a_prefix_without_a_slash_or_a_base_frame_with_one_verifies(robot_bag: Path, tmp_path: Path, prefix: str,
                                                                   base: str) -> None:
    """Honest recordings of `frame_prefix:=r1_` (`r1_world` beside `r1_gpr_base`) or `base_frame:=gpr/base` failed
    every robot check: the prefix was taken as every part of the base frame before its last `/`. The node records
    its prefix now; a robot frame is exactly that prefix and the world frame. An older node's records (no prefix)
    take any prefix the two frames share."""
    def frame(f: str) -> str:
        return prefix + (base if f == 'gpr_base' else f) if f else f

    for line, kind in ((f"frame_prefix: '{prefix}'\n" if prefix == '' else f'frame_prefix: {prefix}\n', 'recorded'),
                       ('', 'older')):
        result = verify_bag(write_bag(tmp_path / f'{kind}{len(prefix)}', _framed(robot_bag, frame, line),
                                      dict(GPR_TOPICS)))
        assert result.passed, (kind, [f.line() for f in result.failures])
    # the recorded prefix decides: the world frame without it, or with another, fails
    def bare(f: str) -> str:
        return f if f in ('world', '') else prefix + (base if f == 'gpr_base' else f)

    if prefix:
        result = verify_bag(write_bag(tmp_path / 'bare', _framed(robot_bag, bare, f'frame_prefix: {prefix}\n'),
                                      dict(GPR_TOPICS)))
        structure = next(c for c in result.checks if c.name == 'robot.structure')
        assert not result.passed and structure.failed == structure.checked > 0



def test_beyond_limits_is_infinite_for_a_joint_the_robot_does_not_have():
    """bags.checks_robot.beyond_limits with the example robot: 0 within the range, the excess beyond it (1e-12 rad of
    slack), inf for NaN and for a name that is not one of the robot's joints."""
    from gpr_kinematics.bags.checks_robot import beyond_limits
    from robot_support import ROBOT
    names = ('arm1_shoulder', 'arm1_elbow')
    rows = np.array([[0.0, 2.9], [0.0, 3.0], [math.nan, 0.0]])
    out = beyond_limits(rows, names, ROBOT)
    assert out[0] == 0.0 and out[1] == pytest.approx(0.1 - 1e-12, abs=1e-15) and out[2] == math.inf
    assert beyond_limits(rows, ('arm1_shoulder', 'arm9_elbow'), ROBOT).tolist() == [math.inf] * 3


def test_in_world_reads_the_prefix_as_its_docstring_says() -> None:
    """The frame rule, case by case: with the recorded prefix exactly ``prefix + world`` beside a PlatformState frame
    that is more than the prefix; without one (an older node's records) any prefix shared by both frames."""
    from gpr_kinematics.bags.checks_robot import in_world

    world = ROBOT.world_frame
    cases = [  # (frame, state frame, recorded prefix, verdict)
        (f'r1_{world}', 'r1_gpr_base', 'r1_', True), (world, 'r1/gpr_base', 'r1/', False),
        (f'r1/{world}', 'r1/gpr_base', 'r1/', True), (f'r1/{world}', 'r1/', 'r1/', False),
        (world, 'gpr_base', '', True), (f'evil/{world}', 'gpr_base', None, False),
        (world, 'gpr/base', None, True), (world, 'r1/gpr_base', None, True),
        (f'r1/{world}', 'r1/', None, False), (f'r1/{world}', 'r2/gpr_base', None, False),
        (f'{world}x', 'gpr_base', None, False)]
    for frame, base, prefix, verdict in cases:
        assert in_world([frame], [base], ROBOT, prefix).tolist() == [verdict], (frame, base, prefix)


def test_a_root_topic_beside_a_namespaced_suite_is_not_listed_as_unchecked(tmp_path: Path) -> None:
    """A suite in /r1 without markers beside another recording's /gpr/markers at the root listed 'not checked on
    /r1/gpr/markers', a topic the bag does not have (the root topic is named in a note as not verified)."""
    from gpr_kinematics.bags.typestore import MARKERS_TOPIC

    msgs = sweep_messages(tilt_step=math.radians(1.0), azimuth_step=math.radians(120.0))
    r1 = [('/r1' + t, s, raw) for t, s, raw in msgs if t != MARKERS_TOPIC]
    root = [(t, s, raw) for t, s, raw in msgs if t == MARKERS_TOPIC]
    types = {'/r1' + k: v for k, v in GPR_TOPICS.items() if k != MARKERS_TOPIC}
    types[MARKERS_TOPIC] = GPR_TOPICS[MARKERS_TOPIC]
    result = verify_bag(write_bag(tmp_path / 'b', r1 + root, types))
    assert result.passed and MARKERS_TOPIC in result.counts and '/r1' + MARKERS_TOPIC not in result.counts
    assert dict(result.unchecked) == {}
    assert any(MARKERS_TOPIC in n and 'not verified' in n for n in result.notes), result.notes
