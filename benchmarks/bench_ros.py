"""Benchmark of the ROS 2 node suite over real DDS (Fast DDS, loopback): service round trips (the platform and
the whole-robot services), calls per second with 1 and 4 concurrent clients, and the trajectory node's achieved
versus requested rate.

Peers measured in the same run: beside each of the node's services a **null service of the same type** (in its own
process, the same QoS, answering at once with a constant response: one the node gave to the same request, so the
messages and their sizes are the same), called in alternation with ours, so the ratio is the node's overhead over
ROS itself; the plain null rclpy service (``std_srvs/Trigger``, in a third process, in the same alternation); and
the core calls alone in this process
(``kinematics.forward``, and the robot core's ``solve_stations`` for one station). ``--before TREE`` runs a second
``kinematics_node`` from the package in ``TREE`` (a checkout of an earlier commit, ``git archive C | tar -x -C
TREE``; the messages are this tree's) under the namespace ``/before`` and calls it in the same alternation.
No two calls in a row go to one process: a process that has just answered answers its next call sooner (0.65
against 0.74 ms for the forward null service called right after the Trigger one in its process, measured), which
made an earlier version of this script read the forward service 1.6-1.7x its null service instead of 1.2-1.5x.

Run: ``.venv/bin/python benchmarks/bench_ros.py [--calls 2000] [--duration 5] [--rates 50,100,200,500,1000]
[--before TREE] [--services-only]`` (``make setup`` first). Prints a Markdown table for docs/benchmarks.md.
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
import tempfile
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
from gpr_kinematics.core.rotations import quaternion_from_matrix, tilt_rotation  # noqa: E402
from gpr_kinematics.nodes.client import GprClient  # noqa: E402
from gpr_kinematics.nodes.conversions import pose_msg  # noqa: E402
from gpr_kinematics.nodes.qos import stream_qos  # noqa: E402
from gpr_kinematics.robot import load_robot, solve_stations  # noqa: E402
from gpr_kinematics.robot.stations import Stations  # noqa: E402
from gpr_kinematics.ros.process import NodeProcess  # noqa: E402
from rclpy.serialization import serialize_message  # noqa: E402
from std_srvs.srv import Trigger  # noqa: E402

from gpr_interfaces.msg import PlatformState  # noqa: E402
from gpr_interfaces.srv import (  # noqa: E402
    AnalyzeMobility,
    Compensate,
    ForwardKinematics,
    InverseKinematics,
    RobotForwardKinematics,
    StationInverseKinematics,
)

#: The null services: each answers at once with the constant response (serialized, in the file named by argv[1])
#: of its type, as ``<argv[2]>/<kind>``; ``<argv[2]>/trigger`` is std_srvs/Trigger. The QoS of the node's services
#: (reliable, keep all).
NULL_SERVER = '''
import importlib, json, sys
import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.serialization import deserialize_message
from std_srvs.srv import Trigger
from gpr_kinematics.nodes.qos import service_qos
rclpy.init()
node = rclpy.create_node(f'{sys.argv[2]}_server')
def constant(response):
    return lambda req, res: response
def trigger(req, res):
    res.success = True
    return res
node.create_service(Trigger, f'{sys.argv[2]}/trigger', trigger, qos_profile=service_qos())
for kind, (module, name, data) in json.load(open(sys.argv[1])).items():
    srv = getattr(importlib.import_module(module), name)
    node.create_service(srv, f'{sys.argv[2]}/{kind}', constant(deserialize_message(bytes.fromhex(data), srv.Response)),
                        qos_profile=service_qos())
print('ready', flush=True)
try:
    rclpy.spin(node)
except (KeyboardInterrupt, ExternalShutdownException):
    pass
rclpy.try_shutdown()
'''

#: A node of an earlier tree (``--before``): its package first on the path, this tree's messages.
BEFORE_NODE = '''
import sys
sys.path.insert(0, sys.argv[1])
import gpr_kinematics
assert gpr_kinematics.__file__.startswith(sys.argv[1]), gpr_kinematics.__file__
from gpr_kinematics.nodes.kinematics_node import main
sys.exit(main(['kinematics_node', '--ros-args', '-r', '__ns:=/before']))
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


def _requests() -> dict[str, tuple[type, str, object]]:
    """kind -> (service type, the node's service name, the request) of every service measured."""
    inverse_target = pose_msg((0.0, 0.0, 0.45), quaternion_from_matrix(tilt_rotation(0.02, 0.0)))
    compensate = Compensate.Request(command=pose_msg((0.0, 0.0, 0.45), (0.0, 0.01, 0.0, math.sqrt(1 - 0.01 ** 2))))
    compensate.tool_offset.z = 0.1
    station = StationInverseKinematics.Request(tilt=STATION_TILT, azimuth=STATION_AZIMUTH, heading=STATION_HEADING,
                                               arm='arm1')
    station.position.x, station.position.y, station.position.z = STATION_POSITION
    return {
        'forward': (ForwardKinematics, 'gpr/forward_kinematics', ForwardKinematics.Request(q=Q)),
        'inverse': (InverseKinematics, 'gpr/inverse_kinematics', InverseKinematics.Request(target=inverse_target)),
        'compensate': (Compensate, 'gpr/compensate', compensate),
        'mobility': (AnalyzeMobility, 'gpr/analyze_mobility', AnalyzeMobility.Request(q=Q)),
        'robot_fk': (RobotForwardKinematics, 'gpr/robot_forward_kinematics',
                     RobotForwardKinematics.Request(rods=ROBOT_RODS, joints=ROBOT_JOINTS, arm='arm1')),
        'station_ik': (StationInverseKinematics, 'gpr/station_inverse_kinematics', station),
    }


REQUESTS = _requests()


def _null_server(responses: dict[str, object], prefix: str = 'null') -> tuple[subprocess.Popen, str]:
    """The null services' process, answering ``<prefix>/<kind>`` with ``responses`` (kind -> a response of the
    node), and ``<prefix>/trigger``."""
    data = {k: (REQUESTS[k][0].__module__.rsplit('.', 1)[0], REQUESTS[k][0].__name__, serialize_message(r).hex())
            for k, r in responses.items()}
    path = tempfile.mkstemp(prefix='bench_null_', suffix='.json')[1]
    Path(path).write_text(json.dumps(data))
    proc = subprocess.Popen([sys.executable, '-c', NULL_SERVER, path, prefix], stdin=subprocess.DEVNULL,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if proc.stdout is None or proc.stdout.readline().strip() != 'ready':
        raise RuntimeError(f'the null server did not start: {proc.stderr.read() if proc.stderr else ""}')
    return proc, path


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
    a round trip (the re-sent call is timed alone). ``kind`` is a key of :data:`REQUESTS` (the node's service),
    ``null/<kind>`` its null peer, ``before/<kind>`` the ``--before`` node's, or ``null`` (std_srvs/Trigger, in a
    process of its own: ``trigger/trigger``)."""

    def __init__(self, name: str) -> None:
        self.client = GprClient(name, executor='events')

    def call(self, kind: str) -> float:
        c = self.client
        if kind == 'null':
            srv, name, req = Trigger, 'trigger/trigger', Trigger.Request()
        else:
            where, _, base = kind.rpartition('/')
            srv, name, req = REQUESTS[base]
            name = f'/before/{name}' if where == 'before' else f'null/{base}' if where == 'null' else name
        lost = c.lost
        t0 = time.perf_counter()
        res = c.call(srv, name, req, timeout=2.0)
        dt = time.perf_counter() - t0
        if not res.success:
            raise RuntimeError(f'{kind}: {res.message}')
        if c.lost != lost:  # a response was lost and the request re-sent: time a clean call instead
            return self.call(kind)
        return dt

    def response(self, kind: str) -> object:
        srv, name, req = REQUESTS[kind]
        return self.client.call(srv, name, req, timeout=5.0)

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


def latency(c: Caller, kinds: list[str], calls: int) -> dict[str, dict[str, float]]:
    """Round trips of ``kinds`` called in alternation (one call of each in turn, ``calls`` rounds after 50 of
    warm-up): the median and 99th percentile of each [ms]."""
    for _ in range(50):
        for k in kinds:
            c.call(k)
    t: dict[str, list[float]] = {k: [] for k in kinds}
    for _ in range(calls):
        for k in kinds:
            t[k].append(c.call(k))
    return {k: {'median_ms': 1e3 * float(np.median(v)), 'p99_ms': 1e3 * float(np.percentile(v, 99)), 'calls': calls}
            for k, v in t.items()}


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


SERVICES = ('forward', 'inverse', 'compensate', 'mobility', 'robot_fk', 'station_ik')
NAMES = {'forward': 'gpr/forward_kinematics', 'inverse': 'gpr/inverse_kinematics', 'compensate': 'gpr/compensate',
         'mobility': 'gpr/analyze_mobility', 'robot_fk': 'gpr/robot_forward_kinematics (arm1)',
         'station_ik': 'gpr/station_inverse_kinematics (arm1)'}


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument('--calls', type=int, default=2000)
    ap.add_argument('--duration', type=float, default=5.0)
    ap.add_argument('--rates', default='50,100,200,500,1000')
    ap.add_argument('--before', type=Path, metavar='TREE', help='also time the kinematics_node of this checkout')
    ap.add_argument('--services-only', action='store_true', help='the round trips only (no throughput, no rates)')
    ap.add_argument('--worker')
    ap.add_argument('--start-at', type=float, default=0.0)
    args = ap.parse_args()
    if args.worker:
        worker(args.worker, args.duration, args.start_at)
        return 0

    kin = NodeProcess('kinematics_node')
    before = None
    if args.before is not None:
        before = subprocess.Popen([sys.executable, '-c', BEFORE_NODE, str(args.before.resolve() / 'gpr_kinematics')],
                                  stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    null, null_file, trigger, trigger_file = None, '', None, ''
    results: dict = {'machine': f'{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}',
                     'rmw': os.environ.get('RMW_IMPLEMENTATION', 'rmw_fastrtps_cpp'), 'load_start': os.getloadavg()}
    try:
        c = Caller('bench_client')
        null, null_file = _null_server({k: c.response(k) for k in SERVICES})
        trigger, trigger_file = _null_server({}, 'trigger')
        results['core_forward_ms'] = core_peer(lambda: forward(Q), args.calls)
        results['core_station_ik_ms'] = core_peer(one_station, args.calls // 10)
        # each service in one alternation with its null service, the Trigger null service and the --before node's,
        # each in a process of its own (module docstring: never two calls in a row to one process)
        results['latency'] = {}
        for k in SERVICES:
            kinds = [f'null/{k}', k, 'null'] + ([f'before/{k}'] if before is not None else [])
            block = latency(c, kinds, args.calls // (1 if k == 'forward' else 4 if k in SERVICES[:4] else 10))
            block[f'null@{k}'] = block.pop('null')
            results['latency'].update(block)
        results['lost_latency'] = c.lost
        c.close()
        if not args.services_only:
            results['throughput'] = {f'{k}_{n}': throughput(k, n, args.duration)
                                     for k in ('forward', 'null') for n in (1, 4)}
    finally:
        kin.stop()
        for proc in (null, trigger, before):
            if proc is not None:
                _stop(proc)
        for path in (null_file, trigger_file):
            if path:
                os.unlink(path)
    if not args.services_only:
        results['trajectory'] = [trajectory_rate(float(r), args.duration) for r in args.rates.split(',')]
    results['load_end'] = os.getloadavg()
    print(json.dumps(results, indent=1))
    _markdown(results)
    return 0


def _markdown(r: dict) -> None:
    lat = r['latency']
    before = any(k.startswith('before/') for k in lat)
    print(f"\nload average {r['load_start'][0]:.2f} at the start, {r['load_end'][0]:.2f} at the end")
    print('\n| service (round trip, 1 client) | null of its type [ms] | ours [ms] | ours / null | Trigger [ms] '
          '| ours / Trigger | p99 ours [ms] |' + (' before [ms] | before / null |' if before else ''))
    print('|---|---:|---:|---:|---:|---:|---:|' + ('---:|---:|' if before else ''))
    for k in SERVICES:
        null, ours, trig = lat[f'null/{k}']['median_ms'], lat[k]['median_ms'], lat[f'null@{k}']['median_ms']
        row = (f'| {NAMES[k]} | {null:.3f} | {ours:.3f} | {ours / null:.2f} | {trig:.3f} | {ours / trig:.2f} | '
               f'{lat[k]["p99_ms"]:.3f} |')
        if before:
            b = lat[f'before/{k}']['median_ms']
            row += f' {b:.3f} | {b / null:.2f} |'
        print(row)
    print(f'\nCore calls in-process (peers): `kinematics.forward` median {r["core_forward_ms"]:.3f} ms, the robot '
          f'core\'s `solve_stations` for one station {r["core_station_ik_ms"]:.3f} ms per call.')
    print(f'\nLost responses during the latency runs (re-sent): {r["lost_latency"]}')
    if 'throughput' in r:
        t = r['throughput']
        print('\n| calls/s | 1 client | 4 clients |\n|---|---|---|')
        for k, name in (('forward', 'gpr/forward_kinematics'), ('null', 'null rclpy service (peer)')):
            one, four = t[f'{k}_1'], t[f'{k}_4']
            print(f'| {name} | {one["calls_per_s"]:.0f} (lost {one["lost"]}) | {four["calls_per_s"]:.0f} '
                  f'(lost {four["lost"]}) |')
    if 'trajectory' in r:
        print('\n| requested [Hz] | samples | in order | node timer [Hz] | header stamps [Hz] | arrivals [Hz] '
              '| stamp error | p99 period [ms] |')
        print('|---|---|---|---|---|---|---|---|')
        for x in r['trajectory']:
            print(f'| {x["requested_hz"]:.0f} | {x["samples"]} | {x["in_order"]} | {x["node_hz"]:.2f} | '
                  f'{x["stamp_hz"]:.2f} | {x["arrival_hz"]:.2f} | {x["error_pct"]:+.2f} % | '
                  f'{x["period_p99_ms"]:.2f} |')


if __name__ == '__main__':
    sys.exit(main())
