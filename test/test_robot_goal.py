"""A FollowJointTrajectory goal checked and planned from its fields (``robot.goal``), without ROS: the rules
``robot_simulator_node`` applies before it moves, each against a number computed here."""
from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest
from gpr_kinematics.robot.controller import INVALID_GOAL, OLD_HEADER_TIMESTAMP, ControllerJoints, GoalError, Tolerances
from gpr_kinematics.robot.goal import Controller, Goal, check_point_count, plan_goal
from gpr_kinematics.robot.servo import servo
from gpr_kinematics.robot.trajectory import MAX_DURATION, MAX_POINTS
from robot_support import ROBOT

JOINTS = ControllerJoints.of(ROBOT)
RATE = 100.0
CONTROLLER = Controller(JOINTS, Tolerances.uniform(len(JOINTS.names), 0.0, 1e-3, 0.5), RATE, ROBOT.config, 1e-3,
                        False)
NS = 1_000_000_000
NOW = 1_000 * NS


def _goal(times=(1.0, 2.0), stamp_ns=0, velocities=([], []), **fields) -> Goal:
    """arm1_elbow from rest to rest + 0.4 rad and back to rest + 0.2 rad at ``times`` [s]."""
    k = JOINTS.names.index('arm1_elbow')
    rest = float(JOINTS.rest[k])
    parts = dict(joint_names=['arm1_elbow'], times=list(times), positions=[[rest + 0.4], [rest + 0.2]],
                 velocities=list(velocities), accelerations=[[], []], efforts=False, multi_dof=False,
                 component_tolerances=False, path_tolerance=[], goal_tolerance=[], goal_time_tolerance=0.0,
                 stamp_ns=stamp_ns)
    parts.update(fields)
    return Goal(**parts)


def test_a_goal_at_once_starts_now_and_samples_at_the_rate():
    motion, start = plan_goal(_goal(), CONTROLLER, JOINTS.rest, NOW)
    assert start == NOW
    assert len(motion) == 201 and np.array_equal(motion.time, np.arange(201) / RATE)
    k = JOINTS.names.index('arm1_elbow')
    assert motion.positions[100, k] == JOINTS.rest[k] + 0.4 and motion.positions[200, k] == JOINTS.rest[k] + 0.2


@pytest.mark.parametrize('fields, words', [
    (dict(multi_dof=True), 'multi_dof_trajectory: this robot has no multi-DOF joints'),
    (dict(component_tolerances=True), 'component tolerances apply to multi-DOF joints'),
    (dict(efforts=True), 'points carry efforts; allowed: positions, velocities and accelerations'),
    (dict(velocities=[[0.0], [0.25]]), r'points\[1\] \(the last\) gives arm1_elbow a velocity of 0.25 rad/s; allowed: '
                                      '0 at the last point'),
])
def test_fields_this_controller_does_not_take_are_invalid_goals(fields, words):
    with pytest.raises(GoalError, match=words) as e:
        plan_goal(_goal(**fields), CONTROLLER, JOINTS.rest, NOW)
    assert e.value.code == INVALID_GOAL


def test_a_last_velocity_is_taken_where_the_parameter_allows_it():
    moving = Controller(*[getattr(CONTROLLER, f) for f in ('joints', 'defaults', 'rate', 'config', 'start_tolerance')],
                        True)
    motion, _ = plan_goal(_goal(velocities=[[0.0], [0.25]]), moving, JOINTS.rest, NOW)
    assert motion.velocities[-1, JOINTS.names.index('arm1_elbow')] == 0.25


def test_one_list_of_each_kind_per_point():
    """A goal's points each carry their lists (a message cannot do otherwise); the Python API is held to it (two lists
    for one point raised StopIteration)."""
    with pytest.raises(GoalError, match=r'0 lists of velocities for 2 points; allowed: one list per point'):
        plan_goal(_goal(velocities=[]), CONTROLLER, JOINTS.rest, NOW)
    with pytest.raises(GoalError, match=r'1 lists of positions for 2 points'):
        plan_goal(_goal(positions=[[0.1]]), CONTROLLER, JOINTS.rest, NOW)


