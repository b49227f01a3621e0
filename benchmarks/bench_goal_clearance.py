"""Benchmark of the robot simulator's clearance check of trajectory goals (issue 21), all in one run.

Measures, on the shipped example cell and its program sent as one FollowJointTrajectory goal (as ``gpr program send``
sends it: one point per sample with velocities, cubic segments; arm2 carrying a wafer throughout): the check of the
goal (:class:`gpr_kinematics.safety.goal.GoalClearance`, the simulator's ``clearance`` hook) for goals of 1,193,
5,960 and 29,792 points (20, 100 and 500 Hz; the program's 59.6 s), the goal's checks without it (``plan_motion``:
limits, tilt, samples) for scale, the pieces (the spline's turning points, the motion bounds per interval, the robot's
poses per instant), the refusal of the same goal with a box on the carried wafer's path, the same check asked for
every pair's minimum to the tolerance (``gpr program check``'s question) instead of the margin alone, and, as the
peer, the collision library's own distance call (``fcl.distance``, bodies placed once) with what a plain sampled
check at the controller's 100 Hz (every pair at every sample, no certificate) costs.

Prints a Markdown table of medians. Usage: ``python benchmarks/bench_goal_clearance.py [--quick]``.
"""
from __future__ import annotations

import argparse
import math
import os
import platform
import statistics
import time

import bench_core
import fcl
import numpy as np
from bench_clearance import fcl_object
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.robot import load_robot
from gpr_kinematics.robot.controller import ControllerJoints, GoalError, Tolerances, plan_motion
from gpr_kinematics.robot.plan import plan_program
from gpr_kinematics.robot.program import load_program
from gpr_kinematics.robot.trajectory import program_trajectory
from gpr_kinematics.safety.bodies import robot_body_set
from gpr_kinematics.safety.cell import Cell, Obstacle, load_cell
from gpr_kinematics.safety.clearance import clearance
from gpr_kinematics.safety.goal import GoalClearance
from gpr_kinematics.safety.joint_motion import TrajectoryMotion
from gpr_kinematics.safety.motion import levers


