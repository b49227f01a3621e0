"""Benchmark of the bag layer: recorder throughput without loss, and ``gpr verify`` messages per second.

Run in the ROS environment (the recorder part starts ``recorder_node`` over DDS):

    .venv/bin/python -m gpr_kinematics.ros.env exec -- .venv/bin/python benchmarks/bench_bags.py [--quick]

1. Recorder: this process publishes serialized ``PlatformState`` messages (the paper sweep's, cycled) on
   ``gpr/platform_state`` at a fixed rate for a fixed time (reliable, keep-last depth = all messages, so the
   publisher never drops), into ``recorder_node`` (``topics:=[gpr/platform_state]``, MCAP, flush interval 1 s,
   fsync on). After the publisher's acknowledgements the recorder gets SIGINT; the bag must hold every
   published message, byte for byte and in order. The highest rate tried without loss is reported.
   Peer in the same run: a bare rclpy raw subscription that only counts (the executor's ceiling).
   Then the trajectory node at its highest rate setting (5000 Hz), all its topics, into the recorder.
2. Verify: a bag of the paper sweep repeated (``passes``), every topic of the trajectory node (state, two
   poses, joint states, markers, the geometry once), written without ROS; ``verify_bag`` (read with every
   CRC and SHA-256 + decode + every check), median of 3 runs, messages/s. Peers in the same run: decoding the
   same messages one by one with ``rosbags``' ``deserialize_cdr``, and reading the MCAP file with the ``mcap``
   library validating its CRCs (the bounded reader's counterpart).
"""
from __future__ import annotations

import argparse
import os
import platform
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from gpr_kinematics.ros import env as ros_env  # noqa: E402


def bench_verify(passes: int, runs: int = 3) -> dict:
    from gpr_kinematics.bags.reader import read_bag
    from gpr_kinematics.bags.synthetic import sweep_messages, write_messages
    from gpr_kinematics.bags.typestore import typestore
    from gpr_kinematics.bags.verify import verify_bag
    from mcap.stream_reader import StreamReader

    tmp = Path(tempfile.mkdtemp(prefix='bench_bags_'))
    msgs = sweep_messages(passes=passes)
    path = write_messages(tmp / 'verify', msgs)
    times, reads = [], []
    for _ in range(runs):
        t0 = time.perf_counter()
        result = verify_bag(path)
        times.append(time.perf_counter() - t0)
        reads.append(result.read_time)
        assert result.passed
    n = len(msgs)
    bag = read_bag(path)
    store = typestore()
    t0 = time.perf_counter()
    for topic in bag.topics.values():
        for raw in topic.raw:
            store.deserialize_cdr(raw, topic.msgtype)
    peer = time.perf_counter() - t0
    t0 = time.perf_counter()
    for f in sorted(path.glob('*.mcap')):
        with f.open('rb') as fh:
            for _ in StreamReader(fh, validate_crcs=True).records:
                pass
    peer_read = time.perf_counter() - t0
    med = statistics.median(times)
    size = sum(f.stat().st_size for f in path.iterdir()) / 1e6
    return {'messages': n, 'states': result.states, 'median_s': med, 'read_s': statistics.median(reads),
            'rate': n / med, 'peer_decode_rate': n / peer, 'peer_read_s': peer_read, 'size_mb': size}


def _publisher_run(rate: float, seconds: float, output: Path, counter_only: bool) -> dict:
    """Publish at ``rate`` for ``seconds`` into a recorder (or a counting subscriber process)."""
    import rclpy
    from gpr_kinematics.bags.synthetic import sweep_messages
    from rclpy.duration import Duration
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

    from gpr_interfaces.msg import PlatformState

    base = [m[2] for m in sweep_messages(topics=('/gpr/platform_state',))]
    n = int(rate * seconds)
    env = dict(os.environ)
    if counter_only:
        proc = subprocess.Popen([sys.executable, __file__, '--counter'], stdout=subprocess.PIPE,
                                stderr=subprocess.STDOUT, env=env, text=True)
    else:
        exe = ros_env.find_executable('gpr_kinematics', 'recorder_node', env)
        proc = subprocess.Popen([str(exe), '--ros-args', '-p', f'output:={output}', '-p',
                                 'topics:=[gpr/platform_state]', '-p', 'flush_interval:=1.0', '-p',
                                 'queue_depth:=100000'], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=env,
                                text=True)
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    node = rclpy.create_node('bench_bags_publisher', context=ctx)
    qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=max(n, 1), reliability=ReliabilityPolicy.RELIABLE)
    pub = node.create_publisher(PlatformState, 'gpr/platform_state', qos)
    deadline = time.monotonic() + 30
    while pub.get_subscription_count() < 1 and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.5)
    sent = []
    t0 = time.monotonic()
    for i in range(n):
        due = t0 + i / rate
        d = due - time.monotonic()
        if d > 0.0005:
            time.sleep(d)
        raw = base[i % len(base)]
        pub.publish(raw)
        sent.append(raw)
    elapsed = time.monotonic() - t0
    pub.wait_for_all_acked(Duration(seconds=30))
    time.sleep(0.5)
    proc.send_signal(signal.SIGINT)
    out, _ = proc.communicate(timeout=60)
    node.destroy_node()
    rclpy.try_shutdown(context=ctx)
    achieved = n / elapsed
    if counter_only:
        got = int(out.strip().splitlines()[-1])
        return {'rate': rate, 'achieved': achieved, 'published': n, 'received': got, 'lossless': got == n}
    from gpr_kinematics.bags.reader import read_bag

    topic = read_bag(output).topic('/gpr/platform_state')
    ok = topic is not None and topic.raw == sent
    return {'rate': rate, 'achieved': achieved, 'published': n, 'received': len(topic) if topic else 0,
            'lossless': bool(ok), 'status': proc.returncode}


