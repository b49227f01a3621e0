"""The robot simulator's clearance check of trajectory goals, without ROS: the spline's exact travel, the motion
bounds of a joint trajectory against the exact interpolated motion, and the controller's refusal of a goal that
would drive the blade into an obstacle (between its points, named, at the right time and distance) beside the
acceptance of a safe goal in the example cell."""
from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest
from gpr_kinematics.core import forward_batch, inverse_batch
from gpr_kinematics.core.machine import MachineGeometry
from gpr_kinematics.errors import ConfigError, InputError
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.robot.controller import INVALID_GOAL, ControllerJoints, GoalError, Tolerances, plan_motion
from gpr_kinematics.robot.goal import Controller, Goal, plan_goal
from gpr_kinematics.robot.plan import plan_program
from gpr_kinematics.robot.program import load_program
from gpr_kinematics.robot.spline import TRAVEL_SLACK, Spline
from gpr_kinematics.robot.trajectory import JointTrajectory, program_trajectory, spline
from gpr_kinematics.safety.bodies import robot_body_set
from gpr_kinematics.safety.cell import load_cell, parse_cell
from gpr_kinematics.safety.clearance import TOLERANCE, clearance
from gpr_kinematics.safety.goal import GoalClearance
from gpr_kinematics.safety.joint_motion import TrajectoryMotion, platform_travel
from gpr_kinematics.safety.motion import LIPSCHITZ, levers, platform_state
from robot_support import ROBOT

fcl = pytest.importorskip('fcl')

JOINTS = ControllerJoints.of(ROBOT)
TOL = Tolerances.uniform(len(JOINTS.names), 0.0, 1e-3, 0.5)
SIGNS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
SHOULDER = JOINTS.names.index('arm1_shoulder')
#: The goal of the obstacle tests: arm1's shoulder from rest (0) to 1.2 rad in 2 s, two points, linear.
TURN = JointTrajectory(('arm1_shoulder',), np.array([0.0, 2.0]), np.array([[0.0], [1.2]]))


def _random_trajectory(degree: int, rng, n: int = 25, joints: int = 4) -> JointTrajectory:
    t = np.cumsum(rng.uniform(0.05, 0.5, n))
    P = rng.normal(size=(n, joints))
    V = rng.normal(size=(n, joints)) if degree > 1 else None
    A = 3.0 * rng.normal(size=(n, joints)) if degree > 3 else None
    return JointTrajectory(tuple('abcd'[:joints]), t, P, V, A)


@pytest.mark.parametrize('degree', [1, 3, 5])
def test_spline_travel_is_the_exact_variation(degree):
    """On 200 random intervals (within a segment, across many, beyond the last point) the travel is never below the
    variation of 20,001 samples that include every point, and above it by no more than sampling and slack."""
    rng = np.random.default_rng(degree)
    traj = _random_trajectory(degree, rng)
    sp = spline(traj, np.zeros(4))
    t0 = rng.uniform(0.0, traj.duration + 0.2, 200)
    t1 = t0 + rng.uniform(0.0, 2.0, 200) * rng.choice([0.0, 1e-3, 1.0], 200)
    travel = sp.travel(t0, t1)
    knots = sp.knots
    h = np.diff(knots)[:, None]
    slack = TRAVEL_SLACK * h * sum(k * np.abs(sp.coefficients[:, k]) * h ** (k - 1) for k in range(1, 6))
    for k in range(200):
        ts = np.union1d(np.linspace(t0[k], t1[k], 20_001), knots[(knots > t0[k]) & (knots < t1[k])])
        tv = np.abs(np.diff(sp.evaluate(ts)[0], axis=0)).sum(axis=0)
        assert np.all(travel[k] >= tv - 1e-12), (k, tv - travel[k])
        inside = (knots[1:] > t0[k]) & (knots[:-1] < t1[k])
        assert np.all(travel[k] <= tv + slack[inside].sum(axis=0) + 1e-6 * tv + 1e-12), (k, travel[k] - tv)
    # the travel adds over consecutive intervals, and a held joint travels nothing after the last point
    mid = 0.5 * (t0 + t1)
    split = sp.travel(t0, mid) + sp.travel(mid, t1) - travel
    assert np.all(np.abs(split) <= 2.0 * slack.max(axis=0) + 1e-9 * travel + 1e-15)
    assert not np.any(sp.travel(np.array([traj.duration]), np.array([traj.duration + 5.0])))


