"""The planar arm: the two-link problem at the edges of its reach, branches seen from above, limits modulo 2 pi."""
import math

import numpy as np
import pytest
from gpr_kinematics.robot.arm_chain import (
    chain_forward,
    fixed_one,
    link_vectors,
    reduce_one,
    reduced_one,
    two_link,
    wrap_to_limits,
)
from gpr_kinematics.robot.planar_arm import branch_of, solve_arm
from robot_support import ROBOT, make_robot, robot_data


def test_two_link_reach_edges():
    D1, D2 = np.array([0.3, 0.0]), np.array([0.2, 0.0])
    p = np.array([[0.5, 0.0], [0.1, 0.0], [0.5 + 1e-13, 0.0], [0.6, 0.0], [0.05, 0.0], [0.3, 0.2]])
    tl = two_link(D1, D2, p, 1.0)
    assert tl.reachable.tolist() == [True, True, True, False, False, True]
    np.testing.assert_allclose(tl.Theta1[:2], [0.0, 0.0], atol=1e-7)  # stretched, folded
    np.testing.assert_allclose(tl.Theta2[:2], [0.0, math.pi], atol=1e-7)
    reached = tl.Theta1[:, None] * 0 + np.stack([0.3 * np.cos(tl.Theta1) + 0.2 * np.cos(tl.Theta2),
                                                 0.3 * np.sin(tl.Theta1) + 0.2 * np.sin(tl.Theta2)], -1)
    np.testing.assert_allclose(reached[[0, 1, 2, 5]], p[[0, 1, 2, 5]], atol=1e-12)
    assert (tl.r_min, tl.r_max) == (pytest.approx(0.1), pytest.approx(0.5))


def test_branch_right_puts_the_elbow_right_of_the_shoulder_wrist_line():
    D1, D2 = np.array([0.3, 0.0]), np.array([0.3, 0.0])
    target = np.array([[0.4, 0.1]])
    for sign, side in ((1.0, -1.0), (-1.0, 1.0)):
        tl = two_link(D1, D2, target, sign)
        elbow = 0.3 * np.array([np.cos(tl.Theta1[0]), np.sin(tl.Theta1[0])])
        cross = target[0, 0] * elbow[1] - target[0, 1] * elbow[0]  # > 0: elbow left of the line (seen from above)
        assert np.sign(cross) == side
        assert np.sign(np.sin(tl.Theta2[0] - tl.Theta1[0])) == sign  # the forearm turns counterclockwise for right


def test_wrap_to_limits():
    lower, upper = np.array([-3.0, -1.0, -4.0]), np.array([3.0, 1.0, 4.0])
    t, v = wrap_to_limits(np.array([[3.2, 1.5, -3.5], [-3.2 + 2 * math.pi, 0.5 + 4 * math.pi, 3.9]]), lower, upper)
    # the representative nearest the middle of the range (within pi of it), and how far beyond the range it is
    two_pi = 2 * math.pi
    np.testing.assert_allclose(t, [[3.2 - two_pi, 1.5, -3.5 + two_pi], [-3.2 + two_pi, 0.5, 3.9 - two_pi]], atol=1e-14)
    np.testing.assert_allclose(v, [[two_pi - 3.2 - 3.0, 0.5, 0.0], [two_pi - 3.2 - 3.0, 0.0, 0.0]], atol=1e-12)


def test_a_joint_at_its_limit_to_rounding_is_within_it():
    """A joint 5e-13 rad beyond a limit (a station solved at the limit, rounded) is within LIMIT_SLACK (1e-12 rad):
    no violation; 3e-12 rad beyond, 2e-12 rad of violation (the slack subtracted)."""
    lower, upper = np.array([-2.9, -2.9]), np.array([2.9, 2.9])
    t, v = wrap_to_limits(np.array([[2.9 + 5e-13, -2.9 - 5e-13], [2.9 + 3e-12, -2.9 - 3e-12]]), lower, upper)
    np.testing.assert_allclose(t, [[2.9, -2.9], [2.9, -2.9]], atol=4e-12)
    np.testing.assert_array_equal(v[0], [0.0, 0.0])
    np.testing.assert_allclose(v[1], [2e-12, 2e-12], rtol=0, atol=1e-15)


def test_blade_offsets_fold_into_the_last_link():
    data = robot_data()
    data['arms'][0]['blade'] = {'position': [0.01, 0.02, 0.0], 'yaw': 0.5, 'wafer_centre': [0.2, -0.03, 0.0]}
    arm = make_robot(data).arm('arm1')
    d, beta = link_vectors(arm)
    w = np.array([0.2, -0.03])
    expected = np.array([0.01, 0.02]) + np.array([[math.cos(0.5), -math.sin(0.5)], [math.sin(0.5), math.cos(0.5)]]) @ w
    np.testing.assert_allclose(d[2], expected, atol=1e-16)
    theta = np.array([[0.3, -0.7, 1.1]])
    _, wafer, heading = chain_forward(arm, theta)
    sol = solve_arm(arm, wafer, heading, np.array([-1.0]))  # elbow -0.7 < 0: left branch
    np.testing.assert_allclose(sol.theta, theta, atol=1e-13)
    assert branch_of(arm, theta) == ('left',)


