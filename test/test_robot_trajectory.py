"""Joint trajectories without ROS: the controller's interpolation (linear, cubic, quintic), a program as a trajectory
timed as `gpr program export` times it, the lead-in from the current state, the YAML `ros2 action send_goal` reads."""
from __future__ import annotations

import math

import numpy as np
import pytest
import yaml
from gpr_kinematics.errors import InputError, RobotStateError
from gpr_kinematics.robot.export import sample_table
from gpr_kinematics.robot.plan import plan_program, sample_plan
from gpr_kinematics.robot.program import load_program
from gpr_kinematics.robot.timing import velocities
from gpr_kinematics.robot.trajectory import (
    JointTrajectory,
    evaluate,
    lead_in,
    program_trajectory,
    trajectory_yaml,
    write_trajectory,
)
from robot_support import ROBOT, SHORT_PROGRAM


def _poly(c, t):
    """A polynomial with coefficients ``c`` (lowest first, one column per joint) and its two derivatives at ``t``."""
    t = np.asarray(t)[:, None]
    p = sum(ck * t ** k for k, ck in enumerate(c))
    v = sum(k * ck * t ** (k - 1) for k, ck in enumerate(c) if k)
    a = sum(k * (k - 1) * ck * t ** (k - 2) for k, ck in enumerate(c) if k > 1)
    return p, v + 0 * p, a + 0 * p


@pytest.mark.parametrize('degree', [1, 3, 5])
def test_interpolation_reproduces_polynomials_of_its_degree(degree):
    """Linear, cubic Hermite and quintic Hermite are exact on polynomials of their degree (two joints)."""
    rng = np.random.default_rng(degree)
    c = rng.normal(size=(degree + 1, 2))
    knots = np.array([0.0, 0.4, 1.1, 1.5])
    p, v, a = _poly(c, knots)
    traj = JointTrajectory(('a', 'b'), knots, p, v if degree > 1 else None, a if degree > 3 else None)
    assert traj.degree == degree
    t = np.linspace(0.0, 1.5, 61)
    pos, vel, acc = evaluate(traj, p[0], t)
    ep, ev, ea = _poly(c, t)
    np.testing.assert_allclose(pos, ep, rtol=0, atol=1e-12)
    if degree > 1:
        np.testing.assert_allclose(vel[:-1], ev[:-1], rtol=0, atol=1e-11)
    if degree > 3:
        np.testing.assert_allclose(acc[:-1], ea[:-1], rtol=0, atol=1e-9)


@pytest.mark.parametrize('degree', [1, 3, 5])
def test_points_are_met_exactly_and_the_velocity_is_the_derivative(degree):
    rng = np.random.default_rng(10 + degree)
    knots = np.cumsum(rng.uniform(0.05, 0.5, 7))
    P = rng.normal(size=(7, 3))
    V = rng.normal(size=(7, 3)) if degree > 1 else None
    A = rng.normal(size=(7, 3)) if degree > 3 else None
    traj = JointTrajectory(('a', 'b', 'c'), knots, P, V, A)
    start = rng.normal(size=3)
    pos, _, _ = evaluate(traj, start, knots)
    assert np.array_equal(pos, P)                   # to the last bit
    # Before the first point: from the start (at rest unless the interpolation is linear).
    pos0, vel0, _ = evaluate(traj, start, np.array([0.0]))
    assert np.array_equal(pos0[0], start)
    assert np.array_equal(vel0[0], np.zeros(3) if degree > 1 else (P[0] - start) / knots[0])
    # The velocity is the derivative of the position (central differences inside the segments).
    mids = 0.5 * (knots[:-1] + knots[1:])
    h = 1e-6
    plus, minus = evaluate(traj, start, mids + h)[0], evaluate(traj, start, mids - h)[0]
    np.testing.assert_allclose(evaluate(traj, start, mids)[1], (plus - minus) / (2 * h), rtol=0, atol=1e-6)
    # After the last point the joints hold it.
    late, late_v, _ = evaluate(traj, start, knots[-1] + np.array([0.1, 10.0]))
    assert np.array_equal(late, np.repeat(P[-1:], 2, axis=0)) and not late_v.any()


def test_cubic_from_rest_to_a_first_point():
    """A single point at T from rest: the cubic from the start with zero velocities at both ends."""
    T, start, goal = 2.0, np.array([0.1]), np.array([0.5])
    traj = JointTrajectory(('a',), np.array([T]), goal[None, :], np.zeros((1, 1)))
    t = np.linspace(0.0, T, 9)
    s = t / T
    pos, vel, _ = evaluate(traj, start, t)
    np.testing.assert_allclose(pos[:, 0], 0.1 + 0.4 * (3 * s ** 2 - 2 * s ** 3), rtol=0, atol=1e-15)
    np.testing.assert_allclose(vel[:, 0], 0.4 * (6 * s - 6 * s ** 2) / T, rtol=0, atol=1e-15)