def test_the_point_count_is_bounded_before_the_points_are_read():
    check_point_count(MAX_POINTS)
    with pytest.raises(GoalError, match=f'the trajectory has {MAX_POINTS + 1} points; allowed: at most {MAX_POINTS}'):
        check_point_count(MAX_POINTS + 1)


def test_a_stamp_ahead_waits_for_it_within_a_day():
    ahead = NOW + 5 * NS
    assert plan_goal(_goal(stamp_ns=ahead), CONTROLLER, JOINTS.rest, NOW)[1] == ahead
    far = NOW + round(MAX_DURATION * NS) + 1
    with pytest.raises(GoalError, match=r'header.stamp lies 86400 s ahead; allowed: at most 86400 s') as e:
        plan_goal(_goal(stamp_ns=far), CONTROLLER, JOINTS.rest, NOW)
    assert e.value.code == INVALID_GOAL


def test_a_stamp_within_one_period_in_the_past_starts_at_the_stamp():
    stamp = NOW - NS // 200   # half a sample period
    motion, start = plan_goal(_goal(stamp_ns=stamp), CONTROLLER, JOINTS.rest, NOW)
    assert start == stamp and len(motion) == 201


def test_a_late_goal_goes_on_from_the_next_sample_on_its_stamps_grid():
    """Stamped 1.234 s ago: the first point (at 1 s) is under way, so the motion goes on from the next sample on the
    stamp's grid, 1.24 s after it: its start is stamp + 1.24 s and its samples are the on-time goal's from there."""
    stamp = NOW - 1_234_000_000
    on_time, _ = plan_goal(_goal(), CONTROLLER, JOINTS.rest, NOW)
    k = JOINTS.names.index('arm1_elbow')
    there = on_time.positions[124]   # where the robot is when the goal arrives (as if it had run on time)
    assert there[k] == pytest.approx(JOINTS.rest[k] + 0.4 - 0.2 * 0.24, abs=1e-12)
    motion, start = plan_goal(_goal(stamp_ns=stamp), CONTROLLER, there, NOW)
    assert start == stamp + 1_240_000_000
    np.testing.assert_allclose(motion.positions[:, k], on_time.positions[124:, k], rtol=0, atol=1e-12)
    with pytest.raises(GoalError, match=r'header.stamp lies 1.24 s in the past: at its arrival the trajectory puts '
                       r'arm1_elbow 0.352 rad from where it is'):   # from rest instead: too far from the robot
        plan_goal(_goal(stamp_ns=stamp), CONTROLLER, JOINTS.rest, NOW)


def test_a_late_goal_whose_first_point_is_still_ahead_keeps_it_at_its_instant():
    """Stamped 0.5 s ago with the first point at 1 s: the points keep their instants (the grid's next sample would
    not pass the point), the start is the arrival, 0.5 s after the stamp."""
    stamp = NOW - NS // 2
    motion, start = plan_goal(_goal(stamp_ns=stamp), CONTROLLER, JOINTS.rest, NOW)
    assert start == stamp + NS // 2
    k = JOINTS.names.index('arm1_elbow')
    assert motion.time[-1] == pytest.approx(1.5, abs=1e-12)
    assert motion.positions[-1, k] == JOINTS.rest[k] + 0.2


def test_a_goal_that_ended_before_it_arrived_is_an_old_header_timestamp():
    with pytest.raises(GoalError, match=r'header.stamp lies 3 s in the past: the trajectory \(2 s\) ended before it '
                       'arrived') as e:
        plan_goal(_goal(stamp_ns=NOW - 3 * NS), CONTROLLER, JOINTS.rest, NOW)
    assert e.value.code == OLD_HEADER_TIMESTAMP


