"""The trajectory controller's decisions without ROS: the joints of a robot, a goal's checks with their standard error
codes and messages, the motion sampled at the rate, tolerances with control_msgs' rules, the servo; the joint values a
JointState message carries (the simulator's and the state publisher's)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from gpr_kinematics.core import forward_batch
from gpr_kinematics.errors import InputError
from gpr_kinematics.robot.controller import (
    GOAL_TOLERANCE_VIOLATED,
    INVALID_GOAL,
    INVALID_JOINTS,
    OLD_HEADER_TIMESTAMP,
    PATH_TOLERANCE_VIOLATED,
    ControllerJoints,
    GoalError,
    Tolerances,
    joint_state_values,
    late_start,
    plan_motion,
    trajectory_from_points,
)
from gpr_kinematics.robot.goal import resolve_tolerances
from gpr_kinematics.robot.servo import servo, violation
from gpr_kinematics.robot.timing import MAX_SAMPLES
from gpr_kinematics.robot.trajectory import JointTrajectory, evaluate
from robot_support import ROBOT

JOINTS = ControllerJoints.of(ROBOT)
CFG = ROBOT.config
DEFAULTS = Tolerances.uniform(len(JOINTS.names), 0.0, 1e-3, 0.5)
RATE = 100.0


def test_joints_of_the_example_robot():
    arm_joints = [n for a in ROBOT.arms for n in a.joint_names]
    assert JOINTS.names == ('rod_1', 'rod_2', 'rod_3', *arm_joints)
    np.testing.assert_array_equal(JOINTS.lower[:3], [CFG.stroke_min] * 3)
    np.testing.assert_array_equal(JOINTS.upper[:3], [CFG.stroke_max] * 3)
    np.testing.assert_array_equal(JOINTS.velocity, [ROBOT.rods.velocity] * 3 + [v for a in ROBOT.arms
                                                                                 for v in a.velocity])
    assert JOINTS.units == ('m',) * 3 + ('rad',) * len(arm_joints)
    # At rest: equal rods at mid-stroke (a level platform), each arm at home.
    np.testing.assert_array_equal(JOINTS.rest, [0.5 * (CFG.stroke_min + CFG.stroke_max)] * 3
                                  + [h for a in ROBOT.arms for h in a.home])
    assert forward_batch(JOINTS.rest[None, :3], CFG).tilt[0] < 1e-12


def test_the_rest_state_is_level_on_a_machine_with_rod_offsets():
    """Rod zero offsets of +-3 mm (a valid geometry): equal rods at mid-stroke tilted the platform 0.0371 rad, beyond
    the 2 deg limit, and the simulator refused every goal at its first sample, its own rest. The rest is the level
    platform at mid-stroke: the rods differ by the offsets, and a goal from there is planned."""
    import dataclasses
    robot = dataclasses.replace(ROBOT, config=CFG.replace(rod_offsets=[0.003, -0.003, 0.0]))
    joints = ControllerJoints.of(robot)
    mid = 0.5 * (CFG.stroke_min + CFG.stroke_max)
    np.testing.assert_allclose(joints.rest[:3], [mid - 0.003, mid + 0.003, mid], atol=1e-12)
    assert forward_batch(joints.rest[None, :3], robot.config).tilt[0] < 1e-12
    traj = JointTrajectory(('rod_1',), np.array([2.0]), np.array([[joints.rest[0] + 0.001]]))
    motion = plan_motion(joints, traj, joints.rest, RATE, robot.config, DEFAULTS, 1e-3)
    assert motion.positions[-1, 0] == joints.rest[0] + 0.001


@pytest.mark.parametrize('names, words', [
    ([], 'joint_names is empty'),
    (['rod_1', 'elbow'], "unknown joint 'elbow'; allowed: rod_1, rod_2, rod_3, arm1_shoulder"),
    (['arm1_elbow', 'arm1_elbow'], "joint 'arm1_elbow' named twice"),
    # a names list beyond MAX_JOINTS (64) is refused by its length before any name is looked up; 64 by the names
    (['x'] * 65, r'^joint_names names 65 joints; allowed: at most 10$'),
    (['x'] * 64, "unknown joint 'x'"),
])
def test_unknown_or_repeated_joints_are_invalid_joints(names, words):
    with pytest.raises(GoalError, match=words) as info:
        JOINTS.indices(names)
    assert info.value.code == INVALID_JOINTS


def _points(names, times, positions, velocities=None, accelerations=None):
    n = len(times)
    return trajectory_from_points(JOINTS, names, times, positions, velocities or [[]] * n, accelerations or [[]] * n)


@pytest.mark.parametrize('times, positions, velocities, accelerations, words', [
    ([], [], None, None, 'no points'),
    ([1.0], [[0.1]], None, None, r'points\[0\].positions has 1 value; allowed: 2 values \(one per joint\)'),
    ([1.0, 2.0], [[0.1, 0.2], [0.1, 0.2]], [[0.0, 0.0], []], None, r'points\[1\].velocities has 0 values'),
    ([1.0], [[0.1, math.nan]], None, None, r'points\[0\].positions\[1\] = nan'),
    ([1.0, 1.0], [[0.1, 0.2], [0.1, 0.2]], None, None, r'points\[1\].time_from_start = 1.0 s is not after points\[0\]'),
    ([2.0, 1.0], [[0.1, 0.2], [0.1, 0.2]], None, None, 'strictly increasing'),
    ([-1.0], [[0.1, 0.2]], None, None, r'points\[0\].time_from_start = -1.0 s; allowed: 0 to 86400 s'),
    ([math.inf], [[0.1, 0.2]], None, None, 'inf'),
    ([1.0], [[0.1, 0.2]], None, [[0.0, 0.0]], 'accelerations but no velocities'),
])
def test_malformed_points_are_invalid_goals(times, positions, velocities, accelerations, words):
    with pytest.raises(GoalError, match=words) as info:
        _points(['rod_1', 'arm1_elbow'], times, positions, velocities, accelerations)
    assert info.value.code == INVALID_GOAL


def _plan(traj, current=None, tolerances=DEFAULTS, start_tolerance=1e-3, clearance=None, under_way=False):
    return plan_motion(JOINTS, traj, JOINTS.rest if current is None else current, RATE, CFG, tolerances,
                       start_tolerance, clearance, under_way)


def _two_points(names, *targets, t=(1.0, 2.0)):
    return JointTrajectory(tuple(names), np.array(t), np.array(targets, dtype=float))


def test_a_feasible_two_point_trajectory_is_sampled_at_the_rate():
    """Two points over an arm joint and a rod: the others held at rest, samples at k / rate, the points met exactly,
    the platform's tilt computed for every sample."""
    traj = _two_points(['arm1_elbow', 'rod_2'], [1.0, 0.256], [1.5, 0.255])
    m = _plan(traj)
    assert len(m) == 201 and np.array_equal(m.time, np.arange(201) / RATE)
    elbow, rod2 = JOINTS.names.index('arm1_elbow'), JOINTS.names.index('rod_2')
    np.testing.assert_array_equal(m.goal, [elbow, rod2])
    assert np.array_equal(m.positions[100, [elbow, rod2]], [1.0, 0.256])
    assert np.array_equal(m.positions[200, [elbow, rod2]], [1.5, 0.255])
    held = [k for k in range(len(JOINTS.names)) if k not in (elbow, rod2)]
    assert np.array_equal(m.positions[:, held], np.repeat(JOINTS.rest[None, held], 201, axis=0))
    # Linear interpolation (positions only) from the rest state: the samples on the chords.
    np.testing.assert_allclose(m.positions[50, elbow], 0.5 * (JOINTS.rest[elbow] + 1.0), rtol=0, atol=1e-15)
    np.testing.assert_allclose(m.velocities[150, elbow], 0.5, rtol=0, atol=1e-14)


