"""Station inverse kinematics: round trips on thousands of stations, batch = single, branches, redundancy, the
naive model's wafer error against an independent computation, and every refusal with its message."""
import contextlib
import math
import re

import numpy as np
import pytest
from gpr_kinematics.core.rotations import rotation_angle
from gpr_kinematics.errors import InputError, LimitError, brief
from gpr_kinematics.robot.arm_chain import link_vectors
from gpr_kinematics.robot.forward import robot_forward
from gpr_kinematics.robot.inverse import solve_stations
from gpr_kinematics.robot.planar_arm import branch_of
from gpr_kinematics.robot.stations import Stations, stations_from_poses
from robot_support import (
    ROBOT,
    TAUGHT_JOINTS,
    TAUGHT_RODS,
    TILTED_RODS,
    elbow_angle,
    make_robot,
    random_stations,
    robot_data,
    tilted_rods_robot,
)
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation


def _assert_reproduces(robot, sol, arm, tol=1e-9):
    """Forward kinematics of the answer, computed afresh, reproduces the stations."""
    fk = robot_forward(robot, sol.rods, sol.joints, arm)
    st = sol.stations
    assert np.max(np.linalg.norm(fk.wafer.position - st.position, axis=1)) < tol
    assert np.max(rotation_angle(st.rotation, fk.wafer.rotation)) < tol
    assert np.max(sol.position_error) < tol and np.max(sol.angle_error) < tol


@pytest.mark.parametrize('arm', ['arm1', 'arm2'])
def test_round_trip_thousands_of_stations(arm):
    st, Q, J = random_stations(ROBOT, arm, 3000, seed=1)
    sol = solve_stations(ROBOT, st, arm, branch=branch_of(ROBOT.arm(arm), J))
    _assert_reproduces(ROBOT, sol, arm, tol=1e-9)
    # the postures come back too (where the elbow is not nearly stretched, which would make them ill-conditioned)
    np.testing.assert_allclose(sol.rods, Q, atol=1e-12)
    ok = np.abs(np.sin(elbow_angle(ROBOT, arm, J))) > 0.05
    assert ok.sum() > 2500
    np.testing.assert_allclose(sol.joints[ok], J[ok], atol=1e-9)


@pytest.mark.parametrize('arm', ['arm1', 'arm2'])
def test_both_branches_reach_the_same_station(arm):
    st, _, _ = random_stations(ROBOT, arm, 400, seed=2)
    for branch in ('left', 'right'):
        sol = solve_stations(ROBOT, st, arm, branch=branch, check=False)
        ok = sol.feasible
        assert ok.sum() > 100
        assert set(branch_of(ROBOT.arm(arm), sol.joints[ok])) == {branch}
        fk = robot_forward(ROBOT, sol.rods[ok], sol.joints[ok], arm)
        assert np.max(np.linalg.norm(fk.wafer.position - st.position[ok], axis=1)) < 1e-9
    left = solve_stations(ROBOT, st, arm, branch='left', check=False)
    right = solve_stations(ROBOT, st, arm, branch='right', check=False)
    # The GPR's answer does not depend on the arm's branch (to rounding: the batch Newton's last step may differ
    # when the rows it iterates differ, as in test_batch_equals_single).
    np.testing.assert_allclose(left.rods, right.rods, atol=1e-15, rtol=0)
    assert np.min(np.abs(left.joints[:, 1] - right.joints[:, 1])) > 0.0


@pytest.mark.parametrize('arm', ['arm1', 'arm2'])
def test_round_trip_with_a_turned_mount_and_an_offset_blade(arm):
    """Mounts turned and moved off the platform centre, blades moved and turned in the flange frame (the shipped arms
    have neither): the wafer comes back to the station and the postures come back, in a batch and one by one."""
    data = robot_data()
    data['arms'][0]['mount'] = {'position': [0.02, -0.01, 0.08], 'yaw': 0.3}
    data['arms'][0]['blade'] = {'position': [0.01, 0.005, 0.01], 'yaw': -0.2, 'wafer_centre': [0.2, 0.01, 0.004]}
    data['arms'][1]['mount'] = {'position': [-0.03, 0.02, 0.21], 'yaw': -2.4}
    data['arms'][1]['blade'] = {'position': [0.015, -0.01, 0.01], 'yaw': 0.3, 'wafer_centre': [0.19, -0.02, 0.005]}
    robot = make_robot(data)
    st, Q, J = random_stations(robot, arm, 200, seed=9)
    branches = branch_of(robot.arm(arm), J)
    sol = solve_stations(robot, st, arm, branch=branches)
    _assert_reproduces(robot, sol, arm, tol=1e-9)
    np.testing.assert_allclose(sol.rods, Q, atol=1e-12)
    ok = np.abs(np.sin(elbow_angle(robot, arm, J))) > 0.05
    assert ok.sum() > 150
    np.testing.assert_allclose(sol.joints[ok], J[ok], atol=1e-9)
    for i in np.flatnonzero(ok)[:10]:
        one = solve_stations(robot, st.take([i]), arm, branch=branches[i])
        np.testing.assert_allclose(one.joints[0], J[i], atol=1e-9)
        assert one.position_error[0] < 1e-12 and one.angle_error[0] < 1e-12


def test_batch_equals_single():
    st, _, J = random_stations(ROBOT, 'arm1', 40, seed=3)
    branches = branch_of(ROBOT.arm('arm1'), J)
    batch = solve_stations(ROBOT, st, 'arm1', branch=branches)
    for i in range(len(st)):
        one = solve_stations(ROBOT, st.take([i]), 'arm1', branch=branches[i])
        np.testing.assert_allclose(one.rods[0], batch.rods[i], atol=1e-15, rtol=0)
        np.testing.assert_allclose(one.joints[0], batch.joints[i], atol=1e-14, rtol=0)
        np.testing.assert_allclose(one.naive_wafer_error[0], batch.naive_wafer_error[i], atol=2e-15, rtol=0)


