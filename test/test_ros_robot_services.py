"""kinematics_node's whole-robot services over real DDS: gpr/robot_forward_kinematics and
gpr/station_inverse_kinematics answer the robot core's numbers (1e-12), round trip a station through both, refuse
bad requests with their message and keep serving; the robot_file and config_file parameters choose the robot and
its geometry."""
from __future__ import annotations

import math

import numpy as np
import pytest
import yaml
from gpr_kinematics.core.rotations import matrix_from_quaternion, rotation_z, tilt_rotation
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.robot import Stations, load_robot, robot_forward, solve_stations
from ros_support import client_session, imperfect_config_file, quat, running, start, vec

pytestmark = pytest.mark.ros

ROBOT = load_robot()
TIGHT = dict(rtol=0.0, atol=1e-12)
NS = '/gpr_robot_srv'


@pytest.fixture(scope='module')
def node(ros_environment):
    yield from running(start('kinematics_node', namespace=NS))


@pytest.fixture(scope='module')
def client(node):
    yield from client_session('gpr_test_robot_services', NS)


def test_a_request_model_is_kept_per_robot_description():
    """The node's robot under a request's model is kept per description: it was kept per configuration (its ``id``),
    so a robot file changed at run time over the same configuration answered with the old arms (and, its configuration
    freed, a new one at the same address could have been taken for the old)."""
    import dataclasses

    from gpr_kinematics.nodes.robot_services import RobotModels

    models = RobotModels()
    polar = models.get(ROBOT, 'polar')
    assert polar.config.model == 'polar' and polar.arm_names == ('arm1', 'arm2') and models.get(ROBOT, 'polar') is polar
    one_arm = dataclasses.replace(ROBOT, arms=ROBOT.arms[:1])       # the same configuration object
    assert one_arm.config is ROBOT.config
    assert models.get(one_arm, 'polar').arm_names == ('arm1',)


def test_a_refused_joint_count_and_branch_say_what_is_allowed_as_the_cli_and_the_programs_do():
    """The joint count had no "allowed:" (the CLI's `allowed: one value per joint, shoulder first`), a branch said
    `allowed: left or right`, though empty (the arm's own) is allowed too. No node: the functions the node calls."""
    from types import SimpleNamespace

    from gpr_kinematics.errors import InputError
    from gpr_kinematics.nodes.robot_services import fill_robot_forward, fill_station_inverse

    fk = SimpleNamespace(arm='arm1', rods=[0.3, 0.3, 0.3], joints=[0.0, 1.0], model='')
    with pytest.raises(InputError) as info:
        fill_robot_forward(ROBOT, fk, SimpleNamespace())
    assert str(info.value) == ('joints: 2 values given; arm arm1 has 3 joints (arm1_shoulder, arm1_elbow, arm1_wrist) '
                               '[rad]; allowed: one value per joint, shoulder first')
    for arm, own in (('arm1', 'right'), ('arm2', ROBOT.arm('arm2').branch)):
        ik = SimpleNamespace(arm=arm, branch='middle', position=SimpleNamespace(x=1.25, y=0.5, z=0.35), tilt=0.0,
                             azimuth=0.0, heading=0.0, heading_free=False, use_redundancy_value=False,
                             redundancy_value=0.0, model='')
        with pytest.raises(InputError) as info:
            fill_station_inverse(ROBOT, ik, SimpleNamespace())
        assert str(info.value) == (f"branch = 'middle' is invalid; allowed: left, right or empty (the arm's own, {own} "
                                   f'for arm {arm})')


