"""Benchmark of the whole robot (issue: whole-robot offline programming), all in one run.

Measures, on the shipped example robot: batch station inverse kinematics per station (``solve_stations``: the
GPR's inverse kinematics, the height for the wafer point, the arm in closed form, and the naive model's joints
with their wafer error) for the 3-joint arm, the 4-joint arm under ``fixed_joint`` and under ``nearest``; one
station per call; whole-robot forward kinematics per configuration in batch; a 1,000-station program checked
(every waypoint solved, every move timed) and its waypoint joint table exported as CSV and JSON; and sampling and
exporting the program at 100 Hz.

The peer is what a user would otherwise write: ``scipy.optimize.least_squares`` on the whole robot's forward
kinematics (6 unknowns: 3 rods, 3 arm joints; 6 residuals: wafer position and orientation), one station at a
time, started from the naive model's joints, at equal accuracy (checked in the run: the same rods and joints to
1e-9 and the station reproduced to 1e-9 m).

Prints a Markdown table of medians. Usage: ``python benchmarks/bench_robot.py [--quick] [--cpu] [--before TREE]``;
``--before TREE`` also times one station and one configuration per call, and the batches, in another checkout
(``TREE/gpr_kinematics``, e.g. the commit before a change) and in this one, alternating the two in fresh processes
(CPU time, best of the repeats per round, median of the rounds).
"""
from __future__ import annotations

import argparse
import os
import platform
import statistics
import tempfile
import time
from pathlib import Path

import bench_core
import numpy as np
import yaml
from bench_core import print_before_after
from gpr_kinematics.core import inverse_batch
from gpr_kinematics.core.rotations import rotation_angle
from gpr_kinematics.robot import Stations, load_robot, robot_forward, solve_stations, stations_from_poses
from gpr_kinematics.robot.description import parse_robot
from gpr_kinematics.robot.export import sample_table, waypoint_table, write_table
from gpr_kinematics.robot.plan import plan_program, sample_plan
from gpr_kinematics.robot.planar_arm import branch_of
from gpr_kinematics.robot.program import load_program
from scipy.optimize import least_squares

CLOCK = time.perf_counter


def timed(fn, repeat: int) -> list[float]:
    """:func:`bench_core.timed` on this script's clock (``--cpu``: the CPU time of the process)."""
    return bench_core.timed(fn, repeat, clock=CLOCK)


def random_stations(robot, arm: str, n: int, seed: int = 0):
    """Reachable stations: the wafer poses of random postures (heights, tilts within 95 % of the limit, joints
    within their limits, a 4-joint arm's held joint at its rule's value)."""
    rng = np.random.default_rng(seed)
    cfg = robot.config
    Q = inverse_batch(rng.uniform(0.08, 0.42, n), rng.uniform(0, 0.95, n) * cfg.tilt_limit,
                      rng.uniform(-np.pi, np.pi, n), cfg).q
    a = robot.arm(arm)
    J = rng.uniform(a.lower + 1e-6, a.upper - 1e-6, (n, len(a.joints)))
    if a.redundancy is not None and a.redundancy.rule == 'fixed_joint':
        J[:, a.redundancy.joint] = a.redundancy.value
    fk = robot_forward(robot, Q, J, arm)
    return stations_from_poses(fk.wafer.position, fk.wafer.rotation), Q, J, branch_of(a, J)


def peer_solve(robot, station: Stations, start: np.ndarray) -> np.ndarray:
    """least_squares on the whole-robot forward kinematics (rods + 3 joints), one station."""
    target_p, target_R = station.position[0], station.rotation[0]

    def residual(x):
        fk = robot_forward(robot, x[None, :3], x[None, 3:], 'arm1', check_limits=False)
        dR = target_R.T @ fk.wafer.rotation[0]
        return np.concatenate([fk.wafer.position[0] - target_p, 0.5 * np.array([dR[2, 1] - dR[1, 2],
                                                                                  dR[0, 2] - dR[2, 0],
                                                                                  dR[1, 0] - dR[0, 1]])])

    return least_squares(residual, start, xtol=1e-15, ftol=1e-15, gtol=1e-15, method='lm').x


def program_files(robot, n: int, folder: Path) -> tuple[Path, Path]:
    """Two programs of ``n`` stations around the robot, each station picked or placed (3 waypoints each): the
    stations inline in the YAML, and the same stations imported from a CSV file."""
    rng = np.random.default_rng(1)
    r = rng.uniform(0.4, 0.7, n)
    ang = rng.uniform(-2.5, 2.5, n)
    base = np.array(robot.base_position)
    stations = [{'name': f's{i}', 'position': [float(base[0] + r[i] * np.cos(ang[i])),
                                               float(base[1] + r[i] * np.sin(ang[i])), float(rng.uniform(0.3, 0.6))],
                 'tilt': float(rng.uniform(0, 0.03)), 'azimuth': float(rng.uniform(-3, 3)), 'heading': float(ang[i]),
                 'branch': 'left' if ang[i] < 0 else 'right'} for i in range(n)]
    steps = [{'pick' if i % 2 else 'place': f's{i}'} for i in range(n)]
    inline = folder / 'inline.yaml'
    inline.write_text(yaml.safe_dump({'format': 'gpr_robot_program', 'stations': stations, 'steps': steps}))
    lines = ['name,x,y,z,tilt,azimuth,heading,branch']
    lines += [','.join([s['name'], *map(repr, s['position']), repr(s['tilt']), repr(s['azimuth']),
                        repr(s['heading']), s['branch']]) for s in stations]
    (folder / 'stations.csv').write_text('\n'.join(lines) + '\n')
    imported = folder / 'imported.yaml'
    imported.write_text(yaml.safe_dump({'format': 'gpr_robot_program', 'import': ['stations.csv'], 'steps': steps}))
    return inline, imported


