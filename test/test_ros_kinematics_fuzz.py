"""Hostile numbers to every service of kinematics_node (issue 10): a seeded, bounded hypothesis run sends NaN,
infinities, 1e308, the smallest subnormal, zeros, negative and huge values and odd model names (and to the robot
services odd arm names, branches, numbers of joints and redundancy values). Every answer is
either ``success: false`` with a message that names the problem (a refusal of the package, not an internal
error), or ``success: true`` with finite numbers equal to the core's; the node keeps serving. Fixed-size arrays
of the wrong length never leave the client with ``ROS_PYTHON_CHECK_FIELDS=1`` (set by conftest.py).

Hostile goals to trajectory_node's ``gpr/run_program`` (issue 18): paths outside the allowed folders (absolute,
``..``, links, devices, /proc), names long and odd, stations with hostile numbers and in hostile numbers, both or
neither of file and stations, cancels at once and second goals while one is planned or runs. Every goal is answered:
accepted or rejected within seconds, a refusal within 2 s of its acceptance with a message of the package (never
"internal error") that never quotes a file, a run to its end or to its cancel; the node keeps serving.

``make test`` runs fixed seeds with :data:`EXAMPLES` examples per test; a deeper run draws more, or others:
``GPR_FUZZ_EXAMPLES=500 GPR_FUZZ_SEED=7 pytest -m ros test/test_ros_kinematics_fuzz.py``."""
from __future__ import annotations

import math
import os
import time

import numpy as np
import pytest
from gpr_kinematics.core import forward
from gpr_kinematics.core.config import load_config
from gpr_kinematics.core.rotations import quaternion_from_matrix, tilt_rotation
from gpr_kinematics.errors import GprError
from gpr_kinematics.robot import Stations, load_robot, robot_forward, solve_stations
from hypothesis import HealthCheck, example, given, seed, settings
from hypothesis import strategies as st
from ros_support import SECRET, program_folder, quat, start, vec

pytestmark = pytest.mark.ros

CFG = load_config()
ROBOT = load_robot()       # the node's default robot description (robot_file empty: the shipped example)
NS = '/gpr_fuzz'
#: Examples per test, and the seed (none: hypothesis's derandomized examples); GPR_FUZZ_EXAMPLES and GPR_FUZZ_SEED
#: for a deeper run, as the CLI fuzz test.
EXAMPLES = int(os.environ.get('GPR_FUZZ_EXAMPLES', '60'))
SEED = os.environ.get('GPR_FUZZ_SEED')
SETTINGS = settings(max_examples=EXAMPLES, deadline=None, derandomize=SEED is None, database=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture])
SEEDED = seed(int(SEED or 0))
HOSTILE = st.one_of(
    st.sampled_from([math.nan, math.inf, -math.inf, 1e308, -1e308, 5e-324, -5e-324, 0.0, -0.0, 1e-300, 1e300]),
    st.floats(allow_nan=True, allow_infinity=True, width=64),
    st.floats(min_value=-1.0, max_value=1.0),            # around the machine's range, to hit valid requests too
)
MODELS = st.one_of(st.sampled_from(['', 'radial', 'polar', 'offset', 'Radial', 'banana', ' ', 'x' * 2000, 'radial\n',
                                    ' polar']),
                   st.text(max_size=40))
#: Near the machine's working range (0.4 m rods, tilts within the limit), so that valid requests are drawn too.
NEAR = st.floats(min_value=0.398, max_value=0.402)
VEC3 = st.one_of(st.lists(HOSTILE, min_size=3, max_size=3), st.lists(NEAR, min_size=3, max_size=3))
TILT = st.builds(lambda a, g: [float(v) for v in quaternion_from_matrix(tilt_rotation(a, g))],
                 st.floats(min_value=-0.03, max_value=0.03), st.floats(min_value=-4.0, max_value=4.0))
QUAT = st.one_of(st.lists(HOSTILE, min_size=4, max_size=4), TILT)
#: Answers per service: (successes, refusals); each must be non-zero at the end (the fuzzing reached both).
SEEN: dict[str, list[int]] = {}


@pytest.fixture(scope='module')
def client(ros_environment):
    from gpr_kinematics.nodes.client import GprClient

    node = start('kinematics_node', namespace=NS)
    with GprClient('gpr_test_fuzz', namespace=NS) as c:
        c.node_process = node
        yield c
    node.stop()


def _numbers(msg, prefix=''):
    """Every float of a message (nested messages and arrays included)."""
    out = []
    for name in msg.get_fields_and_field_types():
        value = getattr(msg, name)
        if hasattr(value, 'get_fields_and_field_types'):
            out += _numbers(value, f'{prefix}{name}.')
        elif isinstance(value, float):
            out.append(value)
        elif hasattr(value, '__len__') and len(value) and isinstance(value[0], (float, np.floating)):
            out += [float(v) for v in value]
    return out


