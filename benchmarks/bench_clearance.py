"""Benchmark of the certified clearance check (issue 19), all in one run.

Measures, on the shipped example cell and its program (docs/cell.md): the whole ``gpr program check`` of the
program (planning, certified clearance of every pair, wafer slip) and of the older example program in the same
cell; the check's cost per sample (of the program at the base rate) and per body pair; the pieces the check is made
of: the robot's poses per instant (the exact kinematics, straight entries solved on their line), the
separating-axis bound per pair and instant (numpy, vectorised) and an exact distance through the check's own
loop (placing the bodies, FCL, nearest points); and, as the peer, the collision library's own distance call
(``fcl.distance`` of two bodies placed once) in the same run, with what a plain sampled check (the library at
every sample for every pair, 100 Hz, no certificate) costs on the same program.

Prints a Markdown table of medians. Usage: ``python benchmarks/bench_clearance.py [--quick]``.
"""
from __future__ import annotations

import argparse
import os
import platform
import statistics
import time

import bench_core
import fcl
import numpy as np
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.robot import load_robot
from gpr_kinematics.robot.plan import plan_program
from gpr_kinematics.robot.program import load_program
from gpr_kinematics.safety.bodies import box_lower_bound, cell_bodies, default_pairs, robot_body_set
from gpr_kinematics.safety.cell import load_cell
from gpr_kinematics.safety.check import check_program, wafer_plan
from gpr_kinematics.safety.clearance import BASE_RATE
from gpr_kinematics.safety.motion import PlanMotion


def timed(fn, repeat: int, clock=time.perf_counter) -> list[float]:
    """:func:`bench_core.timed`, one call per sample, on the wall clock unless ``clock`` says otherwise."""
    return bench_core.timed(fn, repeat, clock=clock)


def fcl_object(body):
    geom = fcl.Box(*body.size) if body.kind == 'box' else fcl.Cylinder(*body.size)
    return fcl.CollisionObject(geom, fcl.Transform(body.rotation, body.position))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--quick', action='store_true', help='fewer repetitions (a smoke run)')
    args = parser.parse_args()
    repeat = 1 if args.quick else 5
    robot = load_robot()
    cell = load_cell(config_path('cells/example_cell.yaml'))
    program = load_program(config_path('programs/example_cell_program.yaml'))
    older = load_program(config_path('programs/example_robot_program.yaml'))
    print(f'machine: {platform.machine()}, {os.cpu_count()} CPUs, Python {platform.python_version()}, numpy '
          f'{np.__version__}, load average {os.getloadavg()[0]:.1f}')
    rows = []

    plan = plan_program(robot, program)
    reports = []
    whole = timed(lambda: reports.append(check_program(plan_program(robot, program), cell)), repeat)
    report, clear, _ = reports[-1]
    samples = int(np.floor(plan.timing.total * 100.0)) + 1   # per sample of 100 Hz, the peer's sampling
    pairs = len(report.pairs)
    rows.append(('whole check of the example cell program (plan, clearance, slip)', statistics.median(whole), 's'))
    cpu = timed(lambda: check_program(plan_program(robot, program), cell), repeat, time.process_time)
    rows.append(('the same, CPU time of the process', statistics.median(cpu), 's'))
    rows.append((f'the same per sample ({samples} at 100 Hz; the check samples at {BASE_RATE:g} Hz and refines) '
                 f'and per body pair ({pairs})',
                 statistics.median(whole) / samples / pairs * 1e6, 'us'))
    older_t = timed(lambda: check_program(plan_program(robot, older), cell), repeat)
    rows.append(('whole check of the older example program in the same cell', statistics.median(older_t), 's'))

    motion = PlanMotion(plan)
    t = np.linspace(0.0, plan.timing.total, 2000)
    poses = timed(lambda: motion.snapshot(t), repeat)
    rows.append(('robot poses at an instant (exact kinematics, every frame; batch of 2,000)',
                 statistics.median(poses) / t.size * 1e6, 'us'))

    bodies = robot_body_set(robot, wafer_plan(plan).carried) + cell_bodies(cell)
    pair_list = default_pairs(bodies)
    snap = motion.snapshot(t)
    a = np.array([i for i, _ in pair_list])
    b = np.array([j for _, j in pair_list])
    k = np.random.default_rng(0).integers(0, t.size, 200_000)
    p = np.random.default_rng(1).integers(0, len(pair_list), 200_000)

    def pose(idx, kk):
        R, c = np.empty((kk.size, 3, 3)), np.empty((kk.size, 3))
        for n in np.unique(idx):
            body, sel = bodies[n], idx == n
            if body.frame is None:
                R[sel], c[sel] = body.rotation, body.position
            else:
                fp, fR = snap.frames[body.frame]
                R[sel], c[sel] = fR[kk[sel]] @ body.rotation, fp[kk[sel]] + fR[kk[sel]] @ body.position
        return R, c

    Ra, ca = pose(a[p], k)
    Rb, cb = pose(b[p], k)
    half = np.stack([x.half for x in bodies])
    sat = timed(lambda: box_lower_bound(Ra, ca, half[a[p]], Rb, cb, half[b[p]]), repeat)
    rows.append(('separating-axis bound, per pair and instant (batch of 200,000)',
                 statistics.median(sat) / p.size * 1e6, 'us'))

    # the library's own call, bodies placed once; then the check's loop (place both bodies, call, nearest points)
    objs = [fcl_object(x) for x in bodies]
    request = fcl.DistanceRequest(enable_nearest_points=True, enable_signed_distance=True)
    n = 2000
    pa, pb = objs[a[p[0]]], objs[b[p[0]]]
    pa.setRotation(Ra[0]); pa.setTranslation(ca[0]); pb.setRotation(Rb[0]); pb.setTranslation(cb[0])  # noqa: E702
    own = timed(lambda: [fcl.distance(pa, pb, request, fcl.DistanceResult()) for _ in range(n)], repeat)
    rows.append(('peer: `fcl.distance` of one pair, bodies placed once', statistics.median(own) / n * 1e6, 'us'))

    def loop() -> None:
        for m in range(n):
            oa, ob = objs[a[p[m]]], objs[b[p[m]]]
            oa.setRotation(Ra[m]); oa.setTranslation(ca[m]); ob.setRotation(Rb[m]); ob.setTranslation(cb[m])  # noqa: E702
            res = fcl.DistanceResult()
            fcl.distance(oa, ob, request, res)
            _ = res.nearest_points[0] - res.nearest_points[1]

    placed = timed(loop, repeat)
    rows.append(('an exact distance as the check calls it (both bodies placed, nearest points)',
                 statistics.median(placed) / n * 1e6, 'us'))
    per_call = statistics.median(own) / n
    sampled = 100 * plan.timing.total * len(pair_list) * per_call
    rows.append((f'plain sampled check at 100 Hz (no certificate): {int(100 * plan.timing.total)} samples x '
                 f'{len(pair_list)} pairs of library calls', sampled, 's (estimate from the peer row)'))
    rows.append(('library calls the certified check made', report.evaluations, 'calls'))
    rows.append(('instants whose poses it computed', report.instants, 'instants'))
    rows.append(('its certified minimum clearance', report.min_clearance * 1e3, 'mm'))

    print(f'\nload average at the end {os.getloadavg()[0]:.1f}\n')
    print('| measurement | median | unit |\n|---|---:|---|')
    for name, value, unit in rows:
        print(f'| {name} | {value:,.3g} | {unit} |')
    del clear


if __name__ == '__main__':
    main()
