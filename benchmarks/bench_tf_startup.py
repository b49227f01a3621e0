"""Benchmark: how long after ``state_publisher_node`` starts a listener has ``gpr_base -> gpr_platform`` on /tf
(issue 21: within 5 s of a launch), and where the time goes.

A listener (a ``GprClient`` subscribed to /tf, in this process, discovered before) starts the node as a process,
``repeat`` times, and records from the process's start: when the node logged that it was built (imports, parameters,
the robot model; its log stamp), when its /tf publisher appeared in the listener's graph (DDS discovery) and when
the first /tf message with ``gpr_platform`` arrived. The peer, in the same run: a bare rclpy node that creates a /tf
publisher and publishes at 10 Hz (no kinematics: the floor that Python, rclpy and DDS discovery set). Then the
state publisher started at the same instant as the other nodes of ``offline_loop.launch.py mode:=idle
record:=false`` (kinematics_node, robot_simulator_node, trajectory_node: four processes importing at once on
the machine's cores, as the launch starts them; ``ros2 launch`` itself is not on the registries). Also the
imports alone (``python -c 'import ...'``) of the node's module and of what the peer imports. Run it in
the ROS environment of the checkout (``make setup``), on a ``ROS_DOMAIN_ID`` of its own.

Prints a Markdown table of medians and maxima. Usage: ``python benchmarks/bench_tf_startup.py [--repeat N]``.
"""
from __future__ import annotations

import argparse
import os
import platform
import re
import statistics
import subprocess
import sys
import time

PEER = '''
import time
import rclpy
from geometry_msgs.msg import TransformStamped
from tf2_msgs.msg import TFMessage
rclpy.init()
node = rclpy.create_node('bare_tf_node')
pub = node.create_publisher(TFMessage, '/tf', 10)
t = TransformStamped(child_frame_id='gpr_platform')
t.header.frame_id = 'gpr_base'
node.create_timer(0.1, lambda: pub.publish(TFMessage(transforms=[t])))
print(f'[INFO] [{time.time():.6f}] [bare_tf_node]: publishing', flush=True)
try:
    rclpy.spin(node)
except BaseException:
    pass
'''
IMPORTS = {
    'the node\'s module (rclpy, the messages, numpy, the kinematics, the robot model)':
        'import gpr_kinematics.nodes.state_publisher_node',
    'rclpy and the messages alone (the peer\'s)': 'import rclpy, rclpy.node, tf2_msgs.msg, geometry_msgs.msg, '
    'sensor_msgs.msg, std_msgs.msg',
}


#: The other nodes of ``offline_loop.launch.py mode:=idle record:=false`` (started with the state publisher by
#: ``loop``), with the arguments the launch file gives them.
LOOP = (('kinematics_node', ()), ('robot_simulator_node', ()), ('trajectory_node', ('-p', 'mode:=idle')))


def _exe(name: str) -> str:
    from gpr_kinematics.ros.env import find_executable

    return str(find_executable('gpr_kinematics', name, dict(os.environ)))


def _start(kind: str) -> list[subprocess.Popen[str]]:
    """The process whose /tf is timed first, then those started with it."""
    if kind == 'peer':
        cmds = [[sys.executable, '-c', PEER]]
    else:
        cmds = [[_exe('state_publisher_node')]]
        if kind == 'loop':
            cmds += [[_exe(name), *(['--ros-args', *args] if args else [])] for name, args in LOOP]
    return [subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True) for cmd in cmds]


def _once(client, kind: str) -> tuple[float, float, float]:
    """(built, in the graph, first /tf) [s after the processes' start]."""
    from tf2_msgs.msg import TFMessage

    got: list[float] = []

    def on_tf(msg: TFMessage) -> None:
        if not got and any(t.child_frame_id == 'gpr_platform' for t in msg.transforms):
            got.append(time.monotonic())

    sub = client.node.create_subscription(TFMessage, '/tf', on_tf, 100)
    client.spin_for(0.5)
    t0, w0 = time.monotonic(), time.time()
    procs = _start(kind)
    seen: list[float] = []

    def arrived() -> bool:
        if not seen and client.node.count_publishers('/tf') > 0:
            seen.append(time.monotonic())
        return bool(got)

    try:
        if not client.spin_until(arrived, 60.0):
            raise RuntimeError(f'{kind}: no /tf within 60 s')
    finally:
        for proc in procs:
            proc.terminate()
        out = procs[0].communicate(timeout=30)[0]
        for proc in procs[1:]:
            proc.communicate(timeout=30)
        client.node.destroy_subscription(sub)
    m = re.search(r'\[INFO\] \[(\d+\.\d+)\] \[\w+\]: publishing', out)
    built = float(m.group(1)) - w0 if m else float('nan')
    return built, (seen[0] if seen else float('nan')) - t0, got[0] - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--repeat', type=int, default=10, help='starts of each (default 10)')
    args = parser.parse_args()
    from gpr_kinematics.ros import env as ros_env

    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    ros_env.activate()
    from gpr_kinematics.nodes.client import GprClient

    print(f'machine: {platform.machine()}, {os.cpu_count()} CPUs, Python {platform.python_version()}, '
          f'ROS_DOMAIN_ID {os.environ.get("ROS_DOMAIN_ID", "0")}, load average {os.getloadavg()[0]:.1f}')
    rows = []
    for name, stmt in IMPORTS.items():
        times = []
        for _ in range(args.repeat):
            r = subprocess.run([sys.executable, '-c', f'import time; t = time.perf_counter(); {stmt}; '
                                'print(time.perf_counter() - t)'], capture_output=True, text=True, check=True)
            times.append(float(r.stdout))
        rows.append((f'imports: {name}', statistics.median(times), max(times)))
    with GprClient('tf_startup_listener') as client:
        for kind, label in (('node', 'state_publisher_node'), ('peer', 'peer: a bare rclpy node publishing /tf'),
                            ('loop', 'state_publisher_node started with the idle loop\'s three other nodes')):
            runs = [_once(client, kind) for _ in range(args.repeat)]
            for k, what in enumerate(('built (its log)', 'its /tf publisher in the listener\'s graph',
                                      'gpr_base -> gpr_platform on /tf')):
                values = [r[k] for r in runs]
                rows.append((f'{label}: {what}', statistics.median(values), max(values)))
    print(f'load average at the end {os.getloadavg()[0]:.1f}\n')
    print('| measurement [s after the process started] | median | max |\n|---|---:|---:|')
    for name, med, top in rows:
        print(f'| {name} | {med:.2f} | {top:.2f} |')


if __name__ == '__main__':
    main()