def test_two_joint_heading_is_per_branch():
    data = robot_data()
    data['arms'][0]['joints'] = data['arms'][0]['joints'][:2]
    data['arms'][0]['home'] = [0.0, 2.0]
    arm = make_robot(data).arm('arm1')
    p = np.array([[0.45, 0.1], [0.45, 0.1]])
    sol = solve_arm(arm, p, None, np.array([1.0, -1.0]))
    _, wafer, heading = chain_forward(arm, sol.theta)
    np.testing.assert_allclose(wafer, p, atol=1e-14)
    np.testing.assert_allclose(heading, sol.heading, atol=1e-14)
    assert abs(heading[0] - heading[1]) > 0.1  # the branches point the blade differently
    assert branch_of(arm, sol.theta) == ('right', 'left')


def test_shipped_arm_reach():
    d, _ = link_vectors(ROBOT.arm('arm1'))
    assert np.hypot(*d[0]) + np.hypot(*d[1]) == pytest.approx(0.6)


@pytest.mark.parametrize('held', ['arm2_shoulder', 'arm2_elbow', 'arm2_wrist', 'arm2_hand'])
def test_branch_of_a_four_joint_arm_is_the_branch_it_was_solved_on(held):
    """arm2 holding each of its joints in turn (fixed_joint): targets solved on the right and the left branch come
    back as that branch from branch_of, which looks at the two-link sub-chain left by the held joint (its axes: the
    three other joints'; for a held shoulder, not the mount)."""
    data = robot_data()
    data['arms'][1]['redundancy'] = {'rule': 'fixed_joint', 'joint': held, 'value': 0.2}
    arm = make_robot(data).arm('arm2')
    rng = np.random.default_rng(5)
    J = rng.uniform(arm.lower + 0.1, arm.upper - 0.1, (200, 4))
    J[:, arm.redundancy.joint] = 0.2
    _, wafer, heading = chain_forward(arm, J)
    for branch, sign in (('right', 1.0), ('left', -1.0)):
        sol = solve_arm(arm, wafer, heading, np.full(200, sign))
        ok = sol.reachable & (np.max(sol.violation, axis=1) <= 0.0)
        assert ok.sum() > 50
        assert set(branch_of(arm, sol.theta[ok])) == {branch}


def test_a_held_value_given_to_the_one_target_solve_holds_the_joint_under_either_rule():
    """``solve_arm_one(..., value)`` holds the redundant joint at ``value`` under ``nearest`` too (the one-station
    path finds the real and the naive target's nearest values in one call and passes them on): the answer is the
    ``fixed_joint`` arm's at that value, and without a value the ``nearest`` rule's own choice."""
    from gpr_kinematics.robot.nearest import nearest_value
    from gpr_kinematics.robot.planar_arm import solve_arm_one
    data = robot_data()
    data['arms'][1]['redundancy'] = {'rule': 'nearest'}  # holds the first joint
    arm_near = make_robot(data).arm('arm2')
    data['arms'][1]['redundancy'] = {'rule': 'fixed_joint', 'joint': 'arm2_shoulder', 'value': 0.0}
    arm_fixed = make_robot(data).arm('arm2')
    p, phi = (0.42, 0.13), 0.3
    for v in (-0.4, 0.0, 0.7):
        held = solve_arm_one(arm_near, *p, phi, 1.0, v)
        fixed = solve_arm_one(arm_fixed, *p, phi, 1.0, v)
        assert held.theta == fixed.theta and held.theta[0] == pytest.approx(v, abs=1e-15)
    d, beta = link_vectors(arm_near)
    chosen = float(nearest_value(arm_near, d, beta, np.array([p]), np.array([phi]), np.array([1.0]))[0])
    own = solve_arm_one(arm_near, *p, phi, 1.0)
    assert own.theta == solve_arm_one(arm_near, *p, phi, 1.0, chosen).theta
    assert abs(chosen) > 1e-3  # the rule chose a value of its own, not the fixed rule's 0


@pytest.mark.parametrize('held', [-1, 0, 1, 2, 3])
def test_a_chain_reduced_once_solves_as_fixed_one_to_the_last_bit(held):
    """The one-station path's chain reduced once per arm (reduce_one, reduced_one) answers fixed_one's numbers for
    every held joint (none, 0 to 3), in and out of reach, on both branches."""
    rng = np.random.default_rng(held + 7)
    links = [(float(x), float(y)) for x, y in rng.uniform(-0.3, 0.3, (3 if held < 0 else 4, 2))]
    for _ in range(300):
        beta, v, px, py, phi = (float(x) for x in rng.uniform(-3.5, 3.5, 5))
        sign = float(rng.choice([-1.0, 1.0]))
        assert reduced_one(reduce_one(links, beta, held, v), 0.3 * px, 0.3 * py, phi, sign) == \
            fixed_one(links, beta, held, v, 0.3 * px, 0.3 * py, phi, sign)