#: One-station calls and batches timed in a fresh process for ``--before``, printed as JSON [us per call or station].
ROBOT_CALLS = """
import json, sys, time, timeit
from pathlib import Path
import yaml
sys.path.insert(0, BENCHMARKS)
from bench_robot import random_stations  # the stations of this script, made by the tree under test
from gpr_kinematics.robot import load_robot, robot_forward, solve_stations
from gpr_kinematics.robot.description import parse_robot
robot = load_robot()
data = yaml.safe_load(Path(robot.source).read_text())
data['arms'][1]['redundancy'] = {'rule': 'nearest'}
nearest = parse_robot(data, 'nearest', Path(robot.source).parent)
def best(fn, number, repeat):
    fn()
    return min(timeit.repeat(fn, number=number, repeat=repeat, timer=time.process_time)) / number * 1e6
out = {}
for label, rob, arm, n in (('arm1', robot, 'arm1', 10_000), ('arm2, fixed_joint', robot, 'arm2', 10_000),
                           ('arm2, nearest', nearest, 'arm2', 1_000)):
    st, Q, J, br = random_stations(rob, arm, n, 2)
    out[f'station IK, batch ({label}), per station'] = best(
        lambda: solve_stations(rob, st, arm, branch=br, check=False), 1, 3) / n
    one, b0 = st.take([0]), br[0]
    calls = 5 if 'nearest' in label else 50
    out[f'station IK, one station per call ({label})'] = best(lambda: solve_stations(rob, one, arm, branch=b0),
                                                              calls, 5)
    if arm == 'arm1':
        out['whole-robot FK, one configuration per call (arm1)'] = best(
            lambda: robot_forward(rob, Q[:1], J[:1], arm), 500, 5)
        out['whole-robot FK, batch of 10,000 (arm1), per configuration'] = best(
            lambda: robot_forward(rob, Q, J, arm), 1, 3) / n
print(json.dumps(out))
""".replace('BENCHMARKS', repr(str(Path(__file__).resolve().parent)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--quick', action='store_true', help='fewer repetitions (smoke run)')
    ap.add_argument('--before', type=Path, metavar='TREE',
                    help='also compare one-station calls and batches with the checkout TREE, alternating')
    ap.add_argument('--cpu', action='store_true', help='time with the CPU time of this process, not the wall clock')
    args = ap.parse_args()
    global CLOCK
    if args.cpu:
        CLOCK = time.process_time
    rep = 3 if args.quick else 7
    robot = load_robot()
    data = yaml.safe_load(Path(robot.source).read_text())
    data['arms'][1]['redundancy'] = {'rule': 'nearest'}
    nearest = parse_robot(data, 'nearest', Path(robot.source).parent)
    rows = []
    n = 10_000
    for label, rob, arm, count in (('3-joint arm (arm1)', robot, 'arm1', n),
                                   ('4-joint arm, fixed_joint (arm2)', robot, 'arm2', n),
                                   ('4-joint arm, nearest (arm2)', nearest, 'arm2', 1_000)):
        st, _, _, br = random_stations(rob, arm, count, seed=2)
        sol = solve_stations(rob, st, arm, branch=br, check=False)
        assert sol.feasible.mean() > 0.9 and np.max(sol.position_error[sol.feasible]) < 1e-9
        t = timed(lambda r=rob, s=st, a=arm, b=br: solve_stations(r, s, a, branch=b, check=False), rep)
        rows.append((f'station IK, batch of {count:,}, {label}', statistics.median(t) / count * 1e6, 'us/station',
                     '<= 10' if 'nearest' not in label else '', min(t) / count * 1e6))
        if arm == 'arm1':
            t = timed(lambda s=st: inverse_batch(0.25, s.tilt, s.azimuth, robot.config), rep)
            rows.append(('  of which the GPR alone: inverse_batch of the same tilts',
                         statistics.median(t) / count * 1e6, 'us/station', '', min(t) / count * 1e6))
    st, Q, J, br = random_stations(robot, 'arm1', 100_000, seed=3)
    t = timed(lambda: robot_forward(robot, Q, J, 'arm1'), rep)
    rows.append(('whole-robot FK, batch of 100,000 (arm1)', statistics.median(t) / 1e5 * 1e6, 'us/configuration',
                 '<= 10', min(t) / 1e5 * 1e6))
    t = timed(lambda: [robot_forward(robot, Q[i:i + 1], J[i:i + 1], 'arm1') for i in range(200)], rep)
    rows.append(('whole-robot FK, one configuration per call (arm1)', statistics.median(t) / 200 * 1e6, 'us/call', ''))
    for label, rob, arm, count in (('3-joint arm (arm1)', robot, 'arm1', 200),
                                   ('4-joint arm, fixed_joint (arm2)', robot, 'arm2', 200),
                                   ('4-joint arm, nearest (arm2)', nearest, 'arm2', 10)):
        st1, _, _, br1 = random_stations(rob, arm, count, seed=5)
        t = timed(lambda r=rob, s=st1, a=arm, b=br1, c=count: [solve_stations(r, s.take([i]), a, branch=b[i])
                                                               for i in range(c)], rep)
        rows.append((f'station IK, one station per call, {label}', statistics.median(t) / count * 1e6, 'us/call',
                     '<= 20x its batch per station'))

    # The peer, at equal accuracy, one station at a time.
    m = 20 if args.quick else 60
    sub = st.take(np.arange(m))
    ours = solve_stations(robot, sub, 'arm1', branch=list(br[:m]))
    starts = np.column_stack([ours.naive_rods, ours.naive_joints])
    for i in range(m):
        x = peer_solve(robot, sub.take([i]), starts[i])
        fk = robot_forward(robot, x[None, :3], x[None, 3:], 'arm1', check_limits=False)
        assert np.linalg.norm(fk.wafer.position[0] - sub.position[i]) < 1e-9, 'peer missed the station'
        assert rotation_angle(fk.wafer.rotation, sub.rotation[i:i + 1])[0] < 1e-9
        assert np.max(np.abs(x - np.concatenate([ours.rods[i], ours.joints[i]]))) < 1e-9, 'peer found another solution'
    t = timed(lambda: [peer_solve(robot, sub.take([i]), starts[i]) for i in range(m)], max(3, rep // 2))
    peer = statistics.median(t) / m * 1e6
    rows.append(('peer: least_squares on the whole-robot FK, per station (arm1)', peer, 'us/station', ''))

    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        inline, imported = program_files(robot, 1000, folder)

        def check_and_export(program):
            plan = plan_program(robot, program)
            columns, table = waypoint_table(plan)
            write_table(folder / 'w.csv', columns, table, {})
            write_table(folder / 'w.json', columns, table, {'robot': robot.name})
            return plan

        program = load_program(imported)
        plan = check_and_export(program)
        assert len(plan.waypoints) == 3000
        t = timed(lambda: check_and_export(program), rep)
        rows.append(('1,000-station program (3,000 waypoints): check + export CSV and JSON', statistics.median(t),
                     's', '< 1'))
        t = timed(lambda: check_and_export(load_program(imported)), rep)
        rows.append(('  the same, reading the program first (stations imported from CSV)', statistics.median(t), 's',
                     '< 1'))
        t = timed(lambda: load_program(inline), rep)
        rows.append(('  reading the program with the 1,000 stations inline in its YAML (PyYAML)', statistics.median(t),
                     's', ''))

        # 50 Hz: the program lasts about 2,900 s at the example robot's limits (290,000 samples at 100 Hz, over the
        # export's bound of 200,000)
        def samples():
            sampled = sample_plan(plan, 50.0)
            write_table(folder / 's.csv', *sample_table(plan, sampled), {})
            return len(sampled)

        count = samples()
        t = timed(samples, max(3, rep // 2))
        rows.append((f'the same program sampled at 50 Hz ({count:,} samples, FK each) + CSV',
                     statistics.median(t) / count * 1e6, 'us/sample', ''))

    print(f'machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, '
          f'numpy {np.__version__}; load average {os.getloadavg()[0]:.2f} at the end; clock: '
          f'{"CPU time of the process" if args.cpu else "wall clock"}')
    print()
    print('| measurement | median | best | unit | target |')
    print('|---|---:|---:|---|---|')
    for name, value, unit, target, *best in rows:
        print(f'| {name} | {value:.3g} | {f"{best[0]:.3g}" if best else ""} | {unit} | {target} |')
    ik = rows[0][1]
    value = {r[0]: r[1] for r in rows}
    one = value['station IK, one station per call, 3-joint arm (arm1)']
    fixed = value['station IK, batch of 10,000, 4-joint arm, fixed_joint (arm2)']
    near = value['station IK, batch of 1,000, 4-joint arm, nearest (arm2)']
    print()
    print(f'speed-up of batch station IK over the peer: {peer / ik:.0f}x (3-joint arm); one station per call: '
          f'{one / ik:.1f}x its batch cost per station (target <= 20), {peer / one:.0f}x faster than the peer '
          f'(target >= 100); nearest one station per call: '
          f'{value["station IK, one station per call, 4-joint arm, nearest (arm2)"] / near:.1f}x its batch cost per '
          f'station (target <= 20); nearest / fixed_joint per station in batch: '
          f'{near / fixed:.1f} (target <= 3)')
    if args.before is not None:
        print_before_after(args.before, 3 if args.quick else 5, ROBOT_CALLS)


if __name__ == '__main__':
    main()