@pytest.mark.parametrize('arm,rods,joints', [
    ('arm1', (0.25, 0.251, 0.252), (0.0, 1.0, -0.5)),
    ('arm2', (0.30, 0.2985, 0.3012), (0.4, -1.1, 0.3, 0.9)),
    ('', (0.2, 0.2, 0.2), (-2.0, 2.2, 1.0)),          # the first arm, at the singular configuration q1 = q2 = q3
])
def test_robot_forward_equals_the_core(client, arm, rods, joints):
    res = client.robot_forward_kinematics(rods, joints, arm)
    assert res.success, res.message
    core = robot_forward(ROBOT, [rods], [joints], arm or None)
    assert res.arm == core.arm and res.world_frame == 'world'
    assert list(res.joint_names) == list(ROBOT.arm(core.arm).joint_names)
    for name in ('wafer', 'blade', 'platform', 'naive_wafer', 'naive_platform'):
        pose = getattr(core, name)
        np.testing.assert_allclose(vec(getattr(res, name).position), pose.position[0], **TIGHT)
        np.testing.assert_allclose(quat(getattr(res, name).orientation), pose.quaternion[0], **TIGHT)
    np.testing.assert_allclose(vec(res.naive_wafer_error), core.naive_wafer_error[0], **TIGHT)
    assert res.naive_wafer_error_norm == pytest.approx(np.linalg.norm(vec(res.naive_wafer_error)), rel=1e-12)
    assert res.naive_wafer_angle_error == pytest.approx(core.naive_wafer_angle_error[0], abs=1e-15)
    np.testing.assert_allclose([res.tilt, res.tilt_azimuth, res.twist],
                               [core.gpr.tilt[0], core.gpr.tilt_azimuth[0], core.gpr.twist[0]], **TIGHT)
    np.testing.assert_allclose(vec(res.centre_shift), core.gpr.centre_shift[0], **TIGHT)
    # Independent of the core's chain: the wafer sits at the arm's wafer height above the platform plane.
    platform_R = matrix_from_quaternion(quat(res.platform.orientation))
    height = platform_R[:, 2] @ (vec(res.wafer.position) - vec(res.platform.position))
    assert height == pytest.approx(ROBOT.arm(core.arm).wafer_height, abs=1e-12)


@pytest.mark.parametrize('arm,branch,position,tilt,azimuth,heading,value', [
    ('arm1', 'right', (1.3, 0.6, 0.45), math.radians(1.2), math.radians(30.0), math.radians(20.0), None),
    ('arm1', 'left', (1.1, 0.9, 0.40), math.radians(1.9), math.radians(-120.0), 0.85, None),
    ('arm2', 'left', (1.3, 0.6, 0.60), 0.0, 0.0, 0.3, 0.2),
    ('arm2', '', (0.3, 0.4, 0.55), math.radians(0.5), math.radians(200.0), 2.9, None),
])
def test_station_inverse_equals_the_core_and_reaches_the_station(client, arm, branch, position, tilt, azimuth,
                                                                    heading, value):
    res = client.station_inverse_kinematics(position, tilt, azimuth, heading, arm, branch, value)
    assert res.success, res.message
    core = solve_stations(ROBOT, Stations.of([position], tilt, azimuth, heading), arm, branch or None, value)
    assert res.branch == core.branch[0] == (branch or ROBOT.arm(arm).branch)
    np.testing.assert_allclose(res.rods, core.rods[0], **TIGHT)
    np.testing.assert_allclose(res.joints, core.joints[0], **TIGHT)
    np.testing.assert_allclose(res.naive_rods, core.naive_rods[0], **TIGHT)
    np.testing.assert_allclose(res.naive_joints, core.naive_joints[0], **TIGHT)
    np.testing.assert_allclose(vec(res.naive_wafer_error_vector), core.naive_wafer_error[0], **TIGHT)
    assert res.naive_wafer_error == pytest.approx(core.naive_wafer_error_norm[0], rel=1e-12)
    # The station is reached (wafer pose computed here from the station's definition, not by the core).
    R = tilt_rotation(tilt, azimuth) @ rotation_z(heading)
    np.testing.assert_allclose(vec(res.wafer.position), position, rtol=0, atol=1e-9)
    np.testing.assert_allclose(matrix_from_quaternion(quat(res.wafer.orientation)), R, rtol=0, atol=1e-9)
    assert res.position_error < 1e-12 and res.angle_error < 1e-12
    if value is not None:
        assert res.joints[2] == pytest.approx(value, abs=1e-12)      # arm2 holds its wrist at the value asked
    # The old tool's joints miss the station on the real machine (micrometres at these tilts, none untilted).
    assert (res.naive_wafer_error > 1e-7) == (tilt > 0.0)
    # Round trip through the forward service.
    fk = client.robot_forward_kinematics(res.rods, res.joints, res.arm)
    assert fk.success, fk.message
    np.testing.assert_allclose(vec(fk.wafer.position), position, rtol=0, atol=1e-9)