def _check(client, res):
    SEEN.setdefault(type(res).__name__, [0, 0])[0 if res.success else 1] += 1
    if res.success:
        assert all(math.isfinite(v) for v in _numbers(res)), res
    else:
        assert res.message and not res.message.startswith('internal error'), res.message
        assert len(res.message) < 1000 and 'Traceback' not in res.message
    assert client.node_process.alive()
    return res


@SETTINGS
@SEEDED
@given(q=VEC3, model=MODELS)
@example(q=[0.4, 0.401, 0.399], model='')      # one valid request whatever hypothesis draws
def test_forward_kinematics(client, q, model):
    res = _check(client, client.forward_kinematics(q, model))
    if res.success:
        core = forward(q, CFG, model or None)
        np.testing.assert_allclose(vec(res.pose.position), core.position, rtol=0, atol=1e-12)
    else:
        with pytest.raises(GprError):       # the core refuses it too: the node did not invent a refusal
            forward(np.asarray(q), CFG, model or None)


@SETTINGS
@SEEDED
@given(position=VEC3, quaternion=QUAT, model=MODELS)
@example(position=[0.0, 0.0, 0.4], quaternion=[0.01, 0.0, 0.0, math.sqrt(1 - 1e-4)], model='polar')
def test_inverse_kinematics(client, position, quaternion, model):
    from gpr_kinematics.nodes.conversions import pose_msg

    from gpr_interfaces.srv import InverseKinematics

    req = InverseKinematics.Request(target=pose_msg(position, quaternion), model=model)
    res = _check(client, client.call(InverseKinematics, 'gpr/inverse_kinematics', req))
    if res.success:
        assert abs(res.achieved.position.z - position[2]) < 1e-9


@SETTINGS
@SEEDED
@given(position=VEC3, quaternion=QUAT, tool=VEC3, model=MODELS)
@example(position=[0.0, 0.0, 0.4], quaternion=[0.0, 0.01, 0.0, math.sqrt(1 - 1e-4)], tool=[0.05, 0.0, 0.1], model='')
def test_compensate(client, position, quaternion, tool, model):
    res = _check(client, client.compensate(position, quaternion, tool, model))
    if res.success:
        assert abs(np.linalg.norm(quat(res.achieved.orientation)) - 1.0) < 1e-12


@SETTINGS
@SEEDED
@given(q=VEC3, dq=VEC3, model=MODELS)
@example(q=[0.4, 0.4, 0.4], dq=[1e-4, 0.0, -1e-4], model='radial')
def test_analyze_mobility(client, q, dq, model):
    res = _check(client, client.analyze_mobility(q, dq, model))
    if res.success:
        assert res.rank_augmented == 12


ARMS = st.one_of(st.sampled_from(['', 'arm1', 'arm2', 'arm3', ' arm1', 'x' * 2000]), st.text(max_size=20))
#: Joint values: hostile, or within the example arms' limits; 0 to 6 of them (the arms have 3 and 4).
JOINTS = st.one_of(st.lists(HOSTILE, max_size=6), st.lists(st.floats(min_value=-2.4, max_value=2.4), min_size=3,
                                                             max_size=4))
#: Station positions in the world: hostile, or near a reachable station of the example robot.
STATION = st.one_of(st.lists(HOSTILE, min_size=3, max_size=3),
                    st.tuples(st.floats(1.2, 1.4), st.floats(0.5, 0.7), st.floats(0.40, 0.50)).map(list))
ANGLE = st.one_of(HOSTILE, st.floats(min_value=-0.03, max_value=0.03))
BRANCHES = st.one_of(st.sampled_from(['', 'left', 'right', 'Left', 'up']), st.text(max_size=10))


@SETTINGS
@SEEDED
@given(rods=VEC3, joints=JOINTS, arm=ARMS, model=MODELS)
@example(rods=[0.3, 0.301, 0.299], joints=[0.1, 1.2, -0.4], arm='', model='')
@example(rods=[0.3, 0.301, 0.299], joints=[0.1, -1.2, 0.3, 0.2], arm='arm2', model='compliant')
def test_robot_forward_kinematics(client, rods, joints, arm, model):
    res = _check(client, client.robot_forward_kinematics(rods, joints, arm, model))
    robot = ROBOT if not model or model == CFG.model else None
    if res.success:
        assert res.arm == (arm or 'arm1') and len(res.joint_names) == len(joints)
        if robot is not None:
            core = robot_forward(robot, [rods], [joints], res.arm)
            np.testing.assert_allclose(vec(res.wafer.position), core.wafer.position[0], rtol=0, atol=1e-12)
            np.testing.assert_allclose(quat(res.wafer.orientation), core.wafer.quaternion[0], rtol=0, atol=1e-12)
    elif robot is not None and arm in ROBOT.arm_names and len(joints) == len(ROBOT.arm(arm).joints):
        with pytest.raises(GprError):       # the core refuses it too
            robot_forward(robot, [rods], [joints], arm)