def test_world_base_pose_is_applied():
    """A base rolled by 0.5 deg: a level station needs the platform tilted by 0.5 deg in gpr_base."""
    data = robot_data()
    data['base'] = {'position': [0.1, -0.2, 0.3], 'rpy': [math.radians(0.5), 0.0, 1.0]}
    robot = make_robot(data)
    st = Stations.of([[0.45, 0.25, 0.62]], tilt=0.0, azimuth=0.0, heading=0.4)
    sol = solve_stations(robot, st, 'arm1')
    assert sol.forward.gpr.tilt[0] == pytest.approx(math.radians(0.5), abs=1e-14)
    _assert_reproduces(robot, sol, 'arm1', tol=1e-12)
    stations, _, J = random_stations(robot, 'arm2', 500, seed=4)
    _assert_reproduces(robot, solve_stations(robot, stations, 'arm2', branch=branch_of(robot.arm('arm2'), J)), 'arm2')


def test_height_is_solved_for_the_wafer_point():
    """The platform plane passes at the arm's wafer height through the station point, also when tilted."""
    st = Stations.of([[1.2, 0.9, 0.5]], tilt=math.radians(1.8), azimuth=0.7, heading=-0.3)
    for arm in ('arm1', 'arm2'):
        sol = solve_stations(ROBOT, st, arm)
        fk = sol.forward
        n = fk.platform.rotation[0][:, 2]
        assert n @ (st.position[0] - fk.platform.position[0]) == pytest.approx(ROBOT.arm(arm).wafer_height, abs=1e-14)
    a1 = solve_stations(ROBOT, st, 'arm1')
    a2 = solve_stations(ROBOT, st, 'arm2')
    # arm2's wafer rides 0.123 m higher above the platform, so its rods are about that much shorter
    assert np.mean(a1.rods - a2.rods) == pytest.approx(ROBOT.arm('arm2').wafer_height - ROBOT.arm('arm1').wafer_height,
                                                      abs=1e-4)


def test_a_batch_puts_every_station_on_its_plane_and_takes_rods_at_the_stroke_ends():
    """A batch mixing a level station and stations tilted 1 and 2 deg (their heights converge in different numbers of
    steps) puts each platform plane at the arm's wafer height through its station to 1e-14 m; and stations taught
    with every rod at an end of the stroke (0 and 0.508 m: the platform level) are solved back to those rods, within
    the stroke's rounding slack, not refused as beyond it."""
    st = Stations.of([[1.2, 0.9, 0.5], [1.2, 0.9, 0.5], [1.1, 0.7, 0.45]], [0.0, math.radians(2.0), math.radians(1.0)],
                     [0.0, 0.7, -2.0], [0.3, -0.3, 1.0])
    sol = solve_stations(ROBOT, st, 'arm1')
    n = sol.forward.platform.rotation[:, :, 2]
    residual = np.einsum('ni,ni->n', n, st.position - sol.forward.platform.position) - ROBOT.arm('arm1').wafer_height
    np.testing.assert_allclose(residual, 0.0, atol=1e-14)
    from gpr_kinematics.robot.teach import teach
    for q in (0.0, 0.508):
        taught = teach(ROBOT, [[q] * 3] * 2, [[0.2, 1.0, -0.4], [-0.3, -1.2, 0.5]], 'arm1')
        back = solve_stations(ROBOT, taught.stations, 'arm1', branch=['right', 'left'])
        np.testing.assert_allclose(back.rods, q, atol=1e-13)


def test_rods_that_are_not_parallel_come_back_at_the_stroke_ends():
    """On rods that are not parallel the height is solved again at corrected heights; an iterate of a station
    taught with a rod at 0 lay 5e-9 m (7e-7 m) below the stroke and the core refused it (q1 = -4.94300834e-09 m is
    outside the stroke), also under check=False. Only the converged rods are judged: fk -> ik -> fk comes back."""
    robot = tilted_rods_robot()
    fk = robot_forward(robot, TAUGHT_RODS, TAUGHT_JOINTS, 'arm1')
    st = stations_from_poses(fk.wafer.position, fk.wafer.rotation)
    branch = branch_of(robot.arm('arm1'), np.array(TAUGHT_JOINTS))
    for check in (True, False):
        sol = solve_stations(robot, st, 'arm1', branch=branch, check=check)
        assert sol.feasible.all()
        np.testing.assert_allclose(sol.rods, TAUGHT_RODS, atol=1e-13, rtol=0)
        np.testing.assert_allclose(sol.joints, TAUGHT_JOINTS, atol=1e-12, rtol=0)
        _assert_reproduces(robot, sol, 'arm1', tol=1e-12)


def test_rods_that_are_not_parallel_beyond_the_stroke_are_refused_in_the_robots_words():
    """A station 1 cm, 1 m and 60 m below the stroke and 5 cm above it on rods that are not parallel: the robot's
    refusal, by the rods' excess (the core had said its own words, or not converged far beyond), or marked."""
    robot = tilted_rods_robot()
    fk = robot_forward(robot, TAUGHT_RODS[:1], TAUGHT_JOINTS[:1], 'arm1')
    st = stations_from_poses(fk.wafer.position, fk.wafer.rotation)
    for dz, side, by in ((-0.01, 'below', '0.009994 m (9.994 mm)'), (-1.0, 'below', '0.9994 m (999.4 mm)'),
                         (-60.0, 'below', '59.96 m (5.996e+04 mm)'), (0.05 + 0.508, 'above', '0.04965 m (49.65 mm)')):
        moved = Stations.of(st.position + [0.0, 0.0, dz], st.tilt, st.azimuth, st.heading)
        with pytest.raises(LimitError, match=rf'^station 0: rod_1 = \S+ m is {side} the stroke \[0, 0\.508\] m by '
                                             rf'{re.escape(by)}: the station is too {"low" if dz < 0 else "high"} for '
                                             r'arm arm1$'):
            solve_stations(robot, moved, 'arm1', branch='right')
        assert not solve_stations(robot, moved, 'arm1', branch='right', check=False).feasible[0]