@pytest.mark.slow
def test_timing_velocities_are_the_derivative_of_the_sampled_program():
    plan = _plan()
    t = np.linspace(0.0, plan.timing.total, 4001)[1:-1]
    h = 1e-7

    def positions(times):
        return np.array([_position_at(plan, x) for x in times])

    numeric = (positions(t + h) - positions(t - h)) / (2 * h)
    np.testing.assert_allclose(velocities(plan.timing, t), numeric, rtol=0, atol=2e-6)
    # The limits hold: |v| <= the joints' velocity limits.
    assert np.all(np.abs(velocities(plan.timing, t)) <= plan.timing.velocity * (1 + 1e-12))


_PLAN = {}


def _plan():
    if 'plan' not in _PLAN:
        import tempfile
        from pathlib import Path

        with tempfile.TemporaryDirectory() as d:
            path = Path(d) / 'short.yaml'
            path.write_text(SHORT_PROGRAM)
            _PLAN['plan'] = plan_program(ROBOT, load_program(path))
    return _PLAN['plan']


def _position_at(plan, t):
    """The program's joints at time ``t`` (one sample), computed as the sampler does."""
    from gpr_kinematics.robot.timing import evaluate, locate

    tm = plan.timing
    i, held, m, tau = locate(tm, np.array([t]))
    if held[0]:
        return tm.positions[i[0]]
    s = evaluate(tm.profiles, m, tau)[0]
    return tm.positions[m[0]] + s[0] * (tm.positions[m[0] + 1] - tm.positions[m[0]])


def test_program_trajectory_points_are_the_export_samples():
    plan = _plan()
    rate = 20.0
    traj = program_trajectory(plan, rate)
    columns, rows = sample_table(plan, sample_plan(plan, rate))
    table = np.array([r[3:3 + len(plan.joint_names)] for r in rows], dtype=float)
    assert traj.joint_names == ('rod_1', 'rod_2', 'rod_3', *plan.joint_names[3:])
    assert np.array_equal(traj.time, np.array([r[0] for r in rows]))
    assert np.array_equal(traj.positions, table)
    assert traj.degree == 3 and not traj.velocities[0].any() and not traj.velocities[-1].any()
    # The controller's cubic meets every point exactly, and between points stays near the program (the trapezoid).
    pos, _, _ = evaluate(traj, traj.positions[0], traj.time)
    assert np.array_equal(pos, traj.positions)
    mid = 0.5 * (traj.time[:-1] + traj.time[1:])
    exact = np.array([_position_at(plan, x) for x in mid])
    # (bounded by a_max h^2 / 8, the bound of the chord of a curve of curvature at most a_max: 6e-3 rad here)
    error = np.max(np.abs(evaluate(traj, traj.positions[0], mid)[0] - exact), axis=0)
    assert np.all(error <= plan.timing.acceleration / rate ** 2 / 8) and error.max() > 0