def test_a_segment_with_only_a_square_term_is_not_taken_for_a_line():
    """A cubic segment from 0 at rest to 1 at 2 /s over 1 s is ``t^2``: its travel is 1 (a linear spline's short cut,
    which skips the turning points' search, must not take it: read as a line it travelled 0)."""
    sp = Spline.of(np.array([0.0, 1.0]), np.array([[0.0], [1.0]]), np.array([[0.0], [2.0]]), np.zeros((2, 1)), 3)
    assert sp.coefficients[0, 2, 0] == 1.0 and not sp.coefficients[0, 3:].any()
    assert 1.0 <= sp.travel(np.array([0.0]), np.array([1.0]))[0, 0] <= 1.0 + 1e-7


def _corners(body, frames):
    p, R = frames[body.frame]
    local = np.vstack([body.position + (SIGNS * body.half) @ body.rotation.T, body.position])
    return p[:, None, :] + np.einsum('nij,kj->nki', R, local)


def _check_bounds(motion: TrajectoryMotion, duration: float, seed: int) -> dict[str, float]:
    """Every body's corners over 150 random intervals (41 instants each) against its bound; per body the median
    ratio of the platform's bound to the distance moved where only the platform moves it."""
    bodies = robot_body_set(ROBOT, {a.name: ((0.0, math.inf),) for a in ROBOT.arms})
    lev = levers(ROBOT, bodies)
    rng = np.random.default_rng(seed)
    K = 150
    t0 = rng.uniform(0.0, duration, K)
    t1 = np.minimum(t0 + rng.choice([0.01, 0.3, 3.0], K) * rng.uniform(0.0, 1.0, K), duration)
    tau = np.linspace(0.0, 1.0, 41)
    snap = motion.snapshot((t0[:, None] + tau[None] * (t1 - t0)[:, None]).ravel())
    ends = motion.snapshot(np.concatenate([t0, t1]))

    def pair(v):
        return np.stack([v[:K], v[K:]], axis=1)

    b = motion.bounds(t0, t1, lev, pair(ends.sigma), pair(ends.gamma), pair(ends.displacement))
    ratios = {}
    for k, body in enumerate(bodies):
        pts = _corners(body, snap.frames).reshape(K, len(tau), 9, 3)
        moved = np.max(np.linalg.norm(pts - pts[:, :1], axis=3), axis=(1, 2))
        bound = b.arm[:, k] + b.platform[:, k]
        assert np.all(moved <= bound + 1e-12), (body.name, np.max(moved - bound))
        assert np.all((bound == 0.0) == np.all(b.shift[:, k] == 0.0, axis=1))
        only = (b.arm[:, k] == 0.0) & (moved > 1e-6)
        if only.any():
            ratios[body.name] = float(np.median(b.platform[only, k] / moved[only]))
    return ratios


def test_bounds_hold_on_a_program_trajectory():
    """The example cell program as the controller gets it (20 Hz points with velocities: cubic segments)."""
    plan = plan_program(ROBOT, load_program(config_path('programs/example_cell_program.yaml')))
    traj = program_trajectory(plan, 20.0)
    motion = TrajectoryMotion.of(ROBOT, traj, np.arange(len(JOINTS.names)), traj.positions[0])
    np.testing.assert_array_equal(motion.snapshot(traj.time).rows, traj.positions)   # the points, to the bit
    _check_bounds(motion, traj.duration, 1)


def _tilts(degree: int, seed: int) -> JointTrajectory:
    """Rods through tilts and back: 2 deg at azimuth 0, level (the singular configuration), 2 deg at 180, 1 deg at
    90, 1.5 deg at -45 (heights 0.24 to 0.27 m), random velocities and accelerations at the points for ``degree``."""
    rng = np.random.default_rng(seed)
    q = inverse_batch(np.array([0.25, 0.26, 0.27, 0.24, 0.25]), np.radians([2.0, 0.0, 2.0, 1.0, 1.5]),
                      np.radians([0.0, 0.0, 180.0, 90.0, -45.0]), ROBOT.config).q
    V = 0.004 * rng.normal(size=q.shape) if degree > 1 else None
    A = 0.004 * rng.normal(size=q.shape) if degree > 3 else None
    return JointTrajectory(('rod_1', 'rod_2', 'rod_3'), np.array([0.0, 1.5, 3.0, 4.0, 5.5]), q, V, A)