def test_fixed_joint_redundancy_holds_the_joint_and_takes_a_value_per_station():
    st, _, _ = random_stations(ROBOT, 'arm2', 200, seed=5)
    sol = solve_stations(ROBOT, st, 'arm2', check=False)
    np.testing.assert_array_equal(sol.joints[:, 2], 0.0)
    values = np.linspace(-0.4, 0.4, 200)
    sol = solve_stations(ROBOT, st, 'arm2', redundancy_value=values, check=False)
    np.testing.assert_array_equal(sol.joints[:, 2], values)   # exactly (0.2 came back as 0.20000000000000018)
    for i in (0, 57, 199):   # one station per call too
        assert solve_stations(ROBOT, st.take([i]), 'arm2', redundancy_value=values[i], check=False).joints[0, 2] == \
            values[i]
    ok = sol.feasible
    assert ok.sum() > 100
    fk = robot_forward(ROBOT, sol.rods[ok], sol.joints[ok], 'arm2')
    assert np.max(np.linalg.norm(fk.wafer.position - st.position[ok], axis=1)) < 1e-9
    with pytest.raises(InputError, match='fixed_joint rule; arm arm1 has 3 joints; allowed: no redundancy value for '
                                         r'arm arm1 \(the service: use_redundancy_value false\)'):
        solve_stations(ROBOT, st, 'arm1', redundancy_value=0.1)
    with pytest.raises(InputError, match=r'redundancy value = nan \(station 0\) is not a finite number'):
        solve_stations(ROBOT, st, 'arm2', redundancy_value=float('nan'))
    with pytest.raises(InputError, match=r'redundancy value must be one number or 200 numbers'):
        solve_stations(ROBOT, st, 'arm2', redundancy_value=[0.1, 0.2])
    # beyond a turn (degrees given as radians) is refused, as in the robot file; so is a value outside the joint's
    # limits as given (6 rad was held at -0.283 rad, modulo a turn, without a word), as the robot file's value is
    with pytest.raises(InputError, match=r'redundancy value = 30 rad \(station 7\) is beyond one turn; allowed: '
                                         r'radians within \[-2pi, 2pi\] \(the held joint arm2_wrist ranges over '
                                         r'\[-2.5, 2.5\] rad\); in degrees\? give radians'):
        solve_stations(ROBOT, st, 'arm2', redundancy_value=np.where(np.arange(200) == 7, 30.0, 0.1), check=False)
    with pytest.raises(InputError, match=r'redundancy value = -7 rad \(station 0\) is beyond one turn'):   # its sign
        solve_stations(ROBOT, st, 'arm2', redundancy_value=-7.0, check=False)
    for one in (st.take([0]), st.take([0, 0])):   # one station per call and a batch alike
        with pytest.raises(InputError, match=r'^redundancy value = 6 rad \(station 0\) is outside the limits of '
                                             r'arm2_wrist, \[-2\.5, 2\.5\] rad; allowed: a value within them; 6 rad is '
                                             r'-0\.283185 rad modulo a turn$'):
            solve_stations(ROBOT, one, 'arm2', redundancy_value=6.0, check=False)
    with pytest.raises(InputError, match=r'^redundancy value = -2\.6 rad \(station 3\) is outside the limits of '
                                         r'arm2_wrist, \[-2\.5, 2\.5\] rad; allowed: a value within them$'):
        solve_stations(ROBOT, st, 'arm2', redundancy_value=np.where(np.arange(200) == 3, -2.6, 0.1), check=False)
    edge = solve_stations(ROBOT, st.take([0]), 'arm2', redundancy_value=2.5 + 1e-12, check=False)   # the slack
    assert edge.joints[0, 2] == 2.5 + 1e-12


def _nearest_robot(joint='arm2_shoulder'):
    data = robot_data()
    data['arms'][1]['redundancy'] = {'rule': 'nearest', 'joint': joint, 'reference': [0.3, -1.0, 0.5, 0.2],
                                     'weights': [1.0, 1.0, 2.0, 1.0]}
    return make_robot(data)


@pytest.mark.slow
@pytest.mark.parametrize('joint', ['arm2_shoulder', 'arm2_elbow', 'arm2_wrist', 'arm2_hand'])
def test_nearest_redundancy_is_the_minimum_of_its_cost(joint):
    """The ``nearest`` rule's posture against the self-motion swept densely here with the fixed_joint solver (not
    the rule's own search): no feasible posture of the sweep, and none within 1e-3 rad of the answer, is better
    (the rule finds the runs' edges in closed form, so it misses no run however narrow)."""
    robot = _nearest_robot(joint)
    a = robot.arm('arm2')
    st, _, _ = random_stations(robot, 'arm2', 60, seed=6)
    sol = solve_stations(robot, st, 'arm2', check=False)
    ok = sol.feasible
    assert ok.sum() > 30
    _assert_reproduces(robot, solve_stations(robot, st.take(np.flatnonzero(ok)), 'arm2'), 'arm2')
    ref, w = np.array(a.redundancy.reference), np.array(a.redundancy.weights)
    span = a.upper - a.lower

    def cost(J):
        return np.sum(w * ((J - ref) / span) ** 2, axis=-1)

    k = a.redundancy.joint
    lo, hi = a.joints[k].lower, a.joints[k].upper
    held = _fixed_variant(k)
    for i in np.flatnonzero(ok)[:30]:
        best = cost(sol.joints[i])
        values = np.concatenate([np.clip(sol.joints[i, k] + np.linspace(-1e-3, 1e-3, 101), lo, hi),
                                 np.linspace(lo, hi, 6001)])
        other = solve_stations(held, st.take([i] * values.size), 'arm2', branch=a.branch, redundancy_value=values,
                               check=False)
        c = np.where(other.feasible, cost(other.joints), np.inf)
        assert best <= c.min() + 1e-9, (i, best, c.min(), values[np.argmin(c)])


def _fixed_variant(k):
    data = robot_data()
    names = [j['name'] for j in data['arms'][1]['joints']]
    data['arms'][1]['redundancy'] = {'rule': 'fixed_joint', 'joint': names[k], 'value': 0.0}
    return make_robot(data)