def test_the_last_point_is_always_a_sample():
    """The samples end at the last point's time, as a platform program's do (robot.timing.grid_times, one rule): a goal
    shorter than 1 ns was sampled at t = 0 alone and one ending within 1 ns after a k / rate instant ended there, so
    the last point's positions were never commanded."""
    elbow = JOINTS.names.index('arm1_elbow')
    target = JOINTS.rest[elbow] + 1e-12
    m = _plan(JointTrajectory(('arm1_elbow',), np.array([5e-10]), np.array([[target]])))
    assert m.time.tolist() == [0.0, 5e-10] and m.positions[-1, elbow] == target
    m = _plan(_two_points(['arm1_elbow'], [1.0], [1.5], t=(1.0, 2.0000000005)))
    assert len(m) == 201 and m.time[-1] == 2.0000000005 and m.positions[-1, elbow] == 1.5
    assert np.array_equal(m.time[:-1], np.arange(200) / RATE)


def test_the_sample_bound_counts_the_samples_made():
    """MAX_SAMPLES bounds the samples the goal has (robot.grid.grid_count, one rule with the programs): a goal of
    1999.99 s at 100 Hz has 200,000 samples and was refused as 200,001; one of 1999.995 s has 200,001."""
    elbow = JOINTS.names.index('arm1_elbow')
    rest = JOINTS.rest[elbow]
    m = _plan(JointTrajectory(('arm1_elbow',), np.array([1999.99]), np.array([[rest + 0.1]])))
    assert len(m) == MAX_SAMPLES and m.time[-1] == 1999.99
    with pytest.raises(GoalError, match=r'the trajectory lasts 1999.99 s: 200001 samples at 100 Hz; allowed: at most '
                                        r'200000 samples'):
        _plan(JointTrajectory(('arm1_elbow',), np.array([1999.995]), np.array([[rest + 0.1]])))