@pytest.mark.parametrize('degree', [1, 3, 5])
def test_platform_bound_for_rods_on_a_spline(degree):
    """Rods on the spline of :func:`_tilts`: over 60 random intervals (33 instants each) no point of a disc of radius
    0.8 m about the platform origin, 0.3 m above it, moves farther than ``A + Omega (rho + rbar)``; on intervals of at
    most 0.5 s the bound is within three times the truth (as for rods on a line, test_safety_bounds; over longer ones
    the rods turn back, and the bound counts their path, not where they end)."""
    traj = _tilts(degree, degree)
    sp = TrajectoryMotion.of(ROBOT, traj, np.arange(3), JOINTS.rest).spline
    N = len(JOINTS.names)
    rng = np.random.default_rng(20 + degree)
    t0 = rng.uniform(0.0, traj.duration, 60)
    t1 = np.minimum(t0 + rng.choice([0.05, 0.5, 4.0], 60) * rng.uniform(0.2, 1.0, 60), traj.duration)
    t0[0], t1[0] = 0.0, traj.duration
    tau = np.linspace(0.0, 1.0, 33)
    Q = sp.evaluate((t0[:, None] + tau[None] * (t1 - t0)[:, None]).ravel())[0][:, :3]
    fk = forward_batch(Q, ROBOT.config, check_limits=False)
    ang = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    pts = np.stack([0.8 * np.cos(ang), 0.8 * np.sin(ang), np.full(24, 0.3)], axis=1)
    world = (fk.position[:, None, :] + np.einsum('nij,kj->nki', fk.rotation, pts)).reshape(60, 33, 24, 3)
    moved = np.max(np.linalg.norm(world - world[:, :1], axis=3), axis=(1, 2))
    ends = sp.evaluate(np.concatenate([t0, t1]))[0][:, :3]
    state = platform_state(ROBOT.config, forward_batch(ends, ROBOT.config, check_limits=False))
    sigma, gamma, disp = (np.stack([v[:60], v[60:]], axis=1) for v in state)
    T = sp.travel(t0, t1)
    A, omega, drift = platform_travel(MachineGeometry.of(ROBOT.config), ends[:60], ends[60:], T[:, :3], T[:, N],
                                      T[:, N + 1:], sigma, gamma, LIPSCHITZ)
    bound = A + omega * (0.8544 + np.max(disp, axis=1) + drift)        # |pts| = hypot(0.8, 0.3)
    assert np.all(moved <= bound), np.max(moved / bound)
    short = t1 - t0 <= 0.5
    assert short.sum() > 25 and np.all(bound[short] < 3.0 * moved[short] + 1e-9), np.max(bound[short] / moved[short])


@pytest.mark.parametrize('degree', [1, 3, 5])
def test_bounds_hold_with_tilting_rods_and_arms(degree):
    """The rods of :func:`_tilts` with arm1's joints moving on the same points (random postures), arm2 held: no body
    of the robot moves farther than its bound; where only the platform moves a body (arm1 still between the first two
    points), its platform bound is what moves it."""
    rods = _tilts(degree, 10 + degree)
    rng = np.random.default_rng(degree)
    arm = JOINTS.rest[3:6] + rng.uniform(-0.6, 0.6, (len(rods), 3))
    arm[1] = arm[0]
    def pad(X, scale):      # arm1's velocities and accelerations, zero at the first two points
        if X is None:
            return None
        return np.hstack([X, scale * rng.normal(size=(len(rods), 3)) * (np.arange(len(rods)) > 1)[:, None]])

    names = ('rod_1', 'rod_2', 'rod_3', 'arm1_shoulder', 'arm1_elbow', 'arm1_wrist')
    traj = JointTrajectory(names, rods.time + 1.0, np.hstack([rods.positions, arm]), pad(rods.velocities, 0.3),
                           pad(rods.accelerations, 0.3))
    motion = TrajectoryMotion.of(ROBOT, traj, JOINTS.indices(names), JOINTS.rest)
    ratios = _check_bounds(motion, traj.duration, degree)
    assert {'arm1_blade', 'arm2_wafer', 'gpr_platform'} <= set(ratios)