def test_two_joint_arm_heading_is_an_outcome():
    data = robot_data()
    arm = data['arms'][0]
    arm['joints'] = arm['joints'][:2]
    arm['home'] = [0.0, 2.5]
    robot = make_robot(data)
    a = robot.arm('arm1')
    st, _, J = random_stations(robot, 'arm1', 300, seed=7)
    free = Stations.of(st.position, st.tilt, st.azimuth, None)
    sol = solve_stations(robot, free, 'arm1', branch=branch_of(a, J))
    assert np.max(sol.position_error) < 1e-9 and np.max(sol.angle_error) < 1e-9  # angle between normals
    # the heading each posture gives is accepted as a requirement, any other is refused
    sol2 = solve_stations(robot, st, 'arm1', branch=branch_of(a, J))
    _assert_reproduces(robot, sol2, 'arm1')
    wrong = Stations.of(st.position[:1], st.tilt[:1], st.azimuth[:1], st.heading[:1] + 0.1)
    with pytest.raises(LimitError, match=r'arm arm1 has 2 joints and cannot choose the blade heading: at this position '
                                         r'it is .* rad \(branch (left|right)\) or .* rad \(the other branch\)'):
        solve_stations(robot, wrong, 'arm1', branch=branch_of(a, J[:1]))
    with pytest.raises(InputError, match='arm arm2 has 4 joints and needs the blade heading'):
        solve_stations(robot, free, 'arm2')



@pytest.mark.parametrize('miss', [1e-4, 2e-9, 5e-10])
def test_a_two_joint_arms_heading_is_held_to_its_tolerance_per_call_and_in_batch(miss):
    """The heading each posture of a 2-joint arm makes, asked ``miss`` rad off (stations tilted up to 1.7 deg):
    beyond the 1e-9 rad tolerance (1e-4, 2e-9) every station is refused, one per call (the float path) and three in
    a batch, naming the headings the arm makes; within it (5e-10) accepted, the blade that far from the station's
    orientation. A tolerance of 1e-3 in either path had passed every test."""
    data = robot_data()
    data['arms'][0]['joints'] = data['arms'][0]['joints'][:2]
    data['arms'][0]['home'] = [0.0, 2.5]
    robot = make_robot(data)
    st, _, J = random_stations(robot, 'arm1', 3, seed=7)
    branch = branch_of(robot.arm('arm1'), J)
    asked = Stations.of(st.position, st.tilt, st.azimuth, st.heading + miss)
    batch = solve_stations(robot, asked, 'arm1', branch=branch, check=False)
    assert batch.feasible.tolist() == [miss < 1e-9] * 3
    np.testing.assert_allclose(batch.angle_error, miss, rtol=3e-5, atol=0)
    messages = []
    for i in range(3):
        free = Stations.of(st.position[i:i + 1], st.tilt[i:i + 1], st.azimuth[i:i + 1], None)
        other = 'left' if branch[i] == 'right' else 'right'
        fk = solve_stations(robot, free, 'arm1', branch=other, check=False).forward.wafer
        made = stations_from_poses(fk.position, fk.rotation).heading[0]
        messages.append(f'station {i}: arm arm1 has 2 joints and cannot choose the blade heading: at this position '
                        f'it is {st.heading[i]:.12g} rad (branch {branch[i]}) or {made:.12g} rad (the other branch), '
                        f'not {st.heading[i] + miss:.12g} rad; leave the heading free or give one of these '
                        '(to 1e-09 rad)')
        if miss < 1e-9:
            one = solve_stations(robot, asked.take([i]), 'arm1', branch=branch[i])
            np.testing.assert_allclose(one.angle_error, miss, rtol=3e-5, atol=0)
            continue
        for check in (False, True):  # a station alone takes the float path
            with pytest.raises(LimitError) if check else contextlib.nullcontext() as caught:
                one = solve_stations(robot, asked.take([i]), 'arm1', branch=branch[i], check=check)
            if check:
                assert str(caught.value) == messages[i]
            else:
                assert one.feasible.tolist() == [False]
    if miss > 1e-9:
        with pytest.raises(LimitError) as caught:
            solve_stations(robot, asked, 'arm1', branch=branch)
        assert str(caught.value) == messages[0] + ' (and 2 more stations)'


def test_a_two_joint_arms_heading_of_the_other_branch_names_that_branch():
    """The heading fk gave, asked on the other branch, was refused as 'it is h1 (branch left) or h2 (the other
    branch), not h2': the message names the branch to give now, with the heading this branch makes."""
    data = robot_data()
    data['gpr'] = {'config': None, **TILTED_RODS}
    data['arms'][0]['joints'] = data['arms'][0]['joints'][:2]
    data['arms'][0]['home'] = [0.0, 2.5]
    robot = make_robot(data)
    a = robot.arm('arm1')
    fk = robot_forward(robot, [[0.45, 0.449, 0.4505]], [[-2.9, 2.8]], 'arm1')
    st = stations_from_poses(fk.wafer.position, fk.wafer.rotation)
    taught = branch_of(a, np.array([[-2.9, 2.8]]))[0]
    other = 'left' if taught == 'right' else 'right'
    free = solve_stations(robot, Stations.of(st.position, st.tilt, st.azimuth, None), 'arm1', branch=other)
    made = stations_from_poses(free.forward.wafer.position, free.forward.wafer.rotation).heading[0]
    with pytest.raises(LimitError) as caught:
        solve_stations(robot, st, 'arm1', branch=other)
    assert str(caught.value) == (
        f'station 0: arm arm1 has 2 joints and cannot choose the blade heading: at this position it is {made:.12g} '
        f'rad on branch {other}; {st.heading[0]:.12g} rad is the heading of branch {taught}: give branch {taught}, or '
        'leave the heading free')
    # 1e-4 rad off the other branch's heading is neither branch's (to 1e-9 rad): no 'give branch' advice
    off = Stations.of(st.position, st.tilt, st.azimuth, st.heading + 1e-4)
    with pytest.raises(LimitError) as caught:
        solve_stations(robot, off, 'arm1', branch=other)
    text = str(caught.value)
    head = (f'station 0: arm arm1 has 2 joints and cannot choose the blade heading: at this position it is '
            f'{made:.12g} rad (branch {other}) or ')
    tail = (f' rad (the other branch), not {st.heading[0] + 1e-4:.12g} rad; leave the heading free or give one of '
            'these (to 1e-09 rad)')
    assert text.startswith(head) and text.endswith(tail) and 'give branch' not in text, text
    assert float(text[len(head):-len(tail)]) == pytest.approx(st.heading[0], abs=1e-9)
    ok = solve_stations(robot, st, 'arm1', branch=taught)
    np.testing.assert_allclose(ok.joints, [[-2.9, 2.8]], atol=1e-12, rtol=0)


