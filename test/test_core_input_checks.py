"""The shared input checks (``inputs.validation``) as the public functions meet them: a value of the wrong shape or
a non-finite one is an :class:`InputError` naming it, never a silent answer for part of it. The shape, finiteness
and bound cases are guards whose removal no test noticed (a mutation audit): without them, two rod triples gave the
forward kinematics of the first, two heights the inverse kinematics of the first, NaN a NaN answer. Numbers given as
text or as complex numbers were taken (below)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from gpr_kinematics.core import inverse_batch
from gpr_kinematics.errors import InputError
from gpr_kinematics.mechanisms import load_mechanism
from gpr_kinematics.robot import load_robot, robot_forward, stations_from_poses

from gpr_kinematics import compensate, forward, forward_batch, inverse

QUAT = (0.0, 0.0, 0.0, 1.0)


@pytest.mark.parametrize('call, message', [
    (lambda: forward([[0.5, 0.5, 0.5], [0.4, 0.4, 0.4]]), 'q must be 3 values, got shape (2, 3)'),
    (lambda: inverse([0.5, 0.4], 0.0, 0.0), 'height must be a single number, got shape (2,)'),
    (lambda: inverse(0.5, [0.01, 0.02], 0.0), 'tilt must be a single number, got shape (2,)'),
    (lambda: compensate((0.0, 0.0), QUAT), 'position must be 3 numbers, got shape (2,)'),
    (lambda: compensate((0.0, 0.0, 0.4), QUAT, (0.0, 0.0, 0.1, 0.0)), 'tool_offset must be 3 numbers, got shape (4,)'),
    (lambda: compensate((0.0, math.nan, 0.4), QUAT),
     'position = [0.0, nan, 0.4] contains NaN or infinity: position[1] = nan is not a finite number'),
    (lambda: compensate((0.0, 0.0, 0.4), QUAT, (0.0, 0.0, math.inf)), 'tool_offset[2] = inf is not a finite number'),
])
def test_a_value_of_the_wrong_shape_or_not_finite_is_refused_by_name(call, message):
    with pytest.raises(InputError) as err:
        call()
    assert message in str(err.value)


@pytest.mark.parametrize('call, message', [
    (lambda: inverse_batch('0.5', 0.0, 0.0), "height must be a number or an array of numbers, got '0.5'"),
    (lambda: inverse_batch([0.5, '0.4'], 0.0, 0.0), 'height must be a number or an array of numbers'),
    (lambda: inverse('0.5', 0.0, 0.0), "height must be a number or an array of numbers, got '0.5'"),
    (lambda: forward(['0.5', '0.5', '0.5']), "q must be numbers, got ['0.5', '0.5', '0.5']"),
    (lambda: forward_batch(np.array([['0.5', '0.5', '0.5']])), 'q must be numbers'),
    (lambda: inverse(0.5, 0.0, 0.0, tool=(0.0, 0.0, b'0.1')), 'tool must be numbers'),
    (lambda: compensate(np.array(['0', '0', '0.4']), QUAT), 'position must be 3 numbers'),
    (lambda: forward_batch(np.array([[0.5 + 1e-3j, 0.5, 0.5]])), 'q must be numbers'),   # was cast to its real part
])
def test_numbers_given_as_text_or_complex_are_refused(call, message):
    """numpy converts the text '0.5' to 0.5 and float() does too: the batch inverse kinematics solved a string height
    while the sweep refused one. Text is no number in the Python API either (the command line and the files read
    their own decimals). A numpy array of complex numbers was cast to its real parts with a warning."""
    with pytest.raises(InputError) as err:
        call()
    assert message in str(err.value)


def test_the_checked_forms_still_answer():
    """The same calls with valid values: the guards above refuse only what they name (one triple, one height). Equal
    rods hold the platform level at their length (the singular configuration of the nominal machine), a level command
    at 0.4 m needs rods of 0.4 m, and the inverse kinematics' rods give back its pose."""
    np.testing.assert_allclose(forward([0.5, 0.5, 0.5]).position, [0.0, 0.0, 0.5], rtol=0, atol=1e-15)
    h = inverse(0.5, 0.01, 0.0)
    assert h.q.shape == (3,) and np.allclose(forward(h.q).position, h.achieved.position, atol=1e-12)
    np.testing.assert_allclose(compensate((0.0, 0.0, 0.4), QUAT).q, [0.4, 0.4, 0.4], rtol=0, atol=1e-15)


def test_robot_joints_and_station_positions_are_bounded_to_a_million():
    """Joint values and station positions beyond +-1e6 (rad, m) are refused before any trigonometry (``bounded``);
    1e6 itself is taken."""
    robot = load_robot()
    n = len(robot.arm('arm1').joints)
    with pytest.raises(InputError, match=r'joints of arm1 \[rad\] = .*allowed: finite values within \+-1e\+06'):
        robot_forward(robot, [[0.3, 0.3, 0.3]], [[0.0] * (n - 1) + [1.0000001e6]], 'arm1', check_limits=False)
    robot_forward(robot, [[0.3, 0.3, 0.3]], [[0.0] * (n - 1) + [1e6]], 'arm1', check_limits=False)
    with pytest.raises(InputError, match=r'station position \[m\] = .*allowed: finite values within'):
        stations_from_poses([[2e6, 0.0, 0.0]], [np.eye(3)])
    st = stations_from_poses([[0.1, 0.0, 0.2], [0.2, 0.0, 0.2]], [np.eye(3), np.eye(3)])
    with pytest.raises(InputError, match=r'distance \[m\] must have shape \(2,\); got \(3,\)'):
        st.offset([0.01, 0.02, 0.03])
    np.testing.assert_allclose(st.offset([0.01, 0.02]).position[:, 2], [0.21, 0.22], rtol=0, atol=1e-15)


def test_a_mechanisms_newton_iterations_are_bounded_by_a_thousand():
    """``max_iterations`` 1000 is the largest count taken (the documented limit), 1001 is refused."""
    mech = load_mechanism('upu3.yaml')
    pose = np.array([[0.01, -0.02, 0.2, 0.0, 0.0, 0.0]])
    joints = mech.inverse_kinematics(pose)
    np.testing.assert_allclose(mech.forward_kinematics(joints, pose + 0.001, max_iterations=1000), pose, atol=1e-12)
    with pytest.raises(InputError, match='max_iterations = 1001 is invalid; allowed: an integer from 1 to 1000'):
        mech.forward_kinematics(joints, pose, max_iterations=1001)
