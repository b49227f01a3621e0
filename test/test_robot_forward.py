"""Whole-robot forward kinematics against an independent chain of homogeneous transforms, the naive model's wafer
error, the frame chain, and the refusals."""
import math

import numpy as np
import pytest
from gpr_kinematics.core import forward, naive_forward
from gpr_kinematics.errors import InputError, LimitError
from gpr_kinematics.robot.forward import arm_transforms, robot_forward
from robot_support import ROBOT, make_robot, random_postures, robot_data
from scipy.spatial.transform import Rotation


def _T(p, R=None):
    T = np.eye(4)
    T[:3, :3] = np.eye(3) if R is None else R
    T[:3, 3] = p
    return T


def _Rz(a):
    return Rotation.from_euler('z', a).as_matrix()


def _independent_wafer(robot, arm_name, q, theta, naive=False):
    """The chain written out with 4x4 matrices: world <- gpr_base <- gpr_platform <- mount, joints, blade, wafer."""
    arm = robot.arm(arm_name)
    roll, pitch, yaw = robot.base_rpy
    T = _T(robot.base_position, Rotation.from_euler('xyz', [roll, pitch, yaw]).as_matrix())  # URDF rpy
    if naive:
        pos, rot = naive_forward(q)
        T = T @ _T(pos[0], rot[0])
    else:
        fk = forward(q)
        T = T @ _T(fk.position, fk.rotation)
    T = T @ _T(arm.mount_position, _Rz(arm.mount_yaw))
    for k, joint in enumerate(arm.joints):
        T = T @ _T([0, 0, 0], _Rz(theta[k])) @ _T([joint.length, 0.0, joint.height])
    T = T @ _T(arm.blade.position, _Rz(arm.blade.yaw)) @ _T(arm.blade.wafer_centre)
    return T


@pytest.mark.parametrize('arm', ['arm1', 'arm2'])
def test_forward_matches_an_independent_chain(arm):
    data = robot_data()
    data['base'] = {'position': [0.3, -0.1, 0.2], 'rpy': [0.01, -0.02, 0.7]}
    data['arms'][0]['mount'] = {'position': [0.02, -0.01, 0.08], 'yaw': 0.3}
    data['arms'][0]['blade'] = {'position': [0.01, 0.005, 0.01], 'yaw': -0.2, 'wafer_centre': [0.2, 0.01, 0.004]}
    data['arms'][1]['mount'] = {'position': [-0.03, 0.02, 0.21], 'yaw': -2.4}
    data['arms'][1]['blade'] = {'position': [0.015, -0.01, 0.01], 'yaw': 0.3, 'wafer_centre': [0.19, -0.02, 0.005]}
    robot = make_robot(data)
    Q, J = random_postures(robot, arm, 200, seed=11)
    fk = robot_forward(robot, Q, J, arm)
    for i in range(0, 200, 7):
        T = _independent_wafer(robot, arm, Q[i], J[i])
        np.testing.assert_allclose(fk.wafer.position[i], T[:3, 3], atol=1e-14)
        np.testing.assert_allclose(fk.wafer.rotation[i], T[:3, :3], atol=1e-14)
        Tn = _independent_wafer(robot, arm, Q[i], J[i], naive=True)
        np.testing.assert_allclose(fk.naive_wafer.position[i], Tn[:3, 3], atol=1e-14)
        np.testing.assert_allclose(fk.naive_wafer_error[i], T[:3, 3] - Tn[:3, 3], atol=1e-14)
        angle = Rotation.from_matrix(Tn[:3, :3].T @ T[:3, :3]).magnitude()
        assert fk.naive_wafer_angle_error[i] == pytest.approx(angle, abs=1e-12)
        # one configuration takes the float path (forward_floats): the same chain
        one = robot_forward(robot, Q[i:i + 1], J[i:i + 1], arm)
        np.testing.assert_allclose(one.wafer.position[0], T[:3, 3], atol=1e-14)
        np.testing.assert_allclose(one.wafer.rotation[0], T[:3, :3], atol=1e-14)
        np.testing.assert_allclose(one.naive_wafer.position[0], Tn[:3, 3], atol=1e-14)
        # ... and its naive side in floats (what the robot service answers), the batch's numbers
        from gpr_kinematics.robot.forward import forward_floats, naive_floats
        naive = naive_floats(robot, Q[i].tolist(), forward_floats(robot, robot.arm(arm), Q[i].tolist(), J[i].tolist()))
        assert naive is not None
        np.testing.assert_allclose(naive.naive_wafer[0], Tn[:3, 3], atol=1e-14)
        np.testing.assert_allclose(naive.naive_wafer_error, fk.naive_wafer_error[i], atol=1e-14)
        assert naive.norm == pytest.approx(float(np.linalg.norm(fk.naive_wafer_error[i])), abs=1e-14)
        assert naive.naive_wafer_angle_error == pytest.approx(angle, abs=1e-12)
    # the wafer frame is the blade frame moved to the wafer centre
    np.testing.assert_allclose(fk.blade.rotation, fk.wafer.rotation, atol=0)
    np.testing.assert_allclose(fk.wafer.quaternion, Rotation.from_matrix(fk.wafer.rotation).as_quat()
                               * np.sign(Rotation.from_matrix(fk.wafer.rotation).as_quat()[:, 3:]), atol=1e-14)