@SETTINGS
@SEEDED
@given(position=STATION, tilt=ANGLE, azimuth=ANGLE, heading=ANGLE, free=st.booleans(), arm=ARMS, branch=BRANCHES,
       redundancy=st.one_of(st.none(), HOSTILE), model=MODELS)
@example(position=[1.3, 0.6, 0.45], tilt=0.02, azimuth=0.5, heading=0.35, free=False, arm='', branch='',
         redundancy=None, model='')
@example(position=[1.3, 0.6, 0.6], tilt=0.0, azimuth=0.0, heading=0.3, free=False, arm='arm2', branch='left',
         redundancy=0.2, model='')
def test_station_inverse_kinematics(client, position, tilt, azimuth, heading, free, arm, branch, redundancy, model):
    res = _check(client, client.station_inverse_kinematics(position, tilt, azimuth, None if free else heading, arm,
                                                           branch, redundancy, model))
    if not res.success:
        return
    assert res.position_error < 1e-9 and res.angle_error < 1e-9
    assert res.naive_wafer_error >= 0.0 and len(res.joints) == len(res.joint_names) == len(res.naive_joints)
    if not model or model == CFG.model:
        core = solve_stations(ROBOT, Stations.of([position], tilt, azimuth, None if free else heading), res.arm,
                              branch or None, redundancy)
        np.testing.assert_allclose(res.rods, core.rods[0], rtol=0, atol=1e-12)
        np.testing.assert_allclose(res.joints, core.joints[0], rtol=0, atol=1e-12)
        assert res.naive_wafer_error == pytest.approx(core.naive_wafer_error_norm[0], rel=1e-9, abs=1e-15)


def test_fuzzing_reached_valid_and_refused_requests():
    names = {'ForwardKinematics_Response', 'InverseKinematics_Response', 'Compensate_Response',
             'AnalyzeMobility_Response', 'RobotForwardKinematics_Response', 'StationInverseKinematics_Response'}
    assert set(SEEN) == names, SEEN
    assert all(ok > 0 and refused > 0 for ok, refused in SEEN.values()), SEEN


def test_wrong_array_lengths_never_leave_the_client(client):
    from gpr_interfaces.srv import AnalyzeMobility, ForwardKinematics, RobotForwardKinematics, StationInverseKinematics

    for req, field in ((ForwardKinematics.Request(), 'q'), (AnalyzeMobility.Request(), 'dq'),
                       (RobotForwardKinematics.Request(), 'rods')):
        for bad in ([0.5, 0.5], [0.5] * 4, []):
            with pytest.raises(AssertionError):
                setattr(req, field, bad)
    with pytest.raises(AssertionError):            # a string where a number goes
        StationInverseKinematics.Request(tilt='0.1')
    res = client.forward_kinematics([0.5, 0.5, 0.5])
    assert res.success, res.message


# -- hostile goals to gpr/run_program (issue 18) ----------------------------------------------------------------------

ACTION_NS = '/gpr_fuzz_action'
#: Program files a goal may name: out of the allowed folders (absolute, by .., by a link), devices, odd names, and
#: the valid ones (the package's, relative; the allowed folder's own).
PATHS = st.one_of(st.sampled_from([
    '/etc/shadow', '/etc/passwd', '/proc/self/environ', '/proc/self/cmdline', '/dev/zero', '/dev/urandom', '/',
    '.', '..', '../../../../etc/passwd', '../gpr.yaml', '../robots/example_robot.yaml', 'x' * 5000,
    'example_stations.yaml', 'example_robot_program.yaml', '{allowed}/short.yaml', '{allowed}/link_out.yaml',
    '{allowed}/../secret.yaml', '{allowed}/names_outside.yaml', '{allowed}', '{allowed}/missing.yaml',
    'ünïcödé.yaml', ' example_stations.yaml']), st.text(max_size=30))
#: Hostile numbers, or short valid ones (so that goals also run).
GOAL_NUMBER = st.one_of(HOSTILE, st.floats(min_value=0.0, max_value=0.02))
GOAL_STATION = st.fixed_dictionaries({'height': st.one_of(HOSTILE, st.floats(0.3, 0.45)), 'tilt': GOAL_NUMBER,
                                      'azimuth': GOAL_NUMBER, 'dwell': GOAL_NUMBER, 'move_time': GOAL_NUMBER,
                                      'name': st.text(max_size=20)})
