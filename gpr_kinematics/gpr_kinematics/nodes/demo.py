"""``make demo``: the node suite end to end, over real DDS on this machine.

Starts ``kinematics_node`` and ``trajectory_node`` as separate processes (found the way ``ros2 run`` finds
them: ament index prefix, then ``lib/gpr_kinematics/<exe>``), calls each service once from this client
process (the platform's and the whole robot's) and prints the answers, records one paper sweep from the
trajectory node and prints a summary.
Exits 0 when every step worked, 1 otherwise. SI units; mm/µm/deg only in the printed text.

Run: ``python -m gpr_kinematics.nodes.demo [--rate HZ] [--azimuth-step-deg D] [--tilt-step-deg D]``.
"""
from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Sequence
from typing import Any

from ..core.messages import Service, Topic
from ..core.sweep import DEFAULT_AZIMUTH_STEP, DEFAULT_HEIGHT, DEFAULT_MAX_TILT, DEFAULT_TILT_STEP
from ..ros import env as ros_env
from ..ros.process import NodeProcess


def _parse(argv: Sequence[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog='gpr-demo', description=__doc__.split('\n\n')[0])
    p.add_argument('--rate', type=float, default=250.0, help='trajectory rate [Hz] (default 250)')
    p.add_argument('--height', type=float, default=DEFAULT_HEIGHT,
                   help=f'sweep height [m] (default {DEFAULT_HEIGHT:g})')
    for name, value in (('tilt-step', DEFAULT_TILT_STEP), ('azimuth-step', DEFAULT_AZIMUTH_STEP),
                        ('max-tilt', DEFAULT_MAX_TILT)):
        deg = round(math.degrees(value), 9)
        p.add_argument(f'--{name}-deg', type=float, default=deg, help=f'sweep {name.replace("-", " ")} [deg] (default '
                       f'{deg:g})')
    return p.parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    args = _parse(argv)
    os.environ.setdefault('ROS_DOMAIN_ID', str(os.getpid() % 5))  # tests use 10..99
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    try:
        ros_env.activate()
    except FileNotFoundError as exc:
        print(f'demo: {exc}', file=sys.stderr)
        return 1
    return _demo(args)


def _start(exe: str, *ros_args: str) -> NodeProcess:
    proc = NodeProcess(exe, ros_args, echo=True)
    print(f'$ {proc.command}', flush=True)
    return proc


def _demo(args: argparse.Namespace) -> int:  # noqa: C901 - a linear script
    import numpy as np

    from gpr_interfaces.msg import PlatformState

    from ..core.config import load_config
    from ..core.rotations import quaternion_from_matrix, tilt_rotation
    from .client import GprClient

    cfg = load_config()
    failures: list[str] = []
    kin = _start('kinematics_node')
    client = GprClient('gpr_demo_client')
    traj = None

    def check(name: str, res: Any) -> Any:
        if not res.success:
            failures.append(f'{name}: {res.message}')
        return res

    def fmt(v: Any, scale: float = 1.0, digits: int = 6) -> str:
        return '(' + ', '.join(f'{scale * x:.{digits}f}' for x in v) + ')'

    def xyz(p: Any) -> list[float]:
        return [p.x, p.y, p.z]

    try:
        print('\n== gpr/forward_kinematics: q = (0.5, 0.498, 0.502) m', flush=True)
        r = check(Service.FORWARD_KINEMATICS, client.forward_kinematics([0.5, 0.498, 0.502]))
        vj = dict(zip(r.virtual_joint_names, (round(v, 9) for v in r.virtual_joints), strict=True))
        print(f'   success {r.success} {r.message}\n   model {r.model}, iterations {r.iterations}, '
              f'residual {r.residual:.2e} m\n   position {fmt(xyz(r.pose.position))} m, tilt '
              f'{math.degrees(r.tilt):.4f} deg about azimuth {math.degrees(r.tilt_azimuth):.2f} deg\n'
              f'   centre shift vs naive model {fmt(xyz(r.centre_shift), 1e6, 3)} µm\n'
              f'   virtual joints {vj}')

        print('\n== gpr/inverse_kinematics: height 0.45 m, tilt 1.5 deg about azimuth 30 deg', flush=True)
        r = check(Service.INVERSE_KINEMATICS, client.inverse_kinematics(0.45, math.radians(1.5), math.radians(30.0)))
        print(f'   success {r.success} {r.message}\n   q {fmt(r.q)} m ({r.iterations} iterations)\n'
              f'   achieved position {fmt(xyz(r.achieved.position))} m, tilt {math.degrees(r.tilt):.6f} deg, '
              f'twist {math.degrees(r.twist):.2e} deg')

        print('\n== gpr/compensate: naive command z 0.40 m, tilt 2 deg about azimuth 90 deg, tool (0.1, 0, 0.15) m',
              flush=True)
        quat = quaternion_from_matrix(tilt_rotation(math.radians(2.0), math.radians(90.0)))
        r = check(Service.COMPENSATE, client.compensate((0.0, 0.0, 0.40), quat, (0.1, 0.0, 0.15)))
        t = r.arm_correction.translation
        print(f'   success {r.success} {r.message}\n   q {fmt(r.q)} m\n'
              f'   tool shift {fmt(xyz(r.tool_shift), 1e6, 3)} µm\n'
              f'   arm correction translation {fmt([t.x, t.y, t.z], 1e6, 3)} µm (platform frame)')

        print('\n== gpr/analyze_mobility: singular q = (0.5, 0.5, 0.5) m and tilted q = (0.5, 0.498, 0.502) m',
              flush=True)
        for q_rods in ((0.5, 0.5, 0.5), (0.5, 0.498, 0.502)):
            r = check(Service.ANALYZE_MOBILITY, client.analyze_mobility(q_rods, (0.0, 1e-4, -1e-4)))
            print(f'   q {q_rods}: success {r.success}, rank dPhi/dP {r.rank_dphi_dp}, rank [dPhi/dP dPhi/dX] '
                  f'{r.rank_augmented}, singular values {fmt(r.singular_values, 1.0, 4)}\n'
                  f'      bounds (4) [{r.eq4_lower:.4f}, {r.eq4_upper:.4f}], (5) [{r.eq5_lower:.4f}, '
                  f'{r.eq5_upper:.4f}]; for dq = (0, 0.1, -0.1) mm: |dX| = {r.dx_norm:.3e} in '
                  f'[{r.dx_lower_eq4:.3e}, {r.dx_upper_eq4:.3e}]')

        print('\n== gpr/station_inverse_kinematics, then gpr/robot_forward_kinematics of its answer: the example '
              'robot, arm1, wafer at (1.2, 1.0, 0.455) m in the world, station plane tilted 1.2 deg about azimuth '
              '30 deg, blade heading 45 deg', flush=True)
        r = check(Service.STATION_INVERSE_KINEMATICS, client.station_inverse_kinematics(
            (1.2, 1.0, 0.455), math.radians(1.2), math.radians(30.0), math.radians(45.0), arm='arm1'))
        print(f'   success {r.success} {r.message}\n   rods {fmt(r.rods)} m; {r.arm} ({r.branch}) '
              + ', '.join(f'{n} {math.degrees(v):.4f} deg' for n, v in zip(r.joint_names, r.joints, strict=True))
              + f'\n   wafer reached to {r.position_error:.1e} m; the naive model\'s joints would miss it by '
              f'{1e6 * r.naive_wafer_error:.3f} µm')
        f = check(Service.ROBOT_FORWARD_KINEMATICS, client.robot_forward_kinematics(r.rods, r.joints, arm=r.arm))
        print(f'   forward kinematics of that answer: wafer at {fmt(xyz(f.wafer.position))} m; for the same rods and '
              f'joints the naive model would place it {1e6 * f.naive_wafer_error_norm:.3f} µm away')

        step, az_step = math.radians(args.tilt_step_deg), math.radians(args.azimuth_step_deg)
        max_tilt = math.radians(args.max_tilt_deg)
        print(f'\n== trajectory_node: paper sweep at {args.height} m, ±{args.max_tilt_deg} deg in '
              f'{args.tilt_step_deg} deg steps, azimuth step {args.azimuth_step_deg} deg, {args.rate} Hz',
              flush=True)
        states = client.subscribe(PlatformState, Topic.PLATFORM_STATE)
        traj = _start('trajectory_node', '-p', 'mode:=sweep', '-p', f'rate:={args.rate}',
                      '-p', f'height:={args.height}', '-p', f'max_tilt:={max_tilt!r}',
                      '-p', f'tilt_step:={step!r}', '-p', f'azimuth_step:={az_step!r}',
                      '-p', 'wait_for_subscribers:=1', '-p', 'wait_all_topics:=false')
        client.spin_until(lambda: not traj.alive(), 300)
        client.spin_for(0.5)
        status = traj.wait(timeout=10)
        if status != 0:
            failures.append(f'trajectory_node exited with status {status}')
        if not states:
            failures.append('no PlatformState received')
        else:
            samples = [m.sample for m in states]
            q = np.array([m.q for m in states])
            alpha = np.array([m.commanded_tilt for m in states])
            shift = np.array([[m.centre_shift.x, m.centre_shift.y] for m in states])
            disp = np.array([m.joint_displacement for m in states])
            stamps = np.array([m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec for m in states])
            in_order = samples == list(range(len(states)))
            if not in_order:
                failures.append('PlatformState samples not received in order')
            k = int(np.argmax(np.linalg.norm(shift, axis=1)))
            rate = (len(stamps) - 1) / (stamps[-1] - stamps[0]) if len(stamps) > 1 else float('nan')
            print(f'   received {len(states)} samples in order: {in_order}; trajectory_node exit status {status}\n'
                  f'   model {states[0].model}; singular crossings (alpha = 0): {int(np.sum(alpha == 0.0))}\n'
                  f'   largest centre shift {1e6 * np.linalg.norm(shift[k]):.3f} µm at tilt '
                  f'{math.degrees(states[k].tilt):.2f} deg, azimuth {math.degrees(states[k].commanded_azimuth):.0f} '
                  f'deg\n   largest joint displacement {1e6 * disp.max():.3f} µm (budget '
                  f'{1e6 * cfg.imperfection_budget:.0f} µm), all within budget: '
                  f'{all(m.within_budget for m in states)}\n'
                  f'   largest rod step between samples {1e6 * np.abs(np.diff(q, axis=0)).max():.1f} µm; '
                  f'stamped rate {rate:.1f} Hz (requested {args.rate} Hz)')
    except Exception as exc:  # noqa: BLE001 - the demo reports and fails, without a traceback
        failures.append(f'{type(exc).__name__}: {exc}')
    finally:
        if traj is not None:
            traj.stop()
        kin_status = kin.stop(timeout=5)
        if kin_status != 0:
            failures.append(f'kinematics_node exited with status {kin_status} after SIGINT')
        client.close()
    if failures:
        print('\ndemo FAILED:\n  ' + '\n  '.join(failures), file=sys.stderr)
        return 1
    print('\ndemo OK: both nodes ran as separate processes, every service answered, the sweep streamed '
          'and both nodes exited with status 0.')
    return 0


if __name__ == '__main__':
    sys.exit(main())
