"""``topic.joint_states_recomputed``: the arm joint values of the joint_states without their RobotState. Where no
RobotState was recorded (a recording of fewer topics, the ends of a late or cut one) only the rods and the arm joints'
names were checked: every arm joint at 1000 rad passed, ``topic.joint_states ok 0.000e+00``. With a record they are
checked against the recomputed stream; without one, against the robot's joint limits, the rest declared unchecked."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import yaml
from bag_support import REFERENCE, messages_of, rewritten, write_bag
from gpr_kinematics.bags.reader import read_bag
from gpr_kinematics.bags.synthetic import robot_program_messages
from gpr_kinematics.bags.typestore import GPR_TOPICS, JOINT_STATES_TOPIC, ROBOT_STATE_TOPIC, typestore
from gpr_kinematics.bags.verify import verify_bag
from gpr_kinematics.robot import load_robot
from gpr_kinematics.robot.program import parse_program
from robot_support import SHORT_PROGRAM

ROBOT = load_robot()
NAMES = [n for a in ROBOT.arms for n in a.joint_names]
CHECK = 'topic.joint_states_recomputed'


@pytest.fixture(scope='module')
def robot_messages() -> list[tuple[str, int, bytes]]:
    return list(robot_program_messages(ROBOT, parse_program(yaml.safe_load(SHORT_PROGRAM), 'test_program'), 10.0))


def _failed(result) -> dict[str, set[int | None]]:
    out: dict[str, set[int | None]] = {}
    for f in result.failures:
        out.setdefault(f.check, set()).add(f.sample)
    return out


def _check(result, name: str = CHECK):
    return [c for c in result.checks if c.name == name]


def _stamp(msg) -> int:
    return msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec


def _samples(bag: Path) -> dict[int, int]:
    """Stamp -> sample counter of every PlatformState."""
    store = typestore()
    states = [store.deserialize_cdr(raw, GPR_TOPICS[t]) for t, _, raw in messages_of(bag) if t == '/gpr/platform_state']
    return {_stamp(s): int(s.sample) for s in states}


def _arms(value, at: set[int] | None = None, joint: int | None = None, topics=(JOINT_STATES_TOPIC,)):
    """An edit setting the arm joints (those after the rods; one of them: ``joint``) of the joint_states at the
    stamps ``at`` (all: None) to ``value(old)``."""
    def edit(topic, msg):
        if topic in topics and len(msg.name) > 3 and (at is None or _stamp(msg) in at):
            p = np.array(msg.position, dtype=float)
            cols = slice(3, None) if joint is None else slice(3 + joint, 4 + joint)
            p[cols] = value(p[cols])
            return dataclasses.replace(msg, position=p)
        return msg
    return edit


def test_a_robot_program_recorded_without_robot_states_checks_its_arm_joints_against_the_record(
        robot_messages, tmp_path: Path) -> None:
    """gpr/robot_state not recorded, every arm joint of joint_states at 1000 rad: passed (topic.joint_states ok 0)."""
    types = {k: v for k, v in GPR_TOPICS.items() if k != ROBOT_STATE_TOPIC}
    fewer = write_bag(tmp_path / 'fewer', [m for m in robot_messages if m[0] != ROBOT_STATE_TOPIC], types)
    result = verify_bag(fewer)
    assert result.passed, [f.line() for f in result.failures]
    samples = _samples(fewer)
    far = verify_bag(rewritten(fewer, tmp_path / 'far', _arms(lambda v: np.full_like(v, 1e3))))
    assert set(_failed(far)) == {CHECK} and _check(far)[0].failed == len(samples), _failed(far)
    [check] = _check(result)
    assert not check.skipped and check.checked == len(samples) and check.limit == 1e-9
    stamp = sorted(samples)[30]
    failed = _failed(verify_bag(rewritten(fewer, tmp_path / 'one', _arms(lambda v: v + 1e-6, {stamp}, joint=2))))
    assert failed == {CHECK: {samples[stamp]}}, failed


def test_the_arm_joints_of_a_late_and_a_cut_recording_are_recomputed(robot_messages, tmp_path: Path) -> None:
    """The first 3 RobotStates (a late recorder) and the last (a cut) not in the bag: their joint_states' arm joints
    were unchecked (only the rods and the names); they are the recomputed stream's."""
    store = typestore()
    states = [k for k, m in enumerate(robot_messages) if m[0] == ROBOT_STATE_TOPIC]
    drop = {*states[:3], states[-1]}
    bag = write_bag(tmp_path / 'ends', [m for k, m in enumerate(robot_messages) if k not in drop], dict(GPR_TOPICS))
    result = verify_bag(bag)
    assert result.passed, [f.line() for f in result.failures]
    stamps = {_stamp(store.deserialize_cdr(robot_messages[k][2], GPR_TOPICS[ROBOT_STATE_TOPIC])) for k in drop}
    samples = _samples(bag)
    failed = _failed(verify_bag(rewritten(bag, tmp_path / 'moved', _arms(lambda v: v + 1e-6, stamps, joint=0))))
    assert failed == {CHECK: {samples[s] for s in stamps}}, failed
    [check] = _check(result)
    assert check.checked == 4 and not check.skipped