def test_beyond_a_joint_limit_is_an_invalid_goal_naming_it():
    traj = _two_points(['arm1_elbow'], [1.0], [3.0])
    with pytest.raises(GoalError, match=r'point 1 \(t = 2 s\): arm1_elbow = 3 rad is beyond its upper limit 2.9 rad '
                                        r'by 0.1 rad; allowed: \[-2.9, 2.9\] rad') as info:
        _plan(traj)
    assert info.value.code == INVALID_GOAL
    with pytest.raises(GoalError, match=r'rod_1 = 0.6 m is beyond its upper limit 0.508 m by 0.092 m; allowed: '
                                        r'\[0, 0.508\] m'):
        _plan(_two_points(['rod_1'], [0.3], [0.6]))
    # a hair beyond: the value and the limit to 12 digits, and by how much (it read '3.05 rad is beyond its limits;
    # allowed: [-3.05, 3.05] rad')
    with pytest.raises(GoalError, match=r'arm1_shoulder = 3.0500000001 rad is beyond its upper limit 3.05 rad by '
                                        r'1e-10 rad; allowed: \[-3.05, 3.05\] rad'):
        _plan(_two_points(['arm1_shoulder'], [3.0], [3.0500000001]))
    # within the slack the planner, forward kinematics and the nodes allow (1e-12) it is taken: a station solved at a
    # limit was refused as a goal, by 5e-13 rad
    top = 0.508 + 5e-13
    m = _plan(_two_points(['arm1_shoulder', 'rod_1', 'rod_2', 'rod_3'], [3.0, 0.5, 0.5, 0.5], [3.05 + 5e-13, top, top,
                                                                                              top], t=(3.0, 4.0)))
    assert m.positions[-1, 0] == top and m.positions[-1, 3] == 3.05 + 5e-13
    with pytest.raises(GoalError, match=r'arm1_shoulder = 3.050000000002 rad is beyond its upper limit 3.05 rad'):
        _plan(_two_points(['arm1_shoulder'], [3.0], [3.05 + 2e-12], t=(3.0, 4.0)))
    m = _plan(_two_points(['arm1_shoulder'], [-3.0], [-3.05 - 5e-13], t=(3.0, 4.0)))   # the lower side alike
    assert m.positions[-1, 3] == -3.05 - 5e-13
    with pytest.raises(GoalError, match=r'arm1_shoulder = -3.050000000002 rad is beyond its lower limit -3.05 rad'):
        _plan(_two_points(['arm1_shoulder'], [-3.0], [-3.05 - 2e-12], t=(3.0, 4.0)))
    # a driver's millimetres or degrees are told so (as the files are), a value a hair beyond is not
    with pytest.raises(GoalError, match=r'rod_1 = 254 m is beyond its upper limit 0.508 m by 253 m; allowed: '
                                        r'\[0, 0.508\] m \(millimetres given as metres\?\)$'):
        _plan(_two_points(['rod_1'], [0.3], [254.0]))
    with pytest.raises(GoalError, match=r'arm1_shoulder = 90 rad is beyond its upper limit 3.05 rad by 87 rad; '
                                        r'allowed: \[-3.05, 3.05\] rad \(radians only here: 90 deg is 1.57079633 '
                                        r'rad\)$'):
        _plan(_two_points(['arm1_shoulder'], [0.0], [90.0]))
    with pytest.raises(GoalError, match=r'rod_1 = 0.6 m is beyond .*\[0, 0.508\] m$'):
        _plan(_two_points(['rod_1'], [0.3], [0.6]))


def test_too_fast_a_move_names_the_joint_and_its_mean_velocity():
    # The elbow (2 rad/s) from 2.5 rad at rest to -2.5 rad in 1 s: 5 rad/s on average.
    with pytest.raises(GoalError, match=r'the move from the current state into points\[0\] needs arm1_elbow at 5 '
                                        r'rad/s on average; allowed: at most 2 rad/s') as info:
        _plan(JointTrajectory(('arm1_elbow',), np.array([1.0]), np.array([[-2.5]])))
    assert info.value.code == INVALID_GOAL
    with pytest.raises(GoalError, match=r'points\[1\] needs rod_1 at 0.2 m/s'):
        _plan(_two_points(['rod_1'], [0.254], [0.274], t=(1.0, 1.1)))
    with pytest.raises(GoalError, match=r'points\[0\].velocities: rod_1 = 0.2 m/s; allowed: at most 0.15 m/s'):
        _plan(JointTrajectory(('rod_1',), np.array([1.0]), np.array([[0.254]]), np.array([[0.2]])))