def _cell(box, position, name='box', rpy=(0.0, 0.0, 0.0)):
    return parse_cell({'format': 'gpr_cell', 'version': 1, 'frame': 'world', 'obstacles': [
        {'name': name, 'box': list(box), 'position': [float(v) for v in position], 'rpy': list(rpy)}]}, 'test_cell')


def _blade_reach():
    """arm1's shoulder axis (vertical, the platform level at rest), the blade's farthest corner from it [m] and that
    corner's angle and height at the middle of :data:`TURN`."""
    motion = TrajectoryMotion.of(ROBOT, TURN, np.array([SHOULDER]), JOINTS.rest)
    snap = motion.snapshot(np.array([1.0]))
    axis = snap.frames['arm1_link1'][0][0]
    blade = next(b for b in robot_body_set(ROBOT) if b.name == 'arm1_blade')
    corners = _corners(blade, snap.frames)[0, :8]
    radial = np.hypot(*(corners[:, :2] - axis[:2]).T)
    k = int(np.argmax(radial))
    return axis, float(radial[k]), float(np.arctan2(*(corners[k, 1::-1] - axis[1::-1]))), float(corners[k, 2])


def _box_at(distance):
    """A box 50 mm deep, 100 mm wide and tall, its inner face ``distance`` beyond the circle the blade's farthest
    corner sweeps, facing the axis where the corner passes at mid-goal: the blade's smallest distance to it is
    ``distance`` exactly (every other point of the arm is nearer the axis)."""
    axis, reach, angle, z = _blade_reach()
    centre = axis + (reach + distance + 0.025) * np.array([math.cos(angle), math.sin(angle), 0.0])
    centre[2] = z
    return _cell((0.05, 0.1, 0.1), centre, rpy=(0.0, 0.0, angle))


def _distance(cell, t, body='arm1_blade'):
    """The library's distances of ``body`` and the cell's box at times ``t`` of :data:`TURN` (a float for one)."""
    motion = TrajectoryMotion.of(ROBOT, TURN, np.array([SHOULDER]), JOINTS.rest)
    times = np.atleast_1d(np.asarray(t, dtype=float))
    b = next(x for x in robot_body_set(ROBOT) if x.name == body)
    p, R = motion.snapshot(times).frames[b.frame]
    ob = cell.obstacles[0]
    req = fcl.DistanceRequest(enable_signed_distance=True)
    box = fcl.CollisionObject(fcl.Box(*ob.size), fcl.Transform(ob.rotation, ob.position))
    shape = fcl.Box(*b.size) if b.kind == 'box' else fcl.Cylinder(*b.size)
    out = np.array([fcl.distance(fcl.CollisionObject(shape, fcl.Transform(R[k] @ b.rotation, p[k] + R[k] @ b.position)),
                                 box, req, fcl.DistanceResult()) for k in range(times.shape[0])])
    return float(out[0]) if np.ndim(t) == 0 else out


def _plan(traj, cell, margin=0.002, wafer_arms=()):
    return plan_motion(JOINTS, traj, JOINTS.rest, 100.0, ROBOT.config, TOL, 1e-3,
                       GoalClearance(ROBOT, cell, margin, wafer_arms=wafer_arms))


REFUSAL = (r'(\w+) and box would come within the margin: -?[\d.e+-]+ m \((-?[\d.]+) mm\) apart at t = ([\d.]+) s '
           r'\(time_from_start; negative: penetration; found by the clearance check over the whole motion, cell '
           r'test_cell\); allowed: every pair at least clearance_margin [\d.]+ m \((\d+) mm\) apart over the whole '
           r'motion')


def _refused(cell, margin=0.002, wafer_arms=()):
    """The body, distance [m] and time [s] a refusal names (an INVALID_GOAL of this form)."""
    with pytest.raises(GoalError) as info:
        _plan(TURN, cell, margin, wafer_arms)
    assert info.value.code == INVALID_GOAL
    m = re.fullmatch(REFUSAL, str(info.value))
    assert m and float(m.group(4)) == margin * 1e3, str(info.value)
    return m.group(1), float(m.group(2)) * 1e-3, float(m.group(3))