def test_lead_in_from_the_current_state():
    plan = _plan()
    rate = 50.0
    traj = program_trajectory(plan, rate)
    current = traj.positions[0] + np.array([0.01, 0.0105, 0.0095, 0.5, -0.3, 0.2, 0, 0, 0, 0.1])
    out, T = lead_in(plan, traj, current, rate)
    n = round(T * rate)
    assert T > 0 and math.isclose(n / rate, T)
    assert np.array_equal(out.positions[0], current) and not out.velocities[0].any()
    assert np.array_equal(out.positions[n:], traj.positions)
    assert np.array_equal(out.time[:n], np.arange(n) / rate)
    on_grid = np.isclose(traj.time * rate, np.round(traj.time * rate), rtol=0, atol=1e-6)
    np.testing.assert_array_equal(out.time[n:][on_grid], (n + np.round(traj.time[on_grid] * rate)) / rate)
    np.testing.assert_allclose(out.time[n:], traj.time + T, rtol=0, atol=1e-12)
    # The move stays within the joints' velocity limits.
    from gpr_kinematics.robot.plan import joint_limits

    _, vmax, _, _ = joint_limits(ROBOT)
    assert np.all(np.abs(out.velocities[:n]) <= vmax * (1 + 1e-12))
    assert np.all(np.abs(np.diff(out.positions[:n + 1], axis=0)) / np.diff(out.time[:n + 1])[:, None] <= vmax * 1.0001)
    # At the first point already: no lead-in.
    same, T0 = lead_in(plan, traj, traj.positions[0].copy(), rate)
    assert T0 == 0.0 and same is traj
    with pytest.raises(InputError, match='10 finite numbers'):
        lead_in(plan, traj, current[:5], rate)
    # A reported state beyond the limits (a rod at 50 m; 1e300 made a program of 6.67e300 s): refused, named.
    for k, value in ((0, 50.0), (0, 1e300), (4, -20.0), (0, plan.robot.config.stroke_max + 0.01)):
        bad = traj.positions[0].copy()
        bad[k] = value
        with pytest.raises(InputError, match=rf'the robot reports {traj.joint_names[k]} = .* outside its limits'):
            lead_in(plan, traj, bad, rate)
    # at a limit as the planner leaves it (1e-13 beyond), or an encoder's overshoot: a state to start from, taken as
    # the limit (a goal from 1e-10 beyond it was built, and a controller refuses a point beyond a limit)
    for over in (1e-13, 1e-10, 1e-4):
        at = traj.positions[0].copy()
        at[:3] = plan.robot.config.stroke_max   # the platform up, level
        at[0] += over
        goal, T = lead_in(plan, traj, at, rate)
        assert T > 0.0 and goal.positions[0, 0] == plan.robot.config.stroke_max
    # rods no platform takes (beyond the tilt limit, or of no pose at all): a goal was built from them, refused by the
    # controller for something else; the robot's state is named (status 1 in send)
    for rods, what in (([0.25, 0.254, 0.262], 'q = [0.25, 0.254, 0.262] m tilts the platform by about 0.07576 rad '
                        '(4.341 deg) in the naive model, beyond the tilt limit 0.03491 rad (2 deg); allowed: rods '
                        'within the tilt limit'),
                       ([0.1, 0.4, 0.3], 'q = [0.1, 0.4, 0.3] m imply no platform orientation (their differences are '
                        "more than the joints' spread can make at any tilt); allowed: rods within the tilt limit "
                        '0.03491 rad (2 deg)')):
        bad = traj.positions[0].copy()
        bad[:3] = rods
        with pytest.raises(RobotStateError) as info:
            lead_in(plan, traj, bad, rate)
        assert str(info.value) == (f'the robot reports rod_1, rod_2, rod_3: {what} (to 0.001 rad beyond: taken as at '
                                   'the limit; are these joint states of this robot?)')
    # a station on the tilt limit, a rod 10 um off (an encoder's overshoot): its differences drawn in to the limit,
    # a goal the controller takes (10 um more had been refused by 1e-9 rad)
    from gpr_kinematics.core import forward, inverse
    cfg = plan.robot.config
    on = np.array(inverse(0.4, cfg.tilt_limit, 0.3, config=cfg).q)
    for k, off in ((0, -1e-5), (1, 1e-5), (2, -1e-5)):
        at = traj.positions[0].copy()
        at[:3] = on
        at[k] += off
        assert forward(at[:3], cfg, check_limits=False).tilt > cfg.tilt_limit + 1e-9
        goal, T = lead_in(plan, traj, at, rate)
        assert forward(goal.positions[0, :3], cfg).tilt <= cfg.tilt_limit + 1e-9
        assert np.max(np.abs(goal.positions[0, :3] - at[:3])) < 2e-5


def test_a_lead_in_that_takes_the_trajectory_past_a_day_is_refused(tmp_path):
    """A program of 86,395 s (a dwell appended) makes a trajectory within the day; its lead-in from a robot away from
    the first point (one period at 0.1 Hz: 10 s) takes it to 86,405 s: refused, naming the day, not made."""
    from gpr_kinematics.robot.trajectory import MAX_DURATION

    rate = 0.1
    short = _plan().timing.total
    path = tmp_path / 'long.yaml'
    path.write_text(SHORT_PROGRAM + f'  - {{dwell: {MAX_DURATION - 5 - short:.6f}}}\n')
    plan = plan_program(ROBOT, load_program(path), rate)
    traj = program_trajectory(plan, rate)
    assert math.isclose(traj.duration, MAX_DURATION - 5, abs_tol=1e-5)
    same, none = lead_in(plan, traj, traj.positions[0].copy(), rate)     # no lead-in: within the day
    assert same is traj and none == 0.0
    with pytest.raises(InputError) as info:
        lead_in(plan, traj, traj.positions[0] + 0.01, rate)
    assert str(info.value) == ('the trajectory with its lead-in lasts 86405 s; allowed: at most 86400 s (a day, the '
                               'longest a FollowJointTrajectory goal of the controller lasts): split the program')