def test_a_segment_at_the_limit_keeps_it_once_its_times_are_whole_nanoseconds():
    """``gpr program export --trajectory --rate 7`` timed a segment exactly at arm1_shoulder's 1.5 rad/s over 1/7 s;
    its message's whole nanoseconds made it 0.86 ns shorter, 6e-9 above the limit, and the simulator refused what the
    command's check (of the unrounded times) passed: a segment is granted the message's 1 ns quantum."""
    from gpr_kinematics.robot.controller import TIME_QUANTUM
    v = JOINTS.velocity[3]                                              # arm1_shoulder
    t = np.array([10.0, 11.0]) / 7.0
    ns = np.round(t * 1e9) / 1e9                                         # as a message carries them
    assert 0.8e-9 < np.diff(t)[0] - np.diff(ns)[0] < TIME_QUANTUM == 1e-9
    start = JOINTS.rest[3]
    for times in (t, ns):
        _plan(_two_points(['arm1_shoulder'], [start], [start + v / 7.0], t=tuple(times)))
    with pytest.raises(GoalError, match=r'points\[1\] needs arm1_shoulder at 1.5 rad/s on average'):  # 2 ns shorter
        _plan(_two_points(['arm1_shoulder'], [start], [start + v / 7.0], t=(ns[0], ns[0] + np.diff(t)[0] - 2e-9)))


@pytest.mark.parametrize('mean, refused', [(0.9, True), (0.66, False)])
def test_a_spline_faster_than_the_limit_between_its_points_is_refused_at_its_sample(mean, refused):
    """Two points at rest 1 s apart on the elbow (2 rad/s), ``mean`` of its limit on average: the cubic's velocity
    ``6 d u (1 - u)`` peaks at 1.5 times the mean mid-way (1.35 times the limit: it was accepted and moved so; 0.99:
    within it). Refused at the first sample beyond the limit and 1 %, the value the spline's."""
    d = 2.0 * mean
    home = float(JOINTS.rest[JOINTS.names.index('arm1_elbow')])
    traj = JointTrajectory(('arm1_elbow',), np.array([1.0, 2.0]), np.array([[home], [home - d]]), np.zeros((2, 1)))
    if not refused:
        m = _plan(traj)
        assert float(np.max(np.abs(m.velocities))) == pytest.approx(1.5 * d, abs=1e-12)   # at t = 1.5 s, a sample
        return
    with pytest.raises(GoalError) as info:
        _plan(traj)
    roots = np.roots([-6.0 * d, 6.0 * d, -1.01 * 2.0])            # 6 d u (1 - u) = 1.01 x 2 rad/s
    first = 1.0 + math.ceil(float(np.min(roots)) * RATE) / RATE   # the first sample beyond it
    k = round(first * RATE)
    v = -6.0 * d * (first - 1.0) * (2.0 - first)
    assert info.value.code == INVALID_GOAL
    assert str(info.value) == (f'sample {k} (t = {first:.6g} s): arm1_elbow moves at {v:.6g} rad/s (the spline '
                               'between the points overshoots); allowed: at most 2.02 rad/s in size (the limit 2 and '
                               "1% for a spline through a timed motion's samples; give the points other velocities, "
                               'later times or more points)')   # it had velocities (0): 'give them' was no help


@pytest.mark.parametrize('program, rate, overshoot', [('example_robot_program.yaml', 10.0, 1.0021486),
                                                      ('example_cell_program.yaml', 10.0, 1.0062579),
                                                      ('example_cell_program.yaml', 100.0, 1.0000605)])
def test_the_example_programs_as_sent_are_within_the_spline_slack(program, rate, overshoot):
    """``gpr program send``'s goals (the program's samples at ``rate`` with their velocities: a cubic) move at most
    ``overshoot`` times a joint's limit between their points (scanned at 1 kHz), under the 1 % the check allows; the
    controller's 100 Hz samples pass (those between the points at 10 Hz above the limit)."""
    from gpr_kinematics.inputs.resources import config_path
    from gpr_kinematics.robot.plan import plan_program
    from gpr_kinematics.robot.program import load_program
    from gpr_kinematics.robot.trajectory import program_trajectory

    traj = program_trajectory(plan_program(ROBOT, load_program(config_path(f'programs/{program}'))), rate)
    cols = JOINTS.indices(traj.joint_names)
    _, vel, _ = evaluate(traj, traj.positions[0], np.arange(0.0, traj.duration, 1e-3))
    assert float(np.max(np.abs(vel) / JOINTS.velocity[cols])) == pytest.approx(overshoot, abs=1e-6)
    current = JOINTS.rest.copy()
    current[cols] = traj.positions[0]
    m = _plan(traj, current)
    peak = float(np.max(np.abs(m.velocities[:, cols]) / JOINTS.velocity[cols]))   # 1 where the samples are the points
    assert (peak > 1.0 if rate < RATE else peak == pytest.approx(1.0, abs=1e-12)) and peak <= overshoot