def _reference_with_arms(dst: Path, value: float | None, beyond: int | None = None) -> Path:
    """The reference sweep (no record) without its listed gpr/robot_state, the example robot's arm joints appended
    to every joint_states at ``value`` (None: mid-range), the last one at state ``beyond`` 1e-9 rad past its upper
    limit."""
    store = typestore()
    bag = read_bag(REFERENCE)
    types = {n: t.msgtype for n, t in bag.topics.items() if n != ROBOT_STATE_TOPIC}
    lower = np.concatenate([a.lower for a in ROBOT.arms])
    upper = np.concatenate([a.upper for a in ROBOT.arms])
    arms = (lower + upper) / 2 if value is None else np.full(len(NAMES), value)
    out, n = [], 0
    for topic, t, raw in messages_of(REFERENCE):
        if topic == ROBOT_STATE_TOPIC:
            continue
        if topic in ('/joint_states', '/gpr/joint_states'):
            msg = store.deserialize_cdr(raw, types[topic])
            values = arms.copy()
            if n == beyond:
                values[-1] = upper[-1] + 1e-9
            n += 1
            msg = dataclasses.replace(msg, name=[*msg.name, *NAMES], position=np.concatenate([msg.position, values]))
            raw = bytes(store.serialize_cdr(msg, types[topic]))
        out.append((topic, t, raw))
    return write_bag(dst, out, types)


def test_an_older_recording_without_robot_states_holds_its_arm_joints_to_the_joint_limits(tmp_path: Path) -> None:
    """No record, no robot states, the robot recorded: arm joints at 1000 rad passed as ok 0. Beyond the limits they
    fail (1e-9 rad past one at one sample, too); within them they are declared not checked, with why."""
    far = verify_bag(_reference_with_arms(tmp_path / 'far', 1e3))
    assert set(_failed(far)) == {CHECK} and _check(far)[0].failed == far.counts['/gpr/platform_state'], _failed(far)
    within = verify_bag(_reference_with_arms(tmp_path / 'within', None))
    assert within.passed, [f.line() for f in within.failures]
    [check] = _check(within)
    n = within.counts['/gpr/platform_state']
    assert check.skipped == (f'{n} joint_states messages without their RobotState carry the arm joints; {n} within '
                             'the joint limits of robot example_dual_arm, their values not checked: no record of the '
                             'stream (gpr/program) to recompute them from: a recording of an older node'), check.skipped
    one = verify_bag(_reference_with_arms(tmp_path / 'one', None, beyond=100))
    assert set(_failed(one)) == {CHECK} and [c.failed for c in _check(one)] == [1, 0], _failed(one)
    assert [c.skipped.split(';')[1].split(':')[0] for c in _check(one) if c.skipped] == [
        f' {n - 1} within the joint limits of robot example_dual_arm, their values not checked']


def test_an_older_recording_holds_its_arm_joints_to_the_lower_limits_too(tmp_path: Path) -> None:
    """No record, no robot states, the robot recorded: one arm joint (arm1's first) at -1000 rad at every state
    fails by how far it is below its lower limit, as +1000 rad fails above the upper one."""
    within = _reference_with_arms(tmp_path / 'within', None)
    assert verify_bag(within).passed
    low = verify_bag(rewritten(within, tmp_path / 'low', _arms(lambda v: np.full_like(v, -1e3), joint=0,
                                                               topics=('/joint_states', '/gpr/joint_states'))))
    n = low.counts['/gpr/platform_state']
    assert set(_failed(low)) == {CHECK} and [c.failed for c in _check(low) if not c.skipped] == [n], _failed(low)
    [check] = [c for c in _check(low) if not c.skipped]
    assert check.worst == pytest.approx(1e3 + ROBOT.arms[0].lower[0], abs=1e-9)
    assert check.failures[0].detail.startswith('an arm joint beyond its range by this much (robot example_dual_arm')


@pytest.mark.parametrize('record', [True, False], ids=['recorded', 'no record'])
def test_joint_states_naming_the_arm_joints_with_the_rods_positions_only_fail(robot_messages, tmp_path: Path,
                                                                              record: bool) -> None:
    """gpr/robot_state not recorded: a joint_states message naming the rods and the arm joints but carrying only the
    3 rod positions fails at its sample (no value for the arm joints: inf), it does not stop verify."""
    types = {k: v for k, v in GPR_TOPICS.items() if k != ROBOT_STATE_TOPIC and (record or k != '/gpr/program')}
    fewer = write_bag(tmp_path / 'fewer', [m for m in robot_messages if m[0] in types], types)
    assert verify_bag(fewer).passed
    samples = _samples(fewer)
    stamp = sorted(samples)[12]

    def short(topic, msg):
        if topic == JOINT_STATES_TOPIC and _stamp(msg) == stamp:
            assert list(msg.name[3:]) == NAMES
            return dataclasses.replace(msg, position=np.array(msg.position[:3]))
        return msg

    result = verify_bag(rewritten(fewer, tmp_path / 'short', short))
    assert _failed(result) == {CHECK: {samples[stamp]}}, _failed(result)
    [fail] = result.failures
    assert fail.value == np.inf and fail.topic == JOINT_STATES_TOPIC