@pytest.mark.parametrize('model', ['radial', 'compliant'])
def test_a_two_joint_arms_refusal_gives_the_headings_it_can_reach_in_the_stations_frame(model):
    """With the base yawed and tilted, the mount yawed and (compliant) the platform twisted, the refusal gave the
    headings in gpr_platform and the heading sent shifted by the mount's yaw: the advised ones were refused in turn.
    They are the station's own now: each, sent on its branch, is accepted."""
    import re
    data = robot_data()
    data['base']['rpy'] = [0.004, -0.003, -0.5]
    arm = data['arms'][0]
    arm['joints'] = arm['joints'][:2]
    arm['home'] = [0.0, 2.5]
    arm['mount'] = {'position': [0.01, -0.02, 0.08], 'yaw': 0.3}
    data['gpr'] = {**data.get('gpr', {}), 'model': model}
    robot = make_robot(data)
    a = robot.arm('arm1')
    st, _, J = random_stations(robot, 'arm1', 5, seed=11)
    branch = branch_of(a, J)
    for i in range(5):
        wrong = Stations.of(st.position[i:i + 1], st.tilt[i:i + 1], st.azimuth[i:i + 1], st.heading[i:i + 1] + 0.01)
        with pytest.raises(LimitError) as caught:
            solve_stations(robot, wrong, 'arm1', branch=branch[i])
        m = re.search(r'it is (\S+) rad \(branch (\w+)\) or (\S+) rad \(the other branch\), not (\S+) rad',
                      str(caught.value))
        assert m is not None, caught.value
        assert float(m[4]) == pytest.approx(float(np.remainder(st.heading[i] + 0.01 + np.pi, 2 * np.pi) - np.pi),
                                            abs=1e-11)
        assert abs(float(m[1]) - st.heading[i]) < 1e-10    # the posture's own heading, as fk gives it
        other = 'left' if m[2] == 'right' else 'right'
        for heading, side in ((float(m[1]), m[2]), (float(m[3]), other)):
            ok = solve_stations(robot, Stations.of(st.position[i:i + 1], st.tilt[i:i + 1], st.azimuth[i:i + 1],
                                                   [heading]), 'arm1', branch=side)
            assert ok.position_error[0] < 1e-9


def _radial_platform(q, R):
    """Exact platform pose under the radial model, independently: least squares on the closure, then a rigid fit."""
    th = np.radians([0.0, 120.0, 240.0])
    u = np.stack([np.cos(th), np.sin(th), np.zeros(3)], -1)
    P = np.column_stack([R * np.cos(th), R * np.sin(th), q])
    edges = ((0, 1), (1, 2), (2, 0))
    L2 = np.array([np.sum((P[j] - P[i]) ** 2) for i, j in edges])
    sol = least_squares(lambda lv: np.array([np.sum((lv[j] * u[j] - lv[i] * u[i]) ** 2) for i, j in edges]) - L2,
                        np.full(3, R), xtol=1e-15, ftol=1e-15, gtol=1e-15, method='lm')
    r = sol.x[:, None] * u
    rot, _ = Rotation.align_vectors(P - P.mean(0), r - r.mean(0))
    return rot.as_matrix(), P.mean(0) - rot.apply(r.mean(0))


@pytest.mark.parametrize('tilt_deg', [0.25, 1.0, 2.0])
@pytest.mark.parametrize('reach, direction', [(0.35, 0.0), (0.55, 1.3), (0.75, -2.2)])
def test_naive_wafer_error_against_an_independent_computation(tilt_deg, reach, direction):
    """The old tool's wafer error: the naive model puts the wafer at platform point w of a platform rotated about
    its centre; the real platform for the same rods is elsewhere. Computed here with scipy only."""
    R = ROBOT.config.radius
    azimuth, h = 0.4, 0.3
    arm = ROBOT.arm('arm1')
    zw = arm.wafer_height
    w = np.array([reach * math.cos(direction), reach * math.sin(direction), zw])
    tilt = math.radians(tilt_deg)
    Rn = Rotation.from_rotvec(tilt * np.array([math.cos(azimuth), math.sin(azimuth), 0.0])).as_matrix()
    base = np.array(ROBOT.base_position)
    errors = []
    for heading in (direction - 0.5, direction, direction + 0.4):  # the blade pointing about outwards
        station_b = np.array([0.0, 0.0, h]) + Rn @ w          # the station as the naive model places it
        th = np.radians([0.0, 120.0, 240.0])
        r_nom = np.column_stack([R * np.cos(th), R * np.sin(th), np.zeros(3)])
        q_naive = h + (r_nom @ Rn.T)[:, 2]                    # q_k = z + (Rot r_k)_z
        Rr, t = _radial_platform(q_naive, R)
        real_b = t + Rr @ w                                   # the naive joints put the wafer at w on the real platform
        st = Stations.of([station_b + base], tilt, azimuth, heading)
        sol = solve_stations(ROBOT, st, 'arm1')
        np.testing.assert_allclose(sol.naive_rods[0], q_naive, atol=1e-15)
        np.testing.assert_allclose(sol.naive_wafer_error[0], real_b - station_b, atol=2e-12)
        angle = Rotation.from_matrix(Rn.T @ Rr).magnitude()
        assert sol.naive_wafer_angle_error[0] == pytest.approx(angle, abs=1e-11)
        errors.append(sol.naive_wafer_error[0])
    # the position error does not depend on the blade heading (only on tilt and reach)
    np.testing.assert_allclose(errors[0], errors[1], atol=1e-13)
    np.testing.assert_allclose(errors[0], errors[2], atol=1e-13)