def test_model_of_a_request(client):
    position, tilt, azimuth, heading = (1.3, 0.6, 0.45), 0.03, 0.4, 0.2
    res = client.station_inverse_kinematics(position, tilt, azimuth, heading, model='compliant')
    assert res.success, res.message
    robot = load_robot(model='compliant')
    core = solve_stations(robot, Stations.of([position], tilt, azimuth, heading))
    np.testing.assert_allclose(res.rods, core.rods[0], **TIGHT)
    radial = client.station_inverse_kinematics(position, tilt, azimuth, heading)
    assert np.max(np.abs(np.subtract(res.joints, radial.joints))) > 1e-7     # another model, other joints


BAD = [
    ('fk', dict(rods=(0.3, 0.3, 0.3), joints=(0.0, 1.0)),
     ['joints: 2 values given; arm arm1 has 3 joints (arm1_shoulder, arm1_elbow, arm1_wrist) [rad]; allowed: one '
      'value per joint, shoulder first']),
    ('fk', dict(rods=(0.3, 0.3, 0.3), joints=(0.0, 1.0, 0.0), arm='arm9'), ["arm = 'arm9'", 'arm1, arm2']),
    ('fk', dict(rods=(0.3, 0.3, 0.3), joints=(0.0, math.nan, 0.0)), ['arm1_elbow', 'not a finite number']),
    ('fk', dict(rods=(0.3, 0.3, 0.3), joints=(0.0, 3.0, 0.0)), ['arm1_elbow', 'upper limit']),
    ('fk', dict(rods=(0.3, 0.3, 0.6), joints=(0.0, 1.0, 0.0)), ['stroke']),
    ('fk', dict(rods=(0.3, 0.3, 0.3), joints=(0.0, 1.0, 0.0), model='banana'), ["model = 'banana'", 'radial']),
    ('ik', dict(position=(3.0, 0.6, 0.45)), ['station request', 'out of reach of arm arm1', 'too far']),
    ('ik', dict(position=(1.3, 0.6, 0.45), tilt=math.radians(3.0)), ['station request', 'beyond the tilt limit']),
    ('ik', dict(position=(1.3, 0.6, 1.2)), ['station request', 'above the stroke', 'too high']),
    ('ik', dict(position=(1.3, 0.6, 0.45), heading=None), ['heading_free', '3 joints']),
    ('ik', dict(position=(1.3, 0.6, 0.45), branch='up'),
     ["branch = 'up' is invalid; allowed: left, right or empty (the arm's own, right for arm arm1)"]),
    ('ik', dict(position=(1.3, 0.6, 0.45), redundancy_value=0.1), ['redundancy value', 'arm arm1 has 3 joints']),
    ('ik', dict(position=(1.3, math.inf, 0.45)), ['position', 'finite']),
    # beyond the world's bound, as a station file and gpr robot ik refuse it (the service solved it: a robot based
    # 99.8 m out reaches a station 100.56 m out)
    ('ik', dict(position=(130.0, 60.0, 45.0)), ['position = (130, 60, 45) m; allowed: each coordinate within +-100 m '
                                                'of the world origin; as millimetres it would be 0.13 m: millimetres '
                                                'given as metres? (the service takes metres)']),
    ('ik', dict(position=(1.3, 0.6, 0.45), azimuth=math.nan), ['azimuth', 'finite']),
    # degrees sent as radians: taken modulo a turn as another station (azimuth 90 -> 2.035 rad), success: true
    ('ik', dict(position=(1.2, 1.0, 0.455), tilt=0.02, azimuth=90.0, heading=0.8),
     ['azimuth = 90 rad is beyond one turn; allowed: [-2pi, 2pi] rad', '90 deg is 1.57079633 rad']),
    ('ik', dict(position=(1.3, 0.6, 0.45), heading=45.0), ['heading = 45 rad is beyond one turn']),
    # a tilt of 1000 turns + 0.02 rad was solved as 0.02 rad, success: true
    ('ik', dict(position=(1.2, 1.0, 0.455), tilt=6283.205307179586, azimuth=0.5, heading=0.8),
     ['tilt = 6283.21 rad is beyond one turn; allowed: [-2pi, 2pi] rad']),
    ('ik', dict(position=(1.3, 0.6, 0.60), heading=0.3, arm='arm2', branch='left', redundancy_value=30.0),
     ['redundancy value = 30 rad', 'beyond one turn']),
    ('ik', dict(position=(1.3, 0.6, 0.45), heading=0.3, arm='arm2', redundancy_value=5.0),   # held at -1.28 rad
     ['redundancy value = 5 rad', 'outside the limits of arm2_wrist, [-2.5, 2.5] rad', '-1.28319 rad modulo a turn']),
]