def test_a_goal_driving_the_blade_into_an_obstacle_is_refused_naming_it():
    """A box 20 mm inside the blade's sweep: both points of the goal are clear of it, the motion between is not. The
    refusal is an INVALID_GOAL naming the blade and the box, an instant and the distance the library gives them
    there: below the margin, never below the true minimum (the smallest of 2001 samples, 20 mm of penetration)."""
    cell = _box_at(-0.02)
    assert _distance(cell, 0.0) > 0.1 and _distance(cell, 2.0) > 0.1
    body, d, t = _refused(cell)
    assert body == 'arm1_blade' and 0.0 < t < 2.0 and d < 0.002
    assert _distance(cell, t) == pytest.approx(d, abs=2e-6)               # the message rounds to 1 um, t to 6 digits
    truth = float(np.min(_distance(cell, np.linspace(0.0, 2.0, 2001))))
    assert truth == pytest.approx(-0.02, abs=1e-4) and d >= truth - 2e-6     # less the library slack


@pytest.mark.parametrize('gap', [0.001, 0.003])
def test_a_box_a_known_distance_from_the_sweep(gap):
    """A box ``gap`` beyond the blade's sweep: the certified clearance of the motion (every pair's minimum to the
    tolerance, as ``gpr program check`` asks) reports the blade and the box at ``gap``, never above, at most the
    tolerance below; the simulator refuses the goal when ``gap`` is below its margin (naming a distance between
    ``gap`` and the margin), accepts it otherwise: 1 mm refused and 3 mm accepted at the 2 mm margin, 3 mm refused at
    4 mm."""
    cell = _box_at(gap)
    truth = float(np.min(_distance(cell, np.linspace(0.9, 1.1, 2001))))
    assert truth == pytest.approx(gap, abs=1e-6)
    check = GoalClearance(ROBOT, cell)
    motion = TrajectoryMotion.of(ROBOT, TURN, np.array([SHOULDER]), JOINTS.rest)
    pair = next(p for p in clearance(motion, check.bodies, check.pairs).pairs if p.bodies == ('arm1_blade', 'box'))
    assert gap - TOLERANCE - 1e-6 <= pair.distance <= gap and 0.9 < pair.time < 1.1
    for margin in (0.002, 0.004):
        if gap >= margin:
            assert len(_plan(TURN, cell, margin)) == 201
            continue
        body, d, t = _refused(cell, margin)
        assert body == 'arm1_blade' and gap - 1e-6 <= d < margin
        assert _distance(cell, t) == pytest.approx(d, abs=2e-6)


def test_a_carried_wafer_is_checked_only_on_the_arms_named():
    """The box 20 mm beyond the blade's sweep lies inside the wafer's (a 300 mm disc reaches farther): refused for
    the wafer when arm1 carries one, accepted when no arm does."""
    cell = _box_at(0.02)
    assert len(_plan(TURN, cell)) == 201
    body, d, t = _refused(cell, wafer_arms=('arm1',))
    assert body == 'arm1_wafer' and d < 0.002 and _distance(cell, t, 'arm1_wafer') == pytest.approx(d, abs=2e-6)


def test_a_safe_goal_in_the_example_cell_is_accepted():
    """The example cell program as one goal (20 Hz points with velocities), arm2 carrying a wafer throughout: every
    pair keeps the margin over the whole motion; the report is a lower bound of at least the margin."""
    plan = plan_program(ROBOT, load_program(config_path('programs/example_cell_program.yaml')))
    traj = program_trajectory(plan, 20.0)
    cell = load_cell(config_path('cells/example_cell.yaml'))
    check = GoalClearance(ROBOT, cell, wafer_arms=('arm2',))
    motion = plan_motion(JOINTS, traj, traj.positions[0], 100.0, ROBOT.config, TOL, 1e-3, check)
    assert motion.duration == pytest.approx(plan.timing.total)
    report = check.report(motion)
    assert not report.below_margin and report.min_clearance >= check.margin
    assert {p.bodies[0] for p in report.pairs} >= {'arm2_wafer', 'arm1_blade'}


def test_bad_settings_are_refused():
    cell = load_cell(config_path('cells/example_cell.yaml'))
    with pytest.raises(ConfigError, match=r"wafer_arms: unknown arm 'arm3'; allowed: some of arm1, arm2, or none"):
        GoalClearance(ROBOT, cell, wafer_arms=('arm3',))
    with pytest.raises(InputError, match=r'margin = nan is invalid'):
        GoalClearance(ROBOT, cell, float('nan'))


