"""The offline-programming loop of ``make demo``: stream the paper's sweep, record it, verify the bag.

Starts ``kinematics_node``, ``recorder_node`` and ``trajectory_node`` (the paper's sweep) as separate
processes, found the way ``ros2 run`` finds them (ament index prefix + ``lib/gpr_kinematics/<exe>``); waits
for the sweep to end; stops the recorder with SIGINT (it drains, closes the bag and exits 0); verifies the
bag against the current kinematics core (:func:`gpr_kinematics.bags.verify.verify_bag`); prints the
verification table and where the bag, the report and the plots are. Exit status 0 when the verification
passes, 1 when a check fails, 2 when a node fails or the bag cannot be read.

Run it in the ROS environment: ``python -m gpr_kinematics.ros_env exec -- python -m gpr_kinematics.offline_loop``.
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

from . import ros_env
from .bags.report import write_report
from .bags.verify import format_table, verify_bag
from .errors import GprError

PACKAGE = 'gpr_kinematics'


class _Proc:
    def __init__(self, exe: str, ros_args: Sequence[str], env: dict[str, str], logs: Path) -> None:
        self.exe = exe
        path = ros_env.find_executable(PACKAGE, exe, env)
        self.log = logs / f'{exe}.log'
        self._f = open(self.log, 'wb')  # noqa: SIM115 - closed in stop()
        self.proc = subprocess.Popen([str(path), '--ros-args', *ros_args], stdout=self._f, stderr=subprocess.STDOUT,
                                     stdin=subprocess.DEVNULL, env=env)

    def stop(self, sig: int = signal.SIGINT, timeout: float = 15.0) -> int:
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
            try:
                self.proc.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self._f.close()
        return int(self.proc.returncode)

    def tail(self, n: int = 5) -> str:
        if not self._f.closed:
            self._f.flush()
        return '\n'.join(self.log.read_text(errors='replace').splitlines()[-n:])


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog='gpr-offline-loop', description=__doc__.split('\n\n')[0])
    p.add_argument('--output', help='bag folder to create (default bags/demo_<date>-<time>)')
    p.add_argument('--report', help='report folder (default <bag>_report)')
    p.add_argument('--storage', choices=('mcap', 'sqlite3'), default='mcap')
    p.add_argument('--compression', choices=('none', 'zstd'), default='none')
    p.add_argument('--flush-interval', type=float, default=1.0, help='recorder flush interval [s]')
    p.add_argument('--rate', type=float, default=400.0, help='publishing rate of the trajectory node [Hz]')
    p.add_argument('--tilt-step-deg', type=float, default=0.2, help='sweep step of the tilt [deg] (paper: 0.2)')
    p.add_argument('--azimuth-step-deg', type=float, default=10.0, help='sweep step of the azimuth [deg]')
    p.add_argument('--timeout', type=float, default=300.0, help='longest wait for the sweep [s]')
    return p


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    stamp = datetime.now().strftime('%Y_%m_%d-%H_%M_%S')
    bag = Path(args.output) if args.output else Path('bags') / f'demo_{stamp}'
    report = Path(args.report) if args.report else bag.with_name(bag.name + '_report')
    env = dict(os.environ)
    env.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    env['PYTHONUNBUFFERED'] = '1'
    logs = Path(tempfile.mkdtemp(prefix='gpr_offline_loop_'))
    procs: list[_Proc] = []
    print(f'offline loop: kinematics_node, recorder_node -> {bag}, trajectory_node (paper sweep, '
          f'{args.tilt_step_deg} deg x {args.azimuth_step_deg} deg at {args.rate} Hz); logs in {logs}', flush=True)
    try:
        kin = _Proc('kinematics_node', [], env, logs)
        rec = _Proc('recorder_node', ['-p', f'output:={bag}', '-p', f'storage:={args.storage}',
                                      '-p', f'compression:={args.compression}',
                                      '-p', f'flush_interval:={float(args.flush_interval)!r}'], env, logs)
        procs += [kin, rec]
        traj = _Proc('trajectory_node', ['-p', f'rate:={args.rate}', '-p', 'wait_for_subscribers:=1',
                                         '-p', 'wait_all_topics:=true',
                                         '-p', f'tilt_step:={math.radians(args.tilt_step_deg)!r}',
                                         '-p', f'azimuth_step:={math.radians(args.azimuth_step_deg)!r}'], env, logs)
        procs.append(traj)
        try:
            status = traj.proc.wait(timeout=args.timeout)
        except subprocess.TimeoutExpired:
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
        print(f'offline loop: {exc} (run `make setup`, then this under `python -m gpr_kinematics.ros_env exec --`)',
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