def test_naive_wafer_error_grows_with_tilt_and_reach():
    az = 0.0
    out = {}
    for reach in (0.35, 0.75):
        for tilt in (0.5, 2.0):
            p = np.array(ROBOT.base_position) + [reach, 0.0, 0.4]
            sol = solve_stations(ROBOT, Stations.of([p], math.radians(tilt), az + math.pi / 2, 0.0), 'arm1')
            out[reach, tilt] = sol.naive_wafer_error_norm[0]
    assert out[0.35, 0.5] < out[0.35, 2.0] and out[0.75, 0.5] < out[0.75, 2.0]
    assert out[0.35, 2.0] < out[0.75, 2.0]
    assert 10e-6 < out[0.75, 2.0] < 100e-6  # tens of micrometres at the tilt limit


@pytest.mark.parametrize('change, kwargs, pattern', [
    ({'tilt': math.radians(2.5)}, {},
     r'station 0: the station plane tilts 2.5 deg in gpr_base, beyond the tilt limit 2 deg by 0.5 deg'),
    # level station: every rod at z - 0.184 m (the arm's wafer height above the platform)
    ({'z': 0.95}, {}, r'station 0: rod_1 = 0.766 m is above the stroke \[0, 0.508\] m by 0\.258 m \(258 mm\): the '
                      r'station is too high for arm arm1'),
    ({'z': 0.05}, {}, r'station 0: rod_1 = -0.134 m is below the stroke \[0, 0.508\] m by 0\.134 m \(134 mm\): the '
                      r'station is too low for arm arm1'),
    ({'x': 2.0}, {}, r'station 0: out of reach of arm arm1: the wrist axis would be 1.\d+ m from the shoulder axis, '
                     r'the arm spans \[0, 0.6\] m \(\d+(\.\d+)? mm too far\)'),
])
def test_refusals_name_what_and_by_how_much(change, kwargs, pattern):
    p = dict(x=1.1, y=0.5, z=0.45, tilt=0.0, heading=0.0) | change
    st = Stations.of([[p['x'], p['y'], p['z']]], p['tilt'], 0.3, p['heading'])
    with pytest.raises(LimitError, match=pattern):
        solve_stations(ROBOT, st, 'arm1', **kwargs)


def test_unchecked_stations_beyond_the_tilt_limit_are_marked_not_raised():
    """check=False marks every station beyond a limit infeasible; the tilt limit raised instead (and a program's
    refusal lost its step: test_robot_plan)."""
    st = Stations.of([[1.1, 0.5, 0.45]] * 3, [0.0, math.radians(2.5), 0.01], 0.3, 0.0)
    sol = solve_stations(ROBOT, st, 'arm1', check=False)
    assert sol.feasible.tolist() == [True, False, True]
    with pytest.raises(LimitError, match=r'^station 1: the station plane tilts 2.5 deg in gpr_base'):
        solve_stations(ROBOT, st, 'arm1')
    alone = solve_stations(ROBOT, st.take([0, 2]), 'arm1')
    np.testing.assert_array_equal(sol.joints[[0, 2]], alone.joints)
    np.testing.assert_array_equal(sol.rods[[0, 2]], alone.rods)


def test_joint_limit_refusal_with_the_value_computed_independently():
    """Level station 0.39 m in front of the shoulder, blade pointing back (heading pi + 0.25): the right branch
    needs the wrist beyond its limit 3.05 rad, the left one does not. The wrist angle from the cosine rule here."""
    phi = math.pi + 0.25
    wafer = np.array([0.39, 0.0])
    wrist = wafer - 0.2 * np.array([math.cos(phi), math.sin(phi)])   # blade: wafer 0.2 m beyond the wrist axis
    r = np.hypot(*wrist)
    g = math.acos((r * r - 2 * 0.3 ** 2) / (2 * 0.3 ** 2))            # right branch: the elbow turns counterclockwise
    forearm = math.atan2(wrist[1], wrist[0]) - math.atan2(0.3 * math.sin(g), 0.3 + 0.3 * math.cos(g)) + g
    theta3 = phi - forearm
    st = Stations.of([np.array(ROBOT.base_position) + [0.39, 0.0, 0.45]], 0.0, 0.0, phi)
    pattern = (rf'^station 0: arm1_wrist = {theta3:.6g} rad is beyond its upper limit 3.05 rad by '
               rf'{theta3 - 3.05:.4g} rad \(branch right; the other branch stays within the limits\)$')
    with pytest.raises(LimitError, match=pattern):
        solve_stations(ROBOT, st, 'arm1', branch='right')
    assert solve_stations(ROBOT, st, 'arm1', branch='left').feasible.all()


def test_no_hint_when_the_other_branch_is_beyond_a_limit_too():
    """Level station 0.14 m in front of the shoulder, blade pointing away (heading 0): the wrist axis lies 0.06 m
    behind the shoulder axis (the wafer 0.2 m beyond it), so the elbow folds to acos((0.06^2 - 2 0.3^2) / (2 0.3^2))
    = 2.94126 rad, beyond +-2.9 rad on either branch: the refusal gives no hint of the other branch."""
    elbow = math.acos((0.06 ** 2 - 2 * 0.3 ** 2) / (2 * 0.3 ** 2))
    st = Stations.of([np.array(ROBOT.base_position) + [0.14, 0.0, 0.45]], 0.0, 0.0, 0.0)
    for branch, side, sign in (('right', 'upper', 1.0), ('left', 'lower', -1.0)):
        pattern = (rf'^station 0: arm1_elbow = {sign * elbow:.6g} rad is beyond its {side} limit {sign * 2.9:g} rad by '
                   rf'{elbow - 2.9:.4g} rad \(branch {branch}\)$')
        with pytest.raises(LimitError, match=pattern):
            solve_stations(ROBOT, st, 'arm1', branch=branch)


