"""The offline-programming loop of ``make demo``: stream the paper's sweep, record it, verify the bag.

Starts ``kinematics_node``, ``recorder_node`` and ``trajectory_node`` (the paper's sweep) as separate
processes, found the way ``ros2 run`` finds them (ament index prefix + ``lib/gpr_kinematics/<exe>``); waits
for the sweep to end; stops the recorder with SIGINT (it drains, closes the bag and exits 0); verifies the
bag against the current kinematics core (:func:`gpr_kinematics.bags.verify.verify_bag`); prints the
verification table and where the bag, the report and the plots are. Exit status 0 when the verification
passes, 1 when a check fails, 2 when a node fails or the bag cannot be read.

Run it in the ROS environment: ``python -m gpr_kinematics.ros.env exec -- python -m gpr_kinematics.ros.offline_loop``.
"""
from __future__ import annotations

import argparse
import math
import os
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from datetime import datetime
from pathlib import Path

from ..bags.errors import BagError
from ..bags.report import write_report
from ..bags.verify import format_table, verify_bag
from ..bags.writer import check_format
from ..core.sweep import DEFAULT_AZIMUTH_STEP, DEFAULT_TILT_STEP
from ..errors import GprError, InputError
from .process import NodeProcess
from .specs import node_specs


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog='gpr-offline-loop', description=__doc__.split('\n\n')[0])
    p.add_argument('--output', help='bag folder to create (default bags/demo_<date>-<time>)')
    p.add_argument('--report', help='report folder (default <bag>_report)')
    p.add_argument('--storage', choices=('mcap', 'sqlite3'), default='mcap')
    p.add_argument('--compression', choices=('none', 'zstd'), default='none')
    p.add_argument('--flush-interval', type=float, default=1.0, help='recorder flush interval [s]')
    p.add_argument('--rate', type=float, default=400.0, help='publishing rate of the trajectory node [Hz]')
    p.add_argument('--tilt-step-deg', type=float, default=round(math.degrees(DEFAULT_TILT_STEP), 9),
                   help='sweep step of the tilt [deg] (paper: 0.2)')
    p.add_argument('--azimuth-step-deg', type=float, default=round(math.degrees(DEFAULT_AZIMUTH_STEP), 9),
                   help='sweep step of the azimuth [deg]')
    p.add_argument('--timeout', type=float, default=300.0, help='longest wait for the sweep [s]')
    return p


def _check_steps(args: argparse.Namespace) -> None:
    """Refuse a sweep step the trajectory node refuses, in the degrees typed (its message named the radians)."""
    steps = {spec.name: spec.limits for spec in node_specs('trajectory_node')}
    for option, name, value in (('--tilt-step-deg', 'tilt_step', args.tilt_step_deg),
                                ('--azimuth-step-deg', 'azimuth_step', args.azimuth_step_deg)):
        lo, hi = steps[name] or (0.0, math.inf)
        if not lo <= math.radians(value) <= hi:
            raise InputError(f'{option} = {value:g} deg; allowed: {math.degrees(lo):.6g} to {math.degrees(hi):.6g} '
                             'deg')


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:   # before any node: the recorder refused zstd on sqlite3 at once, the sweep ran on without it
        check_format(args.storage, args.compression)
        _check_steps(args)
    except (BagError, InputError) as exc:
        print(f'offline loop: {exc}', file=sys.stderr)
        return 2
    stamp = datetime.now().strftime('%Y_%m_%d-%H_%M_%S')
    bag = Path(args.output) if args.output else Path('bags') / f'demo_{stamp}'
    report = Path(args.report) if args.report else bag.with_name(bag.name + '_report')
    env = dict(os.environ)
    env.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    env['PYTHONUNBUFFERED'] = '1'
    logs = Path(tempfile.mkdtemp(prefix='gpr_offline_loop_'))
    procs: list[NodeProcess] = []
    print(f'offline loop: kinematics_node, recorder_node -> {bag}, trajectory_node (paper sweep, '
          f'{args.tilt_step_deg} deg x {args.azimuth_step_deg} deg at {args.rate} Hz); logs in {logs}', flush=True)
    try:
        kin = NodeProcess('kinematics_node', env=env, log_dir=logs)
        rec = NodeProcess('recorder_node', ['-p', f'output:={bag}', '-p', f'storage:={args.storage}',
                                            '-p', f'compression:={args.compression}',
                                            '-p', f'flush_interval:={float(args.flush_interval)!r}'],
                          env=env, log_dir=logs)
        procs += [kin, rec]
        traj = NodeProcess('trajectory_node', ['-p', f'rate:={args.rate}', '-p', 'wait_for_subscribers:=1',
                                               '-p', f'tilt_step:={math.radians(args.tilt_step_deg)!r}',
                                               '-p', f'azimuth_step:={math.radians(args.azimuth_step_deg)!r}'],
                           env=env, log_dir=logs)
        procs.append(traj)
        end = time.monotonic() + args.timeout
        while True:
            try:
                status = traj.wait(timeout=0.5)
                break
            except subprocess.TimeoutExpired:
                if not rec.alive():   # a recorder that ended has nothing to record: the sweep is not waited for
                    print(f'offline loop: recorder_node exited with status {rec.wait()}:\n{rec.tail()}',
                          file=sys.stderr)
                    return 2
                if time.monotonic() > end:
                    print(f'offline loop: the sweep did not end within {args.timeout} s', file=sys.stderr)
                    return 2
        print(traj.tail(2), flush=True)
        if status != 0:
            print(f'offline loop: trajectory_node exited with status {status}:\n{traj.tail()}', file=sys.stderr)
            return 2
        time.sleep(0.3)
        rstatus = rec.stop(signal.SIGINT)
        print(rec.tail(1), flush=True)
        if rstatus != 0:
            print(f'offline loop: recorder_node exited with status {rstatus}:\n{rec.tail()}', file=sys.stderr)
            return 2
    except FileNotFoundError as exc:
        print(f'offline loop: {exc} (run `make setup`, then this under `python -m gpr_kinematics.ros.env exec --`)',
              file=sys.stderr)
        return 2
    finally:
        for p in procs:
            p.stop()
    try:
        result = verify_bag(bag)
        files = write_report(result, report)
    except GprError as exc:
        print(f'offline loop: error: {exc}', file=sys.stderr)
        return 2
    print(format_table(result))
    print(f'bag: {bag}\nreport: {report} ({len(files)} files; plots: '
          + ', '.join(f.name for f in files if f.suffix == '.png') + ')')
    return 0 if result.passed else 1


if __name__ == '__main__':
    sys.exit(main())