def test_a_goal_under_way_at_its_splines_peak_is_checked_as_its_samples():
    """The example cell program as sent at 10 Hz (a cubic peaking at 1.00626 times a limit between its points,
    accepted on time) arriving late at that peak with the joints on it: the cut point carries the spline's velocity
    there, which the points' strict check refused ('points[0].velocities: ... allowed: at most'); under way it is a
    sample, within the samples' 1 %, and the motion goes on as the original's (to 1e-12)."""
    from gpr_kinematics.inputs.resources import config_path
    from gpr_kinematics.robot.plan import plan_program
    from gpr_kinematics.robot.program import load_program
    from gpr_kinematics.robot.trajectory import program_trajectory

    plan = plan_program(ROBOT, load_program(config_path('programs/example_cell_program.yaml')))
    traj = program_trajectory(plan, 10.0)
    cols = JOINTS.indices(traj.joint_names)
    t = np.arange(0.0, traj.duration, 1e-3)
    _, vel, _ = evaluate(traj, traj.positions[0], t)
    ratio = np.abs(vel) / JOINTS.velocity[cols]
    i, k = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
    late = float(t[i])
    assert ratio[i, k] == pytest.approx(1.0062579, abs=1e-6)
    current = JOINTS.rest.copy()
    current[cols] = evaluate(traj, traj.positions[0], np.array([late]))[0][0]
    cut = late_start(JOINTS, traj, current, late, 1e-3)
    with pytest.raises(GoalError, match=r'points\[0\]\.velocities: '):
        _plan(cut, current)
    m = _plan(cut, current, under_way=True)
    ahead = m.time[m.time <= traj.duration - late]
    expected = evaluate(traj, traj.positions[0], late + ahead)[0]
    np.testing.assert_allclose(m.positions[:ahead.size][:, cols], expected, rtol=0.0, atol=1e-12)


def test_a_first_point_at_time_zero_must_be_where_the_robot_is():
    at_rest = JOINTS.rest[JOINTS.names.index('arm1_elbow')]
    assert len(_plan(JointTrajectory(('arm1_elbow',), np.array([0.0, 1.0]), np.array([[at_rest], [2.0]])))) == 101
    with pytest.raises(GoalError, match=r'points\[0\] at time_from_start 0 puts arm1_elbow 0.5 rad from where it is '
                                        r'\(2.5 rad\); allowed: at most 0\.001 rad \(start_tolerance\)'):   # its unit
        _plan(JointTrajectory(('arm1_elbow',), np.array([0.0, 1.0]), np.array([[2.0], [2.0]])))


def test_a_platform_tilt_beyond_the_limit_is_refused_at_its_sample():
    """Each rod within its stroke, but together they tilt the platform beyond tilt_limit."""
    d = 1.3 * CFG.tilt_limit * 1.5 * CFG.radius          # rod 1 this much above the others: about 1.3 tilt_limit
    q = [0.25 + d, 0.25, 0.25]
    assert forward_batch(np.array([q]), CFG, check_limits=False).tilt[0] > CFG.tilt_limit
    traj = JointTrajectory(('rod_1', 'rod_2', 'rod_3'), np.array([4.0]), np.array([q]))
    with pytest.raises(GoalError, match=r'sample \d+ \(t = [\d.]+ s\): the platform would tilt [\d.]+ rad .*allowed: '
                                        r'at most tilt_limit') as info:
        _plan(traj)
    assert info.value.code == INVALID_GOAL


def test_rods_inverse_kinematics_answers_at_the_tilt_limit_are_a_valid_goal():
    """Rods of ``inverse`` at exactly tilt_limit at 200 azimuths: 51 of them tilted the platform up to 9.5e-16 rad
    beyond the limit, and the goal was refused; the controller allows forward kinematics' slack now."""
    from gpr_kinematics import inverse
    accepted = 0
    for az in np.linspace(-math.pi, math.pi, 60, endpoint=False):
        q = inverse(0.3, CFG.tilt_limit, az, CFG).q
        traj = JointTrajectory(('rod_1', 'rod_2', 'rod_3'), np.array([4.0]), np.array([q]))
        assert _plan(traj).positions[-1, :3] == pytest.approx(q, abs=1e-15)
        accepted += 1
    assert accepted == 60


def test_the_clearance_hook_sees_the_checked_motion_and_refuses():
    """The hook gets the motion the controller would run (its trajectory, the goal's joints, every joint at the
    start and at the samples) after every other check, and its refusal is an INVALID_GOAL with its words."""
    seen = {}

    def clearance(motion):
        seen['motion'] = motion
        return 'arm1_blade would hit chamber_a at t = 1.2 s' if motion.positions[:, 4].max() > 1.2 else None

    traj = _two_points(['arm1_elbow'], [2.0], [1.0])
    with pytest.raises(GoalError, match='arm1_blade would hit chamber_a') as info:
        _plan(traj, clearance=clearance)
    m = seen['motion']
    assert info.value.code == INVALID_GOAL and m.positions.shape == (201, len(JOINTS.names))
    assert m.trajectory is traj and list(m.goal) == [JOINTS.names.index('arm1_elbow')]
    np.testing.assert_array_equal(m.positions[0], JOINTS.rest)
    assert len(_plan(traj, clearance=lambda motion: None)) == 201
    seen.clear()
    with pytest.raises(GoalError, match='beyond its upper limit'):      # refused before the hook is asked
        _plan(_two_points(['arm1_elbow'], [99.0]), clearance=clearance)
    assert not seen