def test_a_late_goals_refusal_says_its_times_count_from_the_arrival():
    """A late goal refused by the planner (too fast once late) names the arrival's offset."""
    k = JOINTS.names.index('arm1_elbow')
    rest = float(JOINTS.rest[k])
    goal = _goal(times=(0.5, 0.51), positions=[[rest + 0.4], [rest + 3.0]], stamp_ns=NOW - NS // 4)
    with pytest.raises(GoalError, match=r"\(times from the goal's arrival, 0.25 s after its header.stamp\)"):
        plan_goal(goal, CONTROLLER, JOINTS.rest, NOW)


@pytest.mark.parametrize('late_ns', [1_110_000_000, 1_120_000_000])
def test_a_stamp_late_by_a_whole_number_of_samples_starts_on_that_sample(late_ns):
    """1.11 s (1.12 s) late at 100 Hz: late / period is 111.00000000000001 (112.00000000000001) in floating point; the
    goal goes on from the sample at stamp + 1.11 s (1.12 s), not from the one after."""
    k = JOINTS.names.index('arm1_elbow')
    on_time, _ = plan_goal(_goal(), CONTROLLER, JOINTS.rest, NOW)
    n = late_ns // 10_000_000
    motion, start = plan_goal(_goal(stamp_ns=NOW - late_ns), CONTROLLER, on_time.positions[n], NOW)
    assert start == NOW
    assert len(motion) == 201 - n
    np.testing.assert_allclose(motion.positions[:, k], on_time.positions[n:, k], rtol=0, atol=1e-12)


def test_an_on_time_goals_refusal_does_not_speak_of_an_arrival():
    """A goal at once (and one stamped within a period of now) refused by the planner: its message is the planner's,
    without the late goal's '(times from the goal's arrival ...)'."""
    k = JOINTS.names.index('arm1_elbow')
    rest = float(JOINTS.rest[k])
    for stamp in (0, NOW - NS // 200):
        goal = _goal(times=(0.5, 0.51), positions=[[rest + 0.4], [rest + 3.0]], stamp_ns=stamp)
        with pytest.raises(GoalError) as e:
            plan_goal(goal, CONTROLLER, JOINTS.rest, NOW)
        assert str(e.value) and 'arrival' not in str(e.value) and 'header.stamp' not in str(e.value)


def test_a_goal_late_by_less_than_its_duration_runs_its_last_samples():
    """Times (1, 2) stamped 1.995 s ago: the next sample on the grid (2 s) is the end, so the goal goes on from its
    arrival for the last 5 ms (not refused as ended before it arrived)."""
    k = JOINTS.names.index('arm1_elbow')
    rest = float(JOINTS.rest[k])
    there = JOINTS.rest.copy()
    there[k] = rest + 0.4 - 0.2 * 0.995    # where the goal puts the joint at 1.995 s (a straight segment)
    motion, start = plan_goal(_goal(stamp_ns=NOW - 1_995_000_000), CONTROLLER, there, NOW)
    assert start == NOW
    assert len(motion) == 2 and motion.time[-1] == pytest.approx(0.005, abs=1e-12)
    assert motion.positions[-1, k] == rest + 0.2
    assert motion.positions[0, k] == pytest.approx(rest + 0.201, abs=1e-12)


def test_a_first_point_on_the_grids_next_sample_is_still_ahead_at_the_arrival():
    """Stamped 0.995 s ago with the first point at 1 s, exactly on the grid's next sample: the point is still ahead,
    so the points keep their instants and the joints reach it from where they are (0.01 rad away) in the 5 ms left;
    taken as under way from 1 s, the goal would be refused 0.01 rad from the robot."""
    k = JOINTS.names.index('arm1_elbow')
    rest = float(JOINTS.rest[k])
    current = JOINTS.rest.copy()
    current[k] = rest + 0.39
    motion, start = plan_goal(_goal(stamp_ns=NOW - 995_000_000), CONTROLLER, current, NOW)
    assert start == NOW
    assert motion.time[-1] == pytest.approx(1.005, abs=1e-12)
    assert motion.positions[0, k] == rest + 0.39 and motion.positions[-1, k] == rest + 0.2


def test_a_stamp_exactly_the_longest_wait_ahead_is_taken():
    ahead = NOW + round(MAX_DURATION * NS)
    assert plan_goal(_goal(stamp_ns=ahead), CONTROLLER, JOINTS.rest, NOW)[1] == ahead
    with pytest.raises(GoalError, match=r'header.stamp lies 86400 s ahead; allowed: at most 86400 s'):
        plan_goal(_goal(stamp_ns=ahead + 1), CONTROLLER, JOINTS.rest, NOW)


def test_a_goal_that_would_run_past_the_int32_sec_of_a_stamp_is_refused():
    # a stamp near 2038: the feedback and joint_states stamps after 2^31 s wrapped negative (or failed rclpy's check)
    stamp = (2**31 - 2) * NS   # 2 s before the end; the goal lasts 2 s, goal_time 0.5 s
    with pytest.raises(GoalError) as e:
        plan_goal(_goal(stamp_ns=stamp), CONTROLLER, JOINTS.rest, stamp)
    assert e.value.code == INVALID_GOAL
    assert str(e.value) == ('the goal would run until 2147483648.5 s on the clock, beyond the int32 sec of a message '
                            'stamp; allowed: a goal ending by 2147483647 s (2038-01-19T03:14:07Z)')
    assert plan_goal(_goal(stamp_ns=stamp - NS), CONTROLLER, JOINTS.rest, stamp - NS)[1] == stamp - NS


def test_a_clock_set_back_more_than_a_sample_period_aborts_the_goal_naming_the_jump():
    from gpr_kinematics.robot.goal import clock_set_back

    assert clock_set_back(NOW, NOW + 1, 0.01, 0.5) is None   # forward
    assert clock_set_back(NOW, NOW - 10_000_000, 0.01, 0.5) is None   # jitter: one period back at most
    assert clock_set_back(1001 * NS, 10 * NS, 0.01, 1.0) == (
        'the clock was set back 991 s (from 1001 s to 10 s) at t = 1 s of the goal: its samples are stamped on that '
        'clock; allowed: a clock that does not go back while a goal runs (send the goal again)')
    assert clock_set_back(NOW, NOW - 10_000_001, 0.01, None) == (
        'the clock was set back 0.010000001 s (from 1000 s to 999.989999999 s) while it waited for its header.stamp: '
        'its samples are stamped on that clock; allowed: a clock that does not go back while a goal runs (send the '
        'goal again)')


def test_a_late_goal_under_way_is_not_jumped_to_beyond_the_velocity_limits():
    """Late by 0.3 s with start_tolerance 1 rad: the trajectory's state at the arrival lies 0.12 rad from where the
    elbow is; the joints jumped there in one sample (12 rad/s against 2 rad/s). Now refused, naming the jump."""
    loose = Controller(*[getattr(CONTROLLER, f) for f in ('joints', 'defaults', 'rate', 'config')], 1.0, False)
    k = JOINTS.names.index('arm1_elbow')
    goal = _goal(times=(0.0, 1.0), positions=[[float(JOINTS.rest[k])], [float(JOINTS.rest[k]) + 0.4]],
                 stamp_ns=NOW - 300_000_000)
    with pytest.raises(GoalError) as e:
        plan_goal(goal, loose, JOINTS.rest, NOW)
    assert e.value.code == INVALID_GOAL
    assert str(e.value) == ('the trajectory at its arrival makes arm1_elbow jump 0.12 rad from where it is (2.5 rad) '
                            'in one sample (0.01 s at rate 100 Hz): 12 rad/s; allowed: at most 0.02 rad (its velocity '
                            'limit 2 rad/s for one sample), or a stamp of 0 (start at once) or one whose first point '
                            "lies ahead (times from the goal's arrival, 0.3 s after its header.stamp)")
    there = JOINTS.rest.copy()
    there[k] += 0.12   # the robot where the trajectory is at the arrival: it goes on from there
    motion, _ = plan_goal(goal, loose, there, NOW)
    assert motion.positions[0, k] == pytest.approx(there[k], abs=1e-12)


def test_the_joints_a_goal_leaves_out_are_held_at_their_command_and_the_motion_is_read_only():
    """Lagging joints (``servo_time_constant``) a goal leaves out go on toward the last goal's end, ``held``: the
    motion is built with it (the simulator wrote it into the built, frozen motion); the goal's own joint starts from
    where it is, whatever ``held`` says of it."""
    k = JOINTS.names.index('arm1_elbow')
    held = JOINTS.rest.copy()
    held[:3] += 0.01   # the rods, level
    held[JOINTS.names.index('arm2_shoulder')] += 0.1
    held[k] += 1.0   # the goal's joint: not held
    current = JOINTS.rest + (held - JOINTS.rest) / 2   # half way there
    current[k] = JOINTS.rest[k]
    motion, _ = plan_goal(_goal(), CONTROLLER, current, NOW, held)
    others = np.setdiff1d(np.arange(len(JOINTS.names)), [k])
    assert np.array_equal(motion.positions[:, others], np.broadcast_to(held[others], (len(motion), others.size)))
    assert not motion.velocities[:, others].any()
    assert motion.positions[0, k] == current[k] and motion.positions[-1, k] == JOINTS.rest[k] + 0.2
    assert np.array_equal(motion.current, current)
    unheld, _ = plan_goal(_goal(), CONTROLLER, current, NOW)   # none held: where they are
    assert np.array_equal(unheld.positions[:, others], np.broadcast_to(current[others], (len(motion), others.size)))
    for name in ('time', 'positions', 'velocities', 'goal', 'current'):
        with pytest.raises(ValueError, match='read-only'):
            getattr(motion, name)[0] = 0
    current[0] = 0.3
    assert motion.current[0] != 0.3   # a copy: the caller's state stays its own (and writable)


LAGGING = dataclasses.replace(CONTROLLER, servo_time_constant=0.5)


def test_a_lagging_goal_is_planned_from_where_its_wait_leaves_the_joints():
    """With a lag (``servo_time_constant`` 0.5 s) the joints converge to the last command while a goal waits for its
    stamp (2 s): the motion starts where that leaves them, ``held + (current - held) exp(-2 / 0.5)``, the goal's own
    joint too; every sample then as the simulator steps it (``servo`` with the samples' spacing, the first without a
    step), and the wait's states lie on the line from the arrival to the first sample, never past it."""
    k, s = JOINTS.names.index('arm1_elbow'), JOINTS.names.index('arm1_shoulder')
    held = JOINTS.rest.copy()
    held[s] += 0.3
    held[k] += 0.1
    current = JOINTS.rest.copy()
    motion, start = plan_goal(_goal(stamp_ns=NOW + 2 * NS), LAGGING, current, NOW, held)
    lag = motion.lag
    assert start == NOW + 2 * NS and lag is not None and lag.wait == 2.0 and lag.tau == 0.5
    begin = held + (current - held) * math.exp(-4.0)
    np.testing.assert_allclose(motion.current, begin, rtol=0, atol=1e-15)
    assert np.array_equal(lag.samples[0], motion.current) and np.array_equal(lag.arrival, current)
    assert motion.positions[0, k] == motion.current[k] and motion.positions[5, s] == held[s]
    x = lag.samples[0]
    for i in range(1, len(motion)):
        x = servo(x, motion.positions[i], float(motion.time[i] - motion.time[i - 1]), 0.5)
        assert np.array_equal(lag.samples[i], x)
    assert abs(lag.samples[-1, k] - (JOINTS.rest[k] + 0.2)) > 1e-3   # still lagging at the last sample
    for t, f in ((0.0, 0.0), (1.0, 1.0 - math.exp(-2.0)), (2.0, 1.0 - math.exp(-4.0)), (9.0, 1.0 - math.exp(-4.0))):
        np.testing.assert_allclose(lag.waited(t), current + f * (held - current), rtol=0, atol=1e-15)
    end = motion.positions[-1]
    path, times = lag.path(motion.time, end)   # corners and the instants they are passed, from the arrival
    assert np.all(np.diff(times) > 0) and np.array_equal(path[0], current) and np.array_equal(path[-1], end)
    waits = np.flatnonzero(times < 2.0)
    assert waits.size == 24 and times[waits[-1] + 1] == 2.0   # the arrival, 23 corners tau ln 2 / 4 apart, the samples
    for j in waits:   # on the wait's line where the response is at that instant
        np.testing.assert_allclose(path[j], current + (1.0 - math.exp(-times[j] / 0.5)) * (held - current), rtol=0,
                                   atol=1e-15)
    assert np.array_equal(path[waits.size:waits.size + len(motion)], lag.samples)
    last = 2.0 + motion.duration
    for j in range(waits.size + len(motion), path.shape[0] - 1):   # the settling line likewise
        f = 1.0 - math.exp(-(times[j] - last) / 0.5)
        np.testing.assert_allclose(path[j], lag.samples[-1] + f * (end - lag.samples[-1]), rtol=0, atol=1e-15)
    assert 1.0 - math.exp(-(times[-2] - last) / 0.5) > 1.0 - 2.0 ** -19   # the last corner before the end
    at_once, _ = plan_goal(_goal(), LAGGING, current, NOW, held)   # no wait: from where they are, exactly
    assert np.array_equal(at_once.current, current) and at_once.lag.path(at_once.time, end)[1][0] == 0.0
    for name in ('arrival', 'command', 'samples'):
        with pytest.raises(ValueError, match='read-only'):
            getattr(lag, name)[0] = 0
    assert np.array_equal(lag.waited(-1.0), current)   # before the arrival: there, not extrapolated back
    late, _ = plan_goal(_goal(stamp_ns=NOW - NS // 2), LAGGING, current, NOW, held)   # a stamp 0.5 s in the past
    assert late.late == pytest.approx(0.5) and late.lag is not None and late.lag.wait == 0.0


def test_the_joints_lagging_into_a_tilt_are_refused():
    """Rod 1 30 mm above the others at the arrival, commanded level by the last goal, a goal on the elbow: the
    samples (the rods at their command) are level, the joints converging there are not at first: refused naming
    the lagging joints' sample."""
    current = JOINTS.rest.copy()
    current[0] += 0.03
    with pytest.raises(GoalError) as e:
        plan_goal(_goal(), LAGGING, current, NOW, JOINTS.rest)
    assert re.fullmatch(r'the joints at sample 0 \(t = 0 s\): the platform would tilt [\d.]+ rad \(rods 0\.284, '
                        r'0\.254, 0\.254 m; lagging 0\.5 s \(servo_time_constant\) behind the samples\); allowed: at '
                        r'most tilt_limit [\d.e-]+ rad', str(e.value)), str(e.value)
    assert plan_goal(_goal(), CONTROLLER, current, NOW, JOINTS.rest)[0].lag is None   # no lag: the samples level


def test_the_lag_moves_on_the_lines_between_its_samples():
    """Under a command held over a step the first-order response ``d + (x - d) exp(-t / tau)`` stays on the line from
    the sample before to the sample after (one factor for every joint): 200 random steps, the response at 7 instants
    within each, its distance from the segment below 1e-15 m and its place along it in [0, 1]."""
    rng = np.random.default_rng(7)
    x = rng.normal(size=9)
    for _ in range(200):
        d, dt, tau = rng.normal(size=9), rng.uniform(1e-3, 0.1), rng.uniform(1e-3, 2.0)
        after = servo(x, d, dt, tau)
        for t in np.linspace(0.0, dt, 7):
            y = d + (x - d) * math.exp(-t / tau)
            step = after - x
            f = float(np.dot(y - x, step) / np.dot(step, step))
            assert -1e-12 <= f <= 1.0 + 1e-12
            assert np.linalg.norm(x + f * step - y) < 1e-12 * max(1.0, float(np.linalg.norm(x)))
        x = after


def test_a_tilt_refusal_names_the_lagging_rods_it_holds_at_their_command():
    """Rods 2 and 3 commanded 20 mm down by the last goal and lagging at rest, a goal raising rod 1 by 20 mm: the
    platform would tilt beyond its limit with them at their command, where the refusal quotes them; it says where
    they are now, lagging."""
    held = JOINTS.rest.copy()
    held[1:3] -= 0.02
    rod = float(JOINTS.rest[0])
    current = JOINTS.rest.copy()
    current[0] += 0.001   # rod 1 lagging too, but the goal commands it: not named
    goal = _goal(joint_names=['rod_1'], times=[1.0], positions=[[rod + 0.02]], velocities=[[]],
                 accelerations=[[]])
    for stamp in (0, NOW + 2 * NS):   # at once, or 2 s ahead (a reviewer's: quoted where the wait takes them)
        with pytest.raises(GoalError) as e:
            plan_goal(dataclasses.replace(goal, stamp_ns=stamp), LAGGING, current, NOW, held)
        assert re.fullmatch(rf'sample \d+ \(t = [\d.]+ s\): the platform would tilt [\d.e-]+ rad \(rods [\d.]+, '
                            rf'{rod - 0.02:.9g}, {rod - 0.02:.9g} m; the rods it leaves out at their command, lagging '
                            rf'now at rod_2 {rod:.9g} m, rod_3 {rod:.9g} m\); allowed: at most tilt_limit [\d.e-]+ rad',
                            str(e.value)), str(e.value)