def test_frame_chain_names_and_composition():
    """The tf chain composed from the platform is the wafer of the forward kinematics, also with the mount turned
    and every joint's zero_offset calibrated (position and orientation)."""
    Q, J = random_postures(ROBOT, 'arm1', 5, seed=12)
    chain = arm_transforms(ROBOT.arm('arm1'), J)
    assert [(f, p) for f, p, _ in chain] == [('arm1_link1', 'gpr_platform'), ('arm1_link2', 'arm1_link1'),
                                             ('arm1_link3', 'arm1_link2'), ('arm1_blade', 'arm1_link3'),
                                             ('arm1_wafer', 'arm1_blade')]
    data = robot_data()
    data['arms'][0]['mount'] = {'position': [0.02, -0.01, 0.08], 'yaw': 0.3}
    for k, joint in enumerate(data['arms'][0]['joints']):
        joint['zero_offset'] = 0.02 * (k + 1) * (-1) ** k
    for robot in (ROBOT, make_robot(data)):
        fk = robot_forward(robot, Q, J, 'arm1')
        pose = fk.platform
        for _, _, step in arm_transforms(robot.arm('arm1'), J):
            pose = pose.compose(step)
        np.testing.assert_allclose(pose.position, fk.wafer.position, atol=1e-15)
        np.testing.assert_allclose(pose.rotation, fk.wafer.rotation, atol=1e-15)


def test_untilted_platform_has_no_naive_error():
    q = np.full((1, 3), 0.3)
    fk = robot_forward(ROBOT, q, [[0.3, -0.5, 0.2]], 'arm1')
    assert fk.naive_wafer_error_norm[0] < 1e-15 and fk.naive_wafer_angle_error[0] < 1e-15
    # at zero tilt the wafer height is rods + the arm's height, in the world frame of the base at z = 0
    assert fk.wafer.position[0, 2] == pytest.approx(0.3 + ROBOT.arm('arm1').wafer_height, abs=1e-15)


def test_naive_error_at_a_tilt_is_micrometres():
    from gpr_kinematics.core import inverse
    q = inverse(0.3, math.radians(2.0), 0.0).q
    fk = robot_forward(ROBOT, q, [[0.0, 0.5, -0.5]], 'arm1')
    assert 5e-6 < fk.naive_wafer_error_norm[0] < 100e-6