def timed(fn, repeat: int, clock=time.process_time) -> list[float]:
    """:func:`bench_core.timed`, one call per sample, on the CPU time of the process unless ``clock`` says otherwise."""
    return bench_core.timed(fn, repeat, clock=clock)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--quick', action='store_true', help='fewer repetitions (a smoke run)')
    args = parser.parse_args()
    repeat = 1 if args.quick else 5
    robot = load_robot()
    cell = load_cell(config_path('cells/example_cell.yaml'))
    plan = plan_program(robot, load_program(config_path('programs/example_cell_program.yaml')))
    joints = ControllerJoints.of(robot)
    tol = Tolerances.uniform(len(joints.names), 0.0, 1e-3, 0.5)
    check = GoalClearance(robot, cell, wafer_arms=('arm2',))
    print(f'machine: {platform.machine()}, {os.cpu_count()} CPUs, Python {platform.python_version()}, numpy '
          f'{np.__version__}, load average {os.getloadavg()[0]:.1f}')
    rows: list[tuple[str, float, str]] = []

    def motion_of(rate: float):
        traj = program_trajectory(plan, rate)
        return traj, plan_motion(joints, traj, traj.positions[0], 100.0, robot.config, tol, 1e-3)

    for rate in (20.0, 100.0, 500.0):
        traj, motion = motion_of(rate)
        reports = []
        cost = timed(lambda m=motion, out=reports: out.append(check.report(m)), repeat)
        checks = timed(lambda t=traj: plan_motion(joints, t, t.positions[0], 100.0, robot.config, tol, 1e-3),
                       repeat)
        r = reports[-1]
        rows.append((f'goal of {len(traj):,} points ({rate:g} Hz, {traj.duration:.1f} s): clearance check, CPU time '
                     f'({r.evaluations:,} library calls, {r.instants:,} instants)', statistics.median(cost), 's'))
        rows.append((f'the same goal: the other checks (limits, tilt, {len(motion):,} samples at 100 Hz)',
                     statistics.median(checks), 's'))
    traj, motion = motion_of(100.0)
    N = len(joints.names)
    build = timed(lambda: TrajectoryMotion.of(robot, traj, np.arange(N), traj.positions[0]).spline.travel(
        np.zeros(1), np.zeros(1)), repeat)
    rows.append((f'spline of the 100 Hz goal and every segment\'s turning points ({len(traj) - 1:,} segments x '
                 f'{N + 4} columns)', statistics.median(build) * 1e3, 'ms'))
    moving = TrajectoryMotion.of(robot, traj, np.arange(N), traj.positions[0])
    bodies = robot_body_set(robot, {'arm2': ((0.0, math.inf),)})
    lev = levers(robot, bodies)
    rng = np.random.default_rng(0)
    t0 = np.sort(rng.uniform(0.0, traj.duration, 20_000))
    t1 = np.minimum(t0 + rng.uniform(0.0, 1.0, t0.size), traj.duration)
    ends = moving.snapshot(np.concatenate([t0, t1]))
    K = t0.size

    def pair(v):
        return np.stack([v[:K], v[K:]], axis=1)

    bounds = timed(lambda: moving.bounds(t0, t1, lev, pair(ends.sigma), pair(ends.gamma), pair(ends.displacement)),
                   repeat)
    rows.append(('motion bounds of every body on an interval (spline travel, arm levers, platform; batch of 20,000)',
                 statistics.median(bounds) / K * 1e6, 'us'))
    poses = timed(lambda: moving.snapshot(t0[:2000]), repeat)
    rows.append(('robot poses at an instant (the spline, exact kinematics, every frame; batch of 2,000)',
                 statistics.median(poses) / 2000 * 1e6, 'us'))

    # a box on the carried wafer's path, 0.2 s into the carrying: the goal is refused
    snap = moving.snapshot(np.array([20.0]))
    p, R = snap.frames['arm2_wafer']
    box = Obstacle('box', 'box', (0.02, 0.02, 0.02), p[0] + R[0] @ np.array([0.12, 0.0, 0.0]), np.eye(3))
    blocked = GoalClearance(robot, Cell((*cell.obstacles, box), cell.frame, cell.source), wafer_arms=('arm2',))
    said: list[str] = []

    def refuse() -> None:
        try:
            plan_motion(joints, traj, traj.positions[0], 100.0, robot.config, tol, 1e-3, blocked)
        except GoalError as exc:
            said.append(str(exc))

    refused = timed(refuse, repeat)
    rows.append(('the 100 Hz goal with a 20 mm box on the carried wafer\'s path: refused (all the goal\'s checks)',
                 statistics.median(refused), 's'))
    full = []
    every = timed(lambda: full.append(clearance(moving, check.bodies, check.pairs, check.margin, check.tolerance)),
                  1)
    rows.append((f'the 100 Hz goal, every pair\'s minimum to the tolerance instead of the margin alone '
                 f'({full[-1].evaluations:,} library calls; once)', every[0], 's'))

    objs = [fcl_object(b) for b in check.bodies]
    request = fcl.DistanceRequest(enable_nearest_points=True, enable_signed_distance=True)
    a, b = next((i, j) for i, j, _ in check.pairs if check.bodies[i].kind == check.bodies[j].kind == 'box'
                and check.bodies[j].frame is None)       # a link's box and a wall's, as bench_clearance.py
    n = 2000
    own = timed(lambda: [fcl.distance(objs[a], objs[b], request, fcl.DistanceResult()) for _ in range(n)], repeat,
                time.perf_counter)
    per_call = statistics.median(own) / n
    rows.append(('peer: `fcl.distance` of one pair, bodies placed once', per_call * 1e6, 'us'))
    rows.append((f'plain sampled check at the controller\'s 100 Hz: {len(motion):,} samples x {len(check.pairs)} '
                 'pairs of library calls', len(motion) * len(check.pairs) * per_call, 's (estimate)'))
    print(f'\nrefusal: {said[-1] if said else "none"}')
    print(f'load average at the end {os.getloadavg()[0]:.1f}\n')
    print('| measurement | median | unit |\n|---|---:|---|')
    for name, value, unit in rows:
        print(f'| {name} | {value:,.3g} | {unit} |')


if __name__ == '__main__':
    main()