def test_tolerances_follow_control_msgs_rules():
    n = len(JOINTS.names)
    elbow, rod1 = JOINTS.names.index('arm1_elbow'), 0
    tol = resolve_tolerances(JOINTS, DEFAULTS, [('arm1_elbow', 0.01, 0.2, 0.0), ('rod_1', -1.0, 0.0, 5.0)],
                             [('arm1_elbow', 0.0, -1.0, 0.0), ('rod_1', 1e-5, 0.0, 0.0)], 0.0)
    assert tol.path_position[elbow] == 0.01 and tol.path_velocity[elbow] == 0.2
    assert math.isinf(tol.path_position[rod1])                  # -1: not checked
    assert np.isinf(np.delete(tol.path_position, [elbow])).all()  # the default 0: not checked
    assert tol.goal_position[elbow] == 1e-3                     # 0: the default
    assert tol.goal_position[rod1] == 1e-5 and np.isinf(tol.goal_velocity).all()
    assert tol.goal_time == 0.5                                 # 0: the default
    assert resolve_tolerances(JOINTS, DEFAULTS, [], [], 2.0).goal_time == 2.0
    assert tol.goal_position.shape == (n,)
    for entry, words in ((('arm1_elbow', -0.5, 0.0, 0.0), r'path_tolerance\[0\].position = -0.5'),
                         (('arm1_elbow', 0.0, math.nan, 0.0), 'velocity = nan'),
                         (('nope', 0.1, 0.0, 0.0), r"path_tolerance\[0\].name: unknown joint 'nope'")):
        with pytest.raises(GoalError, match=words) as info:
            resolve_tolerances(JOINTS, DEFAULTS, [entry], [], 0.0)
        assert info.value.code == INVALID_GOAL   # a bad tolerance, an unknown joint's too (it was INVALID_JOINTS)
    with pytest.raises(GoalError, match='goal_time_tolerance = -1.0 s'):
        resolve_tolerances(JOINTS, DEFAULTS, [], [], -1.0)
    with pytest.raises(GoalError, match='goal_tolerance has 11 entries; allowed: at most one per joint'):
        resolve_tolerances(JOINTS, DEFAULTS, [], [('rod_1', 0.1, 0.0, 0.0)] * 11, 0.0)
    with pytest.raises(GoalError, match=r"goal_tolerance\[1\] names joint 'rod_1' as goal_tolerance\[0\] does"):
        resolve_tolerances(JOINTS, DEFAULTS, [], [('rod_1', 0.1, 0.0, 0.0), ('rod_1', 0.2, 0.0, 0.0)], 0.0)
    with pytest.raises(GoalError, match=r'goal_time_tolerance = 2147483648.0 s; .* at most 86400 s'):
        resolve_tolerances(JOINTS, DEFAULTS, [], [], 2.0 ** 31)


def test_servo_is_exact_first_order_and_tolerance_violations_are_named():
    a, d = np.array([0.0, 1.0]), np.array([1.0, 1.0])
    assert np.array_equal(servo(a, d, 0.01, 0.0), d)
    np.testing.assert_allclose(servo(a, d, 0.01, 0.1), [1.0 - math.exp(-0.1), 1.0], rtol=0, atol=1e-15)
    # Two steps of dt equal one of 2 dt (a constant target): the discrete response is the exact one.
    np.testing.assert_allclose(servo(servo(a, d, 0.01, 0.1), d, 0.01, 0.1), servo(a, d, 0.02, 0.1), rtol=0,
                               atol=1e-15)
    n = len(JOINTS.names)
    tol = Tolerances.uniform(n, 0.01, 0.001, 0.5)
    err = np.zeros(n)
    cols = np.arange(n)
    assert violation(JOINTS, cols, err, err, tol.path_position, tol.path_velocity, 'path') is None
    err[4] = 0.02
    assert violation(JOINTS, cols, err, np.zeros(n), tol.path_position, tol.path_velocity, 'path') == \
        'arm1_elbow: position error 0.02 rad exceeds the path tolerance 0.01 rad'
    assert violation(JOINTS, np.array([0, 1]), err, np.zeros(n), tol.path_position, tol.path_velocity, 'path') is None
    assert PATH_TOLERANCE_VIOLATED == -4 and GOAL_TOLERANCE_VIOLATED == -5