def test_refusal_counts_the_other_failing_stations_and_names_them():
    st = Stations.of([[1.1, 0.5, 0.45], [3.0, 0.5, 0.45], [3.1, 0.5, 0.45]], 0.0, 0.0, 0.0,
                     names=['ok', 'far1', 'far2'])
    with pytest.raises(LimitError, match=r'^station far1: out of reach .* \(and 1 more station\)$'):
        solve_stations(ROBOT, st, 'arm1')
    sol = solve_stations(ROBOT, st, 'arm1', check=False)
    assert sol.feasible.tolist() == [True, False, False]


@pytest.mark.parametrize('check', ['no', '', 0, None, 1])
def test_check_is_a_truth_value(check):
    """check='no' checked and check='' or 0 did not: the truthiness of any value; the switch of forward_batch now."""
    st = Stations.of([[1.1, 0.5, 0.45], [3.0, 0.5, 0.45]], 0.0, 0.0, 0.0)
    with pytest.raises(InputError) as err:
        solve_stations(ROBOT, st, 'arm1', check=check)
    assert str(err.value) == f'check = {check!r}; allowed: True or False'
    assert solve_stations(ROBOT, st, 'arm1', check=np.bool_(False)).feasible.tolist() == [True, False]


@pytest.mark.parametrize('kwargs, pattern', [
    ({'branch': 'up'}, "branch = 'up' is invalid; allowed: left, right, or empty or None"),
    ({'branch': ['left']}, r'branch must be one value or one per station \(2\), got 1'),
    ({'arm': 'arm3'}, "no arm 'arm3'; allowed: arm1, arm2"),
])
def test_bad_arguments(kwargs, pattern):
    st = Stations.of([[1.1, 0.5, 0.45], [1.0, 0.6, 0.4]], 0.0, 0.0, 0.0)
    with pytest.raises((InputError, LimitError, Exception), match=pattern):
        solve_stations(ROBOT, st, **kwargs)


@pytest.mark.parametrize('kwargs, pattern', [
    ({'position': [[1.0, float('nan'), 0.4]]}, 'y = nan is not a finite number'),
    ({'position': [[1.0, 0.4]]}, r'position must have 3 values per sample'),
    ({'position': [[1.0, 0.5, 0.4]], 'tilt': float('inf')}, r'tilt = inf \(station 0\) is not a finite number'),
    ({'position': [[1.0, 0.5, 0.4]], 'heading': [0.1, 0.2]}, r'heading must be one number or 1 numbers'),
    ({'position': [[1.0, 0.5, 0.4]], 'names': ['a', 'b']}, 'names must name the 1 stations, got 2 names'),
])
def test_malformed_stations(kwargs, pattern):
    with pytest.raises(InputError, match=pattern):
        Stations.of(**kwargs)


def test_stations_keep_their_own_positions():
    """Stations.of and stations_from_poses kept the caller's position array: a NaN written into it afterwards passed
    by the validation (a solve then read "q1 = nan")."""
    from gpr_kinematics.robot.stations import stations_from_poses

    for make in (lambda P: Stations.of(P), lambda P: stations_from_poses(P, np.eye(3)[None])):
        P = np.array([[1.1, 0.5, 0.45]])
        st = make(P)
        P[0, 0] = np.nan
        assert st.position.tolist() == [[1.1, 0.5, 0.45]]
        assert np.all(np.isfinite(st.position))


@pytest.mark.parametrize('names, pattern', [
    ('abc', "names must be a list of station names, got 'abc'"),
    (5, 'names must be a list of station names, got 5'),
    (['a', 'b'], 'names must name the 3 stations, got 2 names'),
    (['a', 'b', 'a'], "names[2] = 'a' names station 0 again; allowed: each station named once"),
])
def test_station_names_follow_one_rule(names, pattern):
    """stations_from_poses took a text as a list of names ('abc': stations a, b and c) and raised TypeError for 5;
    Stations.of refused both: one rule for both. A name given twice was taken (station files refuse it)."""
    from gpr_kinematics.robot.stations import stations_from_poses

    P = [[1.1, 0.5, 0.45]] * 3
    with pytest.raises(InputError, match=re.escape(pattern)):
        stations_from_poses(P, np.stack([np.eye(3)] * 3), names=names)
    with pytest.raises(InputError, match=re.escape(pattern)):
        Stations.of(P, names=names)
    assert stations_from_poses(P, np.stack([np.eye(3)] * 3), names=('a', 'b', 'c')).names == ('a', 'b', 'c')


@pytest.mark.parametrize('name', [None, 5, '', '-x', 'a b', 'a' * 100])
def test_station_names_follow_the_station_files_rule(name):
    """Stations.of(P, names=[None]) named a station 'None'; 5, '', '-x', 'a b' and 100 characters were taken too."""
    from gpr_kinematics.robot.stations import stations_from_poses

    rule = '1 to 64 letters, digits, _ . - (not - first: a spreadsheet reads such a cell as a formula)'
    message = f'names[1] = {brief(name)} is invalid; allowed: {rule}'
    P = [[1.1, 0.5, 0.45]] * 2
    with pytest.raises(InputError) as err:
        Stations.of(P, names=['ok', name])
    assert str(err.value) == message
    with pytest.raises(InputError) as err:
        stations_from_poses(P, np.stack([np.eye(3)] * 2), names=['ok', name])
    assert str(err.value) == message
    assert Stations.of(P, names=np.array(['a' * 64, 'pm1.slot-2'])).names == ('a' * 64, 'pm1.slot-2')


def test_stations_of_a_position_alone_are_level_with_the_heading_free():
    """Stations.of(position): tilt 0, azimuth 0 (the station plane level), every heading free (0, unused), names by
    index; the orientation the identity."""
    st = Stations.of([[1.1, 0.5, 0.45], [1.0, 0.6, 0.4]])
    assert st.tilt.tolist() == [0.0, 0.0] and st.azimuth.tolist() == [0.0, 0.0] and st.heading.tolist() == [0.0, 0.0]
    assert st.heading_free.tolist() == [True, True] and st.names == ('0', '1')
    np.testing.assert_array_equal(st.rotation, np.stack([np.eye(3)] * 2))