@pytest.mark.parametrize('kind,fields,words', BAD, ids=[f'{b[0]}-{i}' for i, b in enumerate(BAD)])
def test_bad_requests_refused_with_their_message(client, node, kind, fields, words):
    call = client.robot_forward_kinematics if kind == 'fk' else client.station_inverse_kinematics
    res = call(**fields)
    assert res.success is False
    for w in words:
        assert w in res.message, res.message
    assert node.alive()
    ok = client.robot_forward_kinematics((0.3, 0.3, 0.3), (0.0, 1.0, 0.0))
    assert ok.success, ok.message


def test_robot_file_and_config_file_choose_the_robot_and_its_geometry(ros_environment, tmp_path):
    """Another robot (base elsewhere, arm1 longer), its geometry replaced by an imperfect machine's config_file: the
    services compute with that robot on that machine, and name its world frame with the node's frame_prefix (as the
    state publisher beside it names it on /tf)."""
    from gpr_kinematics.nodes.client import GprClient

    data = yaml.safe_load(config_path('robots/example_robot.yaml').read_text())
    data['name'] = 'shifted'
    data['base'] = {'frame': 'tool', 'position': [1.0, -0.5, 0.1], 'rpy': [0.0, 0.0, 0.5]}
    data['arms'][0]['joints'][0]['length'] = 0.35
    robot_file = tmp_path / 'shifted_robot.yaml'
    robot_file.write_text(yaml.safe_dump(data))
    config_file, cfg = imperfect_config_file(tmp_path)
    robot = load_robot(robot_file, geometry=cfg)
    proc = start('kinematics_node', namespace='/gpr_shifted', robot_file=str(robot_file), config_file=str(config_file),
                 frame_prefix='r7/')
    try:
        with GprClient('gpr_test_robot_file', namespace='/gpr_shifted') as c:
            position = (1.6, -0.2, 0.55)
            res = c.station_inverse_kinematics(position, 0.01, 1.0, 0.7)
            assert res.success, res.message
            assert res.world_frame == 'r7/tool'   # the robot's world frame, with the node's frame_prefix
            core = solve_stations(robot, Stations.of([position], 0.01, 1.0, 0.7))
            np.testing.assert_allclose(res.rods, core.rods[0], **TIGHT)
            np.testing.assert_allclose(res.joints, core.joints[0], **TIGHT)
            fk = c.robot_forward_kinematics(res.rods, res.joints)
            np.testing.assert_allclose(vec(fk.wafer.position), position, rtol=0, atol=1e-9)
            assert fk.world_frame == 'r7/tool'
            # The platform service of the same node is on the same machine (one geometry per node).
            gpr = c.forward_kinematics(res.rods)
            np.testing.assert_allclose(vec(gpr.pose.position), core.forward.gpr.position[0], **TIGHT)
    finally:
        proc.stop()


def test_unreadable_robot_file_cannot_start(ros_environment, tmp_path):
    from ros_support import assert_one_error_line

    bad = tmp_path / 'robot.yaml'
    bad.write_text('name: r\narms: []\n')
    proc = start('kinematics_node', robot_file=str(bad))
    status = proc.wait(timeout=30)
    assert_one_error_line(proc.output(), status, 2, 'cannot start: robot_file: ', 'rods: missing key velocity')