def test_a_cell_in_another_frame_is_refused_by_the_goal_check():
    cell = _cell((0.1, 0.1, 0.1), (5.0, 5.0, 0.5))
    other = type(cell)(cell.obstacles, 'gpr_base', 'cell.yaml')
    with pytest.raises(ConfigError, match=r"cell\.yaml: frame = 'gpr_base'.*allowed: 'world'"):
        GoalClearance(ROBOT, other)


def _at(shoulder):
    """The rest state with arm1's shoulder at ``shoulder`` [rad] (0.6: the blade 20 mm inside :func:`_box_at`'s box)."""
    q = JOINTS.rest.copy()
    q[SHOULDER] = shoulder
    return q


def test_the_jump_to_a_first_point_at_time_zero_is_checked_against_the_cell():
    """start_tolerance 1 rad, rate 1 Hz (one sample reaches 1.5 rad): a first point at t = 0 1 rad from rest, beyond
    the box, was jumped to through it (the check began at the first point). Now the jump is part of the check."""
    cell = _box_at(-0.02)
    traj = JointTrajectory(('arm1_shoulder',), np.array([0.0, 2.0]), np.array([[1.0], [1.2]]))
    check = GoalClearance(ROBOT, cell, 0.002)
    assert check.report(plan_motion(JOINTS, traj, _at(1.0), 1.0, ROBOT.config, TOL, 1.0)).below_margin == ()
    with pytest.raises(GoalError) as e:
        plan_motion(JOINTS, traj, JOINTS.rest, 1.0, ROBOT.config, TOL, 1.0, check)
    assert e.value.code == INVALID_GOAL
    m = re.fullmatch(r'the jump from where the joints are to the first point at time_from_start 0 \(in one sample\) '
                     r'brings arm1_blade and box within the margin: (-0\.0[\d]+) m \(-[\d.]+ mm\) apart \(negative: '
                     r'penetration; cell test_cell\); allowed: every pair at least clearance_margin 0.002 m apart '
                     r'over the jump too, or a first point after 0 s, which the joints then reach along the '
                     r'interpolated motion that is checked', str(e.value))
    assert m, str(e.value)
    assert -0.0201 < float(m.group(1)) < 0.002   # the line passes 0.6 rad, the box 20 mm deep there


def test_a_goal_from_a_current_state_within_the_margin_says_so():
    """The robot held with its blade in the box (a foreign joint_states took it there): every goal, one moving the elbow
    only, was refused '... -20.001 mm apart at t = 0 s' without a word that the current state is the problem."""
    cell = _box_at(-0.02)
    traj = JointTrajectory(('arm1_elbow',), np.array([1.0]), np.array([[JOINTS.rest[SHOULDER + 1] - 0.1]]))
    with pytest.raises(GoalError) as e:
        plan_motion(JOINTS, traj, _at(0.6), 100.0, ROBOT.config, TOL, 1e-3, GoalClearance(ROBOT, cell, 0.002))
    assert str(e.value) == ("the robot's current state (where every goal starts, t = 0) has arm1_blade and box "
                            '-0.020001 m (-20.001 mm) apart, within clearance_margin 0.002 m (negative: penetration; '
                            'cell test_cell); allowed: a current state with every pair at least clearance_margin apart '
                            '(every goal starts there; joint_states of another publisher outside the margin move it '
                            'while no goal runs)')


def test_another_publishers_state_is_judged_with_the_line_from_the_held_one():
    """robot_simulator_node's rule for foreign joint_states with a cell: a state in the box, or one whose joint-space
    line from the held state passes through it, is refused; a clear move is taken, and from a held state in the box a
    clear state is the way out."""
    check = GoalClearance(ROBOT, _box_at(-0.02), 0.002)
    assert check.move(_at(0.0), _at(0.05)) is None
    assert check.move(_at(0.0), _at(0.6)) == ('it has arm1_blade and box -0.020001 m (-20.001 mm) apart, within '
                                              'clearance_margin 0.002 m (negative: penetration; cell test_cell)')
    assert check.move(_at(0.0), _at(1.2)) == ('the joint-space line from the held state to it brings arm1_blade and '
                                              'box within clearance_margin 0.002 m: -0.020001 m (-20.001 mm) apart '
                                              '(negative: penetration; cell test_cell)')
    assert check.move(_at(0.6), _at(1.2)) is None


def _lag_goal(names, times, positions, stamp_ns=0):
    return Goal(list(names), list(times), [list(p) for p in positions], [[] for _ in times], [[] for _ in times],
                False, False, False, [], [], 0.0, stamp_ns)