def test_link_vectors_fold_the_blade():
    d, beta = link_vectors(ROBOT.arm('arm1'))
    np.testing.assert_allclose(d[0], [0.3, 0.0])
    np.testing.assert_allclose(d[2], [0.2, 0.0])
    assert beta == 0.0


@pytest.mark.parametrize('position, rotation, words', [
    ([[1.15, 0.5, 0.4]], np.zeros((1, 3, 3)), r'rotation = .* is not a rotation matrix; allowed: finite, orthonormal'),
    ([[1.15, 0.5, 0.4]], 1.01 * np.eye(3)[None], r'is not a rotation matrix'),
    ([[1.15, 0.5, 0.4]], np.diag([1.0, 1.0, -1.0])[None], r'determinant \+1 \(not a mirror image\)'),
    ([[1.15, 0.5, 0.4]], np.array([[[1.0, 1e-3, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]]), r'is not a rotation'),
    ([[np.nan, 0.5, 0.4]], np.eye(3)[None], r'x = nan is not a finite number'),
    ([[1.15, 0.5, 0.4]], np.stack([np.eye(3)] * 2), r'1 positions and 2 rotations; allowed: one rotation per'),
    ([1.15, 0.5], np.eye(3), r'position must have 3 values per sample'),
])
def test_stations_from_poses_refuses_what_is_not_a_pose(position, rotation, words):
    """A zero or scaled matrix became tilt 0, heading 0, and was solved; NaN positions passed into the stations."""
    from gpr_kinematics.robot.stations import stations_from_poses

    with pytest.raises(InputError, match=words):
        stations_from_poses(position, rotation)


def test_stations_from_poses_takes_lists_and_offset_checks_its_distances():
    from gpr_kinematics.robot.stations import stations_from_poses

    R = Rotation.from_rotvec([0.01, -0.02, 0.7]).as_matrix()
    st = stations_from_poses([[1.15, 0.5, 0.4]], R.tolist(), names=['pm1'])
    np.testing.assert_allclose(st.rotation[0], R, atol=1e-15)
    assert st.names == ('pm1',)
    np.testing.assert_allclose(st.offset(0.008).position[0], st.position[0] + 0.008 * R[:, 2], atol=1e-15)
    for bad, words in (([np.nan], r'distance \[m\] = \[nan\]'), ('a', r'distance \[m\] must be numbers'),
                       ([0.0, 0.0], r'must have shape \(1,\)'), (10 ** 400, r'must be numbers')):
        with pytest.raises(InputError, match=words):
            st.offset(bad)


def test_stations_and_their_options_that_are_not_are_named():
    """None, a float branch, an array as the arm, index 5 of one station, a heading_free per two stations: bare
    TypeErrors, ValueErrors and IndexErrors before."""
    from gpr_kinematics.core.config import load_config
    from gpr_kinematics.errors import ConfigError

    st = Stations.of([[1.15, 0.5, 0.4]], heading=0.3)
    for call, error, words in (
            (lambda: solve_stations(ROBOT, None), InputError, r'stations = None; allowed: Stations'),
            (lambda: solve_stations(None, st), InputError, r'robot = None; allowed: a RobotDescription \(load_robot\)'),
            (lambda: load_config(3), ConfigError, r'geometry file path = 3; allowed: a file path \(str or Path\)'),
            (lambda: solve_stations(ROBOT, st, branch=0.5), InputError, r'branch = 0.5 is invalid; allowed: left or'),
            (lambda: solve_stations(ROBOT, st, arm=np.zeros((0, 3))), ConfigError, r'no arm .*; allowed: arm1, arm2'),
            (lambda: st.take([5]), InputError, r'station index \[5\]; allowed: integers from -1 to 0 \(1 stations\)'),
            (lambda: st.take([0, 5]), InputError, r'station index \[0, 5\]; allowed: integers from -1 to 0'),
            (lambda: st.take([1]), InputError, r'station index \[1\]; allowed: integers from -1 to 0'),
            (lambda: Stations.of([[1, 2, 3]], heading=-2e6), InputError,
             r'heading = -2e\+06 rad \(station 0\); allowed: finite values within \+-1e\+06 rad'),
            (lambda: Stations.of([[1, 2, 3]], tilt=[2e6]), InputError,
             r'tilt = 2e\+06 rad \(station 0\); allowed: finite values within \+-1e\+06 rad'),
            (lambda: st.take([-2, 0]), InputError, r'station index \[-2, 0\]; allowed: integers from -1 to 0'),
            (lambda: st.take([np.nan]), InputError, r'station index \[nan\]'),
            (lambda: Stations.of([[1, 2, 3]], heading_free=[True, False]), InputError,
             r'heading_free must be one bool or one per station \(1\)'),
            (lambda: Stations.of([[1, 2, 3]], names=0.5), InputError, r'names must be a list of station names')):
        with pytest.raises(error, match=words):
            call()
    assert len(st.take([])) == 0 and st.take([-1]).names == st.names
    empty = solve_stations(ROBOT, Stations.of(np.zeros((0, 3))))   # no station: no answer, not a refusal
    assert empty.rods.shape == (0, 3) and len(empty.feasible) == 0
    # a robot forward's record(-1) read an empty slice ("station index 0 ... (0 stations)"), record(5) an IndexError
    fk = solve_stations(ROBOT, st).forward
    np.testing.assert_array_equal(fk.record(-1).rods, fk.record(0).rods)
    for i in (5, -2, '0', 1.0, True):
        with pytest.raises(InputError, match=rf'^configuration index {re.escape(repr(i))}; allowed: an integer from -1 '
                                             r'to 0 \(1 configurations\)$'):
            fk.record(i)
    with pytest.raises(InputError, match=r'^station index 3; allowed: an integer from -1 to 0 \(1 stations\)$'):
        st.record(3)
    with pytest.raises(InputError, match=r'station index 5; allowed: an integer from -1 to 0 \(1 stations\)'):
        st.record(5)
    assert st.record(-1).heading == pytest.approx(0.3)