def test_quintic_goal_from_rest_is_checked_along_the_path():
    """With velocities and accelerations the samples follow the quintic; a quintic that overshoots the stroke between
    its points is refused at the sample where it does, although both points are inside."""
    top = CFG.stroke_max - 1e-4
    traj = JointTrajectory(('rod_1',), np.array([2.0, 2.5]), np.array([[top], [top]]), np.array([[0.1], [0.0]]),
                           np.zeros((2, 1)))
    pos, _, _ = evaluate(traj, JOINTS.rest[:1], np.linspace(2.0, 2.5, 51))
    assert pos.max() > CFG.stroke_max
    with pytest.raises(GoalError, match=r'sample \d+ \(t = 2\.\d+ s\): rod_1 = 0.508\d* m is beyond its upper limit '
                                        r'0.508 m by'):
        _plan(traj)


def test_joint_states_give_the_finite_values_of_known_joints():
    k, v, left = joint_state_values(JOINTS.names, ['other', 'rod_2', 'arm1_elbow', 'rod_1', 'arm1_wrist'],
                                    [9.0, 0.31, 0.5, math.nan, math.inf])
    assert k.tolist() == [1, JOINTS.names.index('arm1_elbow')] and v.tolist() == [0.31, 0.5]
    assert left == ['rod_1', 'arm1_wrist']   # named for the callers' warning (they were dropped without a word)
    k, v, left = joint_state_values(JOINTS.names, ['rod_1', 'rod_2'], [])   # velocities only: no position taken
    assert k.size == 0 and v.size == 0 and left == []


@pytest.mark.parametrize('names, positions, words', [
    (['rod_1', 'rod_2', 'rod_3'], [0.3, 0.31], '3 names and 2 positions; allowed: one position per name, or none'),
    (['rod_1'], [0.3, 0.31, 0.32], '1 names and 3 positions'),
    (['rod_1', 'rod_2', 'rod_1'], [0.3, 0.31, 0.32], "joint 'rod_1' named twice; allowed: each joint once"),
])
def test_malformed_joint_states_are_refused(names, positions, words):
    """A JointState of three names and two positions moved rod_1 and rod_2 (the first values taken, misaligned or
    not); rod_1 named twice took the last of its values."""
    with pytest.raises(InputError, match=words):
        joint_state_values(JOINTS.names, names, positions)


def test_a_joint_named_twice_is_found_in_one_pass():
    names = ['rod_1'] + [f'j{i}' for i in range(200_000)] * 2 + ['rod_1']   # other names may repeat: not ours
    with pytest.raises(InputError, match="'rod_1' named twice"):
        joint_state_values(JOINTS.names, names, [0.0] * len(names))


def _late_case(velocities: bool) -> tuple[JointTrajectory, np.ndarray]:
    """A three-point trajectory of arm1_elbow and rod_2 from where the robot rests (first point at t = 0), with
    velocities (cubic) or without (linear); the robot's rest state."""
    cols = JOINTS.indices(['arm1_elbow', 'rod_2'])
    rest = JOINTS.rest.copy()
    P = np.array([rest[cols], rest[cols] + [-0.4, 0.002], rest[cols] + [-0.8, 0.001]])
    V = np.array([[0.0, 0.0], [-0.3, 0.0005], [0.0, 0.0]]) if velocities else None
    return JointTrajectory(('arm1_elbow', 'rod_2'), np.array([0.0, 1.0, 2.5]), P, V), rest


@pytest.mark.parametrize('velocities', [False, True])
def test_a_stamp_in_the_past_continues_the_trajectory_under_way(velocities):
    """joint_trajectory_controller's rule for a header.stamp in the past: refused only when the trajectory ended before
    the goal arrived. Under way, the rest of it from the arrival is the same motion: the new trajectory at s equals the
    goal's at s + late (the spline evaluated independently at both); it was refused OLD_HEADER_TIMESTAMP whenever the
    stamp lay more than one sample period in the past (a goal stamped by its client and 86 ms in transit)."""
    traj, rest = _late_case(velocities)
    cols = JOINTS.indices(traj.joint_names)
    for late in (0.3, 1.0, 1.7):
        cut = late_start(JOINTS, traj, rest, late, start_tolerance=1.0)
        assert cut.time[0] == 0.0 and cut.degree == traj.degree
        np.testing.assert_allclose(cut.time[1:] + late, traj.time[traj.time > late], rtol=0, atol=1e-15)
        s = np.linspace(0.0, traj.duration - late, 101)
        new, old = evaluate(cut, rest[cols], s), evaluate(traj, rest[cols], s + late)
        for a, b in zip(new[:2], old[:2], strict=True):      # positions and velocities
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)
        there = rest.copy()   # the robot where the trajectory is at the arrival: a valid goal from there
        there[cols] = evaluate(traj, rest[cols], np.array([late]))[0][0]
        motion = plan_motion(JOINTS, cut, there, RATE, CFG, DEFAULTS, 1.0, under_way=True)
        np.testing.assert_allclose(motion.positions[-1, cols], traj.positions[-1], rtol=0, atol=1e-15)
    # the state at the arrival farther from where the joints are than start_tolerance: refused, naming the joint
    with pytest.raises(GoalError, match=r'header.stamp lies 0.3 s in the past: at its arrival the trajectory puts '
                       r'arm1_elbow 0.12 rad from where it is .*start_tolerance') as e:
        late_start(JOINTS, _late_case(False)[0], rest, 0.3, start_tolerance=1e-3)
    assert e.value.code == INVALID_GOAL