def test_trajectory_yaml_reads_back_exactly_and_embeds_in_a_goal(tmp_path):
    plan = _plan()
    traj = program_trajectory(plan, 10.0)
    text = trajectory_yaml(traj)
    data = yaml.safe_load(text)
    assert data['joint_names'] == list(traj.joint_names)
    points = data['points']
    assert len(points) == len(traj)
    assert np.array_equal(np.array([p['positions'] for p in points]), traj.positions)
    assert np.array_equal(np.array([p['velocities'] for p in points]), traj.velocities)
    ns = np.array([p['time_from_start']['sec'] * 10 ** 9 + p['time_from_start']['nanosec'] for p in points])
    np.testing.assert_array_equal(ns, np.round(traj.time * 1e9).astype(np.int64))
    assert all(0 <= p['time_from_start']['nanosec'] < 10 ** 9 for p in points)
    goal = yaml.safe_load('{trajectory: ' + text + '}')            # "{trajectory: $(cat FILE)}"
    assert goal['trajectory'] == data
    path = write_trajectory(str(tmp_path / 't.yaml'), traj)
    assert (tmp_path / 't.yaml').read_text() == text and path.endswith('t.yaml')
    with pytest.raises(InputError, match='.yaml'):
        write_trajectory(str(tmp_path / 't.csv'), traj)


def test_a_trajectory_through_straight_entries_follows_the_line():
    """The cell program enters chambers on straight lines: the trajectory's points are the plan's samples on the line
    (as `gpr program export --samples`) and their velocities the time derivative of those positions."""
    from gpr_kinematics.inputs.resources import config_path
    from gpr_kinematics.robot.description import load_robot
    from gpr_kinematics.robot.plan import line_moves, plan_samples
    from gpr_kinematics.robot.timing import sample_at

    program = load_program(config_path('programs/example_cell_program.yaml'))
    plan = plan_program(load_robot(program.robot), program)
    assert line_moves(plan.waypoints), 'the cell program has straight entries'
    traj = program_trajectory(plan, 50.0)
    sampled = sample_plan(plan, 50.0)
    np.testing.assert_array_equal(traj.positions, sampled.samples.positions)
    on_line = np.isin(sampled.samples.target - 1, line_moves(plan.waypoints)) & (sampled.samples.held < 0)
    idx = np.flatnonzero(on_line)[::7]
    assert idx.size > 10
    h = 1e-5
    t = traj.time[idx]
    ahead, back = (plan_samples(plan, sample_at(plan.timing, t + d)).positions for d in (h, -h))
    np.testing.assert_allclose(traj.velocities[idx], (ahead - back) / (2 * h), rtol=0, atol=1e-6)
    # and the joints' velocity limits hold along the lines
    assert np.all(np.abs(traj.velocities) <= plan.timing.velocity * (1 + 1e-9))


@pytest.mark.parametrize('rate', [0.0, float('inf'), float('nan'), 'a', -5.0, 10 ** 400])
def test_lead_in_checks_its_rate(rate):
    """0 divided by zero, inf overflowed, NaN was a bare ValueError, -5 a misleading "too short"."""
    plan = _plan()
    traj = program_trajectory(plan, 50.0)
    with pytest.raises(InputError, match=r'rate = .* is invalid; allowed: 0.1 <= rate <= 5000 Hz'):
        lead_in(plan, traj, traj.positions[0] + 0.01, rate)


def test_sample_plan_times_are_checked_and_counted_before_work():
    plan = _plan()
    got = sample_plan(plan, times=[0.0, 0.5])     # a list: was an AttributeError
    np.testing.assert_array_equal(got.samples.time, [0.0, 0.5])
    np.testing.assert_array_equal(got.wafer.position, sample_plan(plan, times=np.array([0.0, 0.5])).wafer.position)
    for times, words in ((np.array([np.nan]), r'times\[0\] = nan is not a finite number'),
                         (float('nan'), r'times = nan is not a finite number'),   # one value: no index
                         (np.arange(10 ** 7) * 1e-6, r'10000000 times; allowed: at most 200000 samples'),
                         ('abc', r'times must be a number or an array of numbers')):
        with pytest.raises(InputError, match=words):
            sample_plan(plan, times=times)
    from gpr_kinematics.robot.plan import sample_times_of
    from gpr_kinematics.robot.timing import MAX_SAMPLES
    assert sample_times_of(np.zeros(MAX_SAMPLES)).shape == (MAX_SAMPLES,)   # at most MAX_SAMPLES: the bound itself
    with pytest.raises(InputError, match=rf'^{MAX_SAMPLES + 1} times; allowed: at most {MAX_SAMPLES} samples$'):
        sample_times_of(np.zeros(MAX_SAMPLES + 1))
