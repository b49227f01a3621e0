"""Benchmark of the ROS 2 node suite over real DDS (Fast DDS, loopback): service round trips (the platform and
the whole-robot services), calls per second with 1 and 4 concurrent clients, and the trajectory node's achieved
versus requested rate.

Peers measured in the same run: the core calls alone in this process (``kinematics.forward``, and the robot
core's ``solve_stations`` for one station), and a null rclpy service (``std_srvs/Trigger`` answering at once, in
its own process) for the cost of ROS itself.

Run: ``.venv/bin/python benchmarks/bench_ros.py [--calls 2000] [--duration 5] [--rates 50,100,200,500,1000]``
(``make setup`` first). Prints a Markdown table for docs/benchmarks.md.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import platform
import signal
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from gpr_kinematics.ros import env as ros_env  # noqa: E402 - after the path

os.environ.setdefault('ROS_DOMAIN_ID', str(5 + os.getpid() % 5))  # tests use 10..99
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
ros_env.activate()

import numpy as np  # noqa: E402 - after the ROS environment
from gpr_kinematics.core import forward  # noqa: E402
from gpr_kinematics.nodes.client import GprClient  # noqa: E402
from gpr_kinematics.nodes.qos import stream_qos  # noqa: E402
from gpr_kinematics.robot import load_robot, solve_stations  # noqa: E402
from gpr_kinematics.robot.stations import Stations  # noqa: E402
from gpr_kinematics.ros.process import NodeProcess  # noqa: E402
from std_srvs.srv import Trigger  # noqa: E402

from gpr_interfaces.msg import PlatformState  # noqa: E402

NULL_SERVER = '''
import rclpy, sys
from rclpy.executors import ExternalShutdownException
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_srvs.srv import Trigger
rclpy.init()
node = rclpy.create_node('null_server')
def cb(req, res):
    res.success = True
    return res
# The same service QoS as kinematics_node (reliable, keep last 100).
qos = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
node.create_service(Trigger, 'null/trigger', cb, qos_profile=qos)
try:
    rclpy.spin(node)
except (KeyboardInterrupt, ExternalShutdownException):
    pass
rclpy.try_shutdown()
'''

Q = [0.5, 0.498, 0.502]
#: The station of the robot services: the example robot's arm1, wafer at (1.2, 1.0, 0.455) m in the world, the
#: station plane tilted 1.2 deg about azimuth 30 deg, blade heading 45 deg (the nodes' demo's station).
ROBOT = load_robot()
STATION_POSITION = (1.2, 1.0, 0.455)
STATION_TILT, STATION_AZIMUTH, STATION_HEADING = math.radians(1.2), math.radians(30.0), math.radians(45.0)
STATION = Stations.of([STATION_POSITION], STATION_TILT, STATION_AZIMUTH, STATION_HEADING)
_SOLVED = solve_stations(ROBOT, STATION, 'arm1')
ROBOT_RODS, ROBOT_JOINTS = _SOLVED.rods[0].tolist(), _SOLVED.joints[0].tolist()


def _null_server() -> subprocess.Popen:
    return subprocess.Popen([sys.executable, '-c', NULL_SERVER], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE)


def _stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            proc.kill()


class Caller:
    """Timed round trips through :class:`GprClient` (client side: rclpy.experimental's EventsExecutor; with the
    classic SingleThreadedExecutor, spin_until_future_complete alone costs ~6-12 ms per call here, which would
    hide the server). A lost response is re-sent by the client and counted in ``client.lost``; its time is not
    a round trip (the re-sent call is timed alone)."""

    def __init__(self, name: str) -> None:
        self.client = GprClient(name, executor='events')

    def call(self, kind: str) -> float:
        c = self.client
        t0 = time.perf_counter()
        lost = c.lost
        if kind == 'forward':
            res = c.forward_kinematics(Q)
        elif kind == 'inverse':
            res = c.inverse_kinematics(0.45, 0.02, 0.0)
        elif kind == 'compensate':
            res = c.compensate((0.0, 0.0, 0.45), (0.0, 0.01, 0.0, float(np.sqrt(1 - 0.01 ** 2))), (0.0, 0.0, 0.1))
        elif kind == 'mobility':
            res = c.analyze_mobility(Q)
        elif kind == 'station_ik':
            res = c.station_inverse_kinematics(STATION_POSITION, STATION_TILT, STATION_AZIMUTH, STATION_HEADING,
                                               arm='arm1')
        elif kind == 'robot_fk':
            res = c.robot_forward_kinematics(ROBOT_RODS, ROBOT_JOINTS, arm='arm1')
        elif kind == 'null':
            res = c.call(Trigger, 'null/trigger', Trigger.Request(), timeout=2.0)
        else:
            raise ValueError(kind)
        dt = time.perf_counter() - t0
        if not res.success:
            raise RuntimeError(f'{kind}: {res.message}')
        if c.lost != lost:  # a response was lost and the request re-sent: time a clean call instead
            return self.call(kind)
        return dt

    @property
    def lost(self) -> int:
        return self.client.lost

    def close(self) -> None:
        self.client.close()


def worker(kind: str, duration: float, start_at: float) -> None:
    """One client process of the concurrency measurement: prints the calls it completed in ``duration``."""
    c = Caller(f'bench_worker_{os.getpid()}')
    for _ in range(20):
        c.call(kind)
    while time.time() < start_at:
        time.sleep(0.001)
    n, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < duration:
        c.call(kind)
        n += 1
    elapsed = time.perf_counter() - t0
    lost = c.lost
    c.close()
    print(json.dumps({'calls': n, 'elapsed': elapsed, 'lost': lost}))


def latency(c: Caller, kind: str, calls: int) -> dict:
    for _ in range(50):
        c.call(kind)
    t = np.array([c.call(kind) for _ in range(calls)])
    return {'median_ms': 1e3 * float(np.median(t)), 'p99_ms': 1e3 * float(np.percentile(t, 99)),
            'calls': calls}


def throughput(kind: str, clients: int, duration: float) -> float:
    start_at = time.time() + 4.0 + clients
    procs = [subprocess.Popen([sys.executable, __file__, '--worker', kind, '--duration', str(duration),
                               '--start-at', repr(start_at)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True) for _ in range(clients)]
    total = 0.0
    lost = 0
    for p in procs:
        out, err = p.communicate(timeout=120 + duration)
        if p.returncode != 0:
            raise RuntimeError(f'worker failed: {err[-2000:]}')
        r = json.loads(out.strip().splitlines()[-1])
        total += r['calls'] / r['elapsed']
        lost += r['lost']
    return {'calls_per_s': total, 'lost': lost}


def trajectory_rate(rate: float, duration: float) -> dict:
    """Run trajectory_node at ``rate`` for about ``duration`` s; achieved rates from the header stamps
    (publisher side) and from the arrival times (subscriber side)."""
    import math

    # Tilt step chosen so that the sweep lasts about `duration` seconds at `rate`.
    n_needed = rate * duration
    az_step = math.radians(10.0)
    per_row = max(3, int(n_needed / 36))
    half = max(1, per_row // 2)
    max_tilt = math.radians(2.0)
    step = max_tilt / half
    client = GprClient(f'bench_traj_{int(rate)}')
    arrivals: list[float] = []
    stamps: list[float] = []
    samples: list[int] = []

    def on_msg(m):
        arrivals.append(time.perf_counter())
        stamps.append(m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec)
        samples.append(m.sample)

    ns = f'/bench_traj_{int(rate)}'
    client.node.create_subscription(PlatformState, f'{ns}/gpr/platform_state', on_msg,
                                    stream_qos(100000))
    proc = NodeProcess('trajectory_node', ['-r', f'__ns:={ns}', '-p', f'rate:={rate!r}',
                                           '-p', f'max_tilt:={max_tilt!r}', '-p', f'tilt_step:={step!r}',
                                           '-p', f'azimuth_step:={az_step!r}', '-p', 'wait_for_subscribers:=1',
                                           '-p', 'wait_all_topics:=false', '-p', 'markers_every:=1'])
    client.spin_until(lambda: not proc.alive(), duration * 3 + 30)
    client.spin_for(0.5)
    proc.stop()
    out = proc.output()
    client.close()
    n = len(stamps)
    node_rate = float('nan')
    for line in out.splitlines():
        if 'achieved' in line:
            node_rate = float(line.split('achieved ')[1].split(' Hz')[0])
    pub = (n - 1) / (stamps[-1] - stamps[0]) if n > 1 else float('nan')
    sub = (n - 1) / (arrivals[-1] - arrivals[0]) if n > 1 else float('nan')
    periods = np.diff(stamps) if n > 1 else np.array([float('nan')])
    return {'requested_hz': rate, 'samples': n, 'in_order': samples == list(range(n)),
            'node_hz': node_rate, 'stamp_hz': pub, 'arrival_hz': sub,
            'period_p99_ms': 1e3 * float(np.percentile(periods, 99)),
            'error_pct': 100.0 * (pub - rate) / rate}


def core_peer(call: Callable[[], object], calls: int) -> float:
    """Median time of ``call()`` in this process [ms] (after 20 warm-up calls)."""
    for _ in range(20):
        call()
    t = []
    for _ in range(calls):
        t0 = time.perf_counter()
        call()
        t.append(time.perf_counter() - t0)
    return 1e3 * statistics.median(t)


def one_station() -> object:
    """The robot core's station IK of the benchmark's station (what gpr/station_inverse_kinematics computes)."""
    return solve_stations(ROBOT, STATION, 'arm1')


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument('--calls', type=int, default=2000)
    ap.add_argument('--duration', type=float, default=5.0)
    ap.add_argument('--rates', default='50,100,200,500,1000')
    ap.add_argument('--worker')
    ap.add_argument('--start-at', type=float, default=0.0)
    args = ap.parse_args()
    if args.worker:
        worker(args.worker, args.duration, args.start_at)
        return 0

    kin = NodeProcess('kinematics_node')
    null = _null_server()
    results: dict = {'machine': f'{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}',
                     'rmw': os.environ.get('RMW_IMPLEMENTATION', 'rmw_fastrtps_cpp')}
    try:
        c = Caller('bench_client')
        results['core_forward_ms'] = core_peer(lambda: forward(Q), args.calls)
        results['core_station_ik_ms'] = core_peer(one_station, args.calls // 10)
        results['latency'] = {k: latency(c, k, args.calls if k in ('forward', 'null') else args.calls // 4)
                              for k in ('null', 'forward', 'inverse', 'compensate', 'mobility')}
        results['latency'].update({k: latency(c, k, args.calls // 10) for k in ('robot_fk', 'station_ik')})
        results['lost_latency'] = c.lost
        c.close()
        results['throughput'] = {f'{k}_{n}': throughput(k, n, args.duration)
                                 for k in ('forward', 'null') for n in (1, 4)}
    finally:
        kin.stop()
        _stop(null)
    results['trajectory'] = [trajectory_rate(float(r), args.duration) for r in args.rates.split(',')]
    print(json.dumps(results, indent=1))
    _markdown(results)
    return 0


def _markdown(r: dict) -> None:
    lat = r['latency']
    print('\n| service (round trip, 1 client) | median [ms] | p99 [ms] | median / null service |')
    print('|---|---|---|---|')
    for k, name in (('null', 'null rclpy service (std_srvs/Trigger), peer'),
                    ('forward', 'gpr/forward_kinematics'), ('inverse', 'gpr/inverse_kinematics'),
                    ('compensate', 'gpr/compensate'), ('mobility', 'gpr/analyze_mobility'),
                    ('robot_fk', 'gpr/robot_forward_kinematics (arm1)'),
                    ('station_ik', 'gpr/station_inverse_kinematics (arm1)')):
        v = lat[k]
        print(f'| {name} | {v["median_ms"]:.3f} | {v["p99_ms"]:.3f} | '
              f'{v["median_ms"] / lat["null"]["median_ms"]:.2f} |')
    print(f'\nCore calls in-process (peers): `kinematics.forward` median {r["core_forward_ms"]:.3f} ms, the robot '
          f'core\'s `solve_stations` for one station {r["core_station_ik_ms"]:.3f} ms per call.')
    t = r['throughput']
    print('\n| calls/s | 1 client | 4 clients |\n|---|---|---|')
    for k, name in (('forward', 'gpr/forward_kinematics'), ('null', 'null rclpy service (peer)')):
        one, four = t[f'{k}_1'], t[f'{k}_4']
        print(f'| {name} | {one["calls_per_s"]:.0f} (lost {one["lost"]}) | {four["calls_per_s"]:.0f} '
              f'(lost {four["lost"]}) |')
    print(f'\nLost responses during the latency runs (re-sent): {r["lost_latency"]}')
    print('\n| requested [Hz] | samples | in order | node timer [Hz] | header stamps [Hz] | arrivals [Hz] '
          '| stamp error | p99 period [ms] |')
    print('|---|---|---|---|---|---|---|---|')
    for x in r['trajectory']:
        print(f'| {x["requested_hz"]:.0f} | {x["samples"]} | {x["in_order"]} | {x["node_hz"]:.2f} | '
              f'{x["stamp_hz"]:.2f} | {x["arrival_hz"]:.2f} | {x["error_pct"]:+.2f} % | {x["period_p99_ms"]:.2f} |')


if __name__ == '__main__':
    sys.exit(main())