def test_a_stamp_in_the_past_keeps_a_first_point_ahead_at_its_instant_and_refuses_an_ended_trajectory():
    traj, rest = _late_case(False)
    later = traj.shifted(1.0)                  # the first point 1 s after the stamp
    cut = late_start(JOINTS, later, rest, 0.25, start_tolerance=0.0)
    np.testing.assert_array_equal(cut.positions, later.positions)
    np.testing.assert_allclose(cut.time, later.time - 0.25, rtol=0, atol=0)
    assert late_start(JOINTS, later, rest, 0.0, 0.0) is later
    for late in (3.5, 10.0):                   # ended (at 3.5 s) before it arrived
        with pytest.raises(GoalError, match=rf'header.stamp lies {late:g} s in the past: the trajectory \(3.5 s\) '
                           'ended before it arrived; allowed: 0') as e:
            late_start(JOINTS, later, rest, late, 0.0)
        assert e.value.code == OLD_HEADER_TIMESTAMP


@pytest.mark.parametrize('times', [(0.5, 1.0), (0.503, 0.508)], ids=['samples inside', 'between two samples'])
def test_a_spline_that_overflows_is_an_invalid_goal(times):
    """A point's acceleration of 1e308 (finite, as the points' check asks) makes the quintic's coefficients inf - inf:
    its samples were NaN, which no limit comparison caught, and the goal succeeded publishing NaN joint states (with
    a cell the clearance search never settled: minutes and gigabytes). Refused with its reason, also where the
    segment lies between two samples."""
    a = float(JOINTS.rest[JOINTS.indices(['arm1_elbow'])[0]])
    traj = _points(['arm1_elbow'], list(times), [[a], [a - 0.001]], [[0.0], [0.0]], [[0.0], [1e308]])
    with pytest.raises(GoalError, match=r'^the spline between the points overflows; allowed: velocities and '
                                        r'accelerations that keep it finite$') as info:
        _plan(traj)
    assert info.value.code == INVALID_GOAL
    ok = _points(['arm1_elbow'], list(times), [[a], [a - 0.001]], [[0.0], [0.0]], [[0.0], [0.0]])
    assert np.all(np.isfinite(_plan(ok).positions))


def test_a_first_point_at_time_zero_is_reached_in_one_sample_within_the_velocity_limits():
    """A first point at t = 0 within start_tolerance (1 rad, in its range) but 1 rad away: the joints jumped there in
    one 10 ms sample (100 rad/s against 1.5 rad/s). Now the jump is within one sample at the velocity limit or
    refused; a first point after 0 s is reached along the spline as before."""
    k = JOINTS.names.index('arm1_shoulder')
    rest = float(JOINTS.rest[k])
    reach = 1.5 / RATE   # arm1_shoulder's velocity limit for one sample

    def first(q0):
        return JointTrajectory(('arm1_shoulder',), np.array([0.0, 2.0]), np.array([[q0], [rest + 1.2]]))

    with pytest.raises(GoalError) as e:
        _plan(first(rest + 1.0), start_tolerance=1.0)
    assert e.value.code == INVALID_GOAL
    assert str(e.value) == ('points[0] at time_from_start 0 makes arm1_shoulder jump 1 rad from where it is (0 rad) '
                            'in one sample (0.01 s at rate 100 Hz): 100 rad/s; allowed: at most 0.015 rad (its '
                            'velocity limit 1.5 rad/s for one sample), or a first point after 0 s, which the joints '
                            'then reach from where they are')
    m = _plan(first(rest + reach), start_tolerance=1.0)   # one sample at the limit: taken
    assert m.positions[0, k] == rest + reach and np.array_equal(m.current, JOINTS.rest)
    with pytest.raises(GoalError, match=r'jump 0.0151 rad .* 1.51 rad/s; allowed: at most 0.015 rad'):
        _plan(first(rest + 0.0151), start_tolerance=1.0)
    later = JointTrajectory(('arm1_shoulder',), np.array([1.0, 2.0]), np.array([[rest + 1.0], [rest + 1.2]]))
    assert len(_plan(later, start_tolerance=1e-3)) == 201   # from where it is, along the spline: unchanged