STATION_LISTS = st.one_of(st.lists(GOAL_STATION, max_size=3), st.sampled_from([0, 1, 10_001]).map(
    lambda n: [{'height': 0.3, 'tilt': 0.0, 'azimuth': 0.0, 'dwell': 0.001}] * n))
#: Contents no answer may quote (the files outside the allowed folder, /etc/shadow, /proc/self/environ).
LEAKS = (SECRET, 'root:', 'PATH=', 'HOME=')
ACTION_ANSWERS: dict[str, int] = {}


@pytest.fixture(scope='module')
def allowed(tmp_path_factory):
    return program_folder(tmp_path_factory.mktemp('fuzz_programs'), 0.01)


@pytest.fixture(scope='module')
def action(ros_environment, allowed):
    from gpr_kinematics.nodes.client import GprClient
    from ros_support import wait_for_log

    node = start('trajectory_node', namespace=ACTION_NS, mode='idle', rate=500.0, move_time=0.01,
                 program_folders=f"['{allowed}']")
    try:
        wait_for_log(node, 'idle: serving')
        with GprClient('gpr_test_fuzz_action', namespace=ACTION_NS) as c:
            c.node_process = node
            yield c
    finally:
        node.stop()


def _answered(client, handle, what):
    """The result of an accepted goal (it must come within 60 s) and the seconds from acceptance."""
    t0 = time.monotonic()
    response = client.wait(handle.get_result_async(), 60, what)
    return response, time.monotonic() - t0


@pytest.mark.slow
@SETTINGS
@SEEDED
@given(path=PATHS, stations=STATION_LISTS, use=st.sampled_from(['file', 'stations', 'both', 'neither']),
       move_time=st.one_of(st.just(0.0), HOSTILE), cancel=st.booleans(), second=st.booleans())
@example(path='/etc/shadow', stations=[], use='file', move_time=0.0, cancel=False, second=False)
@example(path='{allowed}/short.yaml', stations=[], use='file', move_time=0.0, cancel=False, second=True)
@example(path='example_robot_program.yaml', stations=[], use='file', move_time=0.0, cancel=True, second=True)
@example(path='', stations=[{'height': 0.3, 'tilt': 0.0, 'azimuth': 0.0, 'dwell': 30.0, 'move_time': 0.0, 'name': 'h'}],
         use='stations', move_time=0.0, cancel=True, second=True)
def test_hostile_goals(action, allowed, path, stations, use, move_time, cancel, second):
    from action_msgs.msg import GoalStatus

    goal = {'program_file': path.format(allowed=allowed) if use in ('file', 'both') else '',
            'stations': stations if use in ('stations', 'both') else [], 'move_time': move_time}
    try:
        handle = action.send_program(**goal)
    except (AssertionError, TypeError, ValueError):   # ROS_PYTHON_CHECK_FIELDS: the client refuses it first
        return
    assert handle.accepted, 'no goal runs: the node must accept'
    if second:
        t0 = time.monotonic()
        other = action.send_program(stations=[{'height': 0.3, 'tilt': 0.0, 'azimuth': 0.0, 'dwell': 0.01}])
        assert time.monotonic() - t0 < 5.0
        if other.accepted:    # the first goal ended already
            action.wait(other.get_result_async(), 60, 'second result')
    if cancel:
        action.wait(handle.cancel_goal_async(), 10, 'cancel')
    response, elapsed = _answered(action, handle, 'result')
    result, status = response.result, response.status
    ACTION_ANSWERS[str(status)] = ACTION_ANSWERS.get(str(status), 0) + 1
    for leak in LEAKS:
        assert leak not in result.message, result.message
    if status == GoalStatus.STATUS_ABORTED:
        assert result.message.startswith('cannot run the program: ') and 'internal error' not in result.message, \
            result.message
        assert result.samples_published == 0 and elapsed < 2.0, (elapsed, result.message)
    elif status == GoalStatus.STATUS_SUCCEEDED:
        assert result.success and result.samples_published == result.samples_total > 0
    else:
        assert status == GoalStatus.STATUS_CANCELED and cancel, (status, result.message)
    assert action.node_process.alive()


@pytest.mark.slow  # reads what test_hostile_goals reached
def test_goal_fuzzing_reached_refusals_runs_and_cancels(action):
    assert {'4', '5', '6'} <= set(ACTION_ANSWERS), ACTION_ANSWERS   # succeeded, canceled, aborted
    out = action.node_process.output()
    assert SECRET not in out and 'root:x' not in out and 'Traceback' not in out