def _lagging(cell, tau, margin=0.002):
    return Controller(JOINTS, TOL, 100.0, ROBOT.config, 1e-3, False, GoalClearance(ROBOT, cell, margin), tau)


LAG_REFUSAL = (r'arm1_blade and box would come within the margin: (-?[\d.e+-]+) m \(-?[\d.]+ mm\) apart at t = '
               r"([\d.]+) s \(s from the goal's arrival, the joints lagging ([\d.]+) s \(servo_time_constant\) behind "
               r'its samples; negative: penetration; found by the clearance check over the whole motion, cell '
               r'test_cell\); allowed: every pair at least clearance_margin 0.002 m \(2 mm\) apart over the whole '
               r'motion')


def _on_path(motion, t):
    """Every joint where the lagging ``motion``'s path passes at ``t`` [s from the arrival] (between its corners)."""
    path, times = motion.lag.path(motion.time, motion.positions[-1])
    return np.array([np.interp(t, times, path[:, j]) for j in range(path.shape[1])])


def test_a_lagging_joint_a_goal_leaves_out_is_checked_on_its_way_to_its_command():
    """A reviewer's case: arm1's shoulder commanded to 1.2 rad by the last goal and still lagging at 0, a next goal
    moving the elbow only. Its check saw the shoulder at its command, past the box, while it turned through it (the
    blade 20 mm inside at 0.6 rad): accepted without the lag's path, refused with it, naming the blade, the box and
    a distance the library gives at the instant named on the path."""
    cell = _box_at(-0.02)
    elbow = JOINTS.names.index('arm1_elbow')
    goal = _lag_goal(['arm1_elbow'], [1.0], [[JOINTS.rest[elbow] - 0.05]])
    held = _at(1.2)
    motion, _ = plan_goal(goal, dataclasses.replace(_lagging(cell, 0.5), servo_time_constant=0.0), _at(0.0), 0,
                          held)   # no lag: the shoulder taken at its command
    assert motion.lag is None and motion.positions[0, SHOULDER] == 1.2
    with pytest.raises(GoalError) as e:
        plan_goal(goal, _lagging(cell, 0.5), _at(0.0), 0, held)
    m = re.fullmatch(LAG_REFUSAL, str(e.value))
    assert m and e.value.code == INVALID_GOAL and m.group(3) == '0.5', str(e.value)
    d, t = float(m.group(1)), float(m.group(2))
    motion = dataclasses.replace(_lagging(cell, 0.5), clearance=None)
    lagging, _ = plan_goal(goal, motion, _at(0.0), 0, held)
    q = _on_path(lagging, t)
    assert 0.3 < q[SHOULDER] < 0.9 and -0.0201 < d < 0.002
    assert GoalClearance(ROBOT, cell, 0.002).line(q, q).below_margin[0].measured == pytest.approx(d, abs=2e-6)
    # a reviewer's: the goal stamped 10 s ahead, the shoulder turning in through the box during the wait, was named at
    # t = 4 s (a share of the wait's line), when the shoulder is at 1.1996 rad and the blade 67 mm clear; now the
    # instant the lagging shoulder is there, 1.2 (1 - exp(-t / 0.5))
    with pytest.raises(GoalError) as e:
        plan_goal(dataclasses.replace(goal, stamp_ns=10 * 10 ** 9), _lagging(cell, 0.5), _at(0.0), 0, held)
    m = re.fullmatch(LAG_REFUSAL, str(e.value))
    assert m, str(e.value)
    d, t = float(m.group(1)), float(m.group(2))
    truth = _at(1.2 * (1.0 - math.exp(-t / 0.5)))
    assert t < 1.0 and d < 0.002
    with pytest.raises(GoalError) as e:   # already in the box at the arrival: said so (its wait would leave it)
        plan_goal(dataclasses.replace(goal, stamp_ns=10 * 10 ** 9), _lagging(cell, 0.5), _at(0.6), 0, held)
    assert str(e.value).startswith("the robot's current state (where every goal starts, t = 0) has arm1_blade and box "
                                   '-0.020001 m'), str(e.value)
    assert GoalClearance(ROBOT, cell, 0.002).line(truth, truth).below_margin[0].measured == pytest.approx(d, abs=2e-3)