def bench_trajectory(rate: float, passes: int, output: Path) -> dict:
    """trajectory_node at ``rate`` (its highest allowed: 5000 Hz), all its topics, into recorder_node."""
    import re

    from gpr_kinematics.bags.verify import verify_bag

    env = dict(os.environ)
    rec = subprocess.Popen([str(ros_env.find_executable('gpr_kinematics', 'recorder_node', env)), '--ros-args',
                            '-p', f'output:={output}'], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=env,
                           text=True)
    time.sleep(2.0)
    traj = subprocess.run([str(ros_env.find_executable('gpr_kinematics', 'trajectory_node', env)), '--ros-args',
                           '-p', f'rate:={rate}', '-p', 'wait_for_subscribers:=1', '-p', 'wait_all_topics:=true',
                           '-p', f'passes:={passes}'],
                          capture_output=True, text=True, env=env, timeout=600)
    time.sleep(0.5)
    rec.send_signal(signal.SIGINT)
    rec_out, _ = rec.communicate(timeout=60)
    m = re.search(r'published (\d+) samples in ([\d.]+) s \(achieved ([\d.]+) Hz', traj.stdout + traj.stderr)
    samples, achieved = int(m.group(1)), float(m.group(3))
    result = verify_bag(output)
    return {'samples': samples, 'achieved_hz': achieved, 'recorded': result.counts, 'passed': result.passed,
            'status': rec.returncode}


def counter_main() -> None:
    """A bare raw subscription that counts messages until SIGINT, drains like the recorder, prints the count."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from rclpy.signals import SignalHandlerOptions

    from gpr_interfaces.msg import PlatformState

    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    stop: list[int] = []
    signal.signal(signal.SIGINT, lambda s, _f: stop.append(s))
    node = rclpy.create_node('bench_bags_counter')
    count = [0]
    last = [time.monotonic()]

    def cb(_data: bytes) -> None:
        count[0] += 1
        last[0] = time.monotonic()

    qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100000, reliability=ReliabilityPolicy.RELIABLE)
    node.create_subscription(PlatformState, 'gpr/platform_state', cb, qos, raw=True)
    ex = SingleThreadedExecutor()
    ex.add_node(node)
    while not stop:
        ex.spin_once(timeout_sec=0.05)
    while time.monotonic() - last[0] < 0.2:
        ex.spin_once(timeout_sec=0.02)
    print(count[0], flush=True)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--quick', action='store_true', help='a short smoke run')
    ap.add_argument('--counter', action='store_true', help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.counter:
        counter_main()
        return 0
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    os.environ.setdefault('ROS_DOMAIN_ID', '7')  # benchmarks and demo: 0..9, tests: 10..200
    print(f'machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, '
          f'load average {os.getloadavg()[0]:.2f}')
    v = bench_verify(passes=2 if args.quick else 40)
    print(f"verify: {v['messages']} messages ({v['states']} PlatformState, {v['size_mb']:.1f} MB): median "
          f"{v['median_s']:.3f} s (read {v['read_s']:.3f} s) -> {v['rate']:,.0f} messages/s; peer rosbags "
          f"deserialize_cdr one by one: {v['peer_decode_rate']:,.0f} messages/s "
          f"(ratio {v['rate'] / v['peer_decode_rate']:.1f}x); peer mcap StreamReader with CRC validation: "
          f"{v['peer_read_s']:.3f} s (ratio of our read {v['read_s'] / v['peer_read_s']:.2f})")
    seconds = 1.0 if args.quick else 3.0
    rates = [1000.0, 5000.0] if args.quick else [1000.0, 2000.0, 5000.0, 8000.0, 12000.0]
    tmp = Path(tempfile.mkdtemp(prefix='bench_bags_rec_'))
    best = 0.0
    for i, rate in enumerate(rates):
        r = _publisher_run(rate, seconds, tmp / f'r{i}', counter_only=False)
        c = _publisher_run(rate, seconds, tmp / f'c{i}', counter_only=True)
        print(f"recorder at {rate:,.0f}/s (achieved {r['achieved']:,.0f}/s): {r['received']}/{r['published']} "
              f"recorded, lossless {r['lossless']}, exit {r['status']}; peer counter (achieved "
              f"{c['achieved']:,.0f}/s): {c['received']}/{c['published']}, lossless {c['lossless']}")
        if r['lossless'] and r['status'] == 0:
            best = max(best, r['achieved'])
    print(f'highest PlatformState rate recorded without loss: {best:,.0f} messages/s')
    from gpr_kinematics.bags.typestore import GEOMETRY_TOPIC

    t = bench_trajectory(5000.0, 1 if args.quick else 4, tmp / 'traj')
    stream = {k: v for k, v in t['recorded'].items() if k != GEOMETRY_TOPIC}  # the geometry: once, not per sample
    lossless = all(v == t['samples'] for v in stream.values())
    print(f"trajectory_node at rate 5000 (its maximum), {len(stream)} stream topics: achieved "
          f"{t['achieved_hz']:,.0f} samples/s ({len(stream) * t['achieved_hz']:,.0f} messages/s); recorded "
          f"{t['recorded']} of {t['samples']} each, "
          f"lossless {lossless}, verify passed {t['passed']}, recorder exit {t['status']}")
    return 0


if __name__ == '__main__':
    sys.exit(main())