@pytest.mark.parametrize('rods, joints, error, pattern', [
    ([[0.3, 0.3, 0.3]], [[0.0, 3.0, 0.0]], LimitError,
     r'^arm1_elbow = 3 rad is beyond its upper limit 2.9 rad by 0.1 rad; allowed: \[-2.9, 2.9\] rad$'),
    ([[0.3, 0.3, 0.3]], [[0.0, 57.2957795, 0.0]], LimitError,   # degrees typed: the hint a joint table's row gets
     r'rad; allowed: \[-2.9, 2.9\] rad; 57.2957795 deg would be within them: degrees given as radians\?$'),
    ([[0.3, 0.3, 0.3], [0.3, 0.3, 0.3]], [[0.0, 0.0, 0.0], [0.0, 0.0, -3.1]], LimitError,
     r'^arm1_wrist = -3.1 rad \(sample 1\) is beyond its lower limit -3.05 rad by 0.05 rad'),
    ([[0.3, 0.3, 0.6]], [[0.0, 0.0, 0.0]], LimitError, r'^rod_3 = 0.6 m is outside the stroke'),   # was q3
    ([[0.3, 0.3, 0.3], [0.3, 0.6, 0.3]], [[0.0, 0.0, 0.0]] * 2, LimitError,
     r'^rod_2 = 0.6 m \(sample 1\) is outside the stroke'),
    ([[250.0, 251.0, 252.0]], [[0.0, 0.0, 0.0]], LimitError,   # typed rods: the hint of millimetres
     r'^rod_1 = 250 m is outside the stroke \[0, 0.508\] m; 250 mm would be within it: millimetres given as '
     r'metres\?$'),
    ([[0.3, 0.3, float('nan')]], [[0.0, 0.0, 0.0]], InputError, r'^rod_3 = nan is not a finite number; allowed: '
     r'finite values in SI units$'),   # it named no rule
    ([[0.3, 0.3, 0.3]], [[0.0, float('inf'), 0.0]], InputError, r'^arm1_elbow = inf is not a finite number; '
     r'allowed: finite values in SI units$'),
    ([[0.3, 0.3, 0.3]], [[0.0, 0.0]], InputError, r'joints of arm1 must have 3 values per sample'),
    ([[0.3, 0.3, 0.3]], [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]], InputError,
     r'rods and joints must have the same number of samples, got 1 and 2'),
    ([['a', 0.3, 0.3]], [[0.0, 0.0, 0.0]], InputError, r'rods must be numbers'),
])
def test_refusals(rods, joints, error, pattern):
    with pytest.raises(error, match=pattern):
        robot_forward(ROBOT, rods, joints, 'arm1')


def test_limits_can_be_skipped_for_analyses():
    fk = robot_forward(ROBOT, [[0.3, 0.3, 0.3]], [[0.0, 3.0, 0.0]], 'arm1', check_limits=False)
    assert np.isfinite(fk.wafer.position).all()


def test_forward_of_something_else_than_a_robot_is_named():
    """robot_forward(None, ...) raised AttributeError ('NoneType' object has no attribute 'arm')."""
    with pytest.raises(InputError, match=r'^robot = None; allowed: a RobotDescription \(load_robot or parse_robot\)$'):
        robot_forward(None, [0.3, 0.3, 0.3], [0.0, 0.0, 0.0])


def test_rods_tilting_beyond_the_limit_are_named_by_the_robot():
    """The core names rods ``q``; the robot's forward kinematics (one configuration and a batch) named them so too,
    where the stroke's refusal names the robot's rods: now its rods' names come first."""
    for rods in ([[0.25, 0.265, 0.25]], [[0.25, 0.25, 0.25], [0.25, 0.265, 0.25]]):
        with pytest.raises(LimitError, match=r'^rod_1, rod_2, rod_3: q = \[0\.25, 0\.265, 0\.25\] m '
                                             r'(\(sample 1\) )?tilts the platform by about 0\.1075 rad'):
            robot_forward(ROBOT, rods, [[0.0, 1.0, -0.5]] * len(rods), 'arm1')