def test_a_lagging_path_within_the_librarys_slack_of_the_margin_is_named_with_its_bound_and_the_lags_clock():
    """arm1's shoulder lagging from 0 to its command 1.2 rad (a goal moving arm2 only) sweeps the blade's corner past
    a box 0.4 um beyond its circle at margin 0: nothing is measured below the margin, but the library's 1 um slack
    keeps the bound from proving it, so the refusal names the certified bound, the distance measured and its instant
    in the lag's clock (the corner passes the box when the shoulder is at half its command, t = 0.5 ln 2 s)."""
    arm2 = JOINTS.names.index('arm2_shoulder')
    goal = _lag_goal(['arm2_shoulder'], [1.0], [[JOINTS.rest[arm2] + 0.05]])
    with pytest.raises(GoalError) as e:
        plan_goal(goal, _lagging(_box_at(4e-7), 0.5, 0.0), _at(0.0), 0, _at(1.2))
    m = re.fullmatch(r'arm1_blade and box could not be shown the margin apart: at least (-[\d.e+-]+) m \(-[\d.]+ mm\) '
                     r'by the bounds between samples, (-?[\d.e+-]+) m measured at t = ([\d.]+) s \(the library\'s '
                     r"distance less its slack of 1e-06 m\) \(s from the goal's arrival, the joints lagging 0.5 s "
                     r'\(servo_time_constant\) behind its samples; cell test_cell\); allowed: every pair at least '
                     r'clearance_margin 0 m \(0 mm\) apart over the whole motion', str(e.value))
    assert m and e.value.code == INVALID_GOAL, str(e.value)
    bound, measured, t = (float(v) for v in m.groups())
    assert bound < measured < 0.0 and 4e-7 - 1e-8 < measured + 1e-6 < 2e-6   # the library's, 0.4 um at best
    assert abs(t - 0.5 * math.log(2.0)) < 0.01


def corner_case():
    """The box of :func:`test_the_lag_cutting_a_corner_into_a_box_is_refused` (size, centre, yaw) and its goal (joints,
    times, positions): the platform lifted 65 mm, arm1's shoulder turned 1.2 rad over the box, the platform lowered."""
    axis, reach, angle, z = _blade_reach()
    yaw = angle - 0.25
    centre = axis + (reach - 0.03) * np.array([math.cos(yaw), math.sin(yaw), 0.0])
    centre[2] = z
    rods, h = JOINTS.rest[:3], 0.065
    t1 = h / 0.14
    return ((0.05, 0.1, 0.09), centre, yaw, ['rod_1', 'rod_2', 'rod_3', 'arm1_shoulder'],
            [t1, t1 + 0.85, 2 * t1 + 0.85], [[*(rods + h), 0.0], [*(rods + h), 1.2], [*rods, 1.2]])


def test_the_lag_cutting_a_corner_into_a_box_is_refused():
    """A goal lifts the platform 65 mm, turns arm1's shoulder 1.2 rad over a box 90 mm tall standing in the blade's
    sweep, and lowers it: the samples clear the box (accepted without a lag and with 0.2 s), but lagging 1 s the
    rods are still low when the shoulder turns in over the box, and the blade enters it: refused, with a distance
    the library gives on the lagging path at the instant named."""
    size, centre, yaw, names, times, positions = corner_case()
    cell = _cell(size, centre, rpy=(0.0, 0.0, yaw))
    goal = _lag_goal(names, times, positions)
    for tau in (0.0, 0.2):
        assert len(plan_goal(goal, _lagging(cell, tau), JOINTS.rest, 0)[0]) == 179   # 1.78 s at 100 Hz
    with pytest.raises(GoalError) as e:
        plan_goal(goal, _lagging(cell, 1.0), JOINTS.rest, 0)
    m = re.fullmatch(LAG_REFUSAL, str(e.value))
    assert m, str(e.value)
    d, t = float(m.group(1)), float(m.group(2))
    lagging, _ = plan_goal(goal, dataclasses.replace(_lagging(cell, 1.0), clearance=None), JOINTS.rest, 0)
    q = _on_path(lagging, t)
    assert d < 0.0
    assert GoalClearance(ROBOT, cell, 0.002).line(q, q).below_margin[0].measured == pytest.approx(d, abs=2e-6)
    assert q[0] - JOINTS.rest[0] < 0.05 and q[SHOULDER] > 0.05   # the rods still low, the shoulder turning in
